// Tests of StratifiedSampler (prism/sampling/stratified.hpp) and of its
// random-access permutation: stratification in 1D and 2D, range, determinism,
// uniformity of each sample over pixels, and lower variance than
// IndependentSampler on smooth and discontinuous 2D integrands.
//
// Chi-squared levels as in warps_test.cpp: kChi2Tests goodness-of-fit tests of
// correct code, each at sidak_alpha(1e-3, kChi2Tests). Seeds are fixed, so the
// outcome is reproducible.
#include <catch2/catch.hpp>
#include "support/sampler_estimates.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <vector>

#include "prism/sampling/pcg32.hpp"
#include "prism/sampling/stratified.hpp"
#include "support/chi2.hpp"
#include "support/reference_physics.hpp"

namespace stratified_test {

using namespace prism;
using prism_test::EstimateStats;
using prism_test::pixel_estimates;

namespace {

constexpr int kChi2Tests = 10;  // permutation laws (3), images of elements (4), sample marginals (3)
const double kAlpha = prism_test::sidak_alpha(1e-3, kChi2Tests);

void check_chi2(const std::vector<double>& observed, const std::vector<double>& expected) {
  prism_test::Chi2Result r = prism_test::chi2_from_counts(observed, expected);
  INFO(r.summary() << " (alpha = " << kAlpha << ")");
  CHECK(r.p_value >= kAlpha);
}

// The numbers a renderer-like caller draws for one pixel sample: 1D, 2D, 2D, 1D.
struct Draw {
  Float a;
  Point2f b, c;
  Float e;
};
template <class Sampler>
Draw draw(Sampler& s, int px, int py, int i) {
  s.start_pixel_sample(px, py, i);
  Draw d;
  d.a = s.get_1d();
  d.b = s.get_2d();
  d.c = s.get_2d();
  d.e = s.get_1d();
  return d;
}

bool in_unit(Float v) { return v >= 0 && v < 1; }

long stratum(Float v, long n) { return long(std::floor(double(v) * double(n))); }

}  // namespace

TEST_CASE("permute_index is a bijection of 0..n-1 for every n", "[sampling][stratified]") {
  std::vector<uint32_t> sizes;
  for (uint32_t n = 1; n <= 70; ++n) sizes.push_back(n);
  for (uint32_t n : {100u, 127u, 128u, 129u, 1000u, 1024u, 4097u}) sizes.push_back(n);
  for (uint32_t n : sizes)
    for (uint64_t seed = 0; seed < 20; ++seed) {
      std::vector<int> hit(n, 0);
      for (uint32_t i = 0; i < n; ++i) {
        uint32_t p = permute_index(i, n, seed);
        REQUIRE(p < n);
        ++hit[p];
      }
      INFO("n = " << n << ", seed = " << seed);
      CHECK(std::all_of(hit.begin(), hit.end(), [](int h) { return h == 1; }));
    }
}

TEST_CASE("permute_index draws small permutations uniformly", "[sampling][stratified][chi2]") {
  // n <= 16 takes the Fisher-Yates path: every one of the n! permutations
  // should be equally likely over seeds.
  for (uint32_t n : {3u, 4u, 5u}) {
    INFO("n = " << n);
    double fact = 1;
    for (uint32_t k = 2; k <= n; ++k) fact *= k;
    const int trials = 240 * int(fact);
    std::map<std::vector<uint32_t>, double> counts;
    for (int t = 0; t < trials; ++t) {
      std::vector<uint32_t> p(n);
      uint64_t seed = hash_values(uint64_t(t), n);
      for (uint32_t i = 0; i < n; ++i) p[i] = permute_index(i, n, seed);
      counts[p] += 1;
    }
    std::vector<uint32_t> perm(n);
    std::iota(perm.begin(), perm.end(), 0u);
    std::vector<double> observed, expected;
    do {
      observed.push_back(counts.count(perm) ? counts[perm] : 0.0);
      expected.push_back(trials / fact);
    } while (std::next_permutation(perm.begin(), perm.end()));
    check_chi2(observed, expected);
  }
}

TEST_CASE("permute_index sends each element to a uniform position", "[sampling][stratified][chi2]") {
  // n > 16 takes the cycle-walking path; each element's image must be uniform
  // over seeds (what unbiased stratified estimates need). Over independent
  // seeds, the image of one element is a multinomial sample: test the first
  // and the last element.
  for (uint32_t n : {17u, 64u})
    for (uint32_t i : {0u, n - 1}) {
      INFO("n = " << n << ", element " << i);
      const int trials = 100 * int(n);
      std::vector<double> observed(n, 0.0), expected(n, 100.0);
      for (int t = 0; t < trials; ++t) observed[permute_index(i, n, hash_values(uint64_t(t), 99))] += 1;
      check_chi2(observed, expected);
    }
}

TEST_CASE("stratified 1D samples fall one per stratum", "[sampling][stratified]") {
  for (int spp : {1, 2, 3, 7, 16, 17, 64, 100, 1024}) {
    StratifiedSampler s(spp, 7);
    for (auto [px, py] : {std::pair{0, 0}, std::pair{13, 5}, std::pair{-3, 1000}}) {
      std::vector<int> hit_a(size_t(spp), 0), hit_e(size_t(spp), 0);
      for (int i = 0; i < spp; ++i) {
        Draw d = draw(s, px, py, i);
        REQUIRE(in_unit(d.a));
        REQUIRE(in_unit(d.e));
        ++hit_a[size_t(stratum(d.a, spp))];
        ++hit_e[size_t(stratum(d.e, spp))];
      }
      INFO("spp = " << spp << ", pixel " << px << ", " << py);
      CHECK(std::all_of(hit_a.begin(), hit_a.end(), [](int h) { return h == 1; }));
      CHECK(std::all_of(hit_e.begin(), hit_e.end(), [](int h) { return h == 1; }));
    }
  }
}

TEST_CASE("stratified 2D samples fill every grid cell, row and column", "[sampling][stratified]") {
  // (spp, expected grid): square, near-square, prime (Latin hypercube only).
  const int cases[][3] = {{1, 1, 1}, {2, 1, 2}, {4, 2, 2},  {7, 1, 7},    {10, 2, 5},
                          {12, 3, 4}, {32, 4, 8}, {64, 8, 8}, {100, 10, 10}, {1024, 32, 32}};
  for (const auto& c : cases) {
    const int spp = c[0];
    StratifiedSampler s(spp, 11);
    INFO("spp = " << spp);
    REQUIRE(s.grid_x() == c[1]);
    REQUIRE(s.grid_y() == c[2]);
    const int nx = s.grid_x(), ny = s.grid_y();
    for (auto [px, py] : {std::pair{0, 0}, std::pair{40, 9}, std::pair{511, 1023}}) {
      INFO("pixel " << px << ", " << py);
      for (int which = 0; which < 2; ++which) {
        std::vector<int> cells(size_t(spp), 0), cols(size_t(spp), 0), rows(size_t(spp), 0);
        for (int i = 0; i < spp; ++i) {
          Draw d = draw(s, px, py, i);
          Point2f p = which == 0 ? d.b : d.c;
          REQUIRE(in_unit(p.x));
          REQUIRE(in_unit(p.y));
          ++cells[size_t(stratum(p.y, ny) * nx + stratum(p.x, nx))];
          ++cols[size_t(stratum(p.x, spp))];
          ++rows[size_t(stratum(p.y, spp))];
        }
        auto once = [](const std::vector<int>& v) { return std::all_of(v.begin(), v.end(), [](int h) { return h == 1; }); };
        CHECK(once(cells));
        CHECK(once(cols));
        CHECK(once(rows));
      }
    }
  }
}

TEST_CASE("stratified numbers depend only on pixel, index and seed", "[sampling][stratified]") {
  StratifiedSampler a(16, 3), b(16, 3), c(16, 4);
  Draw first = draw(a, 5, 6, 9);
  // Unrelated history on a: other pixels, indices, extra dimensions.
  for (int i = 0; i < 16; ++i) {
    Draw d = draw(a, 7, 1, i);
    (void)d;
    a.get_2d();
  }
  Draw again = draw(a, 5, 6, 9), fresh = draw(b, 5, 6, 9), other_seed = draw(c, 5, 6, 9);
  CHECK(again.a == first.a);
  CHECK(again.b == first.b);
  CHECK(again.c == first.c);
  CHECK(again.e == first.e);
  CHECK(fresh.b == first.b);
  CHECK(fresh.e == first.e);
  CHECK(other_seed.b != first.b);
  CHECK(other_seed.a != first.a);
}

TEST_CASE("stratified indices beyond spp give independent numbers in range", "[sampling][stratified]") {
  StratifiedSampler s(8, 1);
  int distinct = 0;
  Float prev = -1;
  for (int i : {8, 9, 100, 1 << 30, -1}) {
    Draw d = draw(s, 3, 4, i);
    Draw again = draw(s, 3, 4, i);
    CHECK(in_unit(d.a));
    CHECK(in_unit(d.b.x));
    CHECK(in_unit(d.b.y));
    CHECK(in_unit(d.c.x));
    CHECK(in_unit(d.e));
    CHECK(d.b == again.b);
    if (d.a != prev) ++distinct;
    prev = d.a;
  }
  CHECK(distinct == 5);
}

TEST_CASE("each stratified sample is uniform over pixels", "[sampling][stratified][chi2]") {
  // For a fixed sample index, a pixel's sample sits in a random stratum with a
  // random jitter: over many pixels it must be uniform (no bias). 1D in 64
  // bins, and both 2D calls in 16 x 16 bins; spp = 12 (a 3 x 4 grid).
  StratifiedSampler s(12, 2024);
  const int pixels = 64000;
  std::vector<double> h1(64, 0.0), h2(256, 0.0), h3(256, 0.0);
  for (int p = 0; p < pixels; ++p) {
    Draw d = draw(s, p % 400, p / 400, 5);
    h1[size_t(stratum(d.a, 64))] += 1;
    h2[size_t(stratum(d.b.y, 16) * 16 + stratum(d.b.x, 16))] += 1;
    h3[size_t(stratum(d.c.y, 16) * 16 + stratum(d.c.x, 16))] += 1;
  }
  check_chi2(h1, std::vector<double>(64, pixels / 64.0));
  check_chi2(h2, std::vector<double>(256, pixels / 256.0));
  check_chi2(h3, std::vector<double>(256, pixels / 256.0));
}



TEST_CASE("stratified sampling has lower variance than independent sampling", "[sampling][stratified][variance]") {
  const int spp = 64, pixels = 4096;
  // exp(-x^2 - y^2) over [0,1]^2 = (sqrt(pi)/2 erf(1))^2; the quarter disk
  // x^2 + y^2 < 1 has area pi/4.
  const double g = 0.74682413281242702540;
  struct Case {
    const char* name;
    double (*f)(double, double);
    double exact, min_ratio;
  };
  const Case cases[] = {{"exp(-x^2-y^2)", [](double x, double y) { return std::exp(-x * x - y * y); }, g * g, 20.0},
                        {"quarter disk", [](double x, double y) { return x * x + y * y < 1 ? 1.0 : 0.0; },
                         0.78539816339744830962, 3.0}};
  // 2 cases x 2 samplers, one family at 10^-3 (Sidak); sigma from 4096 pixel means (the normal limit).
  const double z = reference_physics::sidak_z(1e-3, 4);
  for (const Case& c : cases) {
    IndependentSampler ind(5);
    StratifiedSampler strat(spp, 5);
    EstimateStats a = pixel_estimates(ind, pixels, spp, c.f), b = pixel_estimates(strat, pixels, spp, c.f);
    double ratio = a.variance / b.variance;
    INFO(c.name << ": independent variance " << a.variance << ", stratified variance " << b.variance
                << ", ratio " << ratio);
    CHECK(ratio >= c.min_ratio);
    // Unbiased: both means within z standard errors of the exact integral.
    CHECK(std::abs(a.mean - c.exact) <= z * std::sqrt(a.variance / pixels));
    CHECK(std::abs(b.mean - c.exact) <= z * std::sqrt(b.variance / pixels));
  }
}

}  // namespace stratified_test
