// AnimatedTransform: keys at the ends, slerp at constant angular velocity,
// decomposition round trips, inverses, conservative motion bounds, bad input.
#include <catch2/catch.hpp>
#include <prism/math/animated_transform.hpp>
#include <prism/sampling/pcg32.hpp>

namespace animated_transform_test {

using namespace prism;

namespace {

Float max_abs_diff(const Matrix4& a, const Matrix4& b) {
  Float d = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) d = std::max(d, std::abs(a.m[size_t(i)][size_t(j)] - b.m[size_t(i)][size_t(j)]));
  return d;
}

Vector3f random_unit(PCG32& rng) {
  for (;;) {
    Vector3f v{2 * rng.next_float() - 1, 2 * rng.next_float() - 1, 2 * rng.next_float() - 1};
    if (length_squared(v) > Float(0.01) && length_squared(v) <= 1) return normalize(v);
  }
}

Transform trs_matrix(const Vector3f& t, const Vector3f& axis, Float angle, const Vector3f& s) {
  return translate(t) * rotate(angle, axis) * scale(s.x, s.y, s.z);
}

}  // namespace

TEST_CASE("animated transform reproduces its keys at the ends and clamps outside", "[math][motion]") {
  Vector3f axis{1, 2, -0.5f};
  TransformKey a = TransformKey::trs({1, 2, 3}, Quaternion::from_axis_angle(axis, 0.3f), {1, 2, 0.5f});
  TransformKey b = TransformKey::trs({-2, 0, 1}, Quaternion::from_axis_angle(axis, 1.9f), {1.5f, 1, 0.5f});
  AnimatedTransform m(a, b, 2, 4);
  CHECK(m.is_moving());
  Transform ma = trs_matrix({1, 2, 3}, axis, 0.3f, {1, 2, 0.5f});
  Transform mb = trs_matrix({-2, 0, 1}, axis, 1.9f, {1.5f, 1, 0.5f});
  // 1e-5: float TRS products with entries ≤ ~4 (ulp 4.8e-7), ~10 roundings each, through quaternion ↔ matrix
  CHECK(max_abs_diff(m.at(2).matrix(), ma.matrix()) < 1e-5f);
  CHECK(max_abs_diff(m.at(4).matrix(), mb.matrix()) < 1e-5f);
  CHECK(max_abs_diff(m.at(-10).matrix(), ma.matrix()) < 1e-5f);
  CHECK(max_abs_diff(m.at(10).matrix(), mb.matrix()) < 1e-5f);
  // Halfway: rotation angle and translation and scale half way.
  Transform mh = trs_matrix({-0.5f, 1, 2}, axis, 1.1f, {1.25f, 1.5f, 0.5f});
  CHECK(max_abs_diff(m.at(3).matrix(), mh.matrix()) < 1e-5f);
}

TEST_CASE("slerp turns at a constant angular velocity the short way round", "[math][motion]") {
  Vector3f axis{0, 0, 1};
  // 0 to 300 degrees is -60 degrees the short way.
  AnimatedTransform m(TransformKey::trs({0, 0, 0}), TransformKey::trs({0, 0, 0}, Quaternion::from_axis_angle(axis, radians(300))));
  // 1e-5: float acos of a quaternion component near cos 30° (slope 2, a few u); 2e-6 for unit-rotation entries (a few ulps)
  CHECK(m.rotation_angle() == Approx(radians(60)).margin(1e-5));
  for (int k = 0; k <= 10; ++k) {
    Float u = Float(k) / 10;
    Transform expect = rotate(-radians(60) * u, axis);
    CHECK(max_abs_diff(m.interpolate(u).matrix(), expect.matrix()) < 2e-6f);
  }
  // 179 degrees about a skew axis: every intermediate angle on the line.
  Vector3f skew{1, -1, 2};
  AnimatedTransform big(TransformKey::trs({0, 0, 0}), TransformKey::trs({0, 0, 0}, Quaternion::from_axis_angle(skew, radians(179))));
  for (int k = 0; k <= 8; ++k) {
    Float u = Float(k) / 8;
    CHECK(max_abs_diff(big.interpolate(u).matrix(), rotate(radians(179) * u, skew).matrix()) < 1e-5f);  // 1e-5: as above, with sin of the 179° axis-angle (slope ~1) at float angle
  }
}

TEST_CASE("decomposition of a transform round-trips, with shear and mirroring", "[math][motion]") {
  PCG32 rng(7, 11);
  for (int trial = 0; trial < 200; ++trial) {
    Vector3f t{10 * rng.next_float() - 5, 10 * rng.next_float() - 5, 10 * rng.next_float() - 5};
    Vector3f s{0.1f + 3 * rng.next_float(), 0.1f + 3 * rng.next_float(), 0.1f + 3 * rng.next_float()};
    if (trial % 3 == 0) s.y = -s.y;  // mirroring
    Transform m = trs_matrix(t, random_unit(rng), 6.28f * rng.next_float(), s);
    if (trial % 4 == 1) m = m * rotate(rng.next_float() * 3, random_unit(rng)) * scale(1, 2.5f, 0.7f);  // shear: R S R'
    TransformKey k = TransformKey::decompose(m);
    AnimatedTransform still(k, k);
    CHECK_FALSE(still.is_moving());
    CHECK(still.swaps_handedness() == m.swaps_handedness());
    Transform back = still.at(0);
    // 1.6e-4 ≈ 170 ulps of entries ≤ 8 (ulp 9.5e-7): iterated float polar decomposition;
    // 1e-4: the inverse of a matrix whose condition number reaches ~45 (scales 0.07 to 3.1), times a few u
    CHECK(max_abs_diff(back.matrix(), m.matrix()) < 2e-5f * 8);
    // The inverse built from the factors is the inverse.
    Matrix4 id = back.matrix() * back.inverse_matrix();
    CHECK(max_abs_diff(id, Matrix4{}) < 1e-4f);
  }
}

