// prism/bxdfs/volume.hpp — absorption inside closed transmissive objects
// (KHR_materials_volume): light travelling a distance t inside is attenuated by
// exp(-sigma_a t), with sigma_a = -ln(attenuation_color) / attenuation_distance,
// so that after attenuation_distance exactly attenuation_color remains
// (Beer–Lambert). No scattering inside. The path integrators track whether a
// path is inside such an object (entered by a transmission through its
// surface, left by another) and attenuate every segment in between.
#pragma once
#include <cmath>
#include <limits>
#include <string>
#include "prism/error.hpp"
#include "prism/spectra/rgb.hpp"

namespace prism {

struct VolumeAbsorption {
  RGB attenuation_color{1};
  Float attenuation_distance = std::numeric_limits<Float>::infinity();

  // True if the volume absorbs anything.
  bool active() const {
    return std::isfinite(attenuation_distance) && !(attenuation_color == RGB(1));
  }
  // attenuation_color in [0, 1] and finite; attenuation_distance > 0 (infinite: no absorption).
  void validate(const std::string& material) const {
    for (int c = 0; c < 3; ++c)
      if (!(attenuation_color[c] >= 0 && attenuation_color[c] <= 1))
        throw Error("material '" + material + "': volume attenuation colour must lie in [0, 1]");
    if (!(attenuation_distance > 0))
      throw Error("material '" + material + "': volume attenuation distance must be positive");
  }
};

// sigma_a at the path's wavelengths: the attenuation colour is uplifted as a
// reflectance (bounded to [0, 1]), then sigma = -ln(c) / d per wavelength; a
// component that is exactly 0 absorbs everything (sigma = infinity).
template <class S, class W>
S absorption_coefficient(const VolumeAbsorption& v, const W& lambda) {
  S c = spectrum_traits<S>::albedo(v.attenuation_color, lambda);
  S sigma;
  for (int i = 0; i < S::size; ++i)
    sigma[i] = c[i] > 0 ? -std::log(std::min(c[i], Float(1))) / v.attenuation_distance
                        : std::numeric_limits<Float>::infinity();
  return sigma;
}

// exp(-sigma t) per wavelength (0 where sigma is infinite and t > 0).
template <class S>
S transmittance(const S& sigma, Float t) {
  S tr;
  for (int i = 0; i < S::size; ++i) tr[i] = sigma[i] == 0 ? 1 : std::exp(-sigma[i] * t);
  return tr;
}

}  // namespace prism
