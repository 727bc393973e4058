// Stability suite, surfaces: grazing views and roughness 0, 1e-4 and 1, on a
// plane in a uniform environment of radiance 1, seen by an orthographic camera
// (so every camera ray meets the plane at the same angle). References:
//   - diffuse (albedo rho): rho, at any angle;
//   - smooth conductor: its Fresnel reflectance F(cos theta) (fresnel_complex);
//   - conductor of roughness 1e-4: F(cos theta) as well (the microfacet
//     albedo differs by O(alpha^2) ~ 1e-8);
//   - conductor of roughness 1: no closed form; NEE + MIS is compared with
//     BSDF sampling (both unbiased), and both must conserve energy (<= 1).
// See docs/stability.md.
#include "stability/stability.hpp"

namespace surfaces_stability_test {

using namespace prism;
using namespace prism::stability;

namespace {

// theta_deg from the plane's normal (+y); the camera is 2000 units away so
// that its window's lower edge stays above the plane even at 89.99 degrees.
OrthographicCamera grazing_camera(double theta_deg, int n) {
  double t = double(radians(Float(theta_deg)));
  Vector3f dir{Float(std::sin(t)), Float(std::cos(t)), 0};
  Point3f eye = Point3f{0, 0, 0} + dir * 2000.f;
  return OrthographicCamera(look_at_camera_to_world(eye, {0, 0, 0}, {0, 1, 0}), 0.2f, n, n);
}

template <class S>
void build_plane(Scene<S>& scene, const typename Scene<S>::material_type& m) {
  TriangleMesh plane;
  append_quad(plane, {-5000, 0, -5000}, {0, 0, 10000}, {10000, 0, 0});
  scene.add_mesh_instance(std::move(plane), scene.add_material(m));
  scene.add_infinite_light(UniformInfiniteLight<S>(RGB(1.f)));
  scene.build();
}

std::string angle_name(double theta) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g deg", theta);
  return buf;
}

}  // namespace

TEST_CASE("diffuse plane at grazing angles in a uniform environment", "[stability][surfaces][grazing]") {
  const double rho = 0.5;
  Scene<RGB> scene;
  const Scene<RGB>::material_type m = DiffuseMaterial{RGB(Float(rho))};
  build_plane(scene, m);
  Scene<Spectral> scene_s;
  const Scene<Spectral>::material_type ms = DiffuseMaterial{RGB(Float(rho))};
  build_plane(scene_s, ms);
  const std::vector<double> ref_px(256, rho);
  for (double theta : {45.0, 89.0, 89.99}) {
    OrthographicCamera cam = grazing_camera(theta, 16);
    RunSpec spec;
    spec.spp = 32;
    std::string c = "diffuse plane, view " + angle_name(theta);
    // BSDF sampling: every sample is rho exactly, so fireflies are bounded by 1.
    Row bsdf = make_row(c, "BSDF-only RGB", run(scene, cam, BSDFPathIntegrator{}, spec), 1, rho, ref_px);
    bsdf.firefly_bound = 1 + rounding_allowance(1);
    bsdf.check();
    Row nee = make_row(c, "NEE+MIS RGB", run(scene, cam, PathIntegrator{}, spec), 1, rho, ref_px);
    nee.check();
    Row nee_s = make_row(c, "NEE+MIS spectral", run(scene_s, cam, PathIntegrator{}, spec), 1, rho, ref_px);
    nee_s.check();
  }
}

TEST_CASE("conductor plane of roughness 0, 1e-4 and 1 at grazing angles", "[stability][surfaces][roughness]") {
  // F0 = 0.9: eta = 1, k = 2 sqrt(F0 / (1 - F0)) = 6 in every channel.
  const Float k = 6;
  for (double alpha : {0.0, 1e-4, 1.0}) {
    Scene<RGB> scene;
    const Scene<RGB>::material_type m =
        ConductorMaterial::from_reflectance(RGB(0.9f), MicrofacetRoughness(Float(alpha)));
    build_plane(scene, m);
    for (double theta : {45.0, 89.0, 89.99}) {
      OrthographicCamera cam = grazing_camera(theta, 16);
      const double F = fresnel_complex(Float(std::cos(double(radians(Float(theta))))), Float(1), k);
      const std::vector<double> ref_px(256, F);
      RunSpec spec;
      spec.spp = 32;
      std::string c = "conductor alpha " + std::to_string(alpha).substr(0, 6) + ", view " + angle_name(theta);
      Run rb = run(scene, cam, BSDFPathIntegrator{}, spec), rn = run(scene, cam, PathIntegrator{}, spec);
      Row bsdf = make_row(c, "BSDF-only RGB", rb, 1, F, ref_px);
      Row nee = make_row(c, "NEE+MIS RGB", rn, 1, F, ref_px);
      if (alpha < 1) {
        // A mirror's every sample is F (times the environment's 1): bounded by 1.
        bsdf.firefly_bound = 1 / F + rounding_allowance(1 / F);
        nee.firefly_bound = 1 / F + rounding_allowance(1 / F);
        bsdf.check();
        nee.check();
      } else {
        // No closed form: NEE + MIS against BSDF sampling; energy conservation.
        nee.reference = bsdf.est.mean;
        nee.est.sigma = std::hypot(nee.est.sigma, bsdf.est.sigma);
        nee.firefly = firefly_ratio(channel(rn.film, 1), channel(rb.film, 1));
        nee.note = "reference: BSDF-only; sigma of the difference";
        bsdf.reference = bsdf.est.mean;
        bsdf.note = "albedo <= 1 checked";
        bsdf.check(false);
        nee.check();
        CHECK(bsdf.est.mean <= 1 + stability_z() * bsdf.est.sigma);
        CHECK(nee.est.mean <= 1 + stability_z() * nee.est.sigma);
      }
    }
  }
}

}  // namespace surfaces_stability_test
