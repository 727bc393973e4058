// prism/accel/bvh/simd.hpp — the instruction sets the BVH uses and the node
// width they select: the PRISM_BVH_* macros (SSE, AVX, FMA_SLABS, ZMM, W,
// AVX_NODES, ZMM_NODES), detail::wide_width, and detail::bx, the box test's
// register of lanes (AVX-512, AVX or SSE wrappers of one shape), so that the
// node, ray-box and traversal headers are written once for every width.
#pragma once
#include <cstdint>
#include <cstring>
#include "prism/math/float.hpp"  // Float; PRISM_AVX512_ZMM

// SIMD paths: SSE2 for the build and (without AVX) traversal, AVX for
// traversal; plain C++ otherwise, or with PRISM_BVH_NO_SIMD defined. All
// paths compute the same values.
#if defined(PRISM_BVH_NO_SIMD)
#elif defined(__AVX__)
#include <immintrin.h>
#define PRISM_BVH_AVX 1
#define PRISM_BVH_SSE 1
#elif defined(__SSE2__) || defined(_M_X64) || (defined(_M_IX86_FP) && _M_IX86_FP >= 2)
#include <emmintrin.h>
#define PRISM_BVH_SSE 1
#endif
// With AVX2 and FMA, box tests take the directed-FMA path (see WideRayPrecomp).
#if defined(PRISM_BVH_AVX) && defined(__AVX2__) && defined(__FMA__)
#define PRISM_BVH_FMA_SLABS 1
#endif

