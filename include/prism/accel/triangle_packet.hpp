// prism/accel/triangle_packet.hpp — four, eight or sixteen triangles stored side by side and
// intersected with one ray at once: the watertight test of
// geometry/triangle.hpp (Woop, Benthin & Wald 2013, with pbrt-v4's bound on
// the rounding error of t), lane for lane the same operations in the same
// order, so a lane's verdict and t are bit for bit the scalar test's.
//
// The SIMD path runs on SSE2 (4-wide packets), AVX (8-wide) or AVX-512
// (16-wide, its comparisons in mask registers), chosen from the compiler's
// flags. The edge functions are difference_of_products, as in
// the scalar test: two FMAs where the hardware has FMA, otherwise products
// of floats taken exactly in double (math/float.hpp). With
// PRISM_BVH_NO_SIMD, or 8-wide packets without AVX and FMA (16-wide without
// 512-bit AVX-512), each lane goes
// through the scalar test. Lanes that the single-precision test cannot decide
// (an edge function exactly zero, which the scalar test re-evaluates in
// double, or a t too small to be proven positive) are handed to the scalar
// test too, so both paths give the same answers.
#pragma once
#include <algorithm>
#include <cstdint>
#include <optional>
#include "prism/attributes.hpp"
#include "prism/geometry/triangle.hpp"

// The packet width: PRISM_TRIANGLE_PACKET_WIDTH if the user sets it (4, 8
// or 16), otherwise 16 where the compiler may use 512-bit AVX-512 registers
// (whose FMA instructions are part of AVX-512F), 8 where it may use AVX and
// FMA, and 4 elsewhere. With the default BVHBuildOptions::max_leaf_size,
// MeshAccel's leaves hold one packet when it is 8 or 16 wide (two of 4), so
// the width also sets the leaf size. docs/performance.md has the
// measurements behind the default (sixteen lanes were measured on AMD Zen 5,
// whose vector units are 512 bits wide; where 512-bit operations run at half
// rate or lower the clock, 8 may be the better choice).
#if defined(PRISM_TRIANGLE_PACKET_WIDTH)
#define PRISM_TRIANGLE_PACKET_W PRISM_TRIANGLE_PACKET_WIDTH
#elif defined(PRISM_AVX512_ZMM) && defined(PRISM_FAST_FMAF) && !defined(PRISM_BVH_NO_SIMD)
#define PRISM_TRIANGLE_PACKET_W 16
#elif defined(__FMA__) && defined(__AVX__) && defined(PRISM_FAST_FMAF) && !defined(PRISM_BVH_NO_SIMD)
#define PRISM_TRIANGLE_PACKET_W 8
#else
#define PRISM_TRIANGLE_PACKET_W 4
#endif

#if defined(PRISM_BVH_NO_SIMD)
#elif PRISM_TRIANGLE_PACKET_W == 16
#if defined(PRISM_AVX512_ZMM) && defined(PRISM_FAST_FMAF)
#include <immintrin.h>
#define PRISM_TRIANGLE_SIMD 1
#endif
#elif PRISM_TRIANGLE_PACKET_W == 8
#if defined(__FMA__) && defined(__AVX__) && defined(PRISM_FAST_FMAF)
#include <immintrin.h>
#define PRISM_TRIANGLE_SIMD 1
#endif
#elif defined(__FMA__) && defined(__AVX__) && defined(PRISM_FAST_FMAF)
#include <immintrin.h>
#define PRISM_TRIANGLE_SIMD 1
#elif (defined(__SSE2__) || defined(_M_X64)) && !defined(PRISM_FAST_FMAF)
// SSE2 without FMA: the edge functions in double, as difference_of_products.
#include <emmintrin.h>
#define PRISM_TRIANGLE_SIMD 1
#define PRISM_TRIANGLE_SIMD_DOUBLE_EDGES 1
#endif

