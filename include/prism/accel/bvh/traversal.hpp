// prism/accel/bvh/traversal.hpp — ray queries on the wide layout: closest
// hit (BVH::intersect, intersect_leaves) and any hit (occluded,
// occluded_leaves), children visited nearest entry first and deferred ones
// prefetched. The ordering of a node's entered lanes, push_by_distance, has
// four forms: an AVX2 sorting network for 8-wide nodes, an AVX-512 one for
// 16-wide nodes, and insertion sort elsewhere (also with more than eight
// lanes entered), plus a form for callers without the box test's lane vector.
#pragma once
#include <bit>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include "prism/accel/bvh/node.hpp"
#include "prism/accel/bvh/ray_box.hpp"
#include "prism/accel/bvh/simd.hpp"
#include "prism/accel/bvh/tree.hpp"

namespace prism {
namespace detail {

// Starts loading a wide node that traversal has deferred, so that it is in
// cache by the time the stack hands it back.
inline void prefetch(const BVHWideNode* n) {
  // Every cache line the node touches. A node aligned to whole lines covers
  // a fixed number of them (a loop the compiler unrolls: this runs per
  // deferred child); a 72-byte node may straddle three.
  constexpr bool whole_lines = alignof(BVHWideNode) % 64 == 0 && sizeof(BVHWideNode) % 64 == 0;
  uintptr_t first = reinterpret_cast<uintptr_t>(n) & ~uintptr_t(63);
  uintptr_t end = whole_lines ? first + sizeof(BVHWideNode)
                              : ((reinterpret_cast<uintptr_t>(n) + sizeof(BVHWideNode) - 1) & ~uintptr_t(63)) + 64;
  for (uintptr_t at = first; at < end; at += 64) {
    const char* line = reinterpret_cast<const char*>(at);
#if defined(PRISM_BVH_SSE)
    _mm_prefetch(line, _MM_HINT_T0);
#elif defined(__GNUC__) || defined(__clang__)
    __builtin_prefetch(line);
#endif
  }
}

// Asks for the cache line of a node's child[0]: with 8 lanes the line of all
// its links (child, count), the last of a float node's four lines and the
// second of a quantized node's two; with 16 lanes the children's line
// (asking for the counts' too measured nothing).
inline void prefetch_links(const BVHWideNode* n) {
  const char* line = reinterpret_cast<const char*>(n->child);
#if defined(PRISM_BVH_SSE)
  _mm_prefetch(line, _MM_HINT_T0);
#elif defined(__GNUC__) || defined(__clang__)
  __builtin_prefetch(line);
#endif
}

// Two entered lanes a < b in order of entry distance, nearer first (equal
// distances keep lane order), without a branch: GCC 12 compiles a selection
// on a float comparison into one, a coin toss for incoherent rays. Entry
// distances are >= +0, so their bits order like them. Any hit uses it (ab:
// shadow rays 1.028); closest hit keeps the branch, which primary rays
// predict well (this form there: primary 0.969, incoherent 0.999).
inline void nearer_first(const Float* t_entry, int& a, int& b) {
  const uint32_t ta = std::bit_cast<uint32_t>(t_entry[a]), tb = std::bit_cast<uint32_t>(t_entry[b]);
  const int x = (a ^ b) & -int(tb < ta);
  a ^= x;
  b ^= x;
}

// Closest-hit ordering (see the AVX2 form below) without SIMD, for builds
// without AVX2 and for 16-wide nodes with more than eight lanes entered:
// (distance, lane) keys sorted by insertion (distances are >= +0, so their
// bit patterns order like their values; ties keep lane order), then written
// farthest first. The vector of lanes not entered is not needed here.
template <bool with_t = true>
inline int push_by_distance_scalar(const BVHWideNode& node, unsigned mask, const Float* t_entry, uint32_t* child,
                                   uint32_t* count, Float* t) {
  uint64_t key[wide_width] = {};  // (initialised: mask is never 0, but GCC cannot tell)
  int n = 0;
  for (; mask != 0; mask &= mask - 1) {
    int c = std::countr_zero(mask);
    uint64_t kc = uint64_t(std::bit_cast<uint32_t>(t_entry[c])) << 32 | uint64_t(c);
    int j = n++;
    for (; j > 0 && kc < key[j - 1]; --j) key[j] = key[j - 1];
    key[j] = kc;
  }
  for (int j = n - 1, s = 0; j > 0; --j, ++s) {
    int c = int(key[j] & 0xff);
    child[s] = node.child[c];
    count[s] = node.count[c];
    if constexpr (with_t) t[s] = t_entry[c];
  }
  return int(key[0] & 0xff);
}

#if defined(__AVX2__) && (defined(PRISM_BVH_AVX_NODES) || defined(PRISM_BVH_ZMM_NODES))
// Eight int32 keys in ascending order: Batcher's odd-even merge sort, 19
// comparators in 6 layers, each layer a permutation to the partner lane, a
// min, a max and a blend keeping the max in the upper lane of each pair.
inline __m256i sort8(__m256i x) {
  auto layer = [](__m256i v, __m256i partner, auto hi_lanes) {
    __m256i y = _mm256_permutevar8x32_epi32(v, partner);
    return _mm256_blend_epi32(_mm256_min_epi32(v, y), _mm256_max_epi32(v, y), decltype(hi_lanes)::value);
  };
  using std::integral_constant;
  x = layer(x, _mm256_setr_epi32(2, 3, 0, 1, 6, 7, 4, 5), integral_constant<int, 0xCC>{});
  x = layer(x, _mm256_setr_epi32(4, 5, 6, 7, 0, 1, 2, 3), integral_constant<int, 0xF0>{});
  x = layer(x, _mm256_setr_epi32(1, 0, 3, 2, 5, 4, 7, 6), integral_constant<int, 0xAA>{});
  x = layer(x, _mm256_setr_epi32(0, 1, 4, 5, 2, 3, 6, 7), integral_constant<int, 0x30>{});
  x = layer(x, _mm256_setr_epi32(0, 4, 2, 6, 1, 5, 3, 7), integral_constant<int, 0x50>{});
  x = layer(x, _mm256_setr_epi32(0, 2, 1, 4, 3, 6, 5, 7), integral_constant<int, 0x54>{});
  return x;
}
// The smallest of eight int32 keys, in three steps (the sort takes six).
inline int min_key8(__m256i k) {
  __m256i m = _mm256_min_epi32(k, _mm256_permute2x128_si256(k, k, 0x01));
  m = _mm256_min_epi32(m, _mm256_shuffle_epi32(m, 0x4E));
  m = _mm256_min_epi32(m, _mm256_shuffle_epi32(m, 0xB1));
  return _mm256_cvtsi256_si32(m);
}
#endif

#if defined(PRISM_BVH_AVX_NODES) && defined(__AVX2__)
#define PRISM_BVH_SORT_AVX2 1

// Closest-hit ordering of a node's entered lanes (`mask`, two or more) without
// branches: the lanes sorted by entry distance (ties, and distances within 8
// ulps, by lane: the key is the distance's bits with the lane in the low
// three), all but the nearest written farthest first to child/count/t (eight
// entries are stored; those past the entered ones are scratch). Returns the
// nearest lane. Entry distances are >= +0, so their bits order like them.
// Precondition: every lane of t_entry, entered or not, has its sign bit clear
// (slab_lanes guarantees it): a lane not entered gets its key by OR with
// INT32_MAX, which leaves a set sign bit set and would sort it first.
// Without `with_t` (any hit, which culls nothing it has pushed), t is neither
// written nor needed. `inside` is intersect_wide's vector of the lanes
// entered (mask's bits), each lane all ones or all zeros.
template <bool with_t = true>
inline int push_by_distance(const BVHWideNode& node, unsigned mask, __m256 inside, const Float* t_entry,
                            uint32_t* child, uint32_t* count, Float* t) {
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i tv = _mm256_load_si256(reinterpret_cast<const __m256i*>(t_entry));
  // Lanes not entered get INT32_MAX (every bit but the sign bit set).
  __m256i key = _mm256_or_si256(_mm256_andnot_si256(_mm256_set1_epi32(7), tv), lane);
  key = _mm256_or_si256(key, _mm256_andnot_si256(_mm256_castps_si256(inside), _mm256_set1_epi32(INT32_MAX)));
  const __m256i by_distance = _mm256_and_si256(sort8(key), _mm256_set1_epi32(7));
  // Slot j of the push holds the (n - 1 - j)-th nearest (n entered lanes).
  const int n = std::popcount(mask);
  const __m256i slot = _mm256_permutevar8x32_epi32(by_distance, _mm256_sub_epi32(_mm256_set1_epi32(n - 1), lane));
  auto gather = [&](const void* p) {
    return _mm256_permutevar8x32_epi32(_mm256_loadu_si256(static_cast<const __m256i*>(p)), slot);
  };
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(child), gather(node.child));
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(count), gather(node.count));
  if constexpr (with_t) _mm256_storeu_si256(reinterpret_cast<__m256i*>(t), _mm256_permutevar8x32_epi32(tv, slot));
  // The nearest lane, the sort's first, by a horizontal minimum of the keys
  // (unique: the lane is in them): three steps instead of the sort's six, so
  // that traversal can go on to the nearest child before the sort is done.
  return min_key8(key) & 7;
}

