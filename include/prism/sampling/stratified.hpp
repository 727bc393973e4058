// prism/sampling/stratified.hpp — a stratified (jittered) sampler with random
// access: the numbers of sample i of a pixel are computed from (pixel, i,
// dimension, seed) alone, with no per-pixel state, like IndependentSampler.
//
// Per dimension, the samples_per_pixel (N) samples of a pixel fall one per stratum:
//   1D   N strata of width 1/N. Sample i takes stratum pi(i), where pi is a
//        random permutation of [0, N) chosen by a hash of (pixel, dimension,
//        seed), and a uniform offset inside it (jittering).
//   2D   multi-jittered (Chiu, Shirley & Wang 1994, "Multi-jittered sampling";
//        random-access form after Kensler 2013, "Correlated multi-jittered
//        sampling"): an nx x ny grid of cells, nx the largest divisor of N with
//        nx^2 <= N and ny = N / nx, one sample per cell, and at the same time
//        one sample per 1/N column in x and per 1/N row in y (n-rooks, i.e.
//        Latin hypercube). Inside cell column c the ny samples occupy the ny
//        sub-columns of width 1/N in the order of a random permutation of the
//        rows, seeded per column (and likewise for rows), so the sub-column
//        permutations are independent (uncorrelated multi-jittering). When N
//        factors badly the grid degenerates gracefully: N prime gives nx = 1,
//        which is exactly Latin-hypercube sampling with independent
//        permutations in x and y; N = 2p gives a 2 x p grid plus n-rooks.
//        Sample i takes cell pi(i) for a per-(pixel, dimension) permutation pi.
// Each call gets its own permutation, so the strata of different dimensions
// are matched at random (as in pbrt's stratified sampler, which shuffles).
//
// Dimension allocation: start_pixel_sample resets a counter d to 0; get_1d
// uses dimension d and adds 1, get_2d uses d (and d + 1) and adds 2. The key
// of a call is a hash of (pixel key, d), the pixel key being
// hash_values(px, py, seed); its permutations and jitter use hashes of that
// key with a role constant (1D, 2D, columns, rows, jitter) and the sample index,
// column or row.
//
// Sample indices >= N (or negative) have no stratum: they get independent
// uniform numbers (a hash of pixel key, index and d), so a caller that draws
// more samples than announced still gets valid, if unstratified, numbers.
#pragma once
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include "prism/math/float.hpp"
#include "prism/math/vector.hpp"
#include "prism/sampling/pcg32.hpp"

namespace prism {

// Element i of a random permutation of [0, n), chosen by seed: evaluated in
// isolation, so that a sampler can ask for any sample's stratum directly.
//   n <= 16: a Fisher-Yates shuffle of nibbles packed in one 64-bit word,
//     stopped at position i. Its random choices are the mixed-radix digits of
//     one 60-bit hash r read as a fraction (digit = floor(r m), then r = r m
//     mod 1), so every permutation has probability 1 / n! to within
//     n! / 2^60 < 2e-5 relative.
//   n > 16: cycle-walking (Black & Rogaway 2002, as Kensler 2013 uses it) on a
//     seeded bijection of [0, 2^b), 2^b the next power of two >= n: apply the
//     bijection until the value falls back into [0, n). Each round of the
//     bijection uses steps that are invertible modulo 2^b: adding a key,
//     multiplying by an odd key, x ^= x >> s and xor with a key. The multiply
//     and add carry bits upwards and the shift carries them down again. Four
//     rounds do not make every permutation equally likely, so a final rotation
//     by a uniform offset mod n makes each element's image exactly uniform,
//     which is what an unbiased estimate needs.
// (i >= n is taken mod n: cycle-walking only terminates from inside [0, n).)
constexpr uint32_t permute_index(uint32_t i, uint32_t n, uint64_t seed) {
  if (n <= 1) return 0;
  if (i >= n) i %= n;
  uint64_t r = mix_bits(seed ^ 0x6a09e667f3bcc909ULL);
  if (n <= 16) {
    constexpr uint64_t frac = (uint64_t(1) << 60) - 1;  // r: a 60-bit binary fraction
    r &= frac;
    uint64_t w = 0xfedcba9876543210ULL;  // nibble k holds k
    uint32_t picked = 0;
    for (uint32_t k = 0; k <= i && k < n; ++k) {
      // j uniform in [k, n): the next digit of r in base n - k (r * (n - k)
      // < 2^64 since n <= 16).
      r *= n - k;
      uint32_t j = k + uint32_t(r >> 60);
      r &= frac;
      uint64_t a = (w >> (4 * k)) & 15u, b = (w >> (4 * j)) & 15u;
      w ^= ((a ^ b) << (4 * k)) | ((a ^ b) << (4 * j));
      picked = uint32_t(b);
    }
    return picked;
  }
  const int bits = int(std::bit_width(n - 1));
  const uint32_t mask = bits >= 32 ? ~0u : (1u << bits) - 1u;
  uint64_t keys[4];  // independent of each other, so computed in parallel
  int shifts[4];
  for (int k = 0; k < 4; ++k) {
    keys[k] = mix_bits(r + (uint64_t(k) + 1) * 0x9e3779b97f4a7c15ULL);
    shifts[k] = 1 + int(((keys[k] >> 58) * uint64_t(bits - 1)) >> 6);  // in [1, bits - 1]
  }
  do {
    for (int k = 0; k < 4; ++k) {
      i = (i + uint32_t(keys[k])) & mask;
      i = (i * (uint32_t(keys[k] >> 32) | 1u)) & mask;
      i ^= i >> shifts[k];
      i ^= uint32_t(keys[k] >> 16) & mask;
    }
  } while (i >= n);
  const uint32_t offset = uint32_t(((mix_bits(r + 5 * 0x9e3779b97f4a7c15ULL) >> 32) * n) >> 32);
  return i >= n - offset ? i - (n - offset) : i + offset;  // (i + offset) mod n
}

// A float in [k / n, (k + 1) / n) (exactly, not just up to rounding), at
// fraction u in [0, 1) of the way through stratum k. Needs n <= 2^24 so that
// every stratum holds a float (their spacing is at most 2^-24 below 1) and the
// product v * n below is exact in double.
inline Float stratum_point(uint32_t k, uint32_t n, double u) {
  const double lo = double(k), hi = double(k) + 1, dn = double(n);
  Float v = std::min(Float((lo + u) / dn), one_minus_epsilon);
  // Rounding to float may have crossed an edge of the stratum: step back in.
  while (double(v) * dn >= hi) v = std::nextafter(v, Float(0));
  while (double(v) * dn < lo) v = std::nextafter(v, Float(1));
  return v;
}

class StratifiedSampler {
 public:
  static constexpr int max_samples_per_pixel = 1 << 24;

