// How much work the ray-query tests do in each of their builds. tests/
// CMakeLists.txt builds tests/accel (and the geometry tests that trace) up to
// eight times: the portable default, then variants for other node widths,
// this machine's instruction set, quantized nodes and no SIMD at all, each
// with PRISM_TEST_ACCEL_VARIANT=1. The variants exist for their node,
// box-test and packet code paths, which a fifth of the default build's rays,
// trials and option sweeps exercises as well; the default build keeps the
// full counts, where rare cases are likelier to be met. Without the cut the
// variants took about 1000 s of the suite's 1700 s of test time on 2 cores.
#pragma once
#include <algorithm>
#include <initializer_list>
#include <vector>

#ifndef PRISM_TEST_ACCEL_VARIANT
#define PRISM_TEST_ACCEL_VARIANT 0
#endif

namespace prism::test {

inline constexpr bool accel_variant = PRISM_TEST_ACCEL_VARIANT != 0;

// n in the default build, n / 5 (at least 1) in a variant.
constexpr int variant_count(int n) { return accel_variant ? std::max(1, n / 5) : n; }

// Every value in the default build; in a variant only `in_variant`.
template <class T>
std::vector<T> variant_sweep(std::initializer_list<T> all, std::initializer_list<T> in_variant) {
  return accel_variant ? std::vector<T>(in_variant) : std::vector<T>(all);
}

}  // namespace prism::test
