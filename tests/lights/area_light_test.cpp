// Area lights: sample_li's density matches pdf_li (chi-squared over directions
// at the receiver), and NEE agrees with BSDF sampling for a sphere light seen
// from outside.
#include <catch2/catch.hpp>
#include <prism/prism.hpp>
#include "support/chi2.hpp"
#include "support/reference_physics.hpp"

namespace area_light_test {

using namespace prism;

namespace {
const double alpha = prism_test::sidak_alpha(1e-3, 2);

// Solid angle of a triangle seen from the origin (Van Oosterom and Strackee
// 1983), in double.
double triangle_solid_angle(const Vector3f& a, const Vector3f& b, const Vector3f& c) {
  double A[3] = {a.x, a.y, a.z}, B[3] = {b.x, b.y, b.z}, C[3] = {c.x, c.y, c.z};
  auto dotd = [](const double* u, const double* v) { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]; };
  double bxc[3] = {B[1] * C[2] - B[2] * C[1], B[2] * C[0] - B[0] * C[2], B[0] * C[1] - B[1] * C[0]};
  double la = std::sqrt(dotd(A, A)), lb = std::sqrt(dotd(B, B)), lc = std::sqrt(dotd(C, C));
  double num = std::abs(dotd(A, bxc));
  double den = la * lb * lc + dotd(A, B) * lc + dotd(A, C) * lb + dotd(B, C) * la;
  return 2 * std::atan2(num, den);
}
}  // namespace

TEST_CASE("triangle light sampling integrates to its solid angle", "[lights][area]") {
  // E[1 / pdf] over sample_li's samples is the solid angle the light subtends:
  // this checks the area-to-solid-angle conversion, independent of binning.
  Point3f p0{-1, 2, -1}, p1{1.5f, 2.2f, -0.5f}, p2{0, 2.5f, 1.5f};
  // Sampled by area here (by solid angle, 1 / pdf is the solid angle itself:
  // tests/lights/spherical_triangle_test.cpp).
  TriangleAreaLight<RGB> light(p0, p1, p2, AreaEmission{RGB(1), 1, true}, 0, 0);
  light.set_solid_angle_sampling(false);
  // 2 receivers: 2 comparisons, one family at 10^-3 (Sidak): z = 3.48.
  const double z = reference_physics::sidak_z(1e-3, 2);
  for (Point3f at : {Point3f{0.1f, 0, 0.2f}, Point3f{2, 2.1f, 3}}) {
    LightSampleContext ctx;
    ctx.p = at;
    double omega = triangle_solid_angle(p0 - at, p1 - at, p2 - at);
    PCG32 rng(1, 2);
    const int n = 200000;
    double s = 0, s2 = 0;
    for (int i = 0; i < n; ++i) {
      auto ls = light.sample_li(ctx, {rng.next_float(), rng.next_float()}, RGBWavelengths{});
      REQUIRE(ls);
      REQUIRE(ls->L.g == 1);
      double v = 1 / double(ls->pdf);
      s += v;
      s2 += v * v;
    }
    double mean = s / n, sigma = std::sqrt((s2 / n - mean * mean) / (n - 1));
    INFO("solid angle " << omega << " estimate " << mean << " sigma " << sigma);
    CHECK(std::abs(mean - omega) <= z * sigma);
  }
}

TEST_CASE("sphere light cone sampling matches pdf_li", "[lights][area][chi2]") {
  for (Float dist : {3.f, 200.f}) {  // 200: the small-angle branch
    Sphere s{{0, 0, dist}, 1};
    SphereAreaLight<RGB> light(s, AreaEmission{RGB(1)}, 0);
    LightSampleContext ctx;
    ctx.p = {0, 0, 0};
    double theta_max = std::asin(1.0 / dist);
    PCG32 rng(2, 1);
    // theta from atan2, which keeps its precision for directions near +z.
    auto sample = [&]() -> std::optional<std::array<double, 2>> {
      auto ls = light.sample_li(ctx, {rng.next_float(), rng.next_float()}, RGBWavelengths{});
      if (!ls) return std::nullopt;
      double theta = std::atan2(std::hypot(double(ls->wi.x), double(ls->wi.y)), double(ls->wi.z));
      double phi = std::atan2(double(ls->wi.y), double(ls->wi.x));
      if (phi < 0) phi += 2 * pi;
      return std::array<double, 2>{std::min(theta, theta_max), phi};
    };
    auto density = [&](double theta, double phi) -> double {
      Vector3f wi = spherical_direction(Float(std::sin(theta)), Float(std::cos(theta)), Float(phi));
      Ray r{ctx.p, wi};
      auto h = intersect_sphere(s, r, infinity);
      if (!h) return 0;
      SurfaceInteraction si;
      sphere_interaction(s, r, *h, &si);
      return double(light.pdf_li(ctx, wi, si)) * std::sin(theta);
    };
    prism_test::Grid2D g{0, theta_max, 16, 0, 2 * pi, 32, 0};
    auto r = prism_test::chi2_test_2d(sample, density, g, 200000);
    INFO("distance " << dist << " chi2 " << r.statistic << " dof " << r.dof << " p " << r.p_value);
    CHECK(r.p_value >= alpha);
  }
}

TEST_CASE("sphere light from outside: NEE with MIS agrees with BSDF sampling", "[lights][area][integrators]") {
  Scene<RGB> scene;
  uint32_t grey = scene.add_material(DiffuseMaterial{RGB(0.7f)});
  TriangleMesh floor;
  append_quad(floor, {-3, 0, 3}, {6, 0, 0}, {0, 0, -6});
  scene.add_mesh_instance(std::move(floor), grey);
  scene.add_sphere(Sphere{{0, 0.6f, 0}, 0.6f}, grey);
  scene.add_sphere(Sphere{{-1, 2.5f, 1}, 0.4f}, grey, AreaEmission{RGB(10.f)});
  scene.build();
  PerspectiveCamera cam(look_at_camera_to_world({0, 1.5f, 4}, {0, 0.5f, 0}, {0, 1, 0}), radians(45), 32, 32);
  Film a(32, 32), b(32, 32);
  RenderOptions opt;
  opt.spp = 256;
  render(scene, cam, PathIntegrator{}, a, opt);
  opt.seed = 1;
  render(scene, cam, BSDFPathIntegrator{}, b, opt);
  // 4 regions (green channel): 4 comparisons, one family at 10^-3 (Sidak):
  // z = sidak_z(1e-3, 4) = 3.66.
  const double z = reference_physics::sidak_z(1e-3, 4);
  for (int ry = 0; ry < 32; ry += 16)
    for (int rx = 0; rx < 32; rx += 16) {
      double ma = 0, mb = 0, va = 0, vb = 0;
      for (int y = ry; y < ry + 16; ++y)
        for (int x = rx; x < rx + 16; ++x) {
          ma += a.pixel(x, y).g / 256.0;
          mb += b.pixel(x, y).g / 256.0;
          va += a.variance(x, y).g / 65536.0;
          vb += b.variance(x, y).g / 65536.0;
        }
      INFO("region " << rx << "," << ry << " MIS " << ma << " BSDF " << mb << " sigma " << std::sqrt(va + vb));
      CHECK(std::abs(ma - mb) <= z * std::sqrt(va + vb));
      // NEE must reduce variance on a diffuse scene lit by a small light.
      CHECK(va < vb);
    }
}

}  // namespace area_light_test