// The lanes of a node that hold inner nodes (bit l for lane l).
inline unsigned inner_lanes(const BVHWideNode& node) {
  __m256i c = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(node.count));
  return unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(c, _mm256_set1_epi32(-1)))));
}
#elif defined(PRISM_BVH_ZMM_NODES)
// 16-wide nodes: the same ordering, the keys with the lane in their low four
// bits. The entered lanes' keys are packed into the low eight lanes and
// sorted by the 8-key network when at most eight are entered (the usual
// case: the mask-register compress leaves the others INT32_MAX), by
// insertion otherwise. Eight entries are stored, as above. (The all-lanes
// masked forms of the intrinsics are the plain instructions; GCC 12 takes
// the plain forms' undefined pass-through register for an uninitialised
// read, -Wmaybe-uninitialized.)
template <bool with_t = true>
inline int push_by_distance(const BVHWideNode& node, unsigned mask, LaneMaskV /*inside*/, const Float* t_entry,
                            uint32_t* child, uint32_t* count, Float* t) {
  const int n = std::popcount(mask);
  if (n > 8) return push_by_distance_scalar<with_t>(node, mask, t_entry, child, count, t);
  const __mmask16 all = 0xffff;
  auto low8 = [](__m512i v) { return _mm512_maskz_extracti64x4_epi64(__mmask8(0xff), v, 0); };
  const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  const __m512i tv = _mm512_loadu_si512(t_entry);
  const __m512i key = _mm512_or_si512(_mm512_maskz_andnot_epi32(all, _mm512_set1_epi32(15), tv), lane);
  const __m256i packed = low8(_mm512_mask_compress_epi32(_mm512_set1_epi32(INT32_MAX), __mmask16(mask), key));
  const __m256i by_distance = _mm256_and_si256(sort8(packed), _mm256_set1_epi32(15));
  // Slot j of the push holds the (n - 1 - j)-th nearest; lanes 8-15 of the
  // index vector are undefined and their results unused.
  const __m512i slot = _mm512_castsi256_si512(_mm256_permutevar8x32_epi32(
      by_distance, _mm256_sub_epi32(_mm256_set1_epi32(n - 1), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7))));
  auto gather = [&](const void* p) { return low8(_mm512_maskz_permutexvar_epi32(all, slot, _mm512_loadu_si512(p))); };
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(child), gather(node.child));
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(count), gather(node.count));
  if constexpr (with_t) _mm256_storeu_si256(reinterpret_cast<__m256i*>(t), gather(t_entry));
  return min_key8(packed) & 15;  // the nearest lane
}
// The lanes of a node that hold inner nodes (bit l for lane l).
inline unsigned inner_lanes(const BVHWideNode& node) {
  return unsigned(_mm512_cmpeq_epi32_mask(_mm512_loadu_si512(node.count), _mm512_set1_epi32(-1)));
}
#else
template <bool with_t = true>
inline int push_by_distance(const BVHWideNode& node, unsigned mask, LaneMaskV /*inside*/, const Float* t_entry,
                            uint32_t* child, uint32_t* count, Float* t) {
  return push_by_distance_scalar<with_t>(node, mask, t_entry, child, count, t);
}
inline unsigned inner_lanes(const BVHWideNode& node) {
  unsigned m = 0;
  for (int l = 0; l < wide_width; ++l) m |= unsigned(node.count[l] == BVHWideNode::interior) << l;
  return m;
}
#endif

