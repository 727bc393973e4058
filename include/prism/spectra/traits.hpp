// prism/spectra/traits.hpp — spectrum_traits for SampledSpectrum<N>: what makes
// every component templated on S work spectrally. RGB parameters (material
// colours, emission) are uplifted at the wavelengths a path carries with the
// sigmoid-polynomial model (rgb_to_spectrum.hpp); the film accumulates CIE XYZ.
#pragma once
#include "prism/spectra/rgb.hpp"
#include "prism/spectra/rgb_to_spectrum.hpp"
#include "prism/spectra/sampled.hpp"
#include "prism/spectra/spectrum.hpp"

namespace prism {

template <int N>
struct spectrum_traits<SampledSpectrum<N>> {
  static constexpr bool is_spectral = true;
  static constexpr int size = N;
  using wavelengths_type = SampledWavelengths<N>;

  static wavelengths_type sample_wavelengths(Float u) { return wavelengths_type::sample(u); }
  // A reflectance in [0, 1]: a bounded sigmoid spectrum (values clamped into
  // [0, 1] first; the scene validates its materials).
  static SampledSpectrum<N> albedo(const RGB& c, const wavelengths_type& lambda) {
    return sample(RGBAlbedoSpectrum(RGB{unit(c.r), unit(c.g), unit(c.b)}), lambda);
  }
  // Emission: the uplifted colour times the colour space's illuminant (D65,
  // normalised to Y = 1), so that RGB(1, 1, 1) emits white.
  static SampledSpectrum<N> illuminant(const RGB& c, const wavelengths_type& lambda) {
    RGB v{finite_non_negative(c.r), finite_non_negative(c.g), finite_non_negative(c.b)};
    if (v.is_black()) return SampledSpectrum<N>(0);
    return sample(RGBIlluminantSpectrum(v), lambda);
  }
  // A non-negative quantity that may exceed 1.
  static SampledSpectrum<N> unbounded(const RGB& c, const wavelengths_type& lambda) {
    RGB v{finite_non_negative(c.r), finite_non_negative(c.g), finite_non_negative(c.b)};
    if (v.is_black()) return SampledSpectrum<N>(0);
    return sample(RGBUnboundedSpectrum(v), lambda);
  }
  // The render loop never throws: NaN becomes 0, values are clamped into range
  // (scenes validate their parameters when built).
  static Float unit(Float v) { return v > 0 ? std::min(v, Float(1)) : Float(0); }
  static Float finite_non_negative(Float v) { return v > 0 && std::isfinite(v) ? v : Float(0); }

  // The film accumulates CIE XYZ (stored in an RGB triple as x, y, z).
  static constexpr bool film_xyz = true;
  static RGB to_film(const SampledSpectrum<N>& L, const wavelengths_type& lambda) {
    XYZ c = to_xyz(L, lambda);
    return {c.x, c.y, c.z};
  }
};

// The default spectral colour type.
using Spectral = SampledSpectrum<4>;

}  // namespace prism
