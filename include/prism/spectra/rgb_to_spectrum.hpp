// prism/spectra/rgb_to_spectrum.hpp — RGB to spectrum uplift after Jakob and
// Hanika 2019, "A Low-Dimensional Function Space for Efficient Spectral
// Upsampling" (Computer Graphics Forum 38(2)). Our own code and fit; pbrt-v4's
// RGBToSpectrumTable was read for the table layout.
//
// The model. A linear sRGB colour c in [0, 1]^3 becomes the smooth reflectance
//
//   s(lambda) = S(c0 t^2 + c1 t + c2),   S(x) = 1/2 + x / (2 sqrt(1 + x^2)),
//
// with t = (lambda - 595 nm) / 235 nm, the wavelength normalised to [-1, 1] over
// 360..830 nm (the coefficients are for t, not nm: the polynomial stays well
// conditioned in single precision). The coefficients are fitted so that s, seen
// under D65 (sRGB's white), has the colour c:
//
//   xyz_to_linear_srgb(spectrum_to_xyz(s * illuminant_d65())) == c,
//
// so a grey albedo is a flat spectrum and RGB(1, 1, 1) lit by an RGB(1, 1, 1)
// light (RGBIlluminantSpectrum: D65 with Y = 1) reflects sRGB white.
//
// The fit (rgb2spec::Fitter). Gauss-Newton on (c0, c1, c2), the residual being
// the CIELAB difference (D65 white) between the spectrum's colour and c, with an
// analytic Jacobian. Colours are integrated at 1 nm over 360..830 nm against
// data/cie_cmf.hpp with the rectangle rule of spectrum_to_xyz, so the fit zeroes
// the very round-trip error the tests measure.
//
// The table (rgb2spec::fit_tables, RGBToSpectrumTable). As in pbrt-v4: three
// tables, one per largest component m; a colour with largest component z = c[m]
// is looked up at (x, y, z), x = c[(m+1)%3] / z, y = c[(m+2)%3] / z. Every axis
// has res nodes at grid_node(i / (res - 1)), denser near 0 and 1, and the
// coefficients are interpolated trilinearly in the grid parameter. Grey
// (r = g = b) is exact: c0 = c1 = 0, c2 = S^-1(r) (infinite at 0 and 1).
// The default resolution is 57 (odd, so that z = 1/2 is a node).
//
// The spectra. RGBAlbedoSpectrum uses the table directly when its colour's
// components straddle 1/2; a dark colour (all components <= 1/2) is 2 max(c)
// times the spectrum of c / (2 max(c)), and a light one (all >= 1/2) is 1 minus
// the dark spectrum of 1 - c. Both read the node slice z = 1/2 and so avoid the
// table's singular corners (black and white, where the coefficients diverge):
// errors there are relative, not absolute. RGBUnboundedSpectrum is 2 max(c)
// times the spectrum of c / (2 max(c)) (equal to the albedo for dark colours);
// RGBIlluminantSpectrum is that times D65.
//
// The table is fitted on first use (0.3-0.5 s on this project's two-core
// machine; docs/spectral.md, "RGB to spectrum uplift", has the measured options,
// the errors and why). Each cell starts from an extrapolation of its fitted
// neighbours, so Gauss-Newton needs 1.6 evaluations per cell on average.
// tools/rgb2spec/ holds a program that fits tables of any resolution with this
// same code, writes them as headers and measures times and round-trip errors.
//
// Render-time cost: srgb_to_spectrum_table() is a function-local static (after
// initialisation, one guard check, no lock); a lookup is a divide, three square
// roots and 24 loads, no allocation; an evaluation is one square root and one
// divide.
#pragma once
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <limits>
#include <span>
#include <string>
#include <thread>
#include <utility>
#include <vector>
#include "prism/error.hpp"
#include "prism/spectra/rgb.hpp"
#include "prism/spectra/spectrum.hpp"
// The fit's hot loop uses SSE2 (x86-64's baseline), and AVX2 with FMA or
// AVX-512 where the CPU has them (GCC and Clang: those functions are compiled
// for their target and chosen at run time). Elsewhere it is plain C++.
#if !defined(PRISM_RGB2SPEC_NO_SIMD) && (defined(__SSE2__) || defined(_M_X64))
#include <emmintrin.h>
#define PRISM_RGB2SPEC_SSE2 1
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define PRISM_RGB2SPEC_AVX2 1
#ifndef PRISM_RGB2SPEC_MAX_SIMD
#define PRISM_RGB2SPEC_MAX_SIMD 2
#endif
#endif
#endif

namespace prism {

namespace detail {
// S(x) = 1/2 + x / (2 sqrt(1 + x^2)); S(+inf) = 1, S(-inf) = 0. Beyond |x| = 1e18
// (where x^2 would overflow in single precision) S is 0 or 1 to working precision.
template <class T>
inline T sigmoid(T x) {
  if (!(std::abs(x) < T(1e18))) return x > 0 ? T(1) : T(0);
  return T(0.5) + x / (T(2) * std::sqrt(T(1) + x * x));
}
// The inverse of S on [0, 1]: (y - 1/2) / sqrt(y (1 - y)); -inf at 0, +inf at 1.
inline double inverse_sigmoid(double y) {
  if (y <= 0) return -std::numeric_limits<double>::infinity();
  if (y >= 1) return std::numeric_limits<double>::infinity();
  return (y - 0.5) / std::sqrt(y * (1 - y));
}
}  // namespace detail

// s(lambda) = S(c0 t^2 + c1 t + c2), t = (lambda - 595 nm) / 235 nm.
struct RGBSigmoidPolynomial {
  Float c0 = 0, c1 = 0, c2 = 0;