  // samples_per_pixel is clamped to [1, 2^24].
  explicit StratifiedSampler(int samples_per_pixel, uint64_t seed = 0)
      : m_seed(seed), m_spp(uint32_t(std::clamp(samples_per_pixel, 1, max_samples_per_pixel))) {
    m_nx = 1;
    for (uint32_t a = 1; uint64_t(a) * a <= m_spp; ++a)
      if (m_spp % a == 0) m_nx = a;
    m_ny = m_spp / m_nx;
  }

  int samples_per_pixel() const { return int(m_spp); }
  // The 2D grid: nx columns (x) by ny rows (y), nx <= ny, nx * ny = N.
  int grid_x() const { return int(m_nx); }
  int grid_y() const { return int(m_ny); }

  void start_pixel_sample(int px, int py, int sample_index) {
    m_pixel_key = hash_values(uint64_t(uint32_t(px)), uint64_t(uint32_t(py)), m_seed);
    m_index = uint32_t(sample_index);  // a negative index becomes >= N
    m_dim = 0;
  }

  Float get_1d() {
    const uint32_t d = m_dim++;
    if (m_index >= m_spp) return unit_float(derive(derive(m_pixel_key, d) ^ role_independent, m_index) >> 40);
    const uint64_t key = derive(m_pixel_key, d) ^ role_1d;
    const uint32_t stratum = permute_index(m_index, m_spp, key);
    return stratum_point(stratum, m_spp, jitter(derive(key ^ role_jitter, m_index) >> 40));
  }

  Point2f get_2d() {
    const uint32_t d = m_dim;
    m_dim += 2;
    if (m_index >= m_spp) {
      const uint64_t h = derive(derive(m_pixel_key, d) ^ role_independent, m_index);
      return {unit_float(h >> 40), unit_float((h >> 16) & 0xffffffu)};
    }
    const uint64_t key = derive(m_pixel_key, d) ^ role_2d;
    const uint32_t cell = permute_index(m_index, m_spp, key);
    const uint32_t col = cell % m_nx, row = cell / m_nx;
    // Sub-column of this sample inside its column (one per row), and sub-row
    // inside its row (one per column), each from a permutation of its own.
    const uint32_t sub_x = permute_index(row, m_ny, derive(key ^ role_columns, col));
    const uint32_t sub_y = permute_index(col, m_nx, derive(key ^ role_rows, row));
    const uint64_t h = derive(key ^ role_jitter, m_index);
    return {stratum_point(col * m_ny + sub_x, m_spp, jitter(h >> 40)),
            stratum_point(row * m_nx + sub_y, m_spp, jitter((h >> 16) & 0xffffffu))};
  }

 private:
  // A key for item v under key k: one round of mixing (splitmix64's step; k is
  // already a well-mixed hash, so one round suffices).
  static constexpr uint64_t derive(uint64_t k, uint64_t v) { return mix_bits(k + (v + 1) * 0x9e3779b97f4a7c15ULL); }
  // Role constants (xored into a call's key) keep its different uses apart.
  static constexpr uint64_t role_1d = 0x243f6a8885a308d3ULL, role_2d = 0x13198a2e03707344ULL,
                            role_columns = 0xa4093822299f31d0ULL, role_rows = 0x082efa98ec4e6c89ULL,
                            role_jitter = 0x452821e638d01377ULL, role_independent = 0xbe5466cf34e90c6cULL;

  // 24 random bits -> [0, 1), as PCG32::next_float.
  static Float unit_float(uint64_t bits24) { return Float(bits24) * 0x1p-24f; }
  static double jitter(uint64_t bits24) { return double(bits24) * 0x1p-24; }

  uint64_t m_seed;
  uint32_t m_spp, m_nx = 1, m_ny = 1;
  uint64_t m_pixel_key = 0;
  uint32_t m_index = 0, m_dim = 0;
};

}  // namespace prism
