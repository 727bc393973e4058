// The lights of lights/ through the path integrators: closed forms where they
// exist, and NEE + MIS against BSDF sampling where they do not.
#include <catch2/catch.hpp>
#include <cmath>
#include <prism/prism.hpp>
#include "support/film_checks.hpp"

namespace lights_test {

using namespace prism;
using namespace prism_test;

namespace {

// A point light of intensity I at height d over a diffuse plane of albedo rho:
// the plane's radiance at a point at horizontal distance x is
// rho / pi * I cos(theta) / r^2 with r^2 = d^2 + x^2 and cos(theta) = d / r.
template <class S>
void check_point_light_over_plane() {
  const float rho = 0.6f, I = 5.f, d = 2.f;
  Scene<S> scene;
  uint32_t m = scene.add_material(DiffuseMaterial{RGB(rho)});
  TriangleMesh plane;
  append_quad(plane, {-4, 0, -4}, {0, 0, 8}, {8, 0, 0});  // normal +y
  scene.add_mesh_instance(std::move(plane), m);
  scene.add_light(PointLight<S>({0, d, 0}, RGB(I)));
  scene.build();
  // An orthographic-like view from far above with a narrow field: each pixel
  // sees a small patch whose x, z we know from the ray.
  const int w = 8, h = 8;
  PerspectiveCamera cam(look_at_camera_to_world({0, 20, 0.001f}, {0, 0, 0}, {0, 1, 0}), radians(8), w, h);
  Film film(w, h);
  RenderOptions opt;
  opt.spp = 64;
  opt.seed = 4;
  RenderStats st = render(scene, cam, PathIntegrator{}, film, opt);
  REQUIRE(st.dropped == 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      // Average the closed form over the pixel (the box filter's footprint).
      double expected = 0;
      const int n = 16;
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          Ray r = cam.generate_ray(CameraSample{{x + (i + 0.5f) / n, y + (j + 0.5f) / n}, {0.5f, 0.5f}});
          double t = -r.o.y / r.d.y;
          double px = r.o.x + t * r.d.x, pz = r.o.z + t * r.d.z;
          double r2 = d * d + px * px + pz * pz;
          expected += rho / pi * I * (d / std::sqrt(r2)) / r2 / (n * n);
        }
      double v = film.pixel(x, y).g, sigma = std::sqrt(double(film.variance(x, y).g));
      INFO("pixel " << x << "," << y << ": " << v << " expected " << expected << " sigma " << sigma);
      // The only noise is the pixel footprint's variation: sigma is small but
      // not zero; allow z sigma (Sidak over the 64 pixels at a family-wise
      // 10^-3: 4.3) plus the colour model's white-point error.
      CHECK(std::abs(v - expected) <= reference_physics::sidak_z(1e-3, w * h) * sigma + 2e-3 * expected);
    }
}

// A diffuse sphere lit by an image environment with a bright sun: NEE with MIS
// (importance-sampled map) and BSDF sampling alone agree.
template <class S>
void check_environment_lit_sphere() {
  EnvironmentImage env = sky_with_sun();
  Scene<S> scene;
  uint32_t m = scene.add_material(DiffuseMaterial{RGB(0.7f)});
  scene.add_sphere(Sphere{{0, 0, 0}, 1}, m);
  scene.add_light(ImageInfiniteLight<S>(env, 1.f));
  scene.build();
  const int w = 16, h = 16, region = 8;
  PerspectiveCamera cam(look_at_camera_to_world({0, 0, 4}, {0, 0, 0}, {0, 1, 0}), radians(35), w, h);
  Film a(w, h), b(w, h);
  RenderOptions opt;
  opt.spp = 1024;
  opt.seed = 21;
  render(scene, cam, PathIntegrator{}, a, opt);
  opt.seed = 22;
  render(scene, cam, BSDFPathIntegrator{}, b, opt);
  check_regions_agree(a, b, region, "MIS", "BSDF");
}

}  // namespace

TEST_CASE("a point light over a diffuse plane gives rho I cos over pi d squared", "[integrators][lights][analytic]") {
  check_point_light_over_plane<RGB>();
}

TEST_CASE("a point light over a diffuse plane gives rho I cos over pi d squared, spectral", "[integrators][lights][analytic][spectral]") {
  check_point_light_over_plane<Spectral>();
}

TEST_CASE("an environment-lit diffuse sphere agrees between NEE with MIS and BSDF sampling", "[integrators][lights][environment]") {
  check_environment_lit_sphere<RGB>();
}

TEST_CASE("an environment-lit diffuse sphere agrees between NEE with MIS and BSDF sampling, spectral", "[integrators][lights][environment][spectral]") {
  check_environment_lit_sphere<Spectral>();
}

}  // namespace lights_test
