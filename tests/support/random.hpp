// Random test inputs from a PCG32 stream: uniform numbers in [a, b) and
// directions uniform on the sphere.
#pragma once
#include "prism/sampling/pcg32.hpp"
#include "prism/sampling/warps.hpp"

namespace prism::test {

inline Float uniform(PCG32& rng, Float a, Float b) { return a + (b - a) * rng.next_float(); }
inline Vector3f random_unit(PCG32& rng) {
  Float a = rng.next_float();
  return sample_uniform_sphere({a, rng.next_float()});
}

}  // namespace prism::test