  static constexpr Float lambda_center = 595, lambda_half_range = 235;
  static constexpr Float normalised_wavelength(Float lambda_nm) {
    return (lambda_nm - lambda_center) * (1 / lambda_half_range);
  }

  Float operator()(Float lambda_nm) const {
    Float t = normalised_wavelength(lambda_nm);
    return detail::sigmoid((c0 * t + c1) * t + c2);
  }
  // The largest and smallest values over 360..830 nm: S is increasing, so they
  // are S of the polynomial's extremes over t in [-1, 1] (an end, or the vertex).
  Float max_value() const { return detail::sigmoid(extreme(Float(1))); }
  Float min_value() const { return detail::sigmoid(-extreme(Float(-1))); }

 private:
  // max over t in [-1, 1] of sign * p(t).
  Float extreme(Float sign) const {
    Float a = sign * c0, b = sign * c1, c = sign * c2;
    Float p = std::max(a - b + c, a + b + c);
    if (a < 0) {
      Float tv = -b / (2 * a);
      if (tv > -1 && tv < 1) p = std::max(p, (a * tv + b) * tv + c);
    }
    return p;
  }
};

// --- the fit ------------------------------------------------------------------

namespace rgb2spec {

// The default resolution of the sRGB table (see docs/spectral.md).
inline constexpr int default_resolution = 57;
// Coefficients are kept within [-max_coefficient, max_coefficient]: the fit
// scales them down uniformly past that, and grey cells at 0 and 1 store the
// clamped S^-1 (the lookup handles grey exactly, so only neighbours see them).
inline constexpr double max_coefficient = 2000;
// Gauss-Newton stops below this CIELAB residual (Delta E 1976), or after a
// full step taken from below fit_trust (measured: the residual after such a
// step is at most 0.2 times the square of the one before, so below 2e-5).
inline constexpr double fit_tolerance = 1e-4, fit_trust = 5e-2, trust_step = 1e-2;

// The grid along every axis (the largest component z and the ratios x, y):
// node i of res sits at g(i / (res - 1)) with g(u) = 2 u^2 for u <= 1/2 and
// 1 - 2 (1 - u)^2 above, so node spacing shrinks like sqrt(v) near 0 and like
// sqrt(1 - v) near 1, where the coefficients grow like v^-1/2 (the sigmoid's
// tails: S(p) ~ 1 / (4 p^2)). Coefficients are interpolated linearly in u.
inline double grid_node(double u) { return u <= 0.5 ? 2 * u * u : 1 - 2 * (1 - u) * (1 - u); }
inline double grid_node(int i, int res) { return grid_node(double(i) / double(res - 1)); }
// The inverse of grid_node on [0, 1].
inline Float grid_parameter(Float v) {
  v = std::clamp(v, Float(0), Float(1));
  return v <= Float(0.5) ? std::sqrt(v * Float(0.5)) : 1 - std::sqrt((1 - v) * Float(0.5));
}

// Gauss-Newton fit of the sigmoid polynomial to one linear sRGB colour.
class Fitter {
 public:
  static constexpr int n = data::cie_samples;

  Fitter() {
    // sRGB <-> XYZ: the same (single-precision) matrices as spectrum.hpp.
    constexpr RGB ex{1, 0, 0}, ey{0, 1, 0}, ez{0, 0, 1};
    const XYZ cols[3] = {linear_srgb_to_xyz(ex), linear_srgb_to_xyz(ey), linear_srgb_to_xyz(ez)};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) m_to_xyz[i][j] = double(cols[j][i]);
    const RGB inv_cols[3] = {xyz_to_linear_srgb({1, 0, 0}), xyz_to_linear_srgb({0, 1, 0}),
                             xyz_to_linear_srgb({0, 0, 1})};
    double to_rgb[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) to_rgb[i][j] = double(inv_cols[j][i]);
    // Weights per wavelength: D65 (Y = 1, as the renderer evaluates it) times
    // the CMFs over the integral of y-bar gives XYZ; to_rgb gives the linear
    // sRGB a round trip reads; m_to_xyz maps that back to XYZ for CIELAB.
    const CIEIlluminant& d65 = illuminant_d65();
    for (int i = 0; i < n; ++i) {
      Float lambda = Float(data::cie_lambda_min + i);
      m_t[i] = double(RGBSigmoidPolynomial::normalised_wavelength(lambda));
      double e = double(d65(lambda)) / data::cie_y_integral;
      double xyz[3] = {e * data::cie_x[i], e * data::cie_y[i], e * data::cie_z[i]}, rgb[3];
      for (int k = 0; k < 3; ++k) rgb[k] = to_rgb[k][0] * xyz[0] + to_rgb[k][1] * xyz[1] + to_rgb[k][2] * xyz[2];
      for (int k = 0; k < 3; ++k)
        m_w[k][i] = m_to_xyz[k][0] * rgb[0] + m_to_xyz[k][1] * rgb[1] + m_to_xyz[k][2] * rgb[2];
    }
    for (int k = 0; k < 3; ++k) m_white[k] = m_to_xyz[k][0] + m_to_xyz[k][1] + m_to_xyz[k][2];
  }