namespace prism {

inline constexpr int triangle_packet_width = PRISM_TRIANGLE_PACKET_W;
static_assert(triangle_packet_width == 4 || triangle_packet_width == 8 || triangle_packet_width == 16);

// v[3 * vertex + axis][lane]. Unused lanes repeat a triangle of the packet
// (a repeated triangle finds the same hit again, which changes nothing).
// (Aligned to its width in bytes, at most a cache line: one vector load per row.)
struct alignas(std::min(4 * triangle_packet_width, 64)) TrianglePacket {
  Float v[9][triangle_packet_width];

  Point3f vertex(int lane, int k) const { return {v[3 * k][lane], v[3 * k + 1][lane], v[3 * k + 2][lane]}; }
  void set(int lane, const Point3f& p0, const Point3f& p1, const Point3f& p2) {
    const Point3f* p[3] = {&p0, &p1, &p2};
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) v[3 * k + a][lane] = (*p[k])[a];
  }
};
static_assert(sizeof(TrianglePacket) == 36 * triangle_packet_width);

// The closest hit among the lanes of `lanes` (a bit mask) before t_max.
struct PacketHit {
  TriangleHit hit;
  int lane;
};

namespace detail {

// Out of line: lanes reach it only when single precision cannot decide
// (rarely), and the traversal loops that inline the packet test stay small.
PRISM_COLD inline std::optional<TriangleHit> intersect_lane(const TrianglePacket& p, int lane, const Point3f& o,
                                                            const RayTrianglePrecomp& pc, Float t_max) {
  return intersect_triangle(o, pc, t_max, p.vertex(lane, 0), p.vertex(lane, 1), p.vertex(lane, 2));
}

#if defined(PRISM_TRIANGLE_SIMD)
// Four, eight or sixteen lanes, one set of names.
namespace pk {
#if PRISM_TRIANGLE_PACKET_W == 16
// Comparisons give mask registers (M), which band, bor and mask take.
using V = __m512;
using M = __mmask16;
inline V load(const float* p) { return _mm512_load_ps(p); }
inline V set1(float x) { return _mm512_set1_ps(x); }
inline V zero() { return _mm512_setzero_ps(); }
inline V add(V a, V b) { return _mm512_add_ps(a, b); }
inline V sub(V a, V b) { return _mm512_sub_ps(a, b); }
inline V mul(V a, V b) { return _mm512_mul_ps(a, b); }
inline V div(V a, V b) { return _mm512_div_ps(a, b); }
// difference_of_products: c*d, then fma(a, b, -cd) + fma(-c, d, cd).
inline V dop(V a, V b, V c, V d) {
  V cd = _mm512_mul_ps(c, d);
  return _mm512_add_ps(_mm512_fmsub_ps(a, b, cd), _mm512_fnmadd_ps(c, d, cd));
}
// (The zero-masking form with every lane set is the same instruction; GCC 12
// warns that the plain form's undefined pass-through register may be used
// uninitialized.)
inline V vmax(V a, V b) { return _mm512_maskz_max_ps(M(0xffff), a, b); }
inline M band(M a, M b) { return M(a & b); }
inline M bor(M a, M b) { return M(a | b); }
inline M eq(V a, V b) { return _mm512_cmp_ps_mask(a, b, _CMP_EQ_OQ); }
inline M lt(V a, V b) { return _mm512_cmp_ps_mask(a, b, _CMP_LT_OQ); }
inline M le(V a, V b) { return _mm512_cmp_ps_mask(a, b, _CMP_LE_OQ); }
inline M gt(V a, V b) { return _mm512_cmp_ps_mask(a, b, _CMP_GT_OQ); }
inline M ge(V a, V b) { return _mm512_cmp_ps_mask(a, b, _CMP_GE_OQ); }
inline int mask(M a) { return int(a); }
inline void store(float* p, V a) { _mm512_store_ps(p, a); }
inline V abs(V a) { return _mm512_abs_ps(a); }
#elif PRISM_TRIANGLE_PACKET_W == 8
using V = __m256;
inline V load(const float* p) { return _mm256_load_ps(p); }
inline V set1(float x) { return _mm256_set1_ps(x); }
inline V zero() { return _mm256_setzero_ps(); }
inline V add(V a, V b) { return _mm256_add_ps(a, b); }
inline V sub(V a, V b) { return _mm256_sub_ps(a, b); }
inline V mul(V a, V b) { return _mm256_mul_ps(a, b); }
inline V div(V a, V b) { return _mm256_div_ps(a, b); }
// difference_of_products: c*d, then fma(a, b, -cd) + fma(-c, d, cd).
inline V dop(V a, V b, V c, V d) {
  V cd = _mm256_mul_ps(c, d);
  return _mm256_add_ps(_mm256_fmsub_ps(a, b, cd), _mm256_fnmadd_ps(c, d, cd));
}
inline V vmax(V a, V b) { return _mm256_max_ps(a, b); }
inline V band(V a, V b) { return _mm256_and_ps(a, b); }
inline V bor(V a, V b) { return _mm256_or_ps(a, b); }
inline V eq(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_EQ_OQ); }
inline V lt(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_LT_OQ); }
inline V le(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }
inline V gt(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
inline V ge(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_GE_OQ); }
inline int mask(V a) { return _mm256_movemask_ps(a); }
inline void store(float* p, V a) { _mm256_store_ps(p, a); }
inline V abs(V a) { return _mm256_and_ps(a, _mm256_castsi256_ps(_mm256_set1_epi32(0x7fffffff))); }
#else
using V = __m128;
inline V load(const float* p) { return _mm_load_ps(p); }
inline V set1(float x) { return _mm_set1_ps(x); }
inline V zero() { return _mm_setzero_ps(); }
inline V add(V a, V b) { return _mm_add_ps(a, b); }
inline V sub(V a, V b) { return _mm_sub_ps(a, b); }
inline V mul(V a, V b) { return _mm_mul_ps(a, b); }
inline V div(V a, V b) { return _mm_div_ps(a, b); }
#if defined(PRISM_TRIANGLE_SIMD_DOUBLE_EDGES)
// difference_of_products without FMA: a*b - c*d in double, lane for lane.
inline V dop(V a, V b, V c, V d) {
  auto half = [](__m128 a2, __m128 b2, __m128 c2, __m128 d2) {
    return _mm_cvtpd_ps(_mm_sub_pd(_mm_mul_pd(_mm_cvtps_pd(a2), _mm_cvtps_pd(b2)),
                                   _mm_mul_pd(_mm_cvtps_pd(c2), _mm_cvtps_pd(d2))));
  };
  __m128 lo = half(a, b, c, d);
  __m128 hi = half(_mm_movehl_ps(a, a), _mm_movehl_ps(b, b), _mm_movehl_ps(c, c), _mm_movehl_ps(d, d));
  return _mm_movelh_ps(lo, hi);
}
#else
// difference_of_products: c*d, then fma(a, b, -cd) + fma(-c, d, cd).
inline V dop(V a, V b, V c, V d) {
  V cd = _mm_mul_ps(c, d);
  return _mm_add_ps(_mm_fmsub_ps(a, b, cd), _mm_fnmadd_ps(c, d, cd));
}
#endif
inline V vmax(V a, V b) { return _mm_max_ps(a, b); }
inline V band(V a, V b) { return _mm_and_ps(a, b); }
inline V bor(V a, V b) { return _mm_or_ps(a, b); }
inline V eq(V a, V b) { return _mm_cmpeq_ps(a, b); }
inline V lt(V a, V b) { return _mm_cmplt_ps(a, b); }
inline V le(V a, V b) { return _mm_cmple_ps(a, b); }
inline V gt(V a, V b) { return _mm_cmpgt_ps(a, b); }
inline V ge(V a, V b) { return _mm_cmpge_ps(a, b); }
inline int mask(V a) { return _mm_movemask_ps(a); }
inline void store(float* p, V a) { _mm_store_ps(p, a); }
inline V abs(V a) { return _mm_and_ps(a, _mm_castsi128_ps(_mm_set1_epi32(0x7fffffff))); }
#endif
}  // namespace pk

