// prism/spectra/rgb.hpp — the RGB colour type (linear Rec.709/sRGB primaries) and
// spectrum_traits, which tells generic code whether a colour type is spectral.
// Every component is templated on a colour type S; RGB is one instantiation, and
// SampledSpectrum<N> (the spectral issue) is the other. In RGB mode the
// wavelengths type is the empty RGBWavelengths, so signatures are identical.
#pragma once
#include <cmath>
#include <concepts>
#include <type_traits>
#include "prism/math/float.hpp"

namespace prism {

struct RGB {
  Float r = 0, g = 0, b = 0;
  static constexpr int size = 3;

  constexpr RGB() = default;
  constexpr explicit RGB(Float v) : r(v), g(v), b(v) {}
  constexpr RGB(Float r_, Float g_, Float b_) : r(r_), g(g_), b(b_) {}

  constexpr Float operator[](int i) const { return i == 0 ? r : (i == 1 ? g : b); }
  constexpr Float& operator[](int i) { return i == 0 ? r : (i == 1 ? g : b); }
  constexpr RGB operator+(const RGB& o) const { return {r + o.r, g + o.g, b + o.b}; }
  constexpr RGB operator-(const RGB& o) const { return {r - o.r, g - o.g, b - o.b}; }
  constexpr RGB operator*(const RGB& o) const { return {r * o.r, g * o.g, b * o.b}; }
  constexpr RGB operator/(const RGB& o) const { return {r / o.r, g / o.g, b / o.b}; }
  constexpr RGB operator*(Float s) const { return {r * s, g * s, b * s}; }
  constexpr RGB operator/(Float s) const { Float i = 1 / s; return {r * i, g * i, b * i}; }
  friend constexpr RGB operator*(Float s, const RGB& c) { return c * s; }
  constexpr RGB& operator+=(const RGB& o) { r += o.r; g += o.g; b += o.b; return *this; }
  constexpr RGB& operator*=(const RGB& o) { r *= o.r; g *= o.g; b *= o.b; return *this; }
  constexpr RGB& operator*=(Float s) { r *= s; g *= s; b *= s; return *this; }
  constexpr RGB& operator/=(Float s) { return *this = *this / s; }
  constexpr bool operator==(const RGB&) const = default;

  constexpr bool is_black() const { return r == 0 && g == 0 && b == 0; }
  constexpr explicit operator bool() const { return !is_black(); }
  constexpr Float max_component() const { return std::max(r, std::max(g, b)); }
  constexpr Float average() const { return (r + g + b) / 3; }
  bool is_finite() const { return std::isfinite(r) && std::isfinite(g) && std::isfinite(b); }
  // Relative luminance (Rec.709 Y).
  constexpr Float luminance() const { return 0.2126f * r + 0.7152f * g + 0.0722f * b; }
};

// Division that returns 0 where the divisor is 0.
inline RGB safe_div(const RGB& a, const RGB& b) {
  return {b.r != 0 ? a.r / b.r : 0, b.g != 0 ? a.g / b.g : 0, b.b != 0 ? a.b / b.b : 0};
}
inline RGB sqrt(const RGB& c) { return {std::sqrt(c.r), std::sqrt(c.g), std::sqrt(c.b)}; }
inline RGB clamp_zero(const RGB& c) { return {std::max(Float(0), c.r), std::max(Float(0), c.g), std::max(Float(0), c.b)}; }

// The wavelengths a path carries; empty in RGB mode.
struct RGBWavelengths {
  static constexpr bool is_spectral = false;
};

// spectrum_traits<S>: is_spectral, size, wavelengths_type, and the edge
// conversions (from an RGB parameter to S, from S to what the film
// accumulates). spectra/traits.hpp specialises it for SampledSpectrum<N>.
template <class S> struct spectrum_traits;

template <> struct spectrum_traits<RGB> {
  static constexpr bool is_spectral = false;
  static constexpr int size = 3;
  using wavelengths_type = RGBWavelengths;

  // Sample the wavelengths a camera path carries: nothing to sample in RGB.
  static wavelengths_type sample_wavelengths(Float /*u*/) { return {}; }
  // Reflectance (bounded to [0, 1]) given as RGB.
  static RGB albedo(const RGB& c, const wavelengths_type&) { return c; }
  // Emission given as RGB.
  static RGB illuminant(const RGB& c, const wavelengths_type&) { return c; }
  // Unbounded RGB quantity (e.g. a scale).
  static RGB unbounded(const RGB& c, const wavelengths_type&) { return c; }
  // What the film accumulates (linear sRGB here) from a path's radiance estimate.
  static constexpr bool film_xyz = false;
  static RGB to_film(const RGB& c, const wavelengths_type&) { return c; }
};

template <class S> inline constexpr bool is_spectral_v = spectrum_traits<S>::is_spectral;
template <class S> using wavelengths_t = typename spectrum_traits<S>::wavelengths_type;

// The operations every colour type provides.
template <class S>
concept Spectrum = requires(S a, S b, Float f) {
  { a + b } -> std::same_as<S>;
  { a * b } -> std::same_as<S>;
  { a * f } -> std::same_as<S>;
  { a / f } -> std::same_as<S>;
  { a.max_component() } -> std::convertible_to<Float>;
  { a.average() } -> std::convertible_to<Float>;
  { a.is_black() } -> std::convertible_to<bool>;
  { a.is_finite() } -> std::convertible_to<bool>;
  typename spectrum_traits<S>::wavelengths_type;
};

}  // namespace prism
