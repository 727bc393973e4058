// prism/accel/bvh/node.hpp — the BVH's node layouts: BVHNode, the binary
// tree's 32-byte node (the build's output), and the wide nodes traversal
// runs on, with float boxes (BVHFloatWideNode) or boxes quantized to bytes
// (BVHQuantWideNode, -DPRISM_BVH_QUANTIZED=1); set_boxes and lane_box write
// and read a lane's box in either. detail::BVHWideNode is the one this build
// traverses.
#pragma once
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <iterator>
#include <limits>
#include "prism/accel/bvh/simd.hpp"
#include "prism/math/bounds.hpp"

namespace prism {

struct alignas(32) BVHNode {
  Float bmin[3];
  uint32_t offset;  // leaf: first primitive; interior: index of the second child
  Float bmax[3];
  uint32_t count;   // primitives in a leaf; 0 for an interior node

  bool is_leaf() const { return count != 0; }
  Bounds3f bounds() const {
    Bounds3f b;
    b.min = {bmin[0], bmin[1], bmin[2]};
    b.max = {bmax[0], bmax[1], bmax[2]};
    return b;
  }
};
static_assert(sizeof(BVHNode) == 32);

namespace detail {

// Up to wide_width children of the binary tree, gathered under one node for
// traversal. Boxes are stored as structure of arrays: b[2W * axis + W * side +
// lane] (W = wide_width), side 0 = min, 1 = max. Unused lanes hold an empty
// box (+inf, -inf) and an empty leaf, so they are never entered by a ray
// without NaNs and are harmless for one with them.
struct alignas(64) BVHFloatWideNode {
  static constexpr uint32_t interior = UINT32_MAX;
  Float b[6 * wide_width];
  uint32_t child[wide_width];  // interior: index of a wide node; leaf: first primitive (leaf order)
  uint32_t count[wide_width];  // leaf: primitive count; interior: `interior`
};
static_assert(sizeof(BVHFloatWideNode) == 32 * wide_width);

#if PRISM_BVH_W <= 8  // (quantized nodes are at most 8 wide: `lanes` is a byte)
// The compact layout (-DPRISM_BVH_QUANTIZED=1), after Ylitie et al. 2017
// ("Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide BVHs")
// and Embree's compressed nodes: per node and axis an origin and a power-of-
// two scale 2^(e - 127) (e a byte: the bits of a float's exponent field; e = 0
// means scale 0), per child and axis two bytes q, the planes being
//   plane(q) = origin + q * scale.
// 128 bytes for 8 children (the boxes in the first cache line, the links in
// the second), 72 for 4.
//
// Why the box test stays conservative. (1) For 1 <= e <= 246 the product
// q * 2^(e - 127) (q < 256) is exact: 8 significant bits scaled by a power of
// two between 2^-126 and 2^119, so neither underflow nor overflow; for e = 0
// it is +0. So origin + q * scale has one rounding whether or not it is
// contracted to an FMA, and traversal (any SIMD path) computes bit for bit the
// plane that the builder computes with dequantize() below. (2) The builder
// checks those computed planes, not real-number ones: it picks for each child
// the largest q whose plane is <= the child's float min and the smallest whose
// plane is >= its float max (plane(q) is non-decreasing in q, rounding being
// monotonic; plane(0) = origin = the node's min and plane(255) >= the node's
// max by the choice of scale). So the box traversal tests contains the child's
// box. (3) On that float box the slab test is slab_lanes', robust in the
// sense of Ize 2013 (exact path: far distance widened by widen_exit;
// directed-FMA path: see WideRayPrecomp): no box the ray really enters is
// culled, and the entry distance it reports is at most the exact box's
// (within the rounding that the culling of deferred children allows for),
// so sorting and that culling stay conservative. An axis that cannot be quantized (non-finite or
// inverted child bounds, or an extent beyond 255 * 2^119) gets origin NaN:
// its planes are NaN, which the slab test ignores (every comparison with NaN
// keeps the running value), so that axis culls nothing. Unused lanes are not
// in `lanes` and are never entered.
struct alignas(wide_width == 8 ? 64 : 8) BVHQuantWideNode {
  static constexpr uint32_t interior = UINT32_MAX;
  Float origin[3];
  uint8_t exp[3];
  uint8_t lanes;                // bit l: lane l holds a child
  uint8_t q[6 * wide_width];    // q[2W * axis + W * side + lane], side 0 = min, 1 = max
  uint32_t child[wide_width];
  uint32_t count[wide_width];
};
static_assert(sizeof(BVHQuantWideNode) == 16 + 14 * wide_width);

// The plane q of an axis with the given origin and scale exponent byte.
inline Float quant_scale(uint8_t e) { return std::bit_cast<Float>(uint32_t(e) << 23); }
inline Float dequantize(Float origin, uint8_t e, int q) { return origin + Float(q) * quant_scale(e); }

// Fills the boxes of a quantized node from the k children's float boxes (see
// BVHQuantWideNode for why the result contains them); the links (child,
// count) are left as they are.
inline void set_boxes(BVHQuantWideNode& n, const Bounds3f* box, int k) {
  constexpr int W = wide_width;
  constexpr int max_e = 246;  // scale 2^119: 255 * scale stays below 2^127
  std::fill(std::begin(n.q), std::end(n.q), uint8_t(0));
  n.lanes = uint8_t((1u << k) - 1);
  for (int a = 0; a < 3; ++a) {
    uint8_t* qlo = n.q + 2 * W * a;
    uint8_t* qhi = qlo + W;
    Float lo = infinity, hi = -infinity;
    bool ok = k > 0;
    for (int l = 0; l < k; ++l) {
      Float bl = box[l].min[a], bh = box[l].max[a];
      if (!(std::isfinite(bl) && std::isfinite(bh) && bl <= bh)) ok = false;
      lo = std::min(lo, bl);
      hi = std::max(hi, bh);
    }
    int e = 0;
    if (ok && hi > lo) {
      // The smallest scale 2^s with 255 * 2^s >= hi - lo (in double: exact).
      int p;
      double m = std::frexp((double(hi) - double(lo)) / 255.0, &p);
      int s = std::max(m == 0.5 ? p - 1 : p, -126);
      e = s + 127;
      while (e <= max_e && dequantize(lo, uint8_t(e), 255) < hi) ++e;  // rounding (not expected)
      if (e > max_e) ok = false;
    }
    if (!ok) {
      n.origin[a] = std::numeric_limits<Float>::quiet_NaN();
      n.exp[a] = 0;
      continue;
    }
    n.origin[a] = lo;
    n.exp[a] = uint8_t(e);
    double scale = double(quant_scale(uint8_t(e)));
    auto plane = [&](int q) { return dequantize(lo, uint8_t(e), q); };
    for (int l = 0; l < k; ++l) {
      Float bl = box[l].min[a], bh = box[l].max[a];
      int ql = 0, qh = 0;
      if (scale > 0) {
        ql = int(std::clamp(std::floor((double(bl) - double(lo)) / scale), 0.0, 255.0));
        qh = int(std::clamp(std::ceil((double(bh) - double(lo)) / scale), 0.0, 255.0));
      }
      // The largest plane <= bl and the smallest >= bh (plane(0) = lo <= bl,
      // plane(255) >= hi >= bh).
      while (ql > 0 && plane(ql) > bl) --ql;
      while (ql < 255 && plane(ql + 1) <= bl) ++ql;
      while (qh < 255 && plane(qh) < bh) ++qh;
      while (qh > 0 && plane(qh - 1) >= bh) --qh;
      qlo[l] = uint8_t(ql);
      qhi[l] = uint8_t(qh);
    }
  }
}
// The box traversal tests for lane l (NaN planes on an unquantized axis).
inline Bounds3f dequantized_box(const BVHQuantWideNode& n, int l) {
  constexpr int W = wide_width;
  Bounds3f b;
  for (int a = 0; a < 3; ++a) {
    b.min[a] = dequantize(n.origin[a], n.exp[a], n.q[2 * W * a + l]);
    b.max[a] = dequantize(n.origin[a], n.exp[a], n.q[2 * W * a + W + l]);
  }
  return b;
}
// The box traversal tests for lane l of a node of either layout.
inline Bounds3f lane_box(const BVHQuantWideNode& n, int l) { return dequantized_box(n, l); }
#endif
inline Bounds3f lane_box(const BVHFloatWideNode& n, int l) {
  constexpr int W = wide_width;
  Bounds3f b;
  for (int a = 0; a < 3; ++a) {
    b.min[a] = n.b[2 * W * a + l];
    b.max[a] = n.b[2 * W * a + W + l];
  }
  return b;
}
// The same for a float node: lanes from k on get the empty box (+inf, -inf).
// A NaN bound (which the builder's unions never produce) is stored as an
// unbounded one, -inf or +inf: the exact slab test ignores NaN planes, the
// directed-FMA one needs them not to be NaN, and both then agree.
inline void set_boxes(BVHFloatWideNode& n, const Bounds3f* box, int k) {
  constexpr int W = wide_width;
  for (int l = 0; l < W; ++l)
    for (int a = 0; a < 3; ++a) {
      Float lo = l < k ? box[l].min[a] : infinity, hi = l < k ? box[l].max[a] : -infinity;
      n.b[2 * W * a + l] = std::isnan(lo) ? -infinity : lo;
      n.b[2 * W * a + W + l] = std::isnan(hi) ? infinity : hi;
    }
}

#if defined(PRISM_BVH_QUANTIZED) && PRISM_BVH_QUANTIZED
using BVHWideNode = BVHQuantWideNode;
#else
using BVHWideNode = BVHFloatWideNode;
#endif

}  // namespace detail
}  // namespace prism
