// PerspectiveCamera: orientation, field of view, and thin-lens focus.
#include <catch2/catch.hpp>
#include <prism/prism.hpp>

namespace perspective_test {

using namespace prism;

TEST_CASE("perspective camera looks at its target with the right field of view", "[cameras]") {
  const int w = 200, h = 100;
  Float fov = radians(50);
  PerspectiveCamera cam(look_at_camera_to_world({1, 2, 3}, {1, 2, -7}, {0, 1, 0}), fov, w, h);
  Ray c = cam.generate_ray({{w / 2.f, h / 2.f}, {0.5f, 0.5f}, 0});
  CHECK(c.o.x == Approx(1));
  CHECK(c.d.z == Approx(-1));
  // The top edge's centre is fov/2 above the axis; the right edge's centre is to +x (no mirroring).
  Ray top = cam.generate_ray({{w / 2.f, 0}, {0.5f, 0.5f}, 0});
  CHECK(std::acos(double(-top.d.z)) == Approx(fov / 2).epsilon(1e-5));
  CHECK(top.d.y > 0);
  Ray right = cam.generate_ray({{Float(w), h / 2.f}, {0.5f, 0.5f}, 0});
  CHECK(right.d.x > 0);
  CHECK(std::atan2(double(right.d.x), double(-right.d.z)) == Approx(std::atan(std::tan(fov / 2) * 2)).epsilon(1e-5));
}

TEST_CASE("thin lens rays through one film point meet at the focus distance", "[cameras][lens]") {
  const Float focus = 5;
  PerspectiveCamera cam(look_at_camera_to_world({0, 0, 0}, {0, 0, -1}, {0, 1, 0}), radians(40), 64, 64, 0.2f, focus);
  PCG32 rng(9, 9);
  Point3f first;
  for (int i = 0; i < 100; ++i) {
    Ray r = cam.generate_ray({{20.3f, 40.7f}, {rng.next_float(), rng.next_float()}, 0});
    Float t = -focus / r.d.z;  // plane z = -focus
    Point3f p = r.at(t);
    if (i == 0) first = p;
    CHECK(p.x == Approx(first.x).margin(1e-4));
    CHECK(p.y == Approx(first.y).margin(1e-4));
    CHECK(std::hypot(r.o.x, r.o.y) <= 0.2f + 1e-6f);
  }
}

}  // namespace perspective_test
