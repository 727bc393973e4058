// prism/bxdfs/thin_film.hpp — the reflectance of a thin transparent film on
// a substrate (KHR_materials_iridescence): light from a medium of index 1
// meets a film of index n_film and thickness d (nm) over a substrate of
// index n_base. The film's two interfaces reflect amplitudes r12 (outside to
// film) and r23 (film to substrate); summing the waves that bounce inside
// the film (Airy's summation, Born & Wolf, Principles of Optics, section
// 1.6.4) gives, per polarisation,
//   r = (r12 + r23 e^(i delta)) / (1 + r12 r23 e^(i delta)),
//   delta = 4 pi n_film d cos(theta_film) / lambda,
// with r12, r23 the Fresnel amplitude coefficients (s and p) at the angles
// Snell's law gives in each medium, and R = (|r_s|^2 + |r_p|^2) / 2 for
// unpolarised light. At d = 0 it is the bare substrate's Fresnel
// reflectance. Complex cosines carry total internal reflection in the film.
//
// Spectral rendering evaluates R at each of the path's wavelengths. RGB
// rendering needs the colour of R(lambda) under white light:
// thin_film_reflectance_rgb sums R over 380..780 nm every 10 nm weighted by
// the CIE 1931 functions and D65 and maps XYZ to linear sRGB, the weights
// normalised so that a constant R gives exactly that R in every channel
// (Belcour and Barla 2017 integrate the same in closed form with Gaussian
// fits to the colour matching functions; a sum of 41 terms is exact to the
// tables and fast enough for materials that use it).
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include "prism/math/float.hpp"
#include "prism/spectra/rgb.hpp"
#include "prism/spectra/spectrum.hpp"

namespace prism {

// R for light at cos_i (in [0, 1]) from outside, wavelength lambda (nm).
inline Float thin_film_reflectance(Float cos_i, Float n_film, Float d_nm, Float n_base, Float lambda) {
  using C = std::complex<double>;
  const double c1 = std::clamp(double(cos_i), 0.0, 1.0), s1sq = 1 - c1 * c1;
  const double n2 = n_film, n3 = n_base;
  const C c2 = std::sqrt(C(1 - s1sq / (n2 * n2), 0)), c3 = std::sqrt(C(1 - s1sq / (n3 * n3), 0));
  const C r12s = (c1 - n2 * c2) / (c1 + n2 * c2), r23s = (n2 * c2 - n3 * c3) / (n2 * c2 + n3 * c3);
  const C r12p = (n2 * c1 - c2) / (n2 * c1 + c2), r23p = (n3 * c2 - n2 * c3) / (n3 * c2 + n2 * c3);
  const C phase = std::exp(C(0, 1) * (4 * 3.14159265358979323846 * n2 * double(d_nm) / double(lambda)) * c2);
  auto airy = [&](C r12, C r23) {
    C r = (r12 + r23 * phase) / (1.0 + r12 * r23 * phase);
    return std::norm(r);
  };
  double R = (airy(r12s, r23s) + airy(r12p, r23p)) / 2;
  return Float(std::clamp(std::isfinite(R) ? R : 1.0, 0.0, 1.0));
}

namespace detail {
// The RGB weights of the 41 wavelengths 380, 390, ..., 780 nm: CIE 1931
// x, y, z times D65, to linear sRGB, each channel's weights summing to 1.
struct ThinFilmWeights {
  static constexpr int n = 41;
  std::array<RGB, n> w{};
  ThinFilmWeights() {
    RGB sum(0);
    for (int k = 0; k < n; ++k) {
      Float l = Float(380 + 10 * k), e = illuminant_d65()(l);
      w[size_t(k)] = xyz_to_linear_srgb({cie_x(l) * e, cie_y(l) * e, cie_z(l) * e});
      sum = sum + w[size_t(k)];
    }
    for (auto& v : w) v = RGB(v.r / sum.r, v.g / sum.g, v.b / sum.b);
  }
  static const ThinFilmWeights& get() {
    static const ThinFilmWeights table;
    return table;
  }
};
}  // namespace detail

// The linear sRGB colour of R under D65 (see the header comment), each
// channel with its own substrate index (a metal's per-channel index),
// clamped to [0, 1] (a saturated interference colour lies outside sRGB).
inline RGB thin_film_reflectance_rgb(Float cos_i, Float n_film, Float d_nm, const RGB& n_base) {
  const auto& t = detail::ThinFilmWeights::get();
  const bool same = n_base.r == n_base.g && n_base.g == n_base.b;
  RGB out(0);
  for (int k = 0; k < detail::ThinFilmWeights::n; ++k) {
    const Float l = Float(380 + 10 * k);
    const RGB& w = t.w[size_t(k)];
    if (same) {
      Float R = thin_film_reflectance(cos_i, n_film, d_nm, n_base.r, l);
      out = out + w * R;
    } else {
      out = out + RGB(w.r * thin_film_reflectance(cos_i, n_film, d_nm, n_base.r, l),
                      w.g * thin_film_reflectance(cos_i, n_film, d_nm, n_base.g, l),
                      w.b * thin_film_reflectance(cos_i, n_film, d_nm, n_base.b, l));
    }
  }
  return RGB(std::clamp(out.r, Float(0), Float(1)), std::clamp(out.g, Float(0), Float(1)),
             std::clamp(out.b, Float(0), Float(1)));
}

// The index of refraction whose normal-incidence Fresnel reflectance is F0
// ((n - 1) / (n + 1))^2 = F0, for a substrate given by its F0 (a metal's
// base colour, as KHR_materials_iridescence does; its k is not modelled).
inline Float ior_from_f0(Float f0) {
  Float s = std::sqrt(std::clamp(f0, Float(0), Float(0.9999)));
  return (1 + s) / (1 - s);
}

}  // namespace prism