// The scalar test's arithmetic on a packet's lanes. Returns the mask of lanes with a
// proven hit in (0, t_max); `undecided` gets the lanes that need the scalar
// test. t, e0..e2 and inv_det are written for the hit lanes.
template <int KZ>
inline int intersect_packet_simd(const TrianglePacket& p, const Point3f& o, const RayTrianglePrecomp& pc,
                                 Float t_max, int lanes, int* undecided, pk::V* t_out, pk::V* e_out,
                                 pk::V* inv_det_out) {
  using namespace pk;
  constexpr int KX = (KZ + 1) % 3, KY = (KZ + 2) % 3;
  const V ox = set1(o[KX]), oy = set1(o[KY]), oz = set1(o[KZ]);
  const V sx = set1(pc.sx), sy = set1(pc.sy), sz = set1(pc.sz);
  V x[3], y[3], z[3];
  for (int k = 0; k < 3; ++k) {
    z[k] = sub(load(p.v[3 * k + KZ]), oz);
    x[k] = add(sub(load(p.v[3 * k + KX]), ox), mul(sx, z[k]));
    y[k] = add(sub(load(p.v[3 * k + KY]), oy), mul(sy, z[k]));
  }
  V e0 = dop(x[1], y[2], y[1], x[2]);
  V e1 = dop(x[2], y[0], y[2], x[0]);
  V e2 = dop(x[0], y[1], y[0], x[1]);
  const V z0 = zero();
  auto any_neg = bor(bor(lt(e0, z0), lt(e1, z0)), lt(e2, z0));
  auto any_pos = bor(bor(gt(e0, z0), gt(e1, z0)), gt(e2, z0));
  int live = lanes & ~mask(band(any_neg, any_pos));
  // Edge functions of both signs reject a lane whatever a zero one would be
  // in double: the signs of difference_of_products are exact, so the scalar
  // test's re-evaluation in double keeps them. Of the other lanes, those with
  // a zero edge function go to the scalar test whatever follows.
  if (live == 0) {
    *undecided = 0;
    return 0;
  }
  int zero_edge = mask(bor(bor(eq(e0, z0), eq(e1, z0)), eq(e2, z0)));
  *undecided = live & zero_edge;
  live &= ~zero_edge;
  if (live == 0) return 0;

  V det = add(add(e0, e1), e2);
  auto max3 = [](V a, V b, V c) { return vmax(vmax(abs(a), abs(b)), abs(c)); };
  V max_z = max3(z[0], z[1], z[2]);
  for (int k = 0; k < 3; ++k) z[k] = mul(z[k], sz);
  V t_scaled = add(add(mul(e0, z[0]), mul(e1, z[1])), mul(e2, z[2]));
  V lim = mul(set1(t_max * triangle_range_widen), det);
  // det < 0: reject t_scaled >= 0 or t_scaled < t_max * det; det > 0: reject
  // t_scaled <= 0 or t_scaled > t_max * det; det == 0 (or NaN): reject.
  auto ok_neg = band(lt(det, z0), band(lt(t_scaled, z0), ge(t_scaled, lim)));
  auto ok_pos = band(gt(det, z0), band(gt(t_scaled, z0), le(t_scaled, lim)));
  live &= mask(bor(ok_neg, ok_pos));
  if (live == 0) return 0;

  V inv_det = div(set1(1.0f), det);
  V t = mul(t_scaled, inv_det);
  V max_zt = max3(z[0], z[1], z[2]);
  V max_xt = max3(x[0], x[1], x[2]);
  V max_yt = max3(y[0], y[1], y[2]);
  V delta_z = mul(set1(gamma(3)), max_zt);
  V delta_x = mul(set1(gamma(5)), add(max_xt, max_z));
  V delta_y = mul(set1(gamma(5)), add(max_yt, max_z));
  V delta_e = mul(set1(2.0f), add(add(mul(mul(set1(gamma(2)), max_xt), max_yt), mul(delta_y, max_xt)),
                                   mul(delta_x, max_yt)));
  V max_e = max3(e0, e1, e2);
  V delta_t = mul(mul(set1(3.0f), add(add(mul(mul(set1(gamma(3)), max_e), max_zt), mul(delta_e, max_zt)),
                                      mul(delta_z, max_e))),
                  abs(inv_det));
  // A t at or beyond t_max (or not finite) is rejected; a t that is not provably positive is
  // decided by the scalar test (in double).
  live &= mask(lt(t, set1(t_max)));
  int proven = mask(gt(t, delta_t));
  *undecided |= live & ~proven;
  live &= proven;
  *t_out = t;
  e_out[0] = e0;
  e_out[1] = e1;
  e_out[2] = e2;
  *inv_det_out = inv_det;
  return live;
}
#endif

}  // namespace detail

