// Chi-squared goodness-of-fit tests of every warp and piecewise-constant
// distribution against the density it claims (see tests/support/chi2.hpp for
// the method). Each sampler's cells are integrated numerically from its pdf;
// each test also checks that the pdf integrates to 1 over its domain.
//
// Levels: the file runs kChi2Tests goodness-of-fit tests on correct samplers;
// each must reach p >= sidak_alpha(1e-3, kChi2Tests), so that the chance of any
// false failure in this file is 1e-3 (and with fixed seeds, the outcome is
// reproducible). The sanity tests at the end show that the same machinery
// rejects wrong densities.
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "prism/sampling/distribution.hpp"
#include "prism/sampling/pcg32.hpp"
#include "prism/sampling/warps.hpp"
#include "support/chi2.hpp"

namespace warps_test {

using namespace prism;
using prism_test::Chi2Result;
using prism_test::Grid2D;

namespace {

constexpr int kChi2Tests = 10;  // goodness-of-fit tests on correct samplers below
constexpr double kFamilyAlpha = 1e-3;
const double kAlpha = prism_test::sidak_alpha(kFamilyAlpha, kChi2Tests);
constexpr size_t kSamples = 1000000;
constexpr double kPi = 3.14159265358979323846;
// Unit roundoff of float.
constexpr double kU = 0x1p-24;
// The pdfs are evaluated in float with a handful (< 8) of roundings each, and
// the Gauss-Legendre quadrature of these smooth (or cell-aligned piecewise
// constant) integrands is exact to far below that; 16 u bounds the integral's error.
constexpr double kIntegralTol = 16 * kU;
// Sample coordinates are computed in float from values of magnitude <= 1 with
// a few roundings (and one libm call of < 1 ulp): they may overshoot a domain
// boundary by at most a few ulps at 1, bounded here by 2^-21.
constexpr double kCoordSlack = 0x1p-21;

Point2f next_2d(PCG32& rng) {
  Float a = rng.next_float();
  return {a, rng.next_float()};
}

std::array<double, 3> to_array(const Vector3f& v) { return {v.x, v.y, v.z}; }

void check_result(const Chi2Result& r) {
  INFO(r.summary() << " (alpha = " << kAlpha << ")");
  CHECK(r.impossible == 0);
  CHECK(r.integral == Approx(1.0).margin(kIntegralTol));
  CHECK(r.p_value >= kAlpha);
}

}  // namespace

TEST_CASE("chi2 helper matches known chi-squared quantiles", "[sampling][chi2]") {
  // Upper 5% and 0.1% points of the chi-squared distribution (standard tables,
  // e.g. NIST/SEMATECH e-Handbook 1.3.6.7.4, here to 17 digits), and
  // Q(1, x) = exp(-x). The series and continued fraction stop at 1e-16
  // relative; exp and lgamma of arguments up to ~75 cost a few more digits,
  // hence 1e-9 (1e-7 far in the tail at 100 dof, where the p-value is 1e-3
  // and the terms are larger).
  CHECK(prism_test::chi2_p_value(3.841458820694124, 1) == Approx(0.05).epsilon(1e-9));
  CHECK(prism_test::chi2_p_value(18.307038053275146, 10) == Approx(0.05).epsilon(1e-9));
  CHECK(prism_test::chi2_p_value(124.34211340400407, 100) == Approx(0.05).epsilon(1e-8));
  CHECK(prism_test::chi2_p_value(10.827566170662733, 1) == Approx(0.001).epsilon(1e-8));
  CHECK(prism_test::chi2_p_value(149.44925277903866, 100) == Approx(0.001).epsilon(1e-7));
  for (double x : {0.1, 1.0, 2.5, 10.0, 50.0}) CHECK(prism_test::regularized_gamma_q(1.0, x) == Approx(std::exp(-x)).epsilon(1e-12));
  CHECK(prism_test::chi2_p_value(0.0, 5) == 1.0);
  // Šidák: m tests at level alpha_m reject nothing with probability (1 - alpha_m)^m.
  double a = prism_test::sidak_alpha(1e-3, 10);
  // 1e-12: double pow of a number within 1e-4 of 1 (10 roundings of 2^-53, far below)
  CHECK(std::pow(1 - a, 10) == Approx(1 - 1e-3).epsilon(1e-12));
  // Pooling: a sample in a zero-probability cell fails outright.
  Chi2Result r = prism_test::chi2_from_counts({10, 1, 9}, {10, 0, 10});
  CHECK(r.impossible == 1);
  CHECK(r.p_value == 0.0);
}

TEST_CASE("concentric disk warp matches its area pdf", "[sampling][warps][chi2]") {
  PCG32 rng(1, 0x5eed);
  auto sample = [&]() -> std::optional<std::array<double, 2>> {
    Point2f p = sample_uniform_disk_concentric(next_2d(rng));
    double r = std::hypot(double(p.x), double(p.y));
    double phi = std::atan2(double(p.y), double(p.x));
    if (phi < 0) phi += 2 * kPi;
    return std::array<double, 2>{r, phi};
  };
  // Density per dr dphi: pdf per unit area times the Jacobian r.
  auto density = [](double r, double) { return double(pdf_uniform_disk()) * r; };
  Grid2D g{0, 1, 16, 0, 2 * kPi, 32, kCoordSlack};
  check_result(prism_test::chi2_test_2d(sample, density, g, kSamples));
}

TEST_CASE("cosine hemisphere warp matches its pdf", "[sampling][warps][chi2]") {
  PCG32 rng(2, 0x5eed);
  auto sample = [&]() -> std::optional<std::array<double, 3>> { return to_array(sample_cosine_hemisphere(next_2d(rng))); };
  auto pdf = [](const std::array<double, 3>& w) { return double(pdf_cosine_hemisphere(Float(w[2]))); };
  // Bin the upper hemisphere (theta = pi/2 included): a sample below the
  // horizon lands outside, where the expected count is 0, and fails the test.
  check_result(prism_test::chi2_test_directions(sample, pdf, kSamples, 16, 32, kPi / 2));
}

TEST_CASE("uniform hemisphere warp matches its pdf", "[sampling][warps][chi2]") {
  PCG32 rng(3, 0x5eed);
  auto sample = [&]() -> std::optional<std::array<double, 3>> { return to_array(sample_uniform_hemisphere(next_2d(rng))); };
  auto pdf = [](const std::array<double, 3>& w) { return w[2] >= 0 ? double(pdf_uniform_hemisphere()) : 0.0; };
  check_result(prism_test::chi2_test_directions(sample, pdf, kSamples, 16, 32, kPi / 2));
}

TEST_CASE("uniform sphere warp matches its pdf", "[sampling][warps][chi2]") {
  PCG32 rng(4, 0x5eed);
  auto sample = [&]() -> std::optional<std::array<double, 3>> { return to_array(sample_uniform_sphere(next_2d(rng))); };
  auto pdf = [](const std::array<double, 3>&) { return double(pdf_uniform_sphere()); };
  check_result(prism_test::chi2_test_directions(sample, pdf, kSamples, 20, 32));
}

TEST_CASE("uniform cone warp matches its pdf", "[sampling][warps][chi2]") {
  // Three apertures: narrow, wide, and wider than a hemisphere. Counts as three
  // of the file's chi-squared tests.
  const Float cos_maxes[3] = {0.99f, 0.5f, -0.5f};
  for (int k = 0; k < 3; ++k) {
    Float cos_max = cos_maxes[k];
    INFO("cos_max = " << cos_max);
    PCG32 rng(5 + uint64_t(k), 0x5eed);
    auto sample = [&]() -> std::optional<std::array<double, 3>> {
      return to_array(sample_uniform_cone(next_2d(rng), cos_max));
    };
    auto pdf = [&](const std::array<double, 3>& w) {
      return w[2] >= double(cos_max) ? double(pdf_uniform_cone(cos_max)) : 0.0;
    };
    // Bin only the cone, so that its cells are fine even when it is narrow; a
    // sample outside it goes to the extra cell whose expected count is ~0.
    // cos(theta) is computed in float from values <= 1, so it may fall below
    // cos_max by a few ulps at 1 (kCoordSlack).
    double theta_max = std::acos(double(cos_max));
    check_result(prism_test::chi2_test_directions(sample, pdf, kSamples, 16, 32, theta_max, kCoordSlack));
  }
}

TEST_CASE("uniform triangle warp is uniform in area", "[sampling][warps][chi2]") {
  // Barycentrics (b0, b1) are uniform on the reference triangle (density 2 per
  // unit barycentric area) iff the warp is area-uniform on every triangle, since
  // barycentric coordinates are an affine map. Map the triangle to the square
  // with s = b0, t = b1 / (1 - b0): density 2 (1 - s) per ds dt, smooth.
  PCG32 rng(8, 0x5eed);
  auto sample = [&]() -> std::optional<std::array<double, 2>> {
    std::array<Float, 3> b = sample_uniform_triangle(next_2d(rng));
    if (!(b[0] >= 0 && b[1] >= 0 && b[2] >= -kCoordSlack)) return std::nullopt;
    double s = b[0], t = double(b[1]) / (1 - double(b[0]));
    return std::array<double, 2>{s, t};
  };
  auto density = [](double s, double) { return 2 * (1 - s); };
  Grid2D g{0, 1, 24, 0, 1, 24, kCoordSlack};
  check_result(prism_test::chi2_test_2d(sample, density, g, kSamples));

  // And barycentrics sum to one up to the rounding of b2 = 1 - b0 - b1.
  PCG32 rng2(9, 0x5eed);
  for (int i = 0; i < 100000; ++i) {
    std::array<Float, 3> b = sample_uniform_triangle(next_2d(rng2));
    REQUIRE(b[0] >= 0);
    REQUIRE(b[1] >= 0);
    REQUIRE(double(b[0]) + double(b[1]) + double(b[2]) == Approx(1.0).margin(2 * kU));
  }
}

namespace {

// A non-trivial function on [-1, 3] with a run of zero segments and one
// negative entry (taken by absolute value).
std::vector<Float> test_function_1d(int n) {
  std::vector<Float> f(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    double x = -1 + 4 * (i + 0.5) / n;
    f[size_t(i)] = Float(std::exp(-x) * std::sin(3 * x) * std::sin(3 * x) + (x > 1.5 ? 0.2 : 0.0));
  }
  f[5] = f[6] = f[7] = 0;
  f[20] = -0.7f;
  return f;
}

}  // namespace

TEST_CASE("PiecewiseConstant1D sampling matches its pdf", "[sampling][distribution][chi2]") {
  const int n = 37;
  std::vector<Float> f = test_function_1d(n);
  PiecewiseConstant1D dist(f, -1, 3);
  PCG32 rng(10, 0x5eed);
  size_t pdf_mismatch = 0, offset_mismatch = 0, invert_bad = 0;
  Float max_pdf = 0;
  for (Float v : f) max_pdf = std::max(max_pdf, std::abs(v) / dist.integral());
  auto sample = [&]() -> std::optional<std::array<double, 2>> {
    Float u = rng.next_float(), pdf = -1;
    int off = -1;
    Float x = dist.sample(u, &pdf, &off);
    if (pdf != dist.pdf(x)) ++pdf_mismatch;
    // The reported segment is the one whose value gives the pdf (up to the
    // float roundings of the two ways of dividing by the integral: <= 3 u).
    double seg_pdf = std::abs(double(f[size_t(off)])) / double(dist.integral());
    if (!(std::abs(seg_pdf - double(pdf)) <= 4 * kU * seg_pdf) || seg_pdf == 0) ++offset_mismatch;
    // invert() undoes sample(): x is rounded to float (error <= ulp(3)) and
    // the cdf is linear with slope pdf, so u is recovered within pdf * 2 ulp(3)
    // plus the float rounding of u itself.
    double tol = double(max_pdf) * 2 * 0x1p-22 + 2 * kU;
    if (std::abs(double(dist.invert(x)) - double(u)) > tol) ++invert_bad;
    return std::array<double, 2>{x, 0.5};
  };
  auto density = [&](double x, double) { return double(dist.pdf(Float(x))); };
  Grid2D g{-1, 3, 2 * n, 0, 1, 1, 0};  // two cells per segment, aligned with them
  check_result(prism_test::chi2_test_2d(sample, density, g, kSamples));
  CHECK(pdf_mismatch == 0);
  CHECK(offset_mismatch == 0);
  CHECK(invert_bad == 0);
  // integral() is the function's integral over [min, max].
  double exact = 0;
  for (Float v : f) exact += std::abs(double(v)) * 4.0 / n;
  // 4u: the integral is summed in double and rounded to float once (≤ u), against a double sum
  CHECK(double(dist.integral()) == Approx(exact).epsilon(4 * kU));
}

TEST_CASE("PiecewiseConstant2D sampling matches its pdf", "[sampling][distribution][chi2]") {
  const int nu = 23, nv = 17;
  std::vector<Float> f(static_cast<size_t>(nu * nv));
  for (int v = 0; v < nv; ++v)
    for (int u = 0; u < nu; ++u) {
      double x = (u + 0.5) / nu, y = (v + 0.5) / nv;
      double g = 1 + std::sin(7 * x) * std::cos(5 * y);
      f[size_t(v * nu + u)] = Float(g * g * std::exp(-2 * y));
    }
  for (int u = 0; u < nu; ++u) f[size_t(3 * nu + u)] = 0;  // an empty row
  for (int v = 9; v < 12; ++v)
    for (int u = 4; u < 10; ++u) f[size_t(v * nu + u)] = 0;  // an empty block
  PiecewiseConstant2D dist(f, nu, nv);
  PCG32 rng(11, 0x5eed);
  size_t pdf_mismatch = 0;
  auto sample = [&]() -> std::optional<std::array<double, 2>> {
    Float pdf = -1;
    Point2f p = dist.sample(next_2d(rng), &pdf);
    if (pdf != dist.pdf(p)) ++pdf_mismatch;
    return std::array<double, 2>{p.x, p.y};
  };
  auto density = [&](double x, double y) { return double(dist.pdf({Float(x), Float(y)})); };
  Grid2D g{0, 1, 2 * nu, 0, 1, 2 * nv, 0};
  check_result(prism_test::chi2_test_2d(sample, density, g, kSamples));
  CHECK(pdf_mismatch == 0);
}

// The tests below must reject: they show that the machinery above can fail.

TEST_CASE("chi2 test rejects cosine samples against the uniform hemisphere pdf", "[sampling][chi2][sanity]") {
  PCG32 rng(2, 0x5eed);
  auto sample = [&]() -> std::optional<std::array<double, 3>> { return to_array(sample_cosine_hemisphere(next_2d(rng))); };
  auto pdf = [](const std::array<double, 3>& w) { return w[2] >= 0 ? double(pdf_uniform_hemisphere()) : 0.0; };
  Chi2Result r = prism_test::chi2_test_directions(sample, pdf, kSamples, 16, 32, kPi / 2);
  INFO(r.summary());
  CHECK(r.impossible == 0);
  CHECK(r.integral == Approx(1.0).margin(kIntegralTol));  // a valid density, just the wrong one
  CHECK(r.p_value < kAlpha);
}

TEST_CASE("chi2 test rejects a 10 percent error in one segment", "[sampling][chi2][sanity]") {
  // Sample one distribution, test against another whose segment 30 is 10% heavier.
  const int n = 37;
  std::vector<Float> f = test_function_1d(n);
  std::vector<Float> wrong = f;
  wrong[30] *= 1.1f;
  PiecewiseConstant1D dist(f, -1, 3), claimed(wrong, -1, 3);
  PCG32 rng(12, 0x5eed);
  auto sample = [&]() -> std::optional<std::array<double, 2>> { return std::array<double, 2>{dist.sample(rng.next_float()), 0.5}; };
  auto density = [&](double x, double) { return double(claimed.pdf(Float(x))); };
  Chi2Result r = prism_test::chi2_test_2d(sample, density, Grid2D{-1, 3, 2 * n, 0, 1, 1, 0}, kSamples);
  INFO(r.summary());
  CHECK(r.p_value < kAlpha);
}

TEST_CASE("chi2 test rejects samples outside the claimed support", "[sampling][chi2][sanity]") {
  // Uniform sphere samples against the uniform hemisphere pdf: half the samples
  // land where the density is zero.
  PCG32 rng(13, 0x5eed);
  auto sample = [&]() -> std::optional<std::array<double, 3>> { return to_array(sample_uniform_sphere(next_2d(rng))); };
  auto pdf = [](const std::array<double, 3>& w) { return w[2] >= 0 ? double(pdf_uniform_hemisphere()) : 0.0; };
  // Binned over the whole sphere: the lower cells expect nothing.
  Chi2Result r = prism_test::chi2_test_directions(sample, pdf, 10000, 20, 32);
  INFO(r.summary());
  CHECK(r.impossible > 0);
  CHECK(r.p_value == 0.0);
  // Binned over the upper hemisphere only: the samples fall outside the grid,
  // where a density integrating to 1 leaves nothing.
  Chi2Result r2 = prism_test::chi2_test_directions(sample, pdf, 10000, 16, 32, kPi / 2);
  INFO(r2.summary());
  CHECK(r2.outside > 0);
  CHECK(r2.impossible == r2.outside);
  CHECK(r2.p_value == 0.0);
}

}  // namespace warps_test