  struct Result {
    int iterations = 0;     // evaluations of the spectrum's colour
    double residual = 0;    // CIELAB distance (Delta E 1976) at the end
    bool converged = false; // residual below the tolerance
    bool last_step_unchecked = false;  // ended with a full step from below `trust`; residual is the one before it
  };

  // The instruction set of the hot loop: "AVX-512", "AVX2+FMA", "SSE2" or "scalar".
  const char* simd() const {
#if defined(PRISM_RGB2SPEC_AVX2)
    if (m_simd == 2) return "AVX-512";
    if (m_simd == 1) return "AVX2+FMA";
#endif
#if defined(PRISM_RGB2SPEC_SSE2)
    return "SSE2";
#else
    return "scalar";
#endif
  }

  // The CIELAB residual of coefficients c for the colour rgb (one evaluation).
  double residual_norm(const double rgb[3], const double c[3]) const {
    double target[3], r[3], J[3][3];
    target_lab(rgb, target);
    residual(c, target, r, J);
    return std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
  }

  // Fits c (read as the starting point, written with the result) to the
  // linear sRGB colour rgb.
  Result fit(const double rgb[3], double c[3], double tolerance = fit_tolerance, double trust = fit_trust,
             int max_iterations = 200) const {
    double target[3];
    target_lab(rgb, target);
    Result res;
    // Gauss-Newton from the best point so far; a step that does not lower the
    // residual is halved (backtracking) until it does.
    double best[3] = {c[0], c[1], c[2]}, d[3] = {0, 0, 0};
    double best_norm = std::numeric_limits<double>::infinity(), damping = 1;
    while (res.iterations < max_iterations) {
      double r[3], J[3][3];
      residual(c, target, r, J);
      ++res.iterations;
      double norm = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
      if (norm < best_norm) {
        best_norm = norm;
        for (int k = 0; k < 3; ++k) best[k] = c[k];
        if (norm < tolerance) {
          res.converged = true;
          break;
        }
        if (!solve_matrix(J, r, d)) break;
        damping = 1;
        if (norm < trust && std::max({std::abs(d[0]), std::abs(d[1]), std::abs(d[2])}) < trust_step) {
          // Quadratic convergence: a small full step lands far below the tolerance.
          for (int k = 0; k < 3; ++k) c[k] = best[k] - d[k];
          clamp(c);
          res.converged = res.last_step_unchecked = true;
          res.residual = norm;
          return res;
        }
      } else {
        damping *= 0.5;
        if (damping < 1e-4) break;
      }
      for (int k = 0; k < 3; ++k) c[k] = best[k] - damping * d[k];
      clamp(c);
    }
    for (int k = 0; k < 3; ++k) c[k] = best[k];
    res.residual = best_norm;
    return res;
  }

 private:
  // Wavelengths padded to a multiple of 8 with zero weights.
  static constexpr int n_padded = (n + 7) / 8 * 8;
  alignas(64) double m_t[n_padded] = {}, m_w[3][n_padded] = {};
  double m_to_xyz[3][3], m_white[3];

  void target_lab(const double rgb[3], double target[3]) const {
    double xyz[3];
    for (int k = 0; k < 3; ++k) xyz[k] = m_to_xyz[k][0] * rgb[0] + m_to_xyz[k][1] * rgb[1] + m_to_xyz[k][2] * rgb[2];
    lab(xyz, target, nullptr);
  }

  static void clamp(double c[3]) {
    double m = std::max({std::abs(c[0]), std::abs(c[1]), std::abs(c[2])});
    if (m > max_coefficient)
      for (int k = 0; k < 3; ++k) c[k] *= max_coefficient / m;
  }

  // CIELAB of xyz with the sRGB white; dlab[i][j] = d lab_i / d xyz_j if asked.
  void lab(const double xyz[3], double out[3], double (*dlab)[3]) const {
    constexpr double delta = 6.0 / 29.0;
    double f[3], df[3];
    for (int k = 0; k < 3; ++k) {
      double v = xyz[k] / m_white[k];
      if (v > delta * delta * delta) {
        f[k] = std::cbrt(v);
        df[k] = 1 / (3 * f[k] * f[k]) / m_white[k];
      } else {
        f[k] = v / (3 * delta * delta) + 4.0 / 29.0;
        df[k] = 1 / (3 * delta * delta) / m_white[k];
      }
    }
    out[0] = 116 * f[1] - 16;
    out[1] = 500 * (f[0] - f[1]);
    out[2] = 200 * (f[1] - f[2]);
    if (dlab) {
      dlab[0][0] = 0, dlab[0][1] = 116 * df[1], dlab[0][2] = 0;
      dlab[1][0] = 500 * df[0], dlab[1][1] = -500 * df[1], dlab[1][2] = 0;
      dlab[2][0] = 0, dlab[2][1] = 200 * df[1], dlab[2][2] = -200 * df[2];
    }
  }

