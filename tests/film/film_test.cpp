// Film and filters: the Gaussian filter's importance sampling reproduces the
// filter (weighted moments), and the film's variance estimate is right.
// Each statistical check is a single comparison at a false-alarm rate of
// 10^-3: z = sidak_z(1e-3, 1) = 3.29 (tests/support/reference_physics.hpp).
#include <catch2/catch.hpp>
#include <prism/prism.hpp>
#include "support/reference_physics.hpp"

namespace film_test {

using namespace prism;

TEST_CASE("Gaussian filter importance sampling reproduces the filter", "[film][filter]") {
  GaussianFilter f(1.5f, 0.5f);
  // E_p[w g(x)] / E_p[w] must equal the filter-weighted mean of g, here g = x^2,
  // computed by quadrature of the filter itself.
  double num = 0, den = 0;
  const int q = 20000;
  for (int i = 0; i < q; ++i) {
    double x = -1.5 + (i + 0.5) * 3.0 / q;
    num += f.eval_1d(Float(x)) * x * x;
    den += f.eval_1d(Float(x));
  }
  const double expected = num / den;
  PCG32 rng(4, 4);
  const int n = 400000;
  double sw = 0, swg = 0, swg2 = 0;
  for (int i = 0; i < n; ++i) {
    FilterSample s = f.sample({rng.next_float(), rng.next_float()});
    REQUIRE(std::abs(s.offset.x) <= 1.5f);
    REQUIRE(std::abs(s.offset.y) <= 1.5f);
    double g = double(s.offset.x) * s.offset.x;
    sw += s.weight;
    swg += s.weight * g;
    swg2 += s.weight * g * s.weight * g;
  }
  double est = swg / sw;
  double sigma = std::sqrt((swg2 / n - sqr(swg / n)) / n) / (sw / n);
  INFO("E[x^2] " << est << " expected " << expected << " sigma " << sigma);
  CHECK(std::abs(est - expected) <= reference_physics::sidak_z(1e-3, 1) * sigma);
}

TEST_CASE("box filter offsets are uniform over the pixel", "[film][filter]") {
  BoxFilter f;
  PCG32 rng(1, 1);
  double s = 0, s2 = 0;
  const int n = 100000;
  for (int i = 0; i < n; ++i) {
    FilterSample fs = f.sample({rng.next_float(), rng.next_float()});
    REQUIRE(fs.weight == 1);
    REQUIRE(std::abs(fs.offset.x) <= 0.5f);
    s += fs.offset.x;
    s2 += double(fs.offset.x) * fs.offset.x;
  }
  // Uniform on [-0.5, 0.5]: mean 0, variance 1/12.
  CHECK(std::abs(s / n) <= reference_physics::sidak_z(1e-3, 1) * std::sqrt(1.0 / 12 / n));
  // E[x^2] = 1/12 with Var x^2 = E[x^4] - 1/144 = 1/80 - 1/144 (was a bare 2% = 7 sigma).
  CHECK(std::abs(s2 / n - 1.0 / 12) <= reference_physics::sidak_z(1e-3, 1) * std::sqrt((1.0 / 80 - 1.0 / 144) / n));
}

TEST_CASE("film accumulates means and the variance of the mean", "[film]") {
  Film film(2, 1);
  const double vals[4] = {1, 2, 3, 6};
  // bare Approx: Catch's 100·FLT_EPSILON ≈ 1.2e-5 relative; the film sums in double and rounds once to float
  for (double v : vals) film.add_sample(1, 0, RGB(Float(v)), 1);
  CHECK(film.pixel(1, 0).r == Approx(3.0));
  // Sample variance (n - 1) = 14/3; of the mean: 14/12.
  CHECK(film.variance(1, 0).g == Approx(14.0 / 12.0));
  CHECK(film.sample_count(1, 0) == 4);
  CHECK(film.pixel(0, 0).is_black());
}

}  // namespace film_test
