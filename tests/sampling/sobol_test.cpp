// Tests of SobolSampler (prism/sampling/sobol.hpp): the Sobol' generator
// matrices, the nesting property of the hashed Owen scramble, the (0,k,2)-net
// property of every power-of-two prefix of every 2D call after shuffling and
// scrambling, 1D stratification, range, determinism, dependence of the
// scrambling on seed, pixel and dimension, uniformity and independence over
// pixels (chi-squared), and lower variance than IndependentSampler.
//
// Chi-squared levels as in warps_test.cpp: kChi2Tests goodness-of-fit tests of
// correct code, each at sidak_alpha(1e-3, kChi2Tests); seeds are fixed, so the
// outcome is reproducible.
#include <catch2/catch.hpp>
#include "support/sampler_estimates.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <vector>

#include "prism/sampling/pcg32.hpp"
#include "prism/sampling/sobol.hpp"
#include "support/reference_physics.hpp"
#include "prism/sampling/stratified.hpp"
#include "support/chi2.hpp"

namespace sobol_test {

using namespace prism;
using prism_test::EstimateStats;
using prism_test::pixel_estimates;

namespace {

constexpr int kChi2Tests = 9;  // marginals (4 + 2 in 1D), pairs of calls, neighbour pixels, seeds
const double kAlpha = prism_test::sidak_alpha(1e-3, kChi2Tests);

void check_chi2(const std::vector<double>& observed, double expected_each) {
  prism_test::Chi2Result r =
      prism_test::chi2_from_counts(observed, std::vector<double>(observed.size(), expected_each));
  INFO(r.summary() << " (alpha = " << kAlpha << ")");
  CHECK(r.p_value >= kAlpha);
}

// The numbers a renderer-like caller draws for one pixel sample: 1D (d = 0),
// then 2D calls at d = 1, 3, 5, then 1D at d = 7.
struct Draw {
  Float a;
  Point2f p[3];
  Float e;
};
Draw draw(SobolSampler& s, int px, int py, int i) {
  s.start_pixel_sample(px, py, i);
  Draw d;
  d.a = s.get_1d();
  for (Point2f& p : d.p) p = s.get_2d();
  d.e = s.get_1d();
  return d;
}

bool in_unit(Float v) { return v >= 0 && v < 1; }
long cell(Float v, int bits) { return long(std::floor(std::ldexp(double(v), bits))); }

// True when each 2^-a x 2^-b box (a + b = k) holds exactly one of the 2^k points.
bool is_02_net(const std::vector<Point2f>& pts, int k) {
  for (int a = 0; a <= k; ++a) {
    std::vector<int> hit(size_t(1) << k, 0);
    for (const Point2f& p : pts) {
      long c = (cell(p.y, k - a) << a) + cell(p.x, a);
      if (++hit[size_t(c)] > 1) return false;
    }
  }
  return true;
}

}  // namespace

TEST_CASE("sobol generator matrices give the unscrambled Sobol points", "[sampling][sobol]") {
  // The first 8 points of Sobol' dimensions 1 and 2 (Joe and Kuo's numbering),
  // in units of 1/8, as usually tabulated: in Gray-code order (Antonov and
  // Saleev 1979), point n = the natural-order point of index n ^ (n >> 1).
  const int x[8] = {0, 4, 6, 2, 3, 7, 5, 1}, y[8] = {0, 4, 2, 6, 3, 7, 1, 5};
  for (uint32_t n = 0; n < 8; ++n) {
    CHECK(sobol_0(n ^ (n >> 1)) == uint32_t(x[n]) << 29);
    CHECK(sobol_1(n ^ (n >> 1)) == uint32_t(y[n]) << 29);
  }
  // Direction numbers of the second dimension: rows of Pascal's triangle mod 2.
  CHECK(sobol_1(1u << 3) == 0xf0000000u);
  CHECK(sobol_1(1u << 16) == 0x80008000u);
  CHECK(sobol_1(1u << 31) == 0xffffffffu);
  CHECK(reverse_bits32(0x00000001u) == 0x80000000u);
  CHECK(reverse_bits32(0x12345678u) == 0x1e6a2c48u);
}

TEST_CASE("owen_scramble flips each digit as a function of the digits above it", "[sampling][sobol]") {
  // Nesting: two fractions that agree on their first t digits and differ in
  // digit t still do so after scrambling (which also makes the map a bijection).
  PCG32 rng(3, 17);
  for (int n = 0; n < 100000; ++n) {
    uint32_t seed = rng.next_u32(), v = rng.next_u32();
    uint32_t w = v ^ (0xffffffffu >> (rng.next_u32() % 32));  // agrees on a random prefix
    INFO("v = " << v << ", w = " << w << ", seed = " << seed);
    REQUIRE(std::countl_zero(owen_scramble(v, seed) ^ owen_scramble(w, seed)) == std::countl_zero(v ^ w));
  }
}

TEST_CASE("sobol 2D calls are (0,k,2)-nets for every power-of-two prefix", "[sampling][sobol]") {
  // Every call of the sampler, for several pixels and seeds: the first 2^k
  // samples, k = 0..10, form a (0,k,2)-net in base 2 despite the shuffle.
  const int kmax = 10, n = 1 << kmax;
  for (uint64_t seed : {0ull, 42ull})
    for (auto [px, py] : {std::pair{0, 0}, std::pair{1, 0}, std::pair{17, 300}, std::pair{-5, 2047}}) {
      SobolSampler s(n, seed);
      std::vector<Point2f> pts[3];
      for (int i = 0; i < n; ++i) {
        Draw d = draw(s, px, py, i);
        for (int c = 0; c < 3; ++c) {
          REQUIRE(in_unit(d.p[c].x));
          REQUIRE(in_unit(d.p[c].y));
          pts[c].push_back(d.p[c]);
        }
      }
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k <= kmax; ++k) {
          INFO("seed " << seed << ", pixel " << px << ", " << py << ", call " << c << ", k = " << k);
          CHECK(is_02_net(std::vector<Point2f>(pts[c].begin(), pts[c].begin() + (1 << k)), k));
        }
    }
}

