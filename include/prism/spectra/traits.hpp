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
    RGB cl{std::clamp(c.r, Float(0), Float(1)), std::clamp(c.g, Float(0), Float(1)), std::clamp(c.b, Float(0), Float(1))};
    return sample(RGBAlbedoSpectrum(cl), lambda);
  }
  // Emission: the uplifted colour times the colour space's illuminant (D65,
  // normalised to Y = 1), so that RGB(1, 1, 1) emits white.
  static SampledSpectrum<N> illuminant(const RGB& c, const wavelengths_type& lambda) {
    if (c.is_black()) return SampledSpectrum<N>(0);
    return sample(RGBIlluminantSpectrum(clamp_zero(c)), lambda);
  }
  // A non-negative quantity that may exceed 1.
  static SampledSpectrum<N> unbounded(const RGB& c, const wavelengths_type& lambda) {
    if (c.is_black()) return SampledSpectrum<N>(0);
    return sample(RGBUnboundedSpectrum(clamp_zero(c)), lambda);
  }
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