// push_by_distance with the vector of lanes entered built from the mask,
// for callers without intersect_wide's vector.
template <bool with_t = true>
inline int push_by_distance(const BVHWideNode& node, unsigned mask, const Float* t_entry, uint32_t* child,
                            uint32_t* count, Float* t) {
#if defined(PRISM_BVH_SORT_AVX2)
  return push_by_distance<with_t>(node, mask, lanes_inside(mask), t_entry, child, count, t);
#else
  return push_by_distance<with_t>(node, mask, LaneMaskV{}, t_entry, child, count, t);
#endif
}

}  // namespace detail

template <class F>
inline bool BVH::intersect(const Point3f& o, const Vector3f& d, Float& t_max, F&& isect) const {
  return intersect(detail::WideRayPrecomp(o, d), t_max, isect);
}
template <class F>
inline bool BVH::intersect(const detail::WideRayPrecomp& r, Float& t_max, F&& isect) const {
  return intersect_leaves(r, t_max, [&](uint32_t first, uint32_t count, Float& tm) {
    bool hit = false;
    for (uint32_t k = first, e = first + count; k < e; ++k)
      if (isect(k, tm)) hit = true;
    return hit;
  });
}
template <class F>
inline bool BVH::intersect_leaves(const detail::WideRayPrecomp& r, Float& t_max, F&& leaf) const {
  if (m_wide.empty()) return false;
  // No separate test of the root box: a ray that misses it misses every
  // child box inside it too (the slab distances are monotonic in the planes).
  // The stack, a field per array (the AVX2 ordering stores eight entries at
  // once: wide_width entries of slack).
  constexpr int stack_slots = wide_stack_size + detail::wide_width;
  alignas(32) uint32_t stack_child[stack_slots], stack_count[stack_slots];
  alignas(32) Float stack_t[stack_slots];
  int sp = 0;
  uint32_t idx = 0;
  bool hit = false;
  Float t_cull = detail::widen_exit(t_max);  // deferred entries beyond it are skipped
  for (;;) {
    const detail::BVHWideNode& node = m_wide[idx];
    // The links' cache line is needed once the box test has chosen a lane;
    // asked for now, it arrives with the planes instead of after them (one
    // cache miss instead of two in a row when the node is not in cache).
    detail::prefetch_links(&node);
    alignas(64) Float t_entry[detail::wide_width];
    detail::LaneMaskV inside{};  // the lanes entered, for push_by_distance (AVX nodes only)
    unsigned mask = unsigned(detail::intersect_wide(node, r, t_cull, t_entry, &inside));
    if (mask != 0) {
      // Visit the nearest child next and defer the others, farthest deepest.
      // Deferred inner nodes start loading now (for rays whose nodes are not
      // in cache). (Any hit does the same through visit_nearest, without
      // the distances; through such a helper GCC 12 compiled this loop 4-6%
      // slower on every closest-hit ray set, so it stays written out.)
      int l = std::countr_zero(mask);
      if ((mask & (mask - 1)) != 0) {
        unsigned rest = mask & (mask - 1);
        if ((rest & (rest - 1)) == 0) {
          // Two: equal entry distances keep lane order. (GCC compiles the
          // selection into a branch, which primary rays predict; the
          // branch-free nearer_first cost them 3%.)
          int l1 = std::countr_zero(rest);
          bool swap = t_entry[l1] < t_entry[l];
          int near = swap ? l1 : l;
          l1 = swap ? l : l1;
          l = near;
          stack_child[sp] = node.child[l1];
          stack_count[sp] = node.count[l1];
          stack_t[sp++] = t_entry[l1];
          if (node.count[l1] == detail::BVHWideNode::interior) detail::prefetch(&m_wide[node.child[l1]]);
        } else {
          // Three or more.
          l = detail::push_by_distance(node, mask, inside, t_entry, stack_child + sp, stack_count + sp,
                                       stack_t + sp);
          sp += std::popcount(mask) - 1;
          prefetch_children(node, detail::inner_lanes(node) & mask & ~(1u << l));
        }
      }
      if (node.count[l] == detail::BVHWideNode::interior) {
        idx = node.child[l];
        continue;
      }
      if (leaf(node.child[l], node.count[l], t_max)) {
        hit = true;
        t_cull = detail::widen_exit(t_max);
      }
    }
    // Pop, skipping entries that a closer hit has since made unreachable
    // (slab_lanes' test with the lowered t_max).
    for (;;) {
      if (sp == 0) return hit;
      --sp;
      if (!(stack_t[sp] <= t_cull)) continue;
      if (stack_count[sp] == detail::BVHWideNode::interior) {
        idx = stack_child[sp];
        break;
      }
      if (leaf(stack_child[sp], stack_count[sp], t_max)) {
        hit = true;
        t_cull = detail::widen_exit(t_max);
      }
    }
  }
}