  // r = lab(spectrum(c)) - target and its Jacobian J = d r / d c.
  void residual(const double c[3], const double target[3], double r[3], double J[3][3]) const {
    double sum[12];
    moments(c, sum);
    double dlab[3][3], lab_c[3];
    lab(sum, lab_c, dlab);
    for (int k = 0; k < 3; ++k) r[k] = lab_c[k] - target[k];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        J[a][b] = dlab[a][0] * sum[3 + b] + dlab[a][1] * sum[6 + b] + dlab[a][2] * sum[9 + b];
  }

  // The spectrum's XYZ (sum[0..2]) and its derivatives: sum[3 + 3 k + j] =
  // d XYZ_k / d c_j = sum_i w_k(lambda_i) S'(p_i) t_i^(2 - j). The hot loop of
  // the fit, 8, 4 or 2 wavelengths a step (AVX-512, AVX2, SSE2).
  void moments(const double c[3], double sum[12]) const {
#if defined(PRISM_RGB2SPEC_AVX2)
    if (m_simd == 2) return moments_avx512(c, sum);
    if (m_simd == 1) return moments_avx2(c, sum);
#endif
#if defined(PRISM_RGB2SPEC_SSE2)
    const __m128d c0 = _mm_set1_pd(c[0]), c1 = _mm_set1_pd(c[1]), c2 = _mm_set1_pd(c[2]);
    const __m128d one = _mm_set1_pd(1), half = _mm_set1_pd(0.5);
    __m128d acc[12];
    for (auto& v : acc) v = _mm_setzero_pd();
    for (int i = 0; i < n_padded; i += 2) {
      __m128d t = _mm_load_pd(m_t + i);
      __m128d p = _mm_add_pd(_mm_mul_pd(_mm_add_pd(_mm_mul_pd(c0, t), c1), t), c2);
      __m128d q = _mm_div_pd(one, _mm_sqrt_pd(_mm_add_pd(one, _mm_mul_pd(p, p))));
      __m128d s = _mm_add_pd(half, _mm_mul_pd(half, _mm_mul_pd(p, q)));
      __m128d ds = _mm_mul_pd(_mm_mul_pd(half, q), _mm_mul_pd(q, q));
      __m128d dst = _mm_mul_pd(ds, t), dst2 = _mm_mul_pd(dst, t);
      for (int k = 0; k < 3; ++k) {
        __m128d w = _mm_load_pd(m_w[k] + i);
        acc[k] = _mm_add_pd(acc[k], _mm_mul_pd(w, s));
        acc[3 + 3 * k] = _mm_add_pd(acc[3 + 3 * k], _mm_mul_pd(w, dst2));
        acc[4 + 3 * k] = _mm_add_pd(acc[4 + 3 * k], _mm_mul_pd(w, dst));
        acc[5 + 3 * k] = _mm_add_pd(acc[5 + 3 * k], _mm_mul_pd(w, ds));
      }
    }
    for (int k = 0; k < 12; ++k) {
      alignas(16) double v[2];
      _mm_store_pd(v, acc[k]);
      sum[k] = v[0] + v[1];
    }
#else
    for (int k = 0; k < 12; ++k) sum[k] = 0;
    for (int i = 0; i < n_padded; ++i) {
      double t = m_t[i], p = (c[0] * t + c[1]) * t + c[2];
      double q = 1 / std::sqrt(1 + p * p);
      double s = 0.5 + 0.5 * p * q, ds = 0.5 * q * q * q, dst = ds * t, dst2 = dst * t;
      for (int k = 0; k < 3; ++k) {
        double w = m_w[k][i];
        sum[k] += w * s, sum[3 + 3 * k] += w * dst2, sum[4 + 3 * k] += w * dst, sum[5 + 3 * k] += w * ds;
      }
    }
#endif
  }

#if defined(PRISM_RGB2SPEC_AVX2)
  __attribute__((target("avx2,fma"))) void moments_avx2(const double c[3], double sum[12]) const {
    const __m256d c0 = _mm256_set1_pd(c[0]), c1 = _mm256_set1_pd(c[1]), c2 = _mm256_set1_pd(c[2]);
    const __m256d one = _mm256_set1_pd(1), half = _mm256_set1_pd(0.5);
    __m256d acc[12];
    for (auto& v : acc) v = _mm256_setzero_pd();
    for (int i = 0; i < n_padded; i += 4) {
      __m256d t = _mm256_load_pd(m_t + i);
      __m256d p = _mm256_fmadd_pd(_mm256_fmadd_pd(c0, t, c1), t, c2);
      __m256d q = _mm256_div_pd(one, _mm256_sqrt_pd(_mm256_fmadd_pd(p, p, one)));
      __m256d hq = _mm256_mul_pd(half, q);
      __m256d s = _mm256_fmadd_pd(hq, p, half);
      __m256d ds = _mm256_mul_pd(hq, _mm256_mul_pd(q, q));
      __m256d dst = _mm256_mul_pd(ds, t), dst2 = _mm256_mul_pd(dst, t);
      for (int k = 0; k < 3; ++k) {
        __m256d w = _mm256_load_pd(m_w[k] + i);
        acc[k] = _mm256_fmadd_pd(w, s, acc[k]);
        acc[3 + 3 * k] = _mm256_fmadd_pd(w, dst2, acc[3 + 3 * k]);
        acc[4 + 3 * k] = _mm256_fmadd_pd(w, dst, acc[4 + 3 * k]);
        acc[5 + 3 * k] = _mm256_fmadd_pd(w, ds, acc[5 + 3 * k]);
      }
    }
    for (int k = 0; k < 12; ++k) {
      alignas(32) double v[4];
      _mm256_store_pd(v, acc[k]);
      sum[k] = (v[0] + v[1]) + (v[2] + v[3]);
    }
  }
  __attribute__((target("avx512f"))) void moments_avx512(const double c[3], double sum[12]) const {
    const __m512d c0 = _mm512_set1_pd(c[0]), c1 = _mm512_set1_pd(c[1]), c2 = _mm512_set1_pd(c[2]);
    const __m512d one = _mm512_set1_pd(1), half = _mm512_set1_pd(0.5);
    __m512d acc[12];
    for (auto& v : acc) v = _mm512_setzero_pd();
    for (int i = 0; i < n_padded; i += 8) {
      __m512d t = _mm512_load_pd(m_t + i);
      __m512d p = _mm512_fmadd_pd(_mm512_fmadd_pd(c0, t, c1), t, c2);
      // (maskz_sqrt: GCC 12 warns about the undefined pass-through of _mm512_sqrt_pd)
      __m512d q = _mm512_div_pd(one, _mm512_maskz_sqrt_pd(0xFF, _mm512_fmadd_pd(p, p, one)));
      __m512d hq = _mm512_mul_pd(half, q);
      __m512d s = _mm512_fmadd_pd(hq, p, half);
      __m512d ds = _mm512_mul_pd(hq, _mm512_mul_pd(q, q));
      __m512d dst = _mm512_mul_pd(ds, t), dst2 = _mm512_mul_pd(dst, t);
      for (int k = 0; k < 3; ++k) {
        __m512d w = _mm512_load_pd(m_w[k] + i);
        acc[k] = _mm512_fmadd_pd(w, s, acc[k]);
        acc[3 + 3 * k] = _mm512_fmadd_pd(w, dst2, acc[3 + 3 * k]);
        acc[4 + 3 * k] = _mm512_fmadd_pd(w, dst, acc[4 + 3 * k]);
        acc[5 + 3 * k] = _mm512_fmadd_pd(w, ds, acc[5 + 3 * k]);
      }
    }
    for (int k = 0; k < 12; ++k) {
      alignas(64) double v[8];
      _mm512_store_pd(v, acc[k]);
      sum[k] = ((v[0] + v[1]) + (v[2] + v[3])) + ((v[4] + v[5]) + (v[6] + v[7]));
    }
  }
  // 2: AVX-512F, 1: AVX2 and FMA, 0: SSE2 (PRISM_RGB2SPEC_MAX_SIMD caps it, to measure).
  static int detect_simd() {
    __builtin_cpu_init();  // in case this runs before the constructors that set up detection
    int level = __builtin_cpu_supports("avx512f")                               ? 2
                : (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")) ? 1
                                                                                    : 0;
    return std::min(level, int(PRISM_RGB2SPEC_MAX_SIMD));
  }
  int m_simd = detect_simd();
#endif

  // Solves A x = b (Gaussian elimination, partial pivoting); false if singular.
  static bool solve_matrix(const double A_in[3][3], const double b_in[3], double x[3]) {
    double A[3][4];
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) A[i][j] = A_in[i][j];
      A[i][3] = b_in[i];
    }
    for (int col = 0; col < 3; ++col) {
      int piv = col;
      for (int i = col + 1; i < 3; ++i)
        if (std::abs(A[i][col]) > std::abs(A[piv][col])) piv = i;
      if (!(std::abs(A[piv][col]) > 1e-300)) return false;
      if (piv != col)
        for (int j = 0; j < 4; ++j) std::swap(A[col][j], A[piv][j]);
      for (int i = col + 1; i < 3; ++i) {
        double f = A[i][col] / A[col][col];
        for (int j = col; j < 4; ++j) A[i][j] -= f * A[col][j];
      }
    }
    for (int i = 2; i >= 0; --i) {
      double v = A[i][3];
      for (int j = i + 1; j < 3; ++j) v -= A[i][j] * x[j];
      x[i] = v / A[i][i];
    }
    return std::isfinite(x[0]) && std::isfinite(x[1]) && std::isfinite(x[2]);
  }
};

