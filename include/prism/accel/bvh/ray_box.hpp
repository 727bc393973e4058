// prism/accel/bvh/ray_box.hpp — ray–box tests, robust in the sense of Ize
// 2013: RayBoxPrecomp and intersect_node for a binary node, with the
// widening of exit distances (detail::widen_exit) that the argument rests on;
// WideRayPrecomp and intersect_wide for every lane of a wide node at once
// (the exact path, and with AVX2 and FMA the directed-FMA one).
#pragma once
#include <cmath>
#include <cstddef>
#include <cstdint>
#include "prism/accel/bvh/node.hpp"
#include "prism/accel/bvh/simd.hpp"
#include "prism/math/float.hpp"
#include "prism/math/vector.hpp"

namespace prism {

// Per-ray data for box tests.
struct RayBoxPrecomp {
  Float o[3], inv_d[3];
  int sign[3];
  explicit RayBoxPrecomp(const Point3f& org, const Vector3f& d) {
    o[0] = org.x; o[1] = org.y; o[2] = org.z;
    inv_d[0] = 1 / d.x; inv_d[1] = 1 / d.y; inv_d[2] = 1 / d.z;
    for (int i = 0; i < 3; ++i) sign[i] = inv_d[i] < 0 ? 1 : 0;
  }
};

namespace detail {

// How the box tests enlarge an exit distance t before comparing it with an
// entry distance: widen_exit(t) = (t + 2^-147) (1 + 2 gamma(5)), rounded
// twice, as Ize 2013's 1 + 2 gamma(3) but also covering distances in the
// subnormal range and the rounding of the widening itself.
// Why it suffices. With u = 2^-24, a computed slab distance
// fl(fl(b - o) fl(1 / d)) is within three roundings of the exact (b - o) / d:
// for a result x >= 0 a rounding gives at most x (1 + u) + 2^-150 and at
// least x (1 - u) - 2^-150, the absolute term for results that underflow (a
// product's error is not relative there; a difference that underflows is
// exact). So the computed entry t0 (the largest near distance and 0) is at
// most E (1 + u)^3 + 2^-150, and if the exact ray meets the box (0 <= E <= X)
// the computed exit t1 (the least far distance and t_max) is at least
// X (1 - u)^3 - 2^-150, so t1 >= -0 and
//   t0 <= (t1 + 2^-150) r + 2^-150,  r = (1 + u)^3 / (1 - u)^3 < 1 + 6u + 19u^2.
// The constant 1 + 2 gamma(5) rounds to w = 1 + 10u, and
// widen_exit(t1) >= (t1 + 2^-147) (1 - u)^2 w - 2^-150, where
// (1 - u)^2 w > 1 + 8u - 19u^2 > r and 2^-147 (1 - u)^2 w exceeds
// 2^-150 (r + 2): so widen_exit(t1) >= t0. (1 / d must be a normal float:
// |d| <= 2^126.) An addition followed by a product cannot be contracted to
// an FMA, so every path computes it bit for bit alike.
inline constexpr Float box_exit_slack = 0x1p-147f;
inline constexpr Float box_exit_widen = 1 + 2 * gamma(5);
inline Float widen_exit(Float t) { return (t + box_exit_slack) * box_exit_widen; }

}  // namespace detail

// Entry distance of the ray into the node's box, or +inf when it misses or the
// box lies beyond t_max.
inline Float intersect_node(const BVHNode& n, const RayBoxPrecomp& r, Float t_max) {
  const Float* lo = n.bmin;
  const Float* hi = n.bmax;
  Float tx0 = ((r.sign[0] ? hi : lo)[0] - r.o[0]) * r.inv_d[0];
  Float tx1 = ((r.sign[0] ? lo : hi)[0] - r.o[0]) * r.inv_d[0];
  Float ty0 = ((r.sign[1] ? hi : lo)[1] - r.o[1]) * r.inv_d[1];
  Float ty1 = ((r.sign[1] ? lo : hi)[1] - r.o[1]) * r.inv_d[1];
  Float tz0 = ((r.sign[2] ? hi : lo)[2] - r.o[2]) * r.inv_d[2];
  Float tz1 = ((r.sign[2] ? lo : hi)[2] - r.o[2]) * r.inv_d[2];
  // NaN (0 * inf on a slab boundary) loses every comparison and is ignored.
  Float t0 = tx0 > 0 ? tx0 : 0;
  t0 = ty0 > t0 ? ty0 : t0;
  t0 = tz0 > t0 ? tz0 : t0;
  Float t1 = tx1 < t_max ? tx1 : t_max;
  t1 = ty1 < t1 ? ty1 : t1;
  t1 = tz1 < t1 ? tz1 : t1;
  return t0 <= detail::widen_exit(t1) ? t0 : infinity;
}

namespace detail {

// Per-ray data for the lane-parallel box tests: the offsets in BVHWideNode::b
// of the near and far slab planes per axis, chosen by the direction's sign as
// in intersect_node.
//
// With AVX2 and FMA (PRISM_BVH_FMA_SLABS) a ray normally takes a shorter
// path: the distance to a plane b is one FMA, b * inv - c, and the entry and
// exit distances are combined with integer max and min (for floats that are
// not NaN, the signed-integer order of their bits is their order as numbers,
// with every negative value below +0). It stays conservative (Ize 2013's
// concern) as follows. Let T = (b - o) / d be the exact distance, u = 2^-24,
// and inv = fl(1 / d), so inv d is in [1 - u, 1 + u].
// - c_near is fl(o inv) moved up by two ulps, so c_near >= o inv plus at
//   least half an ulp; the FMA's exact value b inv - c_near is then at most
//   (b - o) inv = T (inv d), and after its one rounding the near distance is
//   at most T (1 + u)^2 for T >= 0 (half a subnormal ulp is covered by the
//   slack of c_near) and at most 0 for T <= 0.
// - c_far is fl(o inv) moved down by two ulps: the far distance is at least
//   T (1 - u)^2 for T >= 0, and negative only when T is.
// So the computed entry is at most E (1 + u)^2 and the computed exit at least
// X (1 - u)^2, E and X the exact entry and exit; the test compares the entry
// with the exit raised by five ulps (five added to its bits: at least a
// factor 1 + 5u > (1 + u)^2 / (1 - u)^2), and a box that the exact ray meets
// before t_max is entered. For rays with a zero (or nearly zero) direction
// component, an origin so far out that o inv nears overflow (|inv| or |c|
// beyond 2^100), or NaNs, `fast` is false and the exact form of
// intersect_node is used instead. The argument assumes the IEEE default
// mode (round to nearest, no flush-to-zero or denormals-are-zero: the slack
// of c is subnormal near zero) and t_max >= +0.

struct WideRayPrecomp {
#if defined(PRISM_BVH_SSE)
  bx::V o[3], inv_d[3];
#if defined(PRISM_BVH_FMA_SLABS)
  bx::V c_near[3], c_far[3];
  bx::V six;  // integer 6 in every lane (a memory operand in the loop, not rebuilt per visit)
#endif
#else
  Float o[3], inv_d[3];
#endif
  std::ptrdiff_t near_off[3], far_off[3];  // pointer-sized: no sign extension per load
  bool fast = false;  // the directed-FMA path (PRISM_BVH_FMA_SLABS only)
  // From a ray: the same values as from RayBoxPrecomp(org, d), in fewer steps
  // (one division for the three axes where SSE is available).
  WideRayPrecomp(const Point3f& org, const Vector3f& d) {
#if defined(PRISM_BVH_SSE)
    init(_mm_setr_ps(org.x, org.y, org.z, 0), _mm_div_ps(_mm_set1_ps(1), _mm_setr_ps(d.x, d.y, d.z, 1)));
#else
    init(RayBoxPrecomp(org, d));
#endif
  }
  explicit WideRayPrecomp(const RayBoxPrecomp& r) {
#if defined(PRISM_BVH_SSE)
    init(_mm_setr_ps(r.o[0], r.o[1], r.o[2], 0), _mm_setr_ps(r.inv_d[0], r.inv_d[1], r.inv_d[2], 1));
#else
    init(r);
#endif
  }