TEST_CASE("sobol 1D calls are stratified for every power-of-two prefix", "[sampling][sobol]") {
  const int kmax = 10, n = 1 << kmax;
  for (auto [px, py] : {std::pair{0, 0}, std::pair{9, 4}, std::pair{640, 480}}) {
    SobolSampler s(n, 7);
    std::vector<Float> a, e;
    for (int i = 0; i < n; ++i) {
      Draw d = draw(s, px, py, i);
      REQUIRE(in_unit(d.a));
      REQUIRE(in_unit(d.e));
      a.push_back(d.a);
      e.push_back(d.e);
    }
    for (int k = 0; k <= kmax; ++k) {
      std::vector<int> ha(size_t(1) << k, 0), he(size_t(1) << k, 0);
      for (int i = 0; i < (1 << k); ++i) {
        ++ha[size_t(cell(a[size_t(i)], k))];
        ++he[size_t(cell(e[size_t(i)], k))];
      }
      INFO("pixel " << px << ", " << py << ", k = " << k);
      CHECK(std::all_of(ha.begin(), ha.end(), [](int h) { return h == 1; }));
      CHECK(std::all_of(he.begin(), he.end(), [](int h) { return h == 1; }));
    }
  }
}

TEST_CASE("sobol scrambling depends on seed, pixel and dimension", "[sampling][sobol]") {
  // Over the first 64 samples, no value may repeat across two seeds, two
  // neighbouring pixels, or two calls of one sample (a shared scramble would
  // repeat them all). Coincidences of random 24-bit values: ~64^2 / 2^24.
  SobolSampler s0(64, 0), s1(64, 1);
  int same_seed = 0, same_pixel = 0, same_call = 0;
  for (int i = 0; i < 64; ++i) {
    Draw a = draw(s0, 10, 20, i), b = draw(s1, 10, 20, i), c = draw(s0, 11, 20, i);
    same_seed += a.p[0] == b.p[0];
    same_pixel += a.p[0] == c.p[0];
    same_call += a.p[0] == a.p[1] || a.p[1] == a.p[2] || a.a == a.e;
  }
  CHECK(same_seed == 0);
  CHECK(same_pixel == 0);
  CHECK(same_call == 0);
}