// What a table fit did: for the documentation and the generator's report.
struct FitStats {
  long cells = 0;           // cells fitted by Gauss-Newton (grey cells are exact)
  long evaluations = 0;     // colour evaluations, in total
  long not_converged = 0;   // cells that stopped above the tolerance
  double max_residual = 0;  // largest last CIELAB residual seen (before the final,
                            // unchecked step of the cells that take one)
};

// Fits the three coefficient tables for linear sRGB at resolution res with the
// given number of threads into coeffs, laid out [m][z][y][x][3] (m the index of
// the largest component; node values grid_node(i, res) on every axis).
inline FitStats fit_tables(int res, int threads, std::vector<float>& coeffs) {
  if (res < 3) throw Error("rgb2spec: table resolution must be at least 3");
  const Fitter fitter;
  const size_t cells = size_t(3) * size_t(res) * size_t(res) * size_t(res);
  std::vector<double> work(cells * 3);  // double precision, for warm starts
  auto idx = [res](int m, int zi, int yi, int xi) {
    return (((size_t(m) * size_t(res) + size_t(zi)) * size_t(res) + size_t(yi)) * size_t(res) + size_t(xi)) * 3;
  };
  const int z_start = (res - 1) / 2;

  // One cell: exact for grey, Gauss-Newton from `start` otherwise.
  auto fit_cell = [&](int m, int zi, int yi, int xi, const double* start, FitStats& st) {
    double* c = &work[idx(m, zi, yi, xi)];
    double z = grid_node(zi, res), x = grid_node(xi, res), y = grid_node(yi, res);
    if (xi == res - 1 && yi == res - 1) {
      c[0] = c[1] = 0;
      c[2] = std::clamp(detail::inverse_sigmoid(z), -max_coefficient, max_coefficient);
      return;
    }
    double rgb[3];
    rgb[m] = z, rgb[(m + 1) % 3] = x * z, rgb[(m + 2) % 3] = y * z;
    for (int k = 0; k < 3; ++k) c[k] = start[k];
    Fitter::Result r = fitter.fit(rgb, c);
    ++st.cells;
    st.evaluations += r.iterations;
    if (!r.converged) ++st.not_converged;
    st.max_residual = std::max(st.max_residual, r.residual);
  };

  std::atomic<int> next{0};
  std::vector<FitStats> stats(size_t(std::max(threads, 1)));
  // Phase 1: the middle slice z_start of each table, one table per task, in a
  // serpentine from the grey corner (x = y = 1, exact) so every cell starts
  // from its converged neighbour.
  auto phase1 = [&](FitStats& st) {
    for (int m; (m = next.fetch_add(1)) < 3;) {
      const double* prev = nullptr;
      for (int yi = res - 1; yi >= 0; --yi) {
        bool down = ((res - 1 - yi) % 2) == 0;
        for (int j = 0; j < res; ++j) {
          int xi = down ? res - 1 - j : j;
          fit_cell(m, z_start, yi, xi, prev, st);  // the first cell is grey: no start needed
          prev = &work[idx(m, z_start, yi, xi)];
        }
      }
    }
  };
  // Phase 2: every (m, y, x) column, from the middle slice up to z = 1 and
  // down to the first node above 0, each cell starting from the linear
  // extrapolation of the two before it. The node z = 0 (black, where S^-1 is
  // infinite) copies node 1; the lookup never reads it.
  auto phase2 = [&](FitStats& st) {
    const int columns = 3 * res * res;
    for (int col; (col = next.fetch_add(1)) < columns;) {
      int m = col / (res * res), yi = (col / res) % res, xi = col % res;
      auto sweep = [&](int from, int to, int dir) {
        for (int zi = from; zi != to; zi += dir) {
          const double* c1 = &work[idx(m, zi - dir, yi, xi)];
          double start[3] = {c1[0], c1[1], c1[2]};
          int behind = (zi - z_start) * dir - 1;  // fitted cells behind zi - dir in this sweep
          if (behind >= 2) {
            const double* c2 = &work[idx(m, zi - 2 * dir, yi, xi)];
            const double* c3 = &work[idx(m, zi - 3 * dir, yi, xi)];
            for (int k = 0; k < 3; ++k) start[k] = 3 * c1[k] - 3 * c2[k] + c3[k];
          } else if (behind == 1) {
            const double* c2 = &work[idx(m, zi - 2 * dir, yi, xi)];
            for (int k = 0; k < 3; ++k) start[k] = 2 * c1[k] - c2[k];
          }
          fit_cell(m, zi, yi, xi, start, st);
        }
      };
      sweep(z_start + 1, res, +1);
      sweep(z_start - 1, 0, -1);
      for (int k = 0; k < 3; ++k) work[idx(m, 0, yi, xi) + size_t(k)] = work[idx(m, 1, yi, xi) + size_t(k)];
    }
  };
  auto run = [&](auto&& phase) {
    next = 0;
    std::vector<std::thread> pool;
    for (int t = 1; t < threads; ++t) {
      try {
        pool.emplace_back([&, t] { phase(stats[size_t(t)]); });
      } catch (...) {
        break;  // no more threads: the calling thread does the rest
      }
    }
    phase(stats[0]);
    for (auto& th : pool) th.join();
  };
  run(phase1);
  run(phase2);

  coeffs.resize(cells * 3);
  for (size_t i = 0; i < work.size(); ++i) coeffs[i] = float(work[i]);
  FitStats total;
  for (const FitStats& s : stats) {
    total.cells += s.cells;
    total.evaluations += s.evaluations;
    total.not_converged += s.not_converged;
    total.max_residual = std::max(total.max_residual, s.max_residual);
  }
  return total;
}

}  // namespace rgb2spec