// Closest hit before t_max among the lanes in `lanes` (bit l = lane l), for a
// ray whose largest direction component is KZ (pc's permutation).
template <int KZ>
inline std::optional<PacketHit> intersect_packet(const TrianglePacket& p, const Point3f& o,
                                                 const RayTrianglePrecomp& pc, Float t_max, int lanes) {
  std::optional<PacketHit> best;
#if defined(PRISM_TRIANGLE_SIMD)
  int undecided = 0;
  detail::pk::V t, e[3], inv_det;
  int hit = detail::intersect_packet_simd<KZ>(p, o, pc, t_max, lanes, &undecided, &t, e, &inv_det);
  if (hit != 0) {
    constexpr int W = triangle_packet_width;
    alignas(64) Float ts[W];
    detail::pk::store(ts, t);
    int l = std::countr_zero(unsigned(hit));
    for (int m = hit & (hit - 1); m != 0; m &= m - 1) {
      int c = std::countr_zero(unsigned(m));
      if (ts[c] < ts[l]) l = c;
    }
    alignas(64) Float es[3][W], id[W];
    for (int k = 0; k < 3; ++k) detail::pk::store(es[k], e[k]);
    detail::pk::store(id, inv_det);
    best = PacketHit{{ts[l], es[0][l] * id[l], es[1][l] * id[l], es[2][l] * id[l]}, l};
    t_max = ts[l];
  }
  for (; undecided != 0; undecided &= undecided - 1) {
    int l = std::countr_zero(unsigned(undecided));
    if (auto h = detail::intersect_lane(p, l, o, pc, t_max)) {
      best = PacketHit{*h, l};
      t_max = h->t;
    }
  }
#else
  for (; lanes != 0; lanes &= lanes - 1) {
    int l = std::countr_zero(unsigned(lanes));
    if (auto h = detail::intersect_lane(p, l, o, pc, t_max)) {
      best = PacketHit{*h, l};
      t_max = h->t;
    }
  }
#endif
  return best;
}

// Whether any lane in `lanes` is hit before t_max.
template <int KZ>
inline bool occluded_packet(const TrianglePacket& p, const Point3f& o, const RayTrianglePrecomp& pc, Float t_max,
                            int lanes) {
#if defined(PRISM_TRIANGLE_SIMD)
  int undecided = 0;
  detail::pk::V t, e[3], inv_det;
  if (detail::intersect_packet_simd<KZ>(p, o, pc, t_max, lanes, &undecided, &t, e, &inv_det) != 0) return true;
  lanes = undecided;
#endif
  for (; lanes != 0; lanes &= lanes - 1)
    if (detail::intersect_lane(p, std::countr_zero(unsigned(lanes)), o, pc, t_max)) return true;
  return false;
}

}  // namespace prism