TEST_CASE("sobol numbers depend only on pixel, index and seed", "[sampling][sobol]") {
  SobolSampler a(16, 3), b(16, 3);
  Draw first = draw(a, 5, 6, 9);
  for (int i = 0; i < 40; ++i) {
    draw(a, 7, 1, i);
    a.get_2d();
  }
  Draw again = draw(a, 5, 6, 9), fresh = draw(b, 5, 6, 9);
  CHECK(again.a == first.a);
  for (int c = 0; c < 3; ++c) CHECK(again.p[c] == first.p[c]);
  CHECK(again.e == first.e);
  CHECK(fresh.p[2] == first.p[2]);
  CHECK(fresh.e == first.e);
}

TEST_CASE("sobol samples are uniform and independent over pixels", "[sampling][sobol][chi2]") {
  // For a fixed sample index the scramble is what randomises a pixel's point:
  // over many pixels it must be uniform (16 x 16 cells for 2D calls, 64 for
  // 1D), two calls of one sample must be independent, and so must neighbouring
  // pixels and two seeds (a weak hash would correlate them).
  const int pixels = 65536;
  SobolSampler s(64, 99), t(64, 100);
  std::vector<double> marg[4], marg1d[2], calls(256, 0.0), neighbours(256, 0.0), seeds(256, 0.0);
  for (auto& m : marg) m.assign(256, 0.0);
  for (auto& m : marg1d) m.assign(64, 0.0);
  const int indices[4] = {0, 1, 5, 37};
  for (int p = 0; p < pixels; ++p) {
    int px = p % 256, py = p / 256;
    for (int k = 0; k < 4; ++k) {
      Draw d = draw(s, px, py, indices[k]);
      marg[k][size_t(cell(d.p[k % 3].y, 4) * 16 + cell(d.p[k % 3].x, 4))] += 1;
      if (k < 2) marg1d[k][size_t(cell(k == 0 ? d.a : d.e, 6))] += 1;
      if (k == 2) {
        calls[size_t(cell(d.p[0].x, 4) * 16 + cell(d.p[1].x, 4))] += 1;
        Draw n = draw(s, px + 1, py, indices[k]), o = draw(t, px, py, indices[k]);
        neighbours[size_t(cell(d.p[1].y, 4) * 16 + cell(n.p[1].y, 4))] += 1;
        seeds[size_t(cell(d.a, 4) * 16 + cell(o.a, 4))] += 1;
      }
    }
  }
  for (auto& m : marg) check_chi2(m, pixels / 256.0);
  for (auto& m : marg1d) check_chi2(m, pixels / 64.0);
  check_chi2(calls, pixels / 256.0);
  check_chi2(neighbours, pixels / 256.0);
  check_chi2(seeds, pixels / 256.0);
}



TEST_CASE("sobol sampling has lower variance than independent and stratified sampling", "[sampling][sobol][variance]") {
  const int spp = 64, pixels = 4096;
  const double g = 0.74682413281242702540;  // integral of exp(-x^2) over [0, 1]
  struct Case {
    const char* name;
    double (*f)(double, double);
    double exact, min_ratio;
  };
  const Case cases[] = {{"exp(-x^2-y^2)", [](double x, double y) { return std::exp(-x * x - y * y); }, g * g, 100.0},
                        {"quarter disk", [](double x, double y) { return x * x + y * y < 1 ? 1.0 : 0.0; },
                         0.78539816339744830962, 3.0}};
  // The Sobol mean of 2 cases, one family at 10^-3 (Sidak); sigma from the pixel means (the normal limit).
  const double z = reference_physics::sidak_z(1e-3, 2);
  for (const Case& c : cases) {
    IndependentSampler ind(5);
    StratifiedSampler strat(spp, 5);
    SobolSampler sobol(spp, 5);
    EstimateStats a = pixel_estimates(ind, pixels, spp, c.f), b = pixel_estimates(strat, pixels, spp, c.f),
                  q = pixel_estimates(sobol, pixels, spp, c.f);
    INFO(c.name << ": variance independent " << a.variance << ", stratified " << b.variance << ", sobol "
                << q.variance << "; independent / sobol = " << a.variance / q.variance
                << ", stratified / sobol = " << b.variance / q.variance);
    CHECK(a.variance / q.variance >= c.min_ratio);
    CHECK(q.variance <= b.variance);
    CHECK(std::abs(q.mean - c.exact) <= z * std::sqrt(q.variance / pixels));
  }
}

}  // namespace sobol_test
