// prism/sampling/sobol.hpp — an Owen-scrambled Sobol' sampler, hash-based as
// in Burley 2020, "Practical Hash-based Owen Scrambling" (JCGT 9(4)), with
// random access: the numbers of sample i of a pixel depend only on (pixel, i,
// dimension, seed).
//
// Only the first two Sobol' dimensions are used: the van der Corput sequence
// (generator matrix = identity) and its partner with the Pascal matrix mod 2.
// Together they form a (0,2)-sequence in base 2: every aligned block of 2^k
// consecutive indices, [j 2^k, (j + 1) 2^k), is a (0,k,2)-net, i.e. each
// elementary box of size 2^-a x 2^-b (a + b = k) holds exactly one point.
// Higher dimensions are "padded" (Kollig & Keller 2002): every call draws from
// the same 2D sequence, decorrelated from the other calls by its own random
// shuffle of the sample order, as Burley proposes.
//
// Two seeded nested uniform (Owen) scrambles are used:
//  - on a coordinate: digit k (the k-th most significant bit) is flipped or not
//    as a random function of digits 0..k-1. Any such map sends elementary
//    intervals to elementary intervals, so nets stay nets, and a random choice
//    makes each point uniform on [0, 1) (Owen 1995).
//  - on the sample index (Burley's shuffle), the same function: the index is
//    read as a binary fraction, most significant bit first, so its bit b is
//    flipped as a function of its bits above b. For indices in [0, 2^k) the
//    bits >= k are all zero, so they come out as constants (functions of the
//    seed only) while the low k bits are permuted. The first 2^k shuffled
//    indices are therefore one aligned block of 2^k consecutive Sobol'
//    indices in a random order, still a (0,k,2)-net: shuffling costs no
//    stratification.
// The scramble is computed with the Laine-Karras style hash of Vegdahl 2021
// ("Building a Better LK Hash", psychopath.io), applied to the bit-reversed
// value (so that the hash's low-to-high carries run from the most to the
// least significant digit).
//
// Dimension allocation. start_pixel_sample(px, py, i) sets the pixel key
// P = hash_values(px, py, seed), the index i and a dimension counter d = 0.
// The call at dimension d hashes H = mix_bits(P + (d + 1) * 0x9e3779b97f4a7c15)
// (a splitmix64 step) and takes its seeds from it: shuffle = low 32 bits of H,
// x = high 32 bits of H, y = low 32 bits of mix_bits(H ^ 0x243f6a8885a308d3).
//   get_1d(): uses dimension d, then d += 1.
//       j = owen_scramble(i, shuffle),  u = owen_scramble(sobol_0(j), x).
//   get_2d(): uses dimensions d and d + 1, then d += 2.
//       j = owen_scramble(i, shuffle),  x = owen_scramble(sobol_0(j), x),
//       y = owen_scramble(sobol_1(j), y).
// With the renderer's order (render.hpp):
// wavelengths d = 0 (1D), film filter d = 1-2, lens d = 3-4, and the
// integrator from d = 5 on. Each call is a fresh (0,2)-sequence (1D: a
// (0,1)-sequence), so the spp numbers of one call are stratified whatever the
// other calls; the coordinates of two different calls are not jointly
// stratified, only independently shuffled.
//
// samples_per_pixel: the net property holds for each power-of-two prefix of a
// pixel's samples, so a power of two gets the most out of this sampler; other
// counts are fine, just less evenly spread. Indices beyond samples_per_pixel
// continue the sequence. The float values keep the top 24 bits of each
// 32-bit coordinate, so they lie in [0, 1 - 2^-24].
#pragma once
#include <algorithm>
#include <cstdint>
#include "prism/math/float.hpp"
#include "prism/math/vector.hpp"
#include "prism/sampling/pcg32.hpp"