// --- the table ----------------------------------------------------------------

// Sigmoid-polynomial coefficients over linear sRGB in [0, 1]^3.
class RGBToSpectrumTable {
 public:
  // Fits a table at resolution res (see rgb2spec::fit_tables).
  static RGBToSpectrumTable fit_srgb(int res = rgb2spec::default_resolution, int threads = default_threads(),
                                     rgb2spec::FitStats* stats = nullptr) {
    std::vector<float> coeffs;
    rgb2spec::FitStats s = rgb2spec::fit_tables(res, threads, coeffs);
    if (stats) *stats = s;
    return RGBToSpectrumTable(res, coeffs);
  }
  // A table from stored coefficients, laid out as fit_tables writes them.
  RGBToSpectrumTable(int res, std::span<const float> coeffs)
      : m_res(res), m_z1(Float(rgb2spec::grid_node(1, res))), m_coeffs(coeffs.begin(), coeffs.end()) {
    if (res < 3 || m_coeffs.size() != size_t(9) * size_t(res) * size_t(res) * size_t(res))
      throw Error("RGBToSpectrumTable: " + std::to_string(m_coeffs.size()) +
                  " coefficients do not match resolution " + std::to_string(res));
  }

  // The sigmoid polynomial of a linear sRGB colour in [0, 1]^3 (not checked
  // here; RGBAlbedoSpectrum checks). Grey is exact; other colours carry the
  // interpolation error (largest near black and white, see RGBAlbedoSpectrum).
  RGBSigmoidPolynomial operator()(const RGB& rgb) const {
    if (rgb.r == rgb.g && rgb.g == rgb.b) return {0, 0, Float(detail::inverse_sigmoid(double(rgb.r)))};
    int m = rgb.r > rgb.g ? (rgb.r > rgb.b ? 0 : 2) : (rgb.g > rgb.b ? 1 : 2);
    const Float z = rgb[m];  // > 0: the components differ and none is negative
    const int res = m_res;
    const Float last = Float(res - 1);
    Float inv_z = 1 / z;
    // Grid coordinates (the parameter u of grid_node, times res - 1).
    Float tx = rgb2spec::grid_parameter(rgb[(m + 1) % 3] * inv_z) * last;
    Float ty = rgb2spec::grid_parameter(rgb[(m + 2) % 3] * inv_z) * last;
    Float tz = rgb2spec::grid_parameter(z) * last;
    int xi = std::clamp(int(tx), 0, res - 2), yi = std::clamp(int(ty), 0, res - 2), zi = std::clamp(int(tz), 0, res - 2);
    Float dx = tx - Float(xi), dy = ty - Float(yi), dz = tz - Float(zi);
    // Between black and the first node above it the coefficients grow like
    // z^-1/2 (S(p) ~ 1 / (4 p^2) as p -> -inf): scale those of node 1.
    Float dark = 1;
    if (zi == 0) {
      dark = std::sqrt(m_z1 * inv_z);
      zi = 1, dz = 0;
    }
    const size_t sx = 3, sy = 3 * size_t(res), sz = sy * size_t(res);
    const float* p = &m_coeffs[size_t(m) * sz * size_t(res) + size_t(zi) * sz + size_t(yi) * sy + size_t(xi) * sx];
    Float c[3];
    for (int k = 0; k < 3; ++k) {
      auto lx = [&](const float* q) { return (1 - dx) * q[k] + dx * q[sx + size_t(k)]; };
      auto ly = [&](const float* q) { return (1 - dy) * lx(q) + dy * lx(q + sy); };
      c[k] = ((1 - dz) * ly(p) + dz * ly(p + sz)) * dark;
    }
    return {c[0], c[1], c[2]};
  }

