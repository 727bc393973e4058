// prism/sampling/pcg32.hpp — the PCG32 generator (O'Neill 2014, "PCG: A Family of
// Simple Fast Space-Efficient Statistically Good Algorithms for Random Number
// Generation"), plus the hashing used to give every pixel sample its own
// deterministic stream, independent of threads and tiles.
#pragma once
#include <cstdint>
#include "prism/math/vector.hpp"

namespace prism {

// 64-bit mixer (a MurmurHash3 finaliser variant, splitmix64 constants).
constexpr uint64_t mix_bits(uint64_t v) {
  v ^= v >> 31;
  v *= 0x7fb5d329728ea185ULL;
  v ^= v >> 27;
  v *= 0x81dadef4bc2dd44dULL;
  v ^= v >> 33;
  return v;
}
template <class... Args>
constexpr uint64_t hash_values(uint64_t first, Args... rest) {
  uint64_t h = mix_bits(first + 0x9e3779b97f4a7c15ULL);
  ((h = mix_bits(h ^ (uint64_t(rest) + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2)))), ...);
  return h;
}

class PCG32 {
 public:
  static constexpr uint64_t default_state = 0x853c49e6748fea9bULL;
  static constexpr uint64_t default_stream = 0xda3e39cb94b95bdbULL;
  static constexpr uint64_t multiplier = 0x5851f42d4c957f2dULL;

  PCG32() = default;
  PCG32(uint64_t seq_index, uint64_t seed) { set_sequence(seq_index, seed); }

  void set_sequence(uint64_t seq_index, uint64_t seed) {
    m_state = 0u;
    m_inc = (seq_index << 1u) | 1u;
    next_u32();
    m_state += seed;
    next_u32();
  }

  uint32_t next_u32() {
    uint64_t old = m_state;
    m_state = old * multiplier + m_inc;
    uint32_t xorshifted = uint32_t(((old >> 18u) ^ old) >> 27u);
    uint32_t rot = uint32_t(old >> 59u);
    return (xorshifted >> rot) | (xorshifted << ((~rot + 1u) & 31));
  }
  // Uniform in [0, 1): 24 random mantissa bits, so the result never rounds to 1.
  Float next_float() { return Float(next_u32() >> 8) * 0x1p-24f; }
  // Uniform integer in [0, bound), unbiased (Lemire-style rejection).
  uint32_t next_bounded(uint32_t bound) {
    uint32_t threshold = (~bound + 1u) % bound;
    for (;;) {
      uint32_t r = next_u32();
      if (r >= threshold) return r % bound;
    }
  }
  // Jump ahead (or back, for negative delta) in O(log n) (Brown 1994).
  void advance(int64_t idelta) {
    uint64_t cur_mult = multiplier, cur_plus = m_inc, acc_mult = 1u, acc_plus = 0u;
    uint64_t delta = uint64_t(idelta);
    while (delta > 0) {
      if (delta & 1) {
        acc_mult *= cur_mult;
        acc_plus = acc_plus * cur_mult + cur_plus;
      }
      cur_plus = (cur_mult + 1) * cur_plus;
      cur_mult *= cur_mult;
      delta /= 2;
    }
    m_state = acc_mult * m_state + acc_plus;
  }

 private:
  uint64_t m_state = default_state, m_inc = default_stream;
};

// The random numbers of one pixel sample: a stream chosen by a hash of the pixel
// and the seed, positioned at the sample index. Dimensions are consumed in a
// fixed order by the integrator, so results never depend on scheduling.
class IndependentSampler {
 public:
  explicit IndependentSampler(uint64_t seed = 0) : m_seed(seed) {}
  void start_pixel_sample(int px, int py, int sample_index) {
    m_rng.set_sequence(hash_values(uint64_t(uint32_t(px)), uint64_t(uint32_t(py)), m_seed), mix_bits(m_seed));
    m_rng.advance(int64_t(sample_index) * 65536);
  }
  Float get_1d() { return m_rng.next_float(); }
  Point2f get_2d() { Float a = m_rng.next_float(); return {a, m_rng.next_float()}; }

 private:
  uint64_t m_seed;
  PCG32 m_rng;
};

}  // namespace prism