namespace prism {
namespace detail {

// The wide nodes' width (wide_width): PRISM_BVH_WIDTH if the user sets it
// (4, 8 or 16), otherwise 16 where the compiler may use 512-bit AVX-512
// registers (512-byte nodes, one AVX-512 pass per visit) and 8 elsewhere
// (256-byte nodes, one AVX pass or two SSE passes per visit; also the width
// of quantized nodes, which are at most 8 wide). 4-wide nodes are 128 bytes,
// one SSE pass. 16-wide nodes without AVX-512 are tested four lanes at a
// time (SSE). The layout depends on the compiler's instruction-set flags:
// every translation unit of a program must be compiled with the same ones
// (or set PRISM_BVH_WIDTH). docs/performance.md has the measurements behind
// the default (16 lanes were measured on AMD Zen 5, whose vector units are
// 512 bits wide).
#if defined(PRISM_BVH_FMA_SLABS) && defined(PRISM_AVX512_ZMM)
#define PRISM_BVH_ZMM 1  // a 16-lane box test is available
#endif
#if defined(PRISM_BVH_WIDTH)
#define PRISM_BVH_W PRISM_BVH_WIDTH
#elif defined(PRISM_BVH_ZMM) && !(defined(PRISM_BVH_QUANTIZED) && PRISM_BVH_QUANTIZED)
#define PRISM_BVH_W 16
#else
#define PRISM_BVH_W 8
#endif
inline constexpr int wide_width = PRISM_BVH_W;
static_assert(wide_width == 4 || wide_width == 8 || wide_width == 16, "PRISM_BVH_WIDTH must be 4, 8 or 16");
#if defined(PRISM_BVH_QUANTIZED) && PRISM_BVH_QUANTIZED && PRISM_BVH_W > 8
#error "quantized BVH nodes are 4 or 8 wide (PRISM_BVH_WIDTH)"
#endif
// The box test's registers: 8 lanes of AVX for 8-wide nodes, 16 of AVX-512
// (with the directed-FMA path) for 16-wide ones; SSE otherwise.
#if defined(PRISM_BVH_AVX) && PRISM_BVH_W == 8
#define PRISM_BVH_AVX_NODES 1
#elif defined(PRISM_BVH_ZMM) && PRISM_BVH_W == 16
#define PRISM_BVH_ZMM_NODES 1
#endif

#if defined(PRISM_BVH_SSE)
// The lanes of one box-test register: sixteen with AVX-512 nodes, eight with
// AVX nodes, four otherwise.
namespace bx {
#if defined(PRISM_BVH_ZMM_NODES)
using V = __m512;
using I = __m512i;
inline V set1(Float x) { return _mm512_set1_ps(x); }
inline V zero() { return _mm512_setzero_ps(); }
inline V sub(V a, V b) { return _mm512_sub_ps(a, b); }
inline V add(V a, V b) { return _mm512_add_ps(a, b); }
inline V mul(V a, V b) { return _mm512_mul_ps(a, b); }
inline V vmax(V a, V b) { return _mm512_maskz_max_ps(__mmask16(0xffff), a, b); }
inline V vmin(V a, V b) { return _mm512_maskz_min_ps(__mmask16(0xffff), a, b); }
inline void store(Float* p, V a) { _mm512_storeu_ps(p, a); }  // (unaligned: tests pass 32-byte arrays)
inline V load(const Float* p) { return _mm512_load_ps(p); }
inline I fmsub_bits(V a, V b, V c) { return _mm512_castps_si512(_mm512_fmsub_ps(a, b, c)); }
inline I bits(V a) { return _mm512_castps_si512(a); }
inline V as_v(I a) { return _mm512_castsi512_ps(a); }
inline I izero() { return _mm512_setzero_si512(); }
inline I imax(I a, I b) { return _mm512_maskz_max_epi32(__mmask16(0xffff), a, b); }
inline I imin(I a, I b) { return _mm512_maskz_min_epi32(__mmask16(0xffff), a, b); }
inline I iadd(I a, int k) { return _mm512_add_epi32(a, _mm512_set1_epi32(k)); }
inline I iadd(I a, I b) { return _mm512_add_epi32(a, b); }
inline void store_bits(Float* p, I a) { _mm512_storeu_ps(p, _mm512_castsi512_ps(a)); }
// Comparisons give mask registers, which are the lane masks themselves; no
// traversal reads a vector of the lanes entered (`inside`) here.
using M = __mmask16;
inline M le(V a, V b) { return _mm512_cmp_ps_mask(a, b, _CMP_LE_OQ); }
inline M igt(I a, I b) { return _mm512_cmpgt_epi32_mask(a, b); }
inline int movemask(M m) { return int(m); }
inline int sign_mask(M m) { return int(m); }
inline void keep_inside(V*, M) {}
#elif defined(PRISM_BVH_AVX_NODES)
using V = __m256;
inline V set1(Float x) { return _mm256_set1_ps(x); }
inline V zero() { return _mm256_setzero_ps(); }
inline V sub(V a, V b) { return _mm256_sub_ps(a, b); }
inline V add(V a, V b) { return _mm256_add_ps(a, b); }
inline V mul(V a, V b) { return _mm256_mul_ps(a, b); }
inline V vmax(V a, V b) { return _mm256_max_ps(a, b); }
inline V vmin(V a, V b) { return _mm256_min_ps(a, b); }
inline V le(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }  // a <= b (NaN: false)
inline int movemask(V a) { return _mm256_movemask_ps(a); }
inline void store(Float* p, V a) { _mm256_store_ps(p, a); }
inline V load(const Float* p) { return _mm256_load_ps(p); }
// Eight bytes as eight floats.
inline V load_u8(const uint8_t* p) {
#if defined(__AVX2__)
  return _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p))));
#else
  __m128i b = _mm_loadl_epi64(reinterpret_cast<const __m128i*>(p));
  __m128i lo = _mm_cvtepu8_epi32(b), hi = _mm_cvtepu8_epi32(_mm_srli_si128(b, 4));
  return _mm256_cvtepi32_ps(_mm256_insertf128_si256(_mm256_castsi128_si256(lo), hi, 1));