  int resolution() const { return m_res; }
  std::span<const float> coefficients() const { return m_coeffs; }

  static int default_threads() {
    unsigned n = std::thread::hardware_concurrency();
    return int(std::clamp(n, 1u, 8u));
  }

 private:
  int m_res;
  Float m_z1;  // the first node above black
  std::vector<float> m_coeffs;
};

// The linear sRGB table, fitted on first use (thread-safe static initialisation).
inline const RGBToSpectrumTable& srgb_to_spectrum_table() {
  static const RGBToSpectrumTable table = RGBToSpectrumTable::fit_srgb();
  return table;
}

// --- spectra ------------------------------------------------------------------

namespace detail {
inline std::string rgb_string(const RGB& c) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%g, %g, %g)", double(c.r), double(c.g), double(c.b));
  return buf;
}
// The largest value of the normalised D65 over 360..830 nm (its 1 nm nodes).
inline Float d65_max_value() {
  static const Float v = [] {
    Float m = 0;
    for (int l = data::cie_lambda_min; l <= data::cie_lambda_max; ++l) m = std::max(m, illuminant_d65()(Float(l)));
    return m;
  }();
  return v;
}
}  // namespace detail

// A reflectance given as linear sRGB in [0, 1]^3: offset + scale * S(p(lambda)),
// whose values lie in [0, 1]. Colours whose components straddle 1/2 use the
// table directly (offset 0, scale 1); dark ones (all <= 1/2) are scale = 2 max(c)
// times the polynomial of c / scale; light ones (all >= 1/2) are 1 minus the
// dark spectrum of 1 - c. The branches meet at 1/2: across max = 1/2 the
// spectrum is continuous, across min = 1/2 the two sides are metamers that
// differ by a few 1e-3 in 400..700 nm (up to ~1e-2 beyond 700 nm).
// Throws prism::Error for components outside [0, 1] (or not finite).
class RGBAlbedoSpectrum {
 public:
  explicit RGBAlbedoSpectrum(const RGB& rgb) : RGBAlbedoSpectrum(srgb_to_spectrum_table(), rgb) {}
  RGBAlbedoSpectrum(const RGBToSpectrumTable& table, const RGB& rgb) {
    if (!(rgb.r >= 0 && rgb.r <= 1 && rgb.g >= 0 && rgb.g <= 1 && rgb.b >= 0 && rgb.b <= 1))
      throw Error("RGBAlbedoSpectrum: albedo " + detail::rgb_string(rgb) + " has a component outside [0, 1]");
    Float hi = rgb.max_component(), lo = std::min(rgb.r, std::min(rgb.g, rgb.b));
    if (hi == lo || (hi > Float(0.5) && lo < Float(0.5))) {
      m_poly = table(rgb);  // grey (exact), or straddling 1/2
    } else if (hi <= Float(0.5)) {
      // Dark: 2 hi times the spectrum of rgb / (2 hi), whose largest component is 1/2.
      m_scale = 2 * hi;
      m_poly = table(rgb / m_scale);
    } else {
      // Light: 1 minus the dark spectrum of 1 - rgb.
      RGB d = RGB(1) - rgb;
      Float m = d.max_component();
      m_offset = 1;
      m_scale = -2 * m;
      m_poly = table(d / (2 * m));
    }
  }
  Float operator()(Float lambda_nm) const { return m_offset + m_scale * m_poly(lambda_nm); }
  Float max_value() const {
    return m_scale >= 0 ? m_offset + m_scale * m_poly.max_value() : m_offset + m_scale * m_poly.min_value();
  }
  // The spectrum is offset() + scale() * polynomial()(lambda).
  const RGBSigmoidPolynomial& polynomial() const { return m_poly; }
  Float scale() const { return m_scale; }
  Float offset() const { return m_offset; }

