// Spectral basics: wavelength sampling against its density (chi^2), the
// normalisations of the CIE data, blackbody peaks, XYZ <-> sRGB.
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>
#include "prism/sampling/pcg32.hpp"
#include "prism/spectra/spectrum.hpp"
#include "support/chi2.hpp"
#include "support/reference_physics.hpp"

namespace spectra_test {

using namespace prism;

TEST_CASE("CIE Y of the normalised D65 and A is 1, and D65 maps to sRGB white", "[spectra][cie]") {
  // 1e-6 relative: the scale is 1/Y in float (one rounding) applied to float table values, summed in double
  CHECK(spectrum_to_y(illuminant_d65()) == Approx(1.0).epsilon(1e-6));
  CHECK(spectrum_to_y(illuminant_a()) == Approx(1.0).epsilon(1e-6));
  // D65 is sRGB's white: its XYZ maps to equal linear RGB (the 1 nm tables and
  // the 4-digit matrices agree to a few 1e-4).
  RGB w = xyz_to_linear_srgb(spectrum_to_xyz(illuminant_d65()));
  // 2e-3: sRGB's white is D65's chromaticity to 4 digits (±5e-5 in x, y): ≤ 3e-4 in X/Y and Z/Y, ≤ 1.2e-3 in R (measured 3.4e-6)
  CHECK(w.r == Approx(1).margin(2e-3));
  CHECK(w.g == Approx(1).margin(2e-3));
  CHECK(w.b == Approx(1).margin(2e-3));
  // Illuminant A is reddish: R > G > B.
  RGB a = xyz_to_linear_srgb(spectrum_to_xyz(illuminant_a()));
  CHECK(a.r > a.g);
  CHECK(a.g > a.b);
}

TEST_CASE("XYZ and linear sRGB matrices are inverses and the sRGB curve round-trips", "[spectra][cie]") {
  PCG32 rng(0, 7);
  for (int i = 0; i < 1000; ++i) {
    RGB c{rng.next_float(), rng.next_float(), rng.next_float()};
    RGB back = xyz_to_linear_srgb(linear_srgb_to_xyz(c));
    // 2e-6: two 3×3 float matrix products with coefficients ≤ 3.3 (≈ 10 roundings of sums ≤ 6: ~2e-6 worst case)
    for (int k = 0; k < 3; ++k) CHECK(back[k] == Approx(c[k]).margin(2e-6));
    Float v = rng.next_float();
    // 1e-6: float pow in encode and decode, ~10 roundings of values ≤ 1; bare Approx: 100·FLT_EPSILON relative
    CHECK(srgb_decode(srgb_encode(v)) == Approx(v).margin(1e-6));
  }
  CHECK(srgb_encode(1) == Approx(1));
  CHECK(srgb_encode(0) == 0);
}

TEST_CASE("Blackbody peaks follow Wien's law and are normalised to 1", "[spectra][blackbody]") {
  for (double T : {2000.0, 3000.0, 4000.0, 5500.0, 6500.0}) {
    BlackbodySpectrum b(T);
    double peak = BlackbodySpectrum::wien_peak_nm(T);
    // 1e-5 relative: the peak is found in float λ (ulp ~6e-5 nm) and the normalisation divides two float Planck values
    CHECK(double(b(Float(peak))) == Approx(1).epsilon(1e-5));
    // The maximum over a fine grid lies at Wien's wavelength (within the grid step).
    double best = 0, best_l = 0;
    for (double l = 100; l < 3000; l += 0.05) {
      double v = planck(l, T);
      if (v > best) best = v, best_l = l;
    }
    // 0.05 nm: the grid step
    CHECK(std::abs(best_l - peak) < 0.05);
  }
  CHECK_THROWS_AS(BlackbodySpectrum(-1), Error);
}

TEST_CASE("Piecewise-linear spectra interpolate, clamp at the ends and reject bad data", "[spectra]") {
  std::vector<float> l{400, 500, 600}, v{1, 3, 2};
  PiecewiseLinearSpectrum s(l, v, "test");
  CHECK(s(400) == 1);
  // bare Approx: Catch's 100·FLT_EPSILON ≈ 1.2e-5 relative, a float linear interpolation
  CHECK(s(450) == Approx(2));
  CHECK(s(550) == Approx(2.5));
  CHECK(s(300) == 1);
  CHECK(s(800) == 2);
  std::vector<float> bad_l{400, 400, 600};
  CHECK_THROWS_AS(PiecewiseLinearSpectrum(bad_l, v, "dup"), Error);
  std::vector<float> nan_v{1, NAN, 2};
  CHECK_THROWS_AS(PiecewiseLinearSpectrum(l, nan_v, "nan"), Error);
}

TEST_CASE("terminate_secondary keeps the hero with density pdf/N", "[spectra][wavelengths]") {
  auto w = SampledWavelengths<4>::sample(0.3f);
  Float p0 = w.pdf()[0];
  CHECK_FALSE(w.secondary_terminated());
  w.terminate_secondary();
  CHECK(w.secondary_terminated());
  // bare Approx: 100·FLT_EPSILON relative; dividing by 4 is exact in float
  CHECK(w.pdf()[0] == Approx(p0 / 4));
  for (int i = 1; i < 4; ++i) CHECK(w.pdf()[i] == 0);
  w.terminate_secondary();  // idempotent
  CHECK(w.pdf()[0] == Approx(p0 / 4));
}

TEST_CASE("Visible-wavelength sampling follows its density (chi-square)", "[spectra][wavelengths][chi2]") {
  PCG32 rng(0, 11);
  // The density integrates to 1 over [360, 830] nm.
  double integral = 0;
  for (int i = 0; i < 47000; ++i) integral += pdf_visible_wavelength(360 + (i + 0.5f) * 0.01f) * 0.01;
  // 1e-4: midpoint rule with 0.01 nm steps on a smooth density (error ~ h²/24·max|p''|·470 nm, ≪ 1e-4) plus float pdf evaluation (~1e-6)
  CHECK(integral == Approx(1).epsilon(1e-4));
  prism_test::Grid2D g{360, 830, 94, 0, 1, 1};
  auto r = prism_test::chi2_test_2d(
      [&]() -> std::optional<std::array<double, 2>> {
        return std::array<double, 2>{double(sample_visible_wavelength(rng.next_float())), 0.5};
      },
      [](double l, double) { return double(pdf_visible_wavelength(Float(l))); }, g, 200000);
  INFO(r.summary());
  CHECK(r.p_value >= 1e-3);  // one χ² test at the suite's false-alarm rate 1e-3
  // The stratified wavelengths of one sample each follow the same density.
  for (int k = 0; k < 4; ++k) {
    PCG32 rk(uint64_t(k), 100);
    auto rs = prism_test::chi2_test_2d(
        [&]() -> std::optional<std::array<double, 2>> {
          return std::array<double, 2>{double(SampledWavelengths<4>::sample(rk.next_float())[k]), 0.5};
        },
        [](double l, double) { return double(pdf_visible_wavelength(Float(l))); }, g, 100000);
    INFO("wavelength " << k << ": " << rs.summary());
    CHECK(rs.p_value >= prism_test::sidak_alpha(1e-3, 4));
  }
}

namespace {
// Variance of the one-sample XYZ estimate (N = 4 stratified wavelengths) of an
// emission spectrum, summed over X, Y, Z, and the estimate's mean.
template <class Spec>
std::pair<double, std::array<double, 3>> xyz_estimator_variance(const Spec& s, WavelengthSampling how, int n) {
  PCG32 rng(0, 5);
  std::array<double, 3> sum{}, sum_sq{};
  for (int i = 0; i < n; ++i) {
    auto w = SampledWavelengths<4>::sample(rng.next_float(), how);
    XYZ c = to_xyz(sample(s, w), w);
    for (int k = 0; k < 3; ++k) {
      sum[k] += c[k];
      sum_sq[k] += double(c[k]) * c[k];
    }
  }
  double var = 0;
  std::array<double, 3> mean{};
  for (int k = 0; k < 3; ++k) {
    mean[k] = sum[k] / n;
    var += sum_sq[k] / n - mean[k] * mean[k];
  }
  return {var, mean};
}
}  // namespace

TEST_CASE("Wavelength sampling: both strategies are unbiased and visible has the lower variance", "[spectra][wavelengths]") {
  const int n = 200000;
  BlackbodySpectrum warm(3000);
  std::vector<float> l{400, 500, 550, 600, 700}, v{0.05f, 0.1f, 0.8f, 0.3f, 0.1f};
  PiecewiseLinearSpectrum greenish(l, v, "greenish");
  // 4 spectra x 3 channels x 2 strategies = 24 comparisons, one family at
  // 10^-3 (Sidak): z = sidak_z(1e-3, 24) = 4.10.
  const double z = reference_physics::sidak_z(1e-3, 4 * 3 * 2);
  auto check = [&](const auto& spec, const char* name) {
    XYZ exact = spectrum_to_xyz(spec);
    auto [var_vis, mean_vis] = xyz_estimator_variance(spec, WavelengthSampling::visible, n);
    auto [var_uni, mean_uni] = xyz_estimator_variance(spec, WavelengthSampling::uniform, n);
    for (int k = 0; k < 3; ++k) {
      // Unbiased: the mean of n estimates is within z sigma (+ the 1 nm table
      // quadrature of the reference) of the exact XYZ; sigma from the variance
      // summed over X, Y and Z, which bounds each channel's.
      double sig_v = std::sqrt(var_vis / n), sig_u = std::sqrt(var_uni / n);
      CHECK(std::abs(mean_vis[size_t(k)] - exact[k]) <= z * sig_v + 1e-3 * std::abs(exact[k]));
      CHECK(std::abs(mean_uni[size_t(k)] - exact[k]) <= z * sig_u + 1e-3 * std::abs(exact[k]));
    }
    WARN(name << ": variance of the XYZ estimate (sum over X, Y, Z), visible " << var_vis << ", uniform " << var_uni
              << ", ratio uniform/visible " << var_uni / var_vis);
    CHECK(var_vis < var_uni);
  };
  check(illuminant_d65(), "D65");
  check(illuminant_a(), "illuminant A");
  check(warm, "blackbody 3000 K");
  check(greenish, "greenish reflectance");
}

}  // namespace spectra_test