#endif
}
// org + q * scale (q * scale exact for quantized planes: fused or not, one rounding).
inline V plane(V q, V scale, V org) {
#if defined(__FMA__)
  return _mm256_fmadd_ps(q, scale, org);
#else
  return _mm256_add_ps(org, _mm256_mul_ps(q, scale));
#endif
}
#if defined(PRISM_BVH_FMA_SLABS)
using I = __m256i;
inline I fmsub_bits(V a, V b, V c) { return _mm256_castps_si256(_mm256_fmsub_ps(a, b, c)); }
inline I bits(V a) { return _mm256_castps_si256(a); }
inline V as_v(I a) { return _mm256_castsi256_ps(a); }
inline I izero() { return _mm256_setzero_si256(); }
inline I imax(I a, I b) { return _mm256_max_epi32(a, b); }
inline I imin(I a, I b) { return _mm256_min_epi32(a, b); }
inline I iadd(I a, int k) { return _mm256_add_epi32(a, _mm256_set1_epi32(k)); }
inline I iadd(I a, I b) { return _mm256_add_epi32(a, b); }
inline I igt(I a, I b) { return _mm256_cmpgt_epi32(a, b); }
inline int sign_mask(I a) { return _mm256_movemask_ps(_mm256_castsi256_ps(a)); }
inline void store_bits(Float* p, I a) { _mm256_store_ps(p, _mm256_castsi256_ps(a)); }
#endif
#else
using V = __m128;
inline V set1(Float x) { return _mm_set1_ps(x); }
inline V zero() { return _mm_setzero_ps(); }
inline V sub(V a, V b) { return _mm_sub_ps(a, b); }
inline V add(V a, V b) { return _mm_add_ps(a, b); }
inline V mul(V a, V b) { return _mm_mul_ps(a, b); }
inline V vmax(V a, V b) { return _mm_max_ps(a, b); }
inline V vmin(V a, V b) { return _mm_min_ps(a, b); }
inline V le(V a, V b) { return _mm_cmple_ps(a, b); }  // a <= b (NaN: false)
inline int movemask(V a) { return _mm_movemask_ps(a); }
inline void store(Float* p, V a) { _mm_store_ps(p, a); }
inline V load(const Float* p) { return _mm_load_ps(p); }
// Four bytes as four floats (SSE2 unpacking).
inline V load_u8(const uint8_t* p) {
  int32_t v;
  std::memcpy(&v, p, 4);
  __m128i z = _mm_setzero_si128();
  return _mm_cvtepi32_ps(_mm_unpacklo_epi16(_mm_unpacklo_epi8(_mm_cvtsi32_si128(v), z), z));
}
inline V plane(V q, V scale, V org) { return _mm_add_ps(org, _mm_mul_ps(q, scale)); }
#if defined(PRISM_BVH_FMA_SLABS)
using I = __m128i;
inline I fmsub_bits(V a, V b, V c) { return _mm_castps_si128(_mm_fmsub_ps(a, b, c)); }
inline I bits(V a) { return _mm_castps_si128(a); }
inline V as_v(I a) { return _mm_castsi128_ps(a); }
inline I izero() { return _mm_setzero_si128(); }
inline I imax(I a, I b) { return _mm_max_epi32(a, b); }
inline I imin(I a, I b) { return _mm_min_epi32(a, b); }
inline I iadd(I a, int k) { return _mm_add_epi32(a, _mm_set1_epi32(k)); }
inline I iadd(I a, I b) { return _mm_add_epi32(a, b); }
inline I igt(I a, I b) { return _mm_cmpgt_epi32(a, b); }
inline int sign_mask(I a) { return _mm_movemask_ps(_mm_castsi128_ps(a)); }
inline void store_bits(Float* p, I a) { _mm_store_ps(p, _mm_castsi128_ps(a)); }
#endif
#endif
#if !defined(PRISM_BVH_ZMM_NODES)
// Hands the vector of the lanes entered to a caller that asks for it.
inline void keep_inside(V* inside, V in) {
  if (inside) *inside = in;
}
#if defined(PRISM_BVH_FMA_SLABS)
inline void keep_inside(V* inside, I in) { keep_inside(inside, as_v(in)); }
#endif
#endif
}  // namespace bx
#endif

#if defined(PRISM_BVH_AVX_NODES) && defined(__AVX2__)
// The vector of the lanes in `mask`: all ones in lane l when bit l is set.
inline __m256 lanes_inside(unsigned mask) {
  const __m256i bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
  return _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(int(mask)), bit), bit));
}
#endif

}  // namespace detail
}  // namespace prism