template <class F>
inline bool BVH::occluded(const Point3f& o, const Vector3f& d, Float t_max, F&& isect) const {
  if (m_wide.empty()) return false;
  return occluded(detail::WideRayPrecomp(o, d), t_max, isect);
}
template <class F>
inline bool BVH::occluded(const detail::WideRayPrecomp& r, Float t_max, F&& isect) const {
  return occluded_leaves(r, t_max, [&](uint32_t first, uint32_t count, Float tm) {
    for (uint32_t k = first, e = first + count; k < e; ++k)
      if (isect(k, tm)) return true;
    return false;
  });
}
template <class F>
inline bool BVH::occluded_leaves(const detail::WideRayPrecomp& r, Float t_max, F&& leaf) const {
  if (m_wide.empty()) return false;
  // Children in the closest-hit order, nearest first, leaves and inner
  // nodes alike: a shadow ray starts on a surface, where an occluder is
  // likeliest, and the near side of the scene is searched first. Nothing
  // pushed is ever culled (t_max does not move), so the stack holds no
  // distances.
  constexpr int stack_slots = wide_stack_size + detail::wide_width;
  alignas(32) uint32_t stack_child[stack_slots], stack_count[stack_slots];
  int sp = 0;
  uint32_t idx = 0;
  const Float t_cull = detail::widen_exit(t_max);
  for (;;) {
    const detail::BVHWideNode& node = m_wide[idx];
    detail::prefetch_links(&node);
    alignas(64) Float t_entry[detail::wide_width];
    detail::LaneMaskV inside{};
    unsigned mask = unsigned(detail::intersect_wide(node, r, t_cull, t_entry, &inside));
    if (mask != 0) {
      int l = visit_nearest(node, mask, inside, t_entry, stack_child, stack_count, sp);
      if (node.count[l] == detail::BVHWideNode::interior) {
        idx = node.child[l];
        continue;
      }
      if (leaf(node.child[l], node.count[l], t_max)) return true;
    }
    for (;;) {
      if (sp == 0) return false;
      --sp;
      if (stack_count[sp] == detail::BVHWideNode::interior) {
        idx = stack_child[sp];
        break;
      }
      if (leaf(stack_child[sp], stack_count[sp], t_max)) return true;
    }
  }
}

