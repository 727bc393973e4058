// prism/spectra/spectrum.hpp — continuous spectra (functions of wavelength in
// nm) and their link to colour: constant, piecewise linear (measured data such
// as metal eta and k), blackbody, the CIE illuminants; the CIE 1931 colour
// matching functions; XYZ and linear sRGB (Rec.709 primaries, D65 white).
//
// A continuous spectrum is any type with Float operator()(Float lambda); the
// free function sample(spec, lambda) evaluates it at a path's wavelengths.
#pragma once
#include <algorithm>
#include <cmath>
#include <concepts>
#include <span>
#include <string>
#include <vector>
#include "prism/error.hpp"
#include "prism/spectra/data/cie_cmf.hpp"
#include "prism/spectra/data/cie_illuminants.hpp"
#include "prism/spectra/rgb.hpp"
#include "prism/spectra/sampled.hpp"

namespace prism {

template <class T>
concept ContinuousSpectrum = requires(const T& s, Float l) {
  { s(l) } -> std::convertible_to<Float>;
};

template <ContinuousSpectrum T, int N>
SampledSpectrum<N> sample(const T& s, const SampledWavelengths<N>& lambda) {
  SampledSpectrum<N> r;
  for (int i = 0; i < N; ++i) r[i] = Float(s(lambda[i]));
  return r;
}

// --- CIE 1931 colour matching functions ------------------------------------

namespace detail {
// Linear interpolation in a table sampled at 1 nm from 360 nm; 0 outside.
inline Float cie_lookup(const float* table, Float lambda) {
  Float x = lambda - Float(data::cie_lambda_min);
  if (!(x >= 0) || x > Float(data::cie_samples - 1)) return 0;
  int i = std::min(int(x), data::cie_samples - 2);
  Float t = x - Float(i);
  return (1 - t) * table[i] + t * table[i + 1];
}
}  // namespace detail

inline Float cie_x(Float lambda) { return detail::cie_lookup(data::cie_x, lambda); }
inline Float cie_y(Float lambda) { return detail::cie_lookup(data::cie_y, lambda); }
inline Float cie_z(Float lambda) { return detail::cie_lookup(data::cie_z, lambda); }
inline constexpr Float cie_y_integral = Float(data::cie_y_integral);

struct XYZ {
  Float x = 0, y = 0, z = 0;
  constexpr Float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
};

// Linear sRGB (Rec.709 primaries, D65 white) from CIE XYZ and back; the
// matrices follow from the primaries' and D65's chromaticities (IEC 61966-2-1).
inline constexpr RGB xyz_to_linear_srgb(const XYZ& c) {
  return {3.2404542f * c.x - 1.5371385f * c.y - 0.4985314f * c.z,
          -0.9692660f * c.x + 1.8760108f * c.y + 0.0415560f * c.z,
          0.0556434f * c.x - 0.2040259f * c.y + 1.0572252f * c.z};
}
inline constexpr XYZ linear_srgb_to_xyz(const RGB& c) {
  return {0.4124564f * c.r + 0.3575761f * c.g + 0.1804375f * c.b,
          0.2126729f * c.r + 0.7151522f * c.g + 0.0721750f * c.b,
          0.0193339f * c.r + 0.1191920f * c.g + 0.9503041f * c.b};
}
// The sRGB transfer function (encoding linear [0, 1] for display) and its inverse.
inline Float srgb_encode(Float v) {
  if (v <= 0.0031308f) return 12.92f * v;
  return 1.055f * std::pow(v, 1 / 2.4f) - 0.055f;
}
inline Float srgb_decode(Float v) {
  if (v <= 0.04045f) return v / 12.92f;
  return std::pow((v + 0.055f) / 1.055f, 2.4f);
}

// Monte Carlo estimate of a sampled spectrum's XYZ: the average over the path's
// wavelengths of cmf(l) S(l) / p(l), divided by the integral of y-bar, so
// that a spectrum with Y = 1 (e.g. the normalised D65) maps to Y = 1.
// Wavelengths with density 0 (terminated secondaries) contribute nothing.
template <int N>
XYZ to_xyz(const SampledSpectrum<N>& s, const SampledWavelengths<N>& lambda) {
  double x = 0, y = 0, z = 0;
  SampledSpectrum<N> pdf = lambda.pdf();
  for (int i = 0; i < N; ++i) {
    if (pdf[i] == 0) continue;
    double v = double(s[i]) / double(pdf[i]);
    x += cie_x(lambda[i]) * v;
    y += cie_y(lambda[i]) * v;
    z += cie_z(lambda[i]) * v;
  }
  double k = 1.0 / (double(N) * data::cie_y_integral);
  return {Float(x * k), Float(y * k), Float(z * k)};
}
// Luminance Y of a path's sampled spectrum (the same estimator, Y only).
template <int N>
Float luminance(const SampledSpectrum<N>& s, const SampledWavelengths<N>& lambda) {
  return to_xyz(s, lambda).y;
}

// --- continuous spectra ----------------------------------------------------

struct ConstantSpectrum {
  Float c = 0;
  Float operator()(Float) const { return c; }
};

// Linear interpolation between samples (lambda_i, v_i) with increasing
// lambda_i; constant beyond the ends (measured tables often stop short of 360
// or 830 nm). Throws prism::Error naming the spectrum on bad data.
class PiecewiseLinearSpectrum {
 public:
  PiecewiseLinearSpectrum() = default;
  PiecewiseLinearSpectrum(std::span<const float> lambda, std::span<const float> values, std::string name = "spectrum")
      : m_lambda(lambda.begin(), lambda.end()), m_v(values.begin(), values.end()), m_name(std::move(name)) {
    if (m_lambda.empty() || m_lambda.size() != m_v.size())
      throw Error(m_name + ": piecewise-linear spectrum needs as many values as wavelengths, and at least one");
    for (size_t i = 0; i < m_lambda.size(); ++i) {
      if (!std::isfinite(m_lambda[i]) || !std::isfinite(m_v[i]))
        throw Error(m_name + ": sample " + std::to_string(i) + " is not finite");
      if (i > 0 && !(m_lambda[i] > m_lambda[i - 1]))
        throw Error(m_name + ": wavelengths must increase (sample " + std::to_string(i) + ")");
    }
  }
  Float operator()(Float l) const {
    if (m_lambda.empty()) return 0;
    if (l <= m_lambda.front()) return m_v.front();
    if (l >= m_lambda.back()) return m_v.back();
    size_t i = size_t(std::upper_bound(m_lambda.begin(), m_lambda.end(), l) - m_lambda.begin()) - 1;
    Float t = (l - m_lambda[i]) / (m_lambda[i + 1] - m_lambda[i]);
    return (1 - t) * m_v[i] + t * m_v[i + 1];
  }
  // Multiplies the values so that the spectrum's CIE Y is 1 (illuminants).
  PiecewiseLinearSpectrum& normalise_y();
  const std::string& name() const { return m_name; }

