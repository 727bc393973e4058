// prism/spectra/sampled.hpp — point-sampled spectra for spectral rendering.
// A camera path carries N wavelengths (SampledWavelengths<N>) chosen per pixel
// sample; every spectral quantity along it is a SampledSpectrum<N>: its values
// at those N wavelengths. The film turns a path's radiance into CIE XYZ by
// Monte Carlo integration against the colour matching functions (cie.hpp).
//
// Wavelength sampling. Two strategies are provided:
//  - visible (the default): the N wavelengths are stratified in u (u, u + 1/N,
//    ... mod 1) and each is warped by the density proportional to
//    1 / cosh^2(0.0072 (lambda - 538)) on [360, 830] nm, which follows the sum of
//    the colour matching functions (the form is from the pbrt-v4 book, 4.6.2);
//  - uniform: stratified hero wavelengths (Wilkie et al. 2014), uniform on
//    [360, 830] nm, each at its own stratum.
// tests/spectra measures the variance of both on white and coloured spectra;
// docs/spectral.md has the figures and why "visible" is the default.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include "prism/math/float.hpp"

namespace prism {

inline constexpr Float lambda_min = 360, lambda_max = 830;

template <int N>
class SampledSpectrum {
 public:
  static constexpr int size = N;

  constexpr SampledSpectrum() { m_v.fill(0); }
  constexpr explicit SampledSpectrum(Float c) { m_v.fill(c); }
  constexpr explicit SampledSpectrum(const std::array<Float, N>& v) : m_v(v) {}

  constexpr Float operator[](int i) const { return m_v[size_t(i)]; }
  constexpr Float& operator[](int i) { return m_v[size_t(i)]; }

#define PRISM_SAMPLED_OP(op)                                                        \
  constexpr SampledSpectrum& operator op##=(const SampledSpectrum& o) {             \
    for (int i = 0; i < N; ++i) m_v[size_t(i)] op## = o.m_v[size_t(i)];             \
    return *this;                                                                   \
  }                                                                                 \
  constexpr SampledSpectrum operator op(const SampledSpectrum& o) const {           \
    SampledSpectrum r = *this;                                                      \
    return r op## = o;                                                              \
  }                                                                                 \
  constexpr SampledSpectrum& operator op##=(Float s) {                              \
    for (int i = 0; i < N; ++i) m_v[size_t(i)] op## = s;                              \
    return *this;                                                                   \
  }                                                                                 \
  constexpr SampledSpectrum operator op(Float s) const {                            \
    SampledSpectrum r = *this;                                                      \
    return r op## = s;                                                              \
  }
  PRISM_SAMPLED_OP(+)
  PRISM_SAMPLED_OP(-)
  PRISM_SAMPLED_OP(*)
  PRISM_SAMPLED_OP(/)
#undef PRISM_SAMPLED_OP
  friend constexpr SampledSpectrum operator*(Float s, const SampledSpectrum& c) { return c * s; }
  constexpr SampledSpectrum operator-() const { return *this * Float(-1); }
  constexpr bool operator==(const SampledSpectrum&) const = default;

  constexpr bool is_black() const {
    for (Float v : m_v)
      if (v != 0) return false;
    return true;
  }
  constexpr explicit operator bool() const { return !is_black(); }
  constexpr Float max_component() const { return *std::max_element(m_v.begin(), m_v.end()); }
  constexpr Float min_component() const { return *std::min_element(m_v.begin(), m_v.end()); }
  constexpr Float average() const {
    Float s = 0;
    for (Float v : m_v) s += v;
    return s / N;
  }
  bool is_finite() const {
    for (Float v : m_v)
      if (!std::isfinite(v)) return false;
    return true;
  }
  const std::array<Float, N>& values() const { return m_v; }

 private:
  std::array<Float, N> m_v;
};