// Starts loading the wide nodes of `lanes` (inner children that traversal defers).
inline void BVH::prefetch_children(const detail::BVHWideNode& node, unsigned lanes) const {
  for (; lanes != 0; lanes &= lanes - 1) detail::prefetch(&m_wide[node.child[std::countr_zero(lanes)]]);
}
// Any hit's ordering of a node's entered lanes `mask` (not 0), nearest
// first: pushes all but the nearest onto the stack at sp, farthest deepest
// (children and counts; no distances, as any hit culls nothing it has
// pushed), starts loading the deferred inner nodes, and returns the nearest
// lane. Closest hit has the same code written out, with distances (see
// intersect_leaves).
inline int BVH::visit_nearest(const detail::BVHWideNode& node, unsigned mask, detail::LaneMaskV inside,
                              const Float* t_entry, uint32_t* stack_child, uint32_t* stack_count, int& sp) const {
  int l = std::countr_zero(mask);
  unsigned rest = mask & (mask - 1);
  if (rest == 0) return l;
  if ((rest & (rest - 1)) == 0) {  // two: equal distances in lane order
    int l1 = std::countr_zero(rest);
    detail::nearer_first(t_entry, l, l1);
    stack_child[sp] = node.child[l1];
    stack_count[sp++] = node.count[l1];
    if (node.count[l1] == detail::BVHWideNode::interior) detail::prefetch(&m_wide[node.child[l1]]);
    return l;
  }
  l = detail::push_by_distance<false>(node, mask, inside, t_entry, stack_child + sp, stack_count + sp, nullptr);
  sp += std::popcount(mask) - 1;
  prefetch_children(node, detail::inner_lanes(node) & mask & ~(1u << l));
  return l;
}

}  // namespace prism
