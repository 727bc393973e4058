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
  // bare Approx: Catch's 100·FLT_EPSILON ≈ 1.2e-5 relative, a few float roundings of the look-at frame
  CHECK(c.o.x == Approx(1));
  CHECK(c.d.z == Approx(-1));
  // The top edge's centre is fov/2 above the axis; the right edge's centre is to +x (no mirroring).
  Ray top = cam.generate_ray({{w / 2.f, 0}, {0.5f, 0.5f}, 0});
  // 1e-5 relative: float ray direction (~10 roundings: 6e-7) through acos at sin 25° = 0.42: ≲ 1.5e-6
  CHECK(std::acos(double(-top.d.z)) == Approx(fov / 2).epsilon(1e-5));
  CHECK(top.d.y > 0);
  Ray right = cam.generate_ray({{Float(w), h / 2.f}, {0.5f, 0.5f}, 0});
  CHECK(right.d.x > 0);
  CHECK(std::atan2(double(right.d.x), double(-right.d.z)) == Approx(std::atan(std::tan(fov / 2) * 2)).epsilon(1e-5));
}

TEST_CASE("a left-handed look-at gives pbrt's camera, the mirror image of the right-handed one", "[cameras]") {
  // pbrt-v4's LookAt from the origin towards +z with +y up is the identity
  // camera-to-world (right = up x dir = +x): camera +x is world +x.
  Transform left = look_at_camera_to_world({0, 0, 0}, {0, 0, 1}, {0, 1, 0}, Handedness::left);
  Vector3f x = left(Vector3f{1, 0, 0}), y = left(Vector3f{0, 1, 0}), z = left(Vector3f{0, 0, 1});
  // bare Approx (100·FLT_EPSILON relative): float cross products and normalisation of unit vectors
  CHECK(x.x == Approx(1));
  CHECK(y.y == Approx(1));
  CHECK(z.z == Approx(1));
  // The right-handed convention puts camera +x at dir x up = -x here.
  Transform right = look_at_camera_to_world({0, 0, 0}, {0, 0, 1}, {0, 1, 0});
  CHECK(right(Vector3f{1, 0, 0}).x == Approx(-1));
  CHECK(right(Vector3f{0, 1, 0}).y == Approx(1));
  // Off-axis: both keep the eye, the view direction and up; only x flips.
  Point3f eye{1, 2, 3}, target{-2, 0.5f, -4};
  Transform l2 = look_at_camera_to_world(eye, target, {0, 1, 0}, Handedness::left);
  Transform r2 = look_at_camera_to_world(eye, target, {0, 1, 0});
  Vector3f lx = l2(Vector3f{1, 0, 0}), rx = r2(Vector3f{1, 0, 0});
  for (int i = 0; i < 3; ++i) {
    // 1e-6: a few float ulps of unit components (2^-24 ≈ 6e-8 each); bare Approx on the eye: 100·FLT_EPSILON relative
    CHECK(lx[i] == Approx(-rx[i]).margin(1e-6));
    CHECK(l2(Vector3f{0, 0, 1})[i] == Approx(r2(Vector3f{0, 0, 1})[i]).margin(1e-6));
    CHECK(l2(Vector3f{0, 1, 0})[i] == Approx(r2(Vector3f{0, 1, 0})[i]).margin(1e-6));
    CHECK(l2(Point3f{0, 0, 0})[i] == Approx(eye[i]));
  }
}

TEST_CASE("the field of view spans the axis it is given for", "[cameras]") {
  const Float fov = radians(50);
  const Transform t = look_at_camera_to_world({0, 0, 0}, {0, 0, -1}, {0, 1, 0});
  // Angle from the axis of the ray through the film point (x, y).
  auto angle = [&](const PerspectiveCamera& c, Float x, Float y) {
    Ray r = c.generate_ray({{x, y}, {0.5f, 0.5f}, 0});
    return std::acos(double(-r.d.z));
  };
  for (auto [w, h] : {std::pair{200, 100}, std::pair{100, 200}}) {
    PerspectiveCamera horizontal(t, fov, FovAxis::horizontal, w, h);
    PerspectiveCamera vertical(t, fov, FovAxis::vertical, w, h);
    PerspectiveCamera shorter(t, fov, FovAxis::shorter, w, h);
    // 1e-5 relative: as above, float direction through acos away from 0 (≲ 1.5e-6)
    CHECK(angle(horizontal, Float(w), h / 2.f) == Approx(fov / 2).epsilon(1e-5));
    CHECK(angle(vertical, w / 2.f, 0) == Approx(fov / 2).epsilon(1e-5));
    // pbrt-v4: the shorter extent spans the field of view.
    if (w < h)
      CHECK(angle(shorter, Float(w), h / 2.f) == Approx(fov / 2).epsilon(1e-5));
    else
      CHECK(angle(shorter, w / 2.f, 0) == Approx(fov / 2).epsilon(1e-5));
  }
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
    // 1e-4: ~10 float roundings at the focus distance 5 (ulp 4.8e-7) give ~5e-6; the lens radius 0.2 adds a few ulps more
    CHECK(p.x == Approx(first.x).margin(1e-4));
    CHECK(p.y == Approx(first.y).margin(1e-4));
    CHECK(std::hypot(r.o.x, r.o.y) <= 0.2f + 1e-6f);  // 1e-6: the lens radius plus one rounding
  }
}

}  // namespace perspective_test
