// Thin lens and orthographic projection: connect() must invert
// generate_ray(), a point at the focus distance must image to one raster
// position whatever the lens sample, and a point off focus to a disk whose
// radius is the circle of confusion.
#include <catch2/catch.hpp>
#include <cmath>
#include <prism/prism.hpp>
#include "support/reference_physics.hpp"

namespace lens_test {

using namespace prism;

namespace {
double ray_point_distance(const Ray& r, const Point3f& p) {
  Vector3f d = normalize(r.d);
  Vector3f v = p - r.o;
  return double(length(v - d * dot(v, d)));
}
}  // namespace

TEST_CASE("thin lens: a point at the focus distance images into one raster position", "[cameras][lens]") {
  const int w = 200, h = 100;
  const Float focus = 4, radius = 0.1f;
  PerspectiveCamera cam(look_at_camera_to_world({0, 0, 0}, {0, 0, -1}, {0, 1, 0}), radians(40), w, h, radius, focus);
  Point3f p{0.3f, -0.2f, -focus};  // camera space z = focus (the camera looks along world -z)
  auto ref = cam.connect(p, {0.5f, 0.5f});
  REQUIRE(ref);
  PCG32 rng(0, 3);
  for (int i = 0; i < 1000; ++i) {
    Point2f u{rng.next_float(), rng.next_float()};
    auto c = cam.connect(p, u);
    REQUIRE(c);
    // 2e-3 px: ~10 float roundings at depth 4 (ulp 4.8e-7) are ~5e-6 world, 1.7e-4 px at 0.029 world units per pixel
    CHECK(std::abs(c->p_raster.x - ref->p_raster.x) < 2e-3f);
    CHECK(std::abs(c->p_raster.y - ref->p_raster.y) < 2e-3f);
    // The camera ray through that raster position and lens sample passes through p.
    Ray r = cam.generate_ray(CameraSample{c->p_raster, u});
    // 1e-4: ~10 float roundings of coordinates ≤ 4 (ulp 4.8e-7) give ~5e-6; 1e-4 · depth below likewise
    CHECK(ray_point_distance(r, p) < 1e-4);
  }
}

TEST_CASE("thin lens: a point off focus images into the circle of confusion", "[cameras][lens]") {
  const int w = 200, h = 200;
  const Float focus = 4, radius = 0.1f, fov = radians(40);
  PerspectiveCamera cam(look_at_camera_to_world({0, 0, 0}, {0, 0, -1}, {0, 1, 0}), fov, w, h, radius, focus);
  // The mean r^2 at 2 depths: 2 comparisons, one family at 10^-3 (Sidak):
  // z = sidak_z(1e-3, 2) = 3.48.
  const double z = reference_physics::sidak_z(1e-3, 2);
  for (Float depth : {2.f, 8.f}) {
    Point3f p{0, 0, -depth};
    // Raster radius of the blur disk: R |1 - f/d| / (f s), s = 2 tan(fov/2) / h.
    const double s = 2 * std::tan(double(fov) / 2) / h;
    const double coc = radius * std::abs(1 - double(focus) / depth) / (double(focus) * s);
    double max_r = 0, mean_r2 = 0;
    PCG32 rng(0, 5);
    const int n = 20000;
    for (int i = 0; i < n; ++i) {
      Point2f u{rng.next_float(), rng.next_float()};
      auto c = cam.connect(p, u);
      REQUIRE(c);
      double dx = c->p_raster.x - w / 2.0, dy = c->p_raster.y - h / 2.0;
      double r = std::sqrt(dx * dx + dy * dy);
      max_r = std::max(max_r, r);
      mean_r2 += r * r / n;
      Ray ray = cam.generate_ray(CameraSample{c->p_raster, u});
      CHECK(ray_point_distance(ray, p) < 1e-4 * depth);
    }
    INFO("depth " << depth << ": circle of confusion " << coc << " px, largest radius " << max_r);
    // 1e-3 px and 1e-4 relative: float rounding of raster positions ≤ 200 (ulp 1.5e-5);
    // 0.99: P(max of 20000 uniform radii < 0.99 coc) = 0.9801^20000 ≈ e^-400.
    CHECK(max_r <= coc * 1.0001 + 1e-3);
    CHECK(max_r >= coc * 0.99);
    // Uniform over the disk: E[r^2] = coc^2 / 2, within z standard errors (var r^2 = coc^4 / 12).
    CHECK(std::abs(mean_r2 - coc * coc / 2) <= z * coc * coc / std::sqrt(12.0 * n));
  }
}

TEST_CASE("orthographic camera: parallel rays, and connect inverts generate_ray", "[cameras][orthographic]") {
  const int w = 64, h = 32;
  OrthographicCamera cam(look_at_camera_to_world({1, 2, 5}, {1, 2, 0}, {0, 1, 0}), 2.f, w, h);
  Ray a = cam.generate_ray(CameraSample{{0.5f, 0.5f}, {}}), b = cam.generate_ray(CameraSample{{60.f, 20.f}, {}});
  // 1e-6: a few ulps of unit components; bare Approx: Catch's 100·FLT_EPSILON relative
  CHECK(length(a.d - b.d) < 1e-6f);
  CHECK(a.d.z == Approx(-1));
  // The window is 2 units tall and 4 wide.
  Ray left = cam.generate_ray(CameraSample{{0, 16}, {}}), right = cam.generate_ray(CameraSample{{64, 16}, {}});
  CHECK(distance(left.o, right.o) == Approx(4).epsilon(1e-5));  // 1e-5: a few float roundings of the window's width 4
  PCG32 rng(0, 9);
  for (int i = 0; i < 1000; ++i) {
    Point2f pf{rng.next_float() * w, rng.next_float() * h};
    Ray r = cam.generate_ray(CameraSample{pf, {}});
    Point3f p = r.o + r.d * (1 + 5 * rng.next_float());
    auto c = cam.connect(p, {});
    REQUIRE(c);
    // 1e-3 px: raster ≤ 64 (ulp 7.6e-6) after ~10 roundings, plus world errors ~ulp(6) = 4.8e-7 at 16 px per unit: ≲ 1e-4 px
    CHECK(c->p_raster.x == Approx(pf.x).margin(1e-3));
    CHECK(c->p_raster.y == Approx(pf.y).margin(1e-3));
  }
  CHECK_FALSE(cam.connect({1, 2, 6}, {}));  // behind the image plane
  CHECK_THROWS_AS(OrthographicCamera(Transform{}, -1.f, 4, 4), Error);
}

}  // namespace lens_test