 private:
  std::vector<float> m_lambda, m_v;
  std::string m_name;
};

// The integral of s times y-bar over 360..830 nm (1 nm rectangle rule, the
// same rule as the CIE's tables), divided by the integral of y-bar: the CIE Y
// of s as an emission spectrum.
template <ContinuousSpectrum T>
double spectrum_to_y(const T& s) {
  double y = 0;
  for (int l = data::cie_lambda_min; l <= data::cie_lambda_max; ++l)
    y += double(s(Float(l))) * data::cie_y[l - data::cie_lambda_min];
  return y / data::cie_y_integral;
}
template <ContinuousSpectrum T>
XYZ spectrum_to_xyz(const T& s) {
  double x = 0, y = 0, z = 0;
  for (int l = data::cie_lambda_min; l <= data::cie_lambda_max; ++l) {
    double v = double(s(Float(l)));
    int i = l - data::cie_lambda_min;
    x += v * data::cie_x[i];
    y += v * data::cie_y[i];
    z += v * data::cie_z[i];
  }
  return {Float(x / data::cie_y_integral), Float(y / data::cie_y_integral), Float(z / data::cie_y_integral)};
}

inline PiecewiseLinearSpectrum& PiecewiseLinearSpectrum::normalise_y() {
  double y = spectrum_to_y(*this);
  if (!(y > 0)) throw Error(m_name + ": cannot normalise a spectrum whose Y is not positive");
  for (float& v : m_v) v = float(double(v) / y);
  return *this;
}

// A CIE illuminant (360..830 nm at 1 nm) scaled so that its Y is 1.
class CIEIlluminant {
 public:
  explicit CIEIlluminant(const float* table) : m_table(table), m_scale(1) {
    m_scale = Float(1 / spectrum_to_y(*this));
  }
  Float operator()(Float l) const { return m_scale * detail::cie_lookup(m_table, l); }

 private:
  const float* m_table;
  Float m_scale;
};
// D65 and A, normalised to Y = 1; built once.
inline const CIEIlluminant& illuminant_d65() {
  static const CIEIlluminant d65(data::d65);
  return d65;
}
inline const CIEIlluminant& illuminant_a() {
  static const CIEIlluminant a(data::illum_a);
  return a;
}

// Planck's law: spectral radiance of a blackbody at temperature T (kelvin) at
// wavelength lambda (nm), in W / (m^2 sr m).
inline double planck(double lambda_nm, double T) {
  if (!(T > 0)) return 0;
  constexpr double c = 299792458.0, h = 6.62606957e-34, kb = 1.3806488e-23;
  double l = lambda_nm * 1e-9;
  return 2 * h * c * c / (l * l * l * l * l * (std::exp(h * c / (l * kb * T)) - 1));
}
// A blackbody normalised so that its peak (at Wien's lambda_max = b / T) is 1.
class BlackbodySpectrum {
 public:
  explicit BlackbodySpectrum(double T) : m_T(T) {
    if (!(T > 0) || !std::isfinite(T)) throw Error("blackbody: temperature must be positive and finite");
    m_norm = 1 / planck(wien_peak_nm(T), T);
  }
  // Wien's displacement law, b = 2.897771955e-3 m K.
  static double wien_peak_nm(double T) { return 2.897771955e-3 / T * 1e9; }
  Float operator()(Float l) const { return Float(planck(l, m_T) * m_norm); }
  double temperature() const { return m_T; }

 private:
  double m_T, m_norm = 1;
};

}  // namespace prism