// Division that returns 0 where the divisor is 0.
template <int N>
SampledSpectrum<N> safe_div(const SampledSpectrum<N>& a, const SampledSpectrum<N>& b) {
  SampledSpectrum<N> r;
  for (int i = 0; i < N; ++i) r[i] = b[i] != 0 ? a[i] / b[i] : 0;
  return r;
}
template <int N>
SampledSpectrum<N> sqrt(const SampledSpectrum<N>& c) {
  SampledSpectrum<N> r;
  for (int i = 0; i < N; ++i) r[i] = std::sqrt(c[i]);
  return r;
}
template <int N>
SampledSpectrum<N> exp(const SampledSpectrum<N>& c) {
  SampledSpectrum<N> r;
  for (int i = 0; i < N; ++i) r[i] = std::exp(c[i]);
  return r;
}
template <int N>
SampledSpectrum<N> clamp_zero(const SampledSpectrum<N>& c) {
  SampledSpectrum<N> r;
  for (int i = 0; i < N; ++i) r[i] = std::max(Float(0), c[i]);
  return r;
}

// --- wavelength sampling densities on [lambda_min, lambda_max] -------------

// The "visible" density p(l) = k / cosh^2(0.0072 (l - 538)), k normalising it
// over [360, 830]: its integral there is (tanh(0.0072*292) + tanh(0.0072*178)) / 0.0072.
inline Float pdf_visible_wavelength(Float lambda) {
  if (lambda < lambda_min || lambda > lambda_max) return 0;
  constexpr double a = 0.0072;
  const double norm = a / (std::tanh(a * (830 - 538)) + std::tanh(a * (538 - 360)));
  double c = std::cosh(a * (double(lambda) - 538));
  return Float(norm / (c * c));
}
// Inverts the CDF of pdf_visible_wavelength: with t0 = tanh(a (360 - 538)) and
// t1 = tanh(a (830 - 538)), lambda = 538 + atanh(t0 + u (t1 - t0)) / a.
inline Float sample_visible_wavelength(Float u) {
  constexpr double a = 0.0072;
  const double t0 = std::tanh(a * (360 - 538)), t1 = std::tanh(a * (830 - 538));
  double l = 538 + std::atanh(t0 + double(u) * (t1 - t0)) / a;
  return Float(std::clamp(l, double(lambda_min), double(lambda_max)));
}

enum class WavelengthSampling { visible, uniform };

template <int N>
class SampledWavelengths {
 public:
  static constexpr bool is_spectral = true;
  static constexpr int size = N;

  // N wavelengths stratified from one uniform number u.
  static SampledWavelengths sample(Float u, WavelengthSampling how = WavelengthSampling::visible) {
    SampledWavelengths w;
    for (int i = 0; i < N; ++i) {
      Float ui = u + Float(i) / N;
      if (ui >= 1) ui -= 1;
      if (how == WavelengthSampling::visible) {
        w.m_lambda[size_t(i)] = sample_visible_wavelength(ui);
        w.m_pdf[size_t(i)] = pdf_visible_wavelength(w.m_lambda[size_t(i)]);
      } else {
        w.m_lambda[size_t(i)] = lerp(ui, lambda_min, lambda_max);
        w.m_pdf[size_t(i)] = 1 / (lambda_max - lambda_min);
      }
    }
    return w;
  }
  // Fixed wavelengths with given densities (tests, and spectra evaluated at known points).
  static SampledWavelengths from(const std::array<Float, N>& lambda, const std::array<Float, N>& pdf) {
    SampledWavelengths w;
    w.m_lambda = lambda;
    w.m_pdf = pdf;
    return w;
  }

  Float operator[](int i) const { return m_lambda[size_t(i)]; }
  Float lambda(int i) const { return m_lambda[size_t(i)]; }
  SampledSpectrum<N> pdf() const { return SampledSpectrum<N>(m_pdf); }

  // After a wavelength-dependent scattering event (dispersion) the path follows
  // the first (hero) wavelength only: the others get density 0, so they add
  // nothing, and the hero's density is divided by N, since it now stands alone
  // for the N strata it was averaged with.
  void terminate_secondary() {
    if (secondary_terminated()) return;
    for (int i = 1; i < N; ++i) m_pdf[size_t(i)] = 0;
    m_pdf[0] /= N;
  }
  bool secondary_terminated() const {
    for (int i = 1; i < N; ++i)
      if (m_pdf[size_t(i)] != 0) return false;
    return true;
  }

 private:
  std::array<Float, N> m_lambda{}, m_pdf{};
};

}  // namespace prism
