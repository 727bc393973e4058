// The quantized wide-node layout (BVHQuantWideNode): the box that traversal
// tests for a lane always contains the child's float box (coordinates from
// 1e-30 to 1e30, flat and point boxes, mixed scales), axes that cannot be
// quantized are left unbounded (NaN planes), and a ray entering a child's
// exact box always enters the quantized lane, with an entry distance no larger.
// These run in every build with nodes at most 8 wide (quantized nodes are not
// 16 wide; tests/CMakeLists.txt leaves this file out of 16-wide builds); the
// closest-hit tests run on the quantized layout in
// prism_test_accel_quant_native.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <type_traits>

#include "prism/accel/bvh.hpp"
#include "prism/sampling/pcg32.hpp"

#include "support/lanes.hpp"
#include "support/random.hpp"

namespace quantized_node_test {

using namespace prism;
using test::random_unit;
using test::uniform;

namespace {

constexpr int W = detail::wide_width;

// A coordinate of random sign and magnitude 10^u, u uniform in [lo, hi).
Float random_coord(PCG32& rng, Float lo, Float hi) {
  Float m = std::pow(Float(10), uniform(rng, lo, hi));
  return rng.next_float() < 0.5f ? -m : m;
}

// Up to W child boxes around one centre, at one of several scales; some flat
// on an axis, some points, some sharing planes with the node's bounds.
int random_children(PCG32& rng, Bounds3f* box) {
  int k = 1 + int(rng.next_u32() % uint32_t(W));
  int scale_kind = int(rng.next_u32() % 4);
  Point3f c;
  for (int a = 0; a < 3; ++a) c[a] = rng.next_float() < 0.2f ? 0 : random_coord(rng, -30, 30);
  for (int l = 0; l < k; ++l) {
    Bounds3f b;
    for (int a = 0; a < 3; ++a) {
      // Offsets relative to |centre| (tiny, comparable or huge) or absolute.
      Float ref = std::max(std::abs(c[a]), Float(1e-30));
      Float mag;
      switch (scale_kind) {
        case 0: mag = ref * std::pow(Float(10), uniform(rng, -7, -3)); break;  // near float spacing
        case 1: mag = ref * uniform(rng, 0, 2); break;
        case 2: mag = std::pow(Float(10), uniform(rng, -30, 30)); break;
        default: mag = ref * std::pow(Float(10), uniform(rng, -3, 3)); break;
      }
      Float x0 = c[a] + uniform(rng, -1, 1) * mag;
      Float x1 = c[a] + uniform(rng, -1, 1) * mag;
      uint32_t shape = rng.next_u32() % 8;
      if (shape == 0) x1 = x0;  // flat on this axis
      b.min[a] = std::min(x0, x1);
      b.max[a] = std::max(x0, x1);
    }
    box[l] = b;
  }
  return k;
}

std::string describe(const Bounds3f& b) {
  std::ostringstream s;
  s.precision(9);
  s << "[" << b.min.x << " " << b.min.y << " " << b.min.z << "] - [" << b.max.x << " " << b.max.y << " " << b.max.z
    << "]";
  return s.str();
}

}  // namespace

TEST_CASE("a quantized node's boxes contain its children's float boxes", "[accel][bvh][quantized]") {
  PCG32 rng(11, 0x9a);
  int nodes = 0, lanes = 0, not_contained = 0, unbounded = 0, bad_lanes = 0;
  double slack_sum = 0;  // mean padding per plane, in units of the node's extent
  int slack_n = 0;
  std::string first;
  for (int it = 0; it < 20000; ++it) {
    Bounds3f box[W];
    int k = random_children(rng, box);
    detail::BVHQuantWideNode n;
    detail::set_boxes(n, box, k);
    ++nodes;
    if (n.lanes != (1u << k) - 1) ++bad_lanes;
    for (int l = 0; l < k; ++l, ++lanes) {
      Bounds3f q = detail::dequantized_box(n, l);
      for (int a = 0; a < 3; ++a) {
        if (std::isnan(n.origin[a])) {
          ++unbounded;
          continue;
        }
        if (!(q.min[a] <= box[l].min[a] && q.max[a] >= box[l].max[a])) {
          if (not_contained++ == 0) first = describe(box[l]) + " dequantized to " + describe(q);
        }
        Float lo = box[0].min[a], hi = box[0].max[a];
        for (int j = 1; j < k; ++j) {
          lo = std::min(lo, box[j].min[a]);
          hi = std::max(hi, box[j].max[a]);
        }
        if (hi > lo) {
          slack_sum += (double(box[l].min[a]) - q.min[a] + (double(q.max[a]) - box[l].max[a])) / (double(hi) - lo);
          slack_n += 2;
        }
      }
    }
  }
  INFO(nodes << " nodes, " << lanes << " lanes, " << not_contained << " boxes not contained (first: " << first
             << "), " << unbounded << " unbounded axes, mean padding per plane " << slack_sum / slack_n
             << " of the node extent");
  CHECK(not_contained == 0);
  CHECK(bad_lanes == 0);
  // Finite boxes below 255 * 2^119 are always quantized.
  CHECK(unbounded == 0);
  // Outward rounding costs at most a grid step (1/255 of the extent, up to 2/255
  // after rounding up the scale) per plane; a mean above that would mean the
  // grid is coarser than it should be.
  CHECK(slack_sum / slack_n < 2.0 / 255);
}

TEST_CASE("a quantized node leaves axes it cannot quantize unbounded", "[accel][bvh][quantized]") {
  constexpr Float big = std::numeric_limits<Float>::max();
  Bounds3f box[2];
  box[0].min = {-big, 0, 1};
  box[0].max = {big, 1, 1};
  box[1].min = {0, 2, 1};
  box[1].max = {1, 3, 1};
  detail::BVHQuantWideNode n;
  detail::set_boxes(n, box, 2);
  CHECK(std::isnan(n.origin[0]));  // extent 2 * FLT_MAX
  CHECK(n.origin[1] == 0);
  CHECK(n.origin[2] == 1);  // flat: scale 0
  CHECK(n.exp[2] == 0);
  for (int l = 0; l < 2; ++l) {
    Bounds3f q = detail::dequantized_box(n, l);
    CHECK(std::isnan(q.min.x));
    CHECK(q.min.y <= box[l].min.y);
    CHECK(q.max.y >= box[l].max.y);
    CHECK(q.min.z == 1);
    CHECK(q.max.z == 1);
  }
  // An infinite child bound also leaves its axis unbounded.
  box[1].max.y = infinity;
  detail::set_boxes(n, box, 2);
  CHECK(std::isnan(n.origin[1]));
}

TEST_CASE("a ray entering a child's box enters its quantized lane no later", "[accel][bvh][quantized]") {
  // The lane test on the float node against the
  // quantized node's, for rays from random origins towards the boxes, some
  // axis-aligned (infinite inv_d) and some grazing a box face.
  PCG32 rng(12, 0x9a);
  int rays = 0, entered = 0, culled = 0, later = 0, inside_wrong = 0;
  std::string first;
  for (int it = 0; it < 4000; ++it) {
    Bounds3f box[W];
    int k = random_children(rng, box);
    detail::BVHQuantWideNode qn;
    detail::BVHFloatWideNode fn;
    detail::set_boxes(qn, box, k);
    detail::set_boxes(fn, box, k);
    for (int j = 0; j < 16; ++j) {
      const Bounds3f& target = box[rng.next_u32() % uint32_t(k)];
      // A point in (or on a face of) the target box and a ray through it.
      Point3f p;
      for (int a = 0; a < 3; ++a) {
        Float u = rng.next_float();
        if (rng.next_u32() % 4 == 0) u = rng.next_float() < 0.5f ? 0 : 1;
        p[a] = target.min[a] + u * (target.max[a] - target.min[a]);
        if (!std::isfinite(p[a])) p[a] = target.min[a];
      }
      Vector3f d = random_unit(rng);
      if (rng.next_u32() % 4 == 0) {
        int a = int(rng.next_u32() % 3);
        d = Vector3f(0, 0, 0);
        d[a] = rng.next_float() < 0.5f ? -1 : 1;
      }
      Vector3f diag = target.diagonal();
      Float dist = 2 * std::max({diag.x, diag.y, diag.z}) + std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}) * 1e-3f + 1;
      Point3f o = p - d * dist;
      Float t_max = rng.next_float() < 0.5f ? infinity : dist * 2;
      detail::WideRayPrecomp r{RayBoxPrecomp(o, d)};
      alignas(32) Float tf[W], tq[W];
      const Float t_cull = detail::widen_exit(t_max);
      int mf = detail::intersect_wide(fn, r, t_cull, tf);
      int mq = detail::intersect_wide(qn, r, t_cull, tq);
#if defined(PRISM_BVH_AVX_NODES) && defined(__AVX2__)
      // The vector of lanes entered (push_by_distance's input): the mask's
      // bits, the unused lanes clear, compared lane by lane in full (not
      // just sign bits).
      {
        detail::LaneMaskV vf, vq;
        alignas(32) Float t2[W];
        if (detail::intersect_wide(fn, r, t_cull, t2, &vf) != mf ||
            !test::same_lanes(vf, detail::lanes_inside(unsigned(mf))) ||
            detail::intersect_wide(qn, r, t_cull, t2, &vq) != mq ||
            !test::same_lanes(vq, detail::lanes_inside(unsigned(mq))))
          ++inside_wrong;
      }
#endif
      ++rays;
      for (int l = 0; l < k; ++l) {
        if (!(mf >> l & 1)) continue;
        ++entered;
        if (!(mq >> l & 1)) {
          if (culled++ == 0 && first.empty()) first = "culled lane of " + describe(box[l]);
        } else if (!(tq[l] <= tf[l])) {
          if (later++ == 0 && first.empty()) first = "later entry into " + describe(box[l]);
        }
      }
      if (mq & ~((1 << k) - 1)) ++culled;  // an unused lane entered
    }
  }
  INFO(rays << " rays, " << entered << " lanes entered exactly, " << culled << " culled by the quantized node, "
            << later << " entered later; first: " << first);
  CHECK(entered > rays / 2);
  CHECK(culled == 0);
  CHECK(later == 0);
  CHECK(inside_wrong == 0);
}

}  // namespace quantized_node_test
