// intersect_triangle on its own: its answer does not depend on the length of
// the ray direction, and it never reports a hit at a t that is not a positive
// finite number, even when products of huge coordinates overflow.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstring>

#include "prism/geometry/triangle.hpp"
#include "prism/sampling/pcg32.hpp"
#include "prism/sampling/warps.hpp"

#include "support/random.hpp"

namespace triangle_test {

using namespace prism;

namespace {

using test::random_unit;
using test::uniform;

}  // namespace

TEST_CASE("intersect_triangle does not depend on the length of the direction", "[geometry][triangle]") {
  // Scaling d by 2^k changes no rounding in the shear (sx, sy are ratios of
  // components) and scales sz, the scaled z and t_scaled by exactly 2^-k, so a
  // correct test gives the same decision and t * 2^k == t bit for bit. (Error
  // bounds mixing spatial and ray-parameter units break this: instanced meshes
  // under a large scale see object-space directions of length ~1e-6.)
  PCG32 rng(1, 0x7a1);
  size_t decisions = 0, t_mismatch = 0, hits = 0;
  for (int i = 0; i < 20000; ++i) {
    Float size = std::exp2(uniform(rng, -12, 12));
    Vector3f c = random_unit(rng) * size * uniform(rng, 0, 4);
    Point3f p0(c + random_unit(rng) * size), p1(c + random_unit(rng) * size), p2(c + random_unit(rng) * size);
    // Aim at a point of the triangle (or just outside it) from ~size away.
    std::array<Float, 3> b = sample_uniform_triangle({rng.next_float(), rng.next_float()});
    Float grow = uniform(rng, 0.9f, 1.1f);  // some targets outside the edges
    Vector3f centroid = (Vector3f(p0) + Vector3f(p1) + Vector3f(p2)) / 3.f;
    Point3f target = Point3f(centroid + (Vector3f(p0) * b[0] + Vector3f(p1) * b[1] + Vector3f(p2) * b[2] - centroid) * grow);
    Point3f o = target + random_unit(rng) * size * uniform(rng, 0.01f, 8);
    Vector3f d = normalize(target - o);
    auto ref = intersect_triangle(o, RayTrianglePrecomp(d), infinity, p0, p1, p2);
    if (ref) ++hits;
    for (int k = -24; k <= 24; k += 4) {
      Vector3f dk = d * std::ldexp(1.0f, k);
      auto h = intersect_triangle(o, RayTrianglePrecomp(dk), infinity, p0, p1, p2);
      if (bool(h) != bool(ref)) {
        ++decisions;
        continue;
      }
      if (h && std::ldexp(h->t, k) != ref->t) ++t_mismatch;
    }
  }
  INFO("hits " << hits);
  CHECK(decisions == 0);
  CHECK(t_mismatch == 0);
  CHECK(hits > 10000);
}

TEST_CASE("intersect_triangle never reports a non-finite or non-positive t", "[geometry][triangle]") {
  // Coordinates up to 2^100 make the edge functions and t_scaled overflow to
  // infinity (and det to NaN); no such hit may be reported.
  PCG32 rng(2, 0x7a1);
  size_t bad = 0, hits = 0;
  for (int i = 0; i < 100000; ++i) {
    Float scale = std::exp2(uniform(rng, 0, 100));
    Vector3f c = random_unit(rng) * scale * uniform(rng, 0, 2);
    Point3f p0(c + random_unit(rng) * scale), p1(c + random_unit(rng) * scale), p2(c + random_unit(rng) * scale);
    Point3f o(random_unit(rng) * std::exp2(uniform(rng, 0, 100)));
    Vector3f d = Vector3f(c) - Vector3f(o) + random_unit(rng) * scale * 0.5f;
    d = d * std::exp2(uniform(rng, -60, 20));
    for (Float t_max : {infinity, Float(1e30f), std::exp2(uniform(rng, -60, 60))}) {
      auto h = intersect_triangle(o, RayTrianglePrecomp(d), t_max, p0, p1, p2);
      if (!h) continue;
      ++hits;
      if (!(h->t > 0 && h->t < infinity)) ++bad;
    }
  }
  INFO("hits " << hits);
  CHECK(bad == 0);
  CHECK(hits > 1000);
}

TEST_CASE("the closest of overlapping coplanar triangles does not depend on their order", "[geometry][triangle]") {
  // Overlapping triangles in one plane give hit distances a rounding apart.
  // Testing A then B (with t_max lowered to A's t) and B then A must keep the
  // same, smaller t: the range test before the division may not reject a hit
  // whose computed t is below t_max. Also checks that a hit at exactly t_max
  // is rejected and one just below is kept.
  PCG32 rng(21, 0xb0b);
  size_t pairs = 0, differing = 0, order_dependent = 0, bad_limit = 0;
  for (int i = 0; i < 200000; ++i) {
    Point3f a{uniform(rng, -10, 10), uniform(rng, -10, 10), 0.5f};
    Point3f b{a.x + uniform(rng, -0.3f, 0.3f), a.y + uniform(rng, -0.3f, 0.3f), 0.5f};
    Point3f tri[2][3] = {{a, a + Vector3f{uniform(rng, 0.5f, 1), 0, 0}, a + Vector3f{0, uniform(rng, 0.5f, 1), 0}},
                         {b, b + Vector3f{uniform(rng, 0.5f, 1), 0, 0}, b + Vector3f{0, uniform(rng, 0.5f, 1), 0}}};
    Point3f target = a + Vector3f{0.1f, 0.1f, 0};
    Point3f o{target.x + uniform(rng, -3, 3), target.y + uniform(rng, -3, 3), uniform(rng, 1, 4)};
    Vector3f d = target - o;
    RayTrianglePrecomp pc(d);
    auto h0 = intersect_triangle(o, pc, infinity, tri[0][0], tri[0][1], tri[0][2]);
    auto h1 = intersect_triangle(o, pc, infinity, tri[1][0], tri[1][1], tri[1][2]);
    if (!h0 || !h1) continue;
    ++pairs;
    if (h0->t == h1->t) continue;
    ++differing;
    Float closest = std::min(h0->t, h1->t);
    auto in_order = [&](int first) {
      Float t_max = infinity;
      for (int k : {first, 1 - first})
        if (auto h = intersect_triangle(o, pc, t_max, tri[k][0], tri[k][1], tri[k][2])) t_max = h->t;
      return t_max;
    };
    if (in_order(0) != closest || in_order(1) != closest) ++order_dependent;
    // The farther triangle with t_max at the closer hit: rejected exactly when its t is not below.
    int far = h0->t > h1->t ? 0 : 1;
    if (intersect_triangle(o, pc, closest, tri[far][0], tri[far][1], tri[far][2])) ++bad_limit;
    if (!intersect_triangle(o, pc, next_float_up(h0->t), tri[0][0], tri[0][1], tri[0][2])) ++bad_limit;
    if (intersect_triangle(o, pc, h0->t, tri[0][0], tri[0][1], tri[0][2])) ++bad_limit;
  }
  INFO(pairs << " overlapping pairs, " << differing << " with different t");
  CHECK(differing > 1000);
  CHECK(order_dependent == 0);
  CHECK(bad_limit == 0);
}

}  // namespace triangle_test