TEST_CASE("motion bounds enclose every point of a moving box and stay tight", "[math][motion]") {
  PCG32 rng(3, 5);
  for (int trial = 0; trial < 60; ++trial) {
    Bounds3f box;
    Point3f c{4 * rng.next_float() - 2, 4 * rng.next_float() - 2, 4 * rng.next_float() - 2};
    Vector3f half{0.05f + rng.next_float(), 0.05f + rng.next_float(), 0.05f + rng.next_float()};
    box = Bounds3f(c - half, c + half);
    Float angle = Float(3.1) * rng.next_float();
    TransformKey a = TransformKey::trs({rng.next_float(), rng.next_float(), rng.next_float()},
                                       Quaternion::from_axis_angle(random_unit(rng), 6 * rng.next_float()),
                                       {0.5f + rng.next_float(), 0.5f + rng.next_float(), 0.5f + rng.next_float()});
    TransformKey b = a;
    b.translation += Vector3f{3 * rng.next_float() - 1.5f, 3 * rng.next_float() - 1.5f, 3 * rng.next_float() - 1.5f};
    Quaternion dq = Quaternion::from_axis_angle(random_unit(rng), angle);
    // b.rotation = dq * a.rotation
    const Quaternion& q = a.rotation;
    b.rotation = Quaternion{dq.w * q.x + dq.x * q.w + dq.y * q.z - dq.z * q.y,
                            dq.w * q.y - dq.x * q.z + dq.y * q.w + dq.z * q.x,
                            dq.w * q.z + dq.x * q.y - dq.y * q.x + dq.z * q.w,
                            dq.w * q.w - dq.x * q.x - dq.y * q.y - dq.z * q.z};
    b.stretch[0][0] *= 1.5f;
    b.stretch[2][2] *= 0.6f;
    AnimatedTransform m(a, b, 0, 1);
    Float ta = rng.next_float() * 0.5f, tb = ta + 0.5f * rng.next_float();
    Bounds3f mb = m.motion_bounds(box, ta, tb);
    // Dense samples of the corners' and random interior points' trajectories.
    Bounds3f seen;
    for (int k = 0; k <= 2000; ++k) {
      Float t = ta + (tb - ta) * Float(k) / 2000;
      Transform x = m.at(t);
      for (int i = 0; i < 8; ++i) {
        Point3f p = x(Point3f{box[i & 1].x, box[(i >> 1) & 1].y, box[(i >> 2) & 1].z});
        seen = union_bounds(seen, p);
        REQUIRE(mb.inside(p));
      }
      Point3f r{box.min.x + (box.max.x - box.min.x) * rng.next_float(), box.min.y + (box.max.y - box.min.y) * rng.next_float(),
                box.min.z + (box.max.z - box.min.z) * rng.next_float()};
      REQUIRE(mb.inside(x(r)));
    }
    // Tight: no side more than 1% of the box's size beyond what was seen
    // (the chord pad is below 1/2048 of the corner radius per unit angle).
    Float size = length(seen.diagonal());
    for (int a3 = 0; a3 < 3; ++a3) {
      CHECK(seen.min[a3] - mb.min[a3] < 0.01f * size);
      CHECK(mb.max[a3] - seen.max[a3] < 0.01f * size);
    }
  }
}

TEST_CASE("animated transform rejects bad keys and intervals with prism Error", "[math][motion][errors]") {
  TransformKey a = TransformKey::trs({0, 0, 0});
  TransformKey b = TransformKey::trs({1, 0, 0});
  CHECK_THROWS_AS(AnimatedTransform(a, b, 1, 1), Error);  // keys differ, zero-length interval
  CHECK_NOTHROW(AnimatedTransform(a, a, 1, 1));           // a still transform
  CHECK_THROWS_AS(AnimatedTransform(a, b, 2, 1), Error);
  CHECK_THROWS_AS(AnimatedTransform(a, b, 0, std::numeric_limits<Float>::infinity()), Error);
  TransformKey mirrored = TransformKey::trs({0, 0, 0}, {}, {-1, 1, 1});
  CHECK_THROWS_WITH(AnimatedTransform(a, mirrored), Catch::Contains("handedness"));
  TransformKey flat = TransformKey::trs({0, 0, 0}, {}, {1, 0, 1});
  CHECK_THROWS_WITH(AnimatedTransform(a, flat), Catch::Contains("singular"));
  TransformKey nan = b;
  nan.translation.x = std::numeric_limits<Float>::quiet_NaN();
  CHECK_THROWS_WITH(AnimatedTransform(a, nan), Catch::Contains("not finite"));
  CHECK_THROWS_AS(TransformKey::decompose(scale(1, 0, 1)), Error);
}

}  // namespace animated_transform_test