namespace prism {

constexpr uint32_t reverse_bits32(uint32_t v) {
  v = ((v >> 1) & 0x55555555u) | ((v & 0x55555555u) << 1);
  v = ((v >> 2) & 0x33333333u) | ((v & 0x33333333u) << 2);
  v = ((v >> 4) & 0x0f0f0f0fu) | ((v & 0x0f0f0f0fu) << 4);
  v = ((v >> 8) & 0x00ff00ffu) | ((v & 0x00ff00ffu) << 8);
  return (v >> 16) | (v << 16);
}

// The first Sobol' dimension (van der Corput): the index's bits, mirrored, as
// a 32-bit binary fraction.
constexpr uint32_t sobol_0(uint32_t index) { return reverse_bits32(index); }

// The second Sobol' dimension: generator matrix = Pascal's triangle mod 2
// (primitive polynomial x + 1; direction numbers v_0 = 2^31,
// v_k = v_{k-1} ^ (v_{k-1} >> 1)). By Lucas' theorem, binomial(c, r) is odd
// iff the bits of r are a subset of those of c, so digit r of the result (r-th
// most significant) is the xor of the index bits c that contain r: a
// superset-sum over the 5-bit positions, done one position bit at a time.
constexpr uint32_t sobol_1(uint32_t index) {
  uint32_t g = index;
  g ^= (g >> 1) & 0x55555555u;
  g ^= (g >> 2) & 0x33333333u;
  g ^= (g >> 4) & 0x0f0f0f0fu;
  g ^= (g >> 8) & 0x00ff00ffu;
  g ^= (g >> 16) & 0x0000ffffu;
  return reverse_bits32(g);  // bit r of g is digit r of the fraction
}

// Nested uniform (Owen) scramble of a 32-bit binary fraction v, seeded. Each
// step of the hash is a bijection in which bit k of the result is bit k of the
// input xor a function of the bits below k (x ^= x * even, x += c, x *= odd):
// applied to reverse_bits32(v), "below" means "more significant in v", which
// is the nesting Owen scrambling needs. Constants from Vegdahl 2021.
constexpr uint32_t owen_scramble(uint32_t v, uint32_t seed) {
  v = reverse_bits32(v);
  v ^= v * 0x3d20adeau;
  v += seed;
  v *= (seed >> 16) | 1u;
  v ^= v * 0x05526c56u;
  v ^= v * 0x53a22864u;
  return reverse_bits32(v);
}

class SobolSampler {
 public:
  explicit SobolSampler(int samples_per_pixel, uint64_t seed = 0)
      : m_seed(seed), m_spp(std::max(1, samples_per_pixel)) {}

  int samples_per_pixel() const { return m_spp; }

  void start_pixel_sample(int px, int py, int sample_index) {
    m_pixel_key = hash_values(uint64_t(uint32_t(px)), uint64_t(uint32_t(py)), m_seed);
    m_index = uint32_t(sample_index);
    m_dim = 0;
  }

  Float get_1d() {
    const uint64_t h = call_hash(m_dim++);
    const uint32_t j = owen_scramble(m_index, uint32_t(h));
    return to_float(owen_scramble(sobol_0(j), uint32_t(h >> 32)));
  }

  Point2f get_2d() {
    const uint64_t h = call_hash(m_dim), h2 = mix_bits(h ^ 0x243f6a8885a308d3ULL);
    m_dim += 2;
    const uint32_t j = owen_scramble(m_index, uint32_t(h));
    return {to_float(owen_scramble(sobol_0(j), uint32_t(h >> 32))),
            to_float(owen_scramble(sobol_1(j), uint32_t(h2)))};
  }

 private:
  // The seeds of the call at dimension d: low half = shuffle, high half = x.
  uint64_t call_hash(uint32_t d) const { return mix_bits(m_pixel_key + uint64_t(d + 1) * 0x9e3779b97f4a7c15ULL); }
  // The top 24 bits: exact in float, and never rounds up to 1.
  static Float to_float(uint32_t v) { return Float(v >> 8) * 0x1p-24f; }

  uint64_t m_seed;
  int m_spp;
  uint64_t m_pixel_key = 0;
  uint32_t m_index = 0, m_dim = 0;
};

}  // namespace prism