 private:
  RGBSigmoidPolynomial m_poly;
  Float m_offset = 0, m_scale = 1;
};

// An unbounded non-negative quantity given as linear sRGB: scale * S(p(lambda))
// with scale = 2 max(r, g, b) and p the polynomial of rgb / scale, read on the
// table's node slice z = 1/2 (s has room both ways there). For rgb in [0, 1/2]^3
// it equals RGBAlbedoSpectrum. Throws prism::Error for negative or non-finite
// components.
class RGBUnboundedSpectrum {
 public:
  explicit RGBUnboundedSpectrum(const RGB& rgb) : RGBUnboundedSpectrum(srgb_to_spectrum_table(), rgb) {}
  RGBUnboundedSpectrum(const RGBToSpectrumTable& table, const RGB& rgb) {
    if (!(rgb.r >= 0 && rgb.g >= 0 && rgb.b >= 0) || !rgb.is_finite())
      throw Error("RGBUnboundedSpectrum: " + detail::rgb_string(rgb) + " has a negative or non-finite component");
    Float m = rgb.max_component();
    m_scale = 2 * m;
    m_poly = table(m_scale > 0 ? rgb / m_scale : RGB(0));
  }
  Float operator()(Float lambda_nm) const { return m_scale * m_poly(lambda_nm); }
  Float max_value() const { return m_scale * m_poly.max_value(); }
  Float scale() const { return m_scale; }
  const RGBSigmoidPolynomial& polynomial() const { return m_poly; }

 private:
  Float m_scale = 0;
  RGBSigmoidPolynomial m_poly;
};

// An emission given as linear sRGB: the unbounded spectrum of rgb times D65
// (Y = 1), so RGB(1, 1, 1) emits D65 with Y = 1 and every rgb maps back to itself.
class RGBIlluminantSpectrum {
 public:
  explicit RGBIlluminantSpectrum(const RGB& rgb) : RGBIlluminantSpectrum(srgb_to_spectrum_table(), rgb) {}
  RGBIlluminantSpectrum(const RGBToSpectrumTable& table, const RGB& rgb)
      : m_unbounded(table, rgb), m_illuminant(&illuminant_d65()) {}
  Float operator()(Float lambda_nm) const { return m_unbounded(lambda_nm) * (*m_illuminant)(lambda_nm); }
  Float max_value() const { return m_unbounded.max_value() * detail::d65_max_value(); }
  Float scale() const { return m_unbounded.scale(); }
  const RGBSigmoidPolynomial& polynomial() const { return m_unbounded.polynomial(); }

 private:
  RGBUnboundedSpectrum m_unbounded;
  const CIEIlluminant* m_illuminant;
};

}  // namespace prism