 private:
  void set_offsets(int neg) {  // bit a of neg: the direction's axis a is negative (RayBoxPrecomp::sign)
    for (int a = 0; a < 3; ++a) {
      near_off[a] = 2 * wide_width * a + wide_width * ((neg >> a) & 1);
      far_off[a] = near_off[a] ^ wide_width;  // the other half of the axis's 2 wide_width planes
    }
  }
#if defined(PRISM_BVH_SSE)
  // org and inv: the origin and 1 / d in lanes 0-2, lane 3 = 0 and 1.
  void init(__m128 org, __m128 inv) {
    alignas(16) Float ov[4], iv[4];
    _mm_store_ps(ov, org);
    _mm_store_ps(iv, inv);
    for (int a = 0; a < 3; ++a) {
      o[a] = bx::set1(ov[a]);
      inv_d[a] = bx::set1(iv[a]);
    }
    set_offsets(_mm_movemask_ps(_mm_cmplt_ps(inv, _mm_setzero_ps())));
#if defined(PRISM_BVH_FMA_SLABS)
    // The next float above x (x finite; -0 is taken as +0 first): the
    // magnitude is in the low bits.
    auto up = [](__m128 x) {
      __m128i b = _mm_castps_si128(_mm_add_ps(x, _mm_setzero_ps()));
      __m128i step = _mm_or_si128(_mm_srai_epi32(b, 31), _mm_set1_epi32(1));  // -1 if negative, else +1
      return _mm_castsi128_ps(_mm_add_epi32(b, step));
    };
    const __m128 neg = _mm_set1_ps(-0.0f);
    const __m128 p = _mm_mul_ps(org, inv);
    const __m128 cn = up(up(p));
    const __m128 cf = _mm_xor_ps(up(up(_mm_xor_ps(p, neg))), neg);
    // All finite and in range: |inv| in [2^-100, 2^100), |c| < 2^100.
    const __m128 lim = _mm_set1_ps(0x1p100f);
    auto mag = [&](__m128 x) { return _mm_andnot_ps(neg, x); };
    __m128 ok = _mm_and_ps(_mm_cmplt_ps(mag(inv), lim), _mm_cmpge_ps(mag(inv), _mm_set1_ps(0x1p-100f)));
    ok = _mm_and_ps(ok, _mm_and_ps(_mm_cmplt_ps(mag(cn), lim), _mm_cmplt_ps(mag(cf), lim)));
    fast = (_mm_movemask_ps(ok) & 7) == 7;
    six = bx::as_v(bx::iadd(bx::izero(), 6));
    alignas(16) Float v[2][4];
    _mm_store_ps(v[0], cn);
    _mm_store_ps(v[1], cf);
    for (int a = 0; a < 3; ++a) {
      c_near[a] = bx::set1(v[0][a]);
      c_far[a] = bx::set1(v[1][a]);
    }
#endif
  }
#else
  void init(const RayBoxPrecomp& r) {
    for (int a = 0; a < 3; ++a) {
      o[a] = r.o[a];
      inv_d[a] = r.inv_d[a];
    }
    set_offsets(r.sign[0] | r.sign[1] << 1 | r.sign[2] << 2);
  }
#endif
};

// The slab test of a wide node's lanes, given their near and far planes per
// axis: returns the mask of lanes entered before t_cull = widen_exit(t_max)
// and writes their entry distances to t_entry.
//
// On the exact path, the operations and their order (including which operand
// wins a comparison with a NaN) are intersect_node's, so every lane's mask bit
// and entry distance are bit for bit intersect_node's with t_max: max(a, b)
// below is a > b ? a : b and min(a, b) is a < b ? a : b, lane by lane, and
// min(widen_exit(A), widen_exit(t_max)) = widen_exit(min(A, t_max)) because
// rounding is monotonic.
// On the directed-FMA path (WideRayPrecomp::fast) the entry distance is at
// most the exact one times (1 + u)^2 and no box the exact ray meets is culled;
// t_cull also keeps its widening there, which covers the rounding of the
// triangle test's t (a hit computed before t_max is never culled).
#if defined(PRISM_BVH_SSE)
// `inside`, if given, gets the lanes entered as a vector, each lane all ones
// or all zeros (the mask's bits). It is written when given, and
// slab_lane_groups gives it only when a node's lanes fill one register; only
// the AVX2 ordering of 8-wide nodes reads it (push_by_distance), which then
// need not rebuild it from the mask.
// Every lane's entry distance, entered or not, is >= +0 (sign bit clear):
// t0 starts at +0 and a NaN plane distance never wins the max.
inline int slab_lanes(const bx::V* pn, const bx::V* pf, const WideRayPrecomp& r, Float t_cull, Float* t_entry,
                      bx::V* inside = nullptr) {
  using namespace bx;
#if defined(PRISM_BVH_FMA_SLABS)
  if (r.fast) {
    I tn[3], tf[3];
    for (int a = 0; a < 3; ++a) {
      tn[a] = fmsub_bits(pn[a], r.inv_d[a], r.c_near[a]);
      tf[a] = fmsub_bits(pf[a], r.inv_d[a], r.c_far[a]);
    }
    // No NaN can arise (b finite or infinite, inv and c finite and nonzero).
    I t0 = imax(imax(tn[0], tn[1]), imax(tn[2], izero()));
    I t1 = imin(imin(tf[0], tf[1]), imin(tf[2], bits(set1(t_cull))));
    store_bits(t_entry, t0);
    // Entered: t0 <= t1 raised by five ulps (see WideRayPrecomp), i.e.
    // t1 + 6 > t0 as integers (t1 is at most +inf, so no overflow). t0 >=
    // +0, so t0 <= t1 as numbers exactly when it is as integers. A negative
    // t1 culls, rightly: a far distance is negative (never -0) only when the
    // exact exit is, and t_cull only for a t_max below -2^-147 (a t_max of
    // +-0 gives a small positive t_cull); +inf + 5 ulps is a positive NaN
    // pattern, above every t0. (One comparison whose result is the mask: its
    // complement cost two more operations per visit; ab 1.01-1.02.)
    const auto in = igt(iadd(t1, bits(r.six)), t0);
    keep_inside(inside, in);
    return sign_mask(in);
  }
#endif
  V t0 = zero();
  V t1 = set1(infinity);
  for (int a = 0; a < 3; ++a) {
    V tn = mul(sub(pn[a], r.o[a]), r.inv_d[a]);
    V tf = mul(sub(pf[a], r.o[a]), r.inv_d[a]);
    t0 = vmax(tn, t0);
    t1 = vmin(tf, t1);
  }
  // widen_exit, lane by lane, then min with t_cull.
  t1 = vmin(mul(add(t1, set1(box_exit_slack)), set1(box_exit_widen)), set1(t_cull));
  store(t_entry, t0);
  const auto in = le(t0, t1);
  keep_inside(inside, in);
  return movemask(in);
}
#else
// One lane from its planes (the portable build: the exact path only).
inline bool slab_lane(const Float* pn, const Float* pf, const WideRayPrecomp& r, Float t_cull, Float* t_entry) {
  Float t0 = 0, t1 = infinity;
  for (int a = 0; a < 3; ++a) {
    Float tn = (pn[a] - r.o[a]) * r.inv_d[a];
    Float tf = (pf[a] - r.o[a]) * r.inv_d[a];
    t0 = tn > t0 ? tn : t0;
    t1 = tf < t1 ? tf : t1;
  }
  t1 = widen_exit(t1);
  t1 = t1 < t_cull ? t1 : t_cull;
  *t_entry = t0;
  return t0 <= t1;
}
#endif

// The slab test of every lane of a wide node, a register of lanes at a time
// (sixteen with AVX-512 nodes, eight with AVX nodes, four with SSE, one in the
// portable build):
// planes(h, pn, pf) writes the near and far planes per axis of the lanes
// from h on.
//
// `inside` gets the lanes entered as a vector (see slab_lanes) when a node's
// lanes fill one AVX or SSE register (8-wide nodes on AVX, 4-wide on SSE);
// it is left as it was otherwise (16-wide nodes on AVX-512 too, whose
// verdicts are a mask register). Whether a quantized node's unused lanes
// are cleared in it depends on the build: see intersect_wide. Traversal
// reads it only under PRISM_BVH_SORT_AVX2.
#if defined(PRISM_BVH_SSE)
using LaneMaskV = bx::V;
#else
using LaneMaskV = Float;  // (not used: the portable build has no lane vectors)
#endif
template <class Planes>
inline int slab_lane_groups(const WideRayPrecomp& r, Float t_cull, Float* t_entry, Planes&& planes,
                            [[maybe_unused]] LaneMaskV* inside) {
  int mask = 0;
#if defined(PRISM_BVH_SSE)
  constexpr int G = int(sizeof(bx::V) / sizeof(Float));
  if constexpr (G == wide_width) {
    bx::V pn[3], pf[3];
    planes(0, pn, pf);
    return slab_lanes(pn, pf, r, t_cull, t_entry, inside);
  }
  for (int h = 0; h < wide_width; h += G) {
    bx::V pn[3], pf[3];
    planes(h, pn, pf);
    mask |= slab_lanes(pn, pf, r, t_cull, t_entry + h) << h;
  }
#else
  for (int l = 0; l < wide_width; ++l) {
    Float pn[3], pf[3];
    planes(l, pn, pf);
    if (slab_lane(pn, pf, r, t_cull, t_entry + l)) mask |= 1 << l;
  }
#endif
  return mask;
}

// The slab test of every lane of a float node (see slab_lanes).
inline int intersect_wide(const BVHFloatWideNode& n, const WideRayPrecomp& r, Float t_cull, Float* t_entry,
                          LaneMaskV* inside = nullptr) {
  return slab_lane_groups(r, t_cull, t_entry, [&](int h, auto* pn, auto* pf) {
    for (int a = 0; a < 3; ++a) {
#if defined(PRISM_BVH_SSE)
      pn[a] = bx::load(n.b + r.near_off[a] + h);
      pf[a] = bx::load(n.b + r.far_off[a] + h);
#else
      pn[a] = n.b[r.near_off[a] + h];
      pf[a] = n.b[r.far_off[a] + h];
#endif
    }
  }, inside);
}

#if PRISM_BVH_W <= 8  // (quantized nodes)
// The same for a quantized node: each lane's planes are dequantized (exactly
// as dequantize() computes them) and then tested as above, so every lane's
// result is the float node's on the box dequantized_box() gives. An axis that
// could not be quantized (origin NaN) is unbounded: NaN planes in the portable
// build (ignored by the exact test), infinite ones in the SIMD builds (the
// directed-FMA path needs planes that are not NaN).
inline int intersect_wide(const BVHQuantWideNode& n, const WideRayPrecomp& r, Float t_cull, Float* t_entry,
                          LaneMaskV* inside = nullptr) {
  int mask = slab_lane_groups(r, t_cull, t_entry, [&](int h, auto* pn, auto* pf) {
    for (int a = 0; a < 3; ++a) {
#if defined(PRISM_BVH_SSE)
      if (std::isnan(n.origin[a])) {
        bool lo_near = r.near_off[a] % (2 * wide_width) == 0;
        pn[a] = bx::set1(lo_near ? -infinity : infinity);
        pf[a] = bx::set1(lo_near ? infinity : -infinity);
        continue;
      }
      const bx::V org = bx::set1(n.origin[a]), scale = bx::set1(quant_scale(n.exp[a]));
      pn[a] = bx::plane(bx::load_u8(n.q + r.near_off[a] + h), scale, org);
      pf[a] = bx::plane(bx::load_u8(n.q + r.far_off[a] + h), scale, org);
#else
      pn[a] = dequantize(n.origin[a], n.exp[a], n.q[r.near_off[a] + h]);
      pf[a] = dequantize(n.origin[a], n.exp[a], n.q[r.far_off[a] + h]);
#endif
    }
  }, inside);
#if defined(PRISM_BVH_AVX_NODES) && defined(__AVX2__)
  // Without the unused lanes, in the one build that reads `inside`
  // (PRISM_BVH_SORT_AVX2); elsewhere it holds only the box test's result.
  if (inside) {
    *inside = _mm256_and_ps(*inside, lanes_inside(n.lanes));
  }
#endif
  return mask & n.lanes;
}
#endif

}  // namespace detail
}  // namespace prism
