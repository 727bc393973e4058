// Whole-lane comparison of two AVX vectors, for the BVH's vectors of lanes
// entered: every bit of every lane, not only the sign bits a movemask
// sees (a vector reduced to its sign bits must fail).
#pragma once
#include "prism/accel/bvh.hpp"

#if defined(PRISM_BVH_AVX_NODES) && defined(__AVX2__)
namespace prism::test {

inline bool same_lanes(__m256 a, __m256 b) {
  __m256i eq = _mm256_cmpeq_epi32(_mm256_castps_si256(a), _mm256_castps_si256(b));
  return _mm256_movemask_epi8(eq) == -1;
}

}  // namespace prism::test
#endif
