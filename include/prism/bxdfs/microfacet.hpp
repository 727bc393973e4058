// prism/bxdfs/microfacet.hpp — the anisotropic Trowbridge–Reitz (GGX)
// microfacet distribution: normal distribution D, Smith masking Lambda / G1,
// the height-correlated masking-shadowing G, and sampling of the visible
// normals (pbrt-v4 book, 9.6). The rough conductor and the rough dielectric
// (conductor.hpp, dielectric.hpp) are built on it.
//
// Conventions: directions and microfacet normals wm are unit vectors in the
// local shading frame (+z = macro normal); D is a density of microfacet
// normals over the upper hemisphere with respect to solid angle, normalised so
// that the projected microfacet area is the macro area: integral of
// D(wm) cos(theta_m) d omega_m = 1. alpha_x and alpha_y are the widths of the
// distribution along the shading frame's x and y axes (for small alpha, the
// RMS slope over sqrt(2)). How alpha follows from a material's "roughness" is
// the caller's choice (glTF: alpha = roughness^2); MicrofacetRoughness holds
// alpha itself.
//
// The smooth threshold (docs/microfacets.md): a distribution with
// max(alpha_x, alpha_y) < smooth_alpha = 2^-12 is effectively_smooth(), and the
// BxDFs replace its lobe with the exact specular (delta) lobe. The value is
// sqrt(machine_epsilon), the scale at which float directions stop resolving
// the lobe:
//  - a microfacet tilted by theta < 2^-12 has cos(theta) = 1 - theta^2 / 2
//    rounded to exactly 1 (the float below 1 is 1 - 2^-24), so every cosine
//    the Fresnel and masking terms see is the mirror configuration's;
//  - a reflected or refracted direction is rounded by a few ulps, about
//    gamma(3) ~ 1.8e-7 rad; the half vector recomputed from it by eval/pdf is
//    off by as much, and the density's log-derivative in theta_m reaches
//    2 / alpha, so the sampled density and pdf() disagree by ~3.6e-7 / alpha
//    relative: 1.5e-3 at alpha = 2^-12, growing without bound below it.
// Roughness exactly 0 therefore always takes the specular path, and any
// alpha below 2^-12 (1e-4, say) too; nothing in this header divides by alpha
// before that decision, and above it every quantity is finite (D peaks at
// 1 / (pi alpha_x alpha_y) < 5.4e6).
#pragma once
#include <algorithm>
#include <cmath>
#include "prism/math/vector.hpp"

namespace prism {

// alpha_u along the shading frame's x (the surface tangent), alpha_v along y.
// A single number is isotropic. 0 (the default) is a perfectly smooth surface.
struct MicrofacetRoughness {
  Float alpha_u = 0, alpha_v = 0;

  constexpr MicrofacetRoughness() = default;
  constexpr MicrofacetRoughness(Float alpha) : alpha_u(alpha), alpha_v(alpha) {}  // NOLINT: isotropic
  constexpr MicrofacetRoughness(Float au, Float av) : alpha_u(au), alpha_v(av) {}
  // The perceptual roughness r of glTF and the Disney model: alpha = r^2.
  static constexpr MicrofacetRoughness from_perceptual(Float r) { return {r * r}; }
  static constexpr MicrofacetRoughness from_perceptual(Float ru, Float rv) { return {ru * ru, rv * rv}; }
  bool is_finite_non_negative() const {
    return std::isfinite(alpha_u) && std::isfinite(alpha_v) && alpha_u >= 0 && alpha_v >= 0;
  }
};

// The two visible-normal samplers. bench/bxdf_bench.cpp times them; the faster
// is TrowbridgeReitz::default_vndf (docs/microfacets.md has the figures).
enum class VNDFMethod {
  heitz2018,      // Heitz 2018, JCGT 7(4): projected-area disk warp
  spherical_caps  // Dupuy & Benyoub 2023, HPG: a spherical cap around the stretched view
};

class TrowbridgeReitz {
 public:
  // Below this alpha the lobe is a delta (see the header comment).
  static constexpr Float smooth_alpha = 0x1p-12f;
  static constexpr VNDFMethod default_vndf = VNDFMethod::spherical_caps;

  TrowbridgeReitz() = default;  // smooth
  // NaN or negative alphas are taken as 0 (materials reject them first). When
  // the distribution is rough, an alpha below smooth_alpha is raised to it: a
  // lobe that is a delta along one axis only cannot be sampled or evaluated.
  TrowbridgeReitz(Float alpha_x, Float alpha_y) : m_ax(sanitize(alpha_x)), m_ay(sanitize(alpha_y)) {
    if (!effectively_smooth()) {
      m_ax = std::max(m_ax, smooth_alpha);
      m_ay = std::max(m_ay, smooth_alpha);
    }
  }
  explicit TrowbridgeReitz(const MicrofacetRoughness& r) : TrowbridgeReitz(r.alpha_u, r.alpha_v) {}

  Float alpha_x() const { return m_ax; }
  Float alpha_y() const { return m_ay; }
  bool effectively_smooth() const { return std::max(m_ax, m_ay) < smooth_alpha; }

  // D(wm) for a unit wm in the upper hemisphere, 0 below. With x = sin cos phi
  // and y = sin sin phi, the textbook
  //   1 / (pi ax ay cos^4 (1 + tan^2 (cos^2 phi / ax^2 + sin^2 phi / ay^2))^2)
  // is 1 / (pi ax ay (x^2/ax^2 + y^2/ay^2 + z^2)^2): no tangent, no division
  // by cos, and exact at the pole and the horizon.
  // alpha = 0 along an axis (only possible while effectively_smooth) is the
  // delta itself, which has no finite density: D = 0 there.
  Float D(const Vector3f& wm) const {
    if (!(wm.z > 0) || m_ax == 0 || m_ay == 0) return 0;
    Float x = wm.x / m_ax, y = wm.y / m_ay;
    Float s = x * x + y * y + wm.z * wm.z;
    return 1 / (pi * m_ax * m_ay * s * s);
  }

  // Smith's Lambda for the direction w (either hemisphere):
  // (sqrt(1 + alpha^2 tan^2) - 1) / 2 with alpha^2 tan^2 =
  // ((ax x)^2 + (ay y)^2) / z^2, written as t / (2 (sqrt(1 + t) + 1)) to avoid
  // the cancellation for small t. Infinite at the horizon.
  Float lambda(const Vector3f& w) const {
    Float z2 = w.z * w.z;
    if (z2 == 0) return infinity;
    Float t = (sqr(m_ax * w.x) + sqr(m_ay * w.y)) / z2;
    if (!(t < infinity)) return infinity;
    return t / (2 * (std::sqrt(1 + t) + 1));
  }
  // Masking of one direction, and the height-correlated masking-shadowing of
  // two (Heitz 2014): 1 / (1 + Lambda(wo) + Lambda(wi)).
  Float G1(const Vector3f& w) const { return 1 / (1 + lambda(w)); }
  Float G(const Vector3f& wo, const Vector3f& wi) const { return 1 / (1 + lambda(wo) + lambda(wi)); }

  // The distribution of normals visible from w, per solid angle of wm (upper
  // hemisphere): G1(w) max(0, w.wm) D(wm) / cos(theta_w). For w below the
  // surface the microsurface is seen from behind: the visible normals are
  // those facing -w, so the density is that of -w. It integrates to 1 over
  // wm; sample_wm() draws from it.
  Float D_visible(const Vector3f& w, const Vector3f& wm) const {
    Float cz = std::abs(w.z);
    if (cz == 0) return 0;
    Float d = dot(w, wm);
    if (w.z < 0) d = -d;
    if (!(d > 0)) return 0;
    return G1(w) / cz * D(wm) * d;
  }

  // A visible normal for w (upper hemisphere), by the default method.
  Vector3f sample_wm(const Vector3f& w, Point2f u) const {
    if constexpr (default_vndf == VNDFMethod::spherical_caps)
      return sample_wm_spherical_caps(w, u);
    else
      return sample_wm_heitz(w, u);
  }
  Vector3f sample_wm(const Vector3f& w, Point2f u, VNDFMethod method) const {
    return method == VNDFMethod::spherical_caps ? sample_wm_spherical_caps(w, u) : sample_wm_heitz(w, u);
  }

  // Heitz 2018: stretch w to the alpha = 1 configuration, where the visible
  // normals of a hemisphere project onto a unit disk seen from wh; sample the
  // projected area (a disk whose far half is squashed by (1 + wh.z) / 2),
  // lift the point onto the hemisphere, and unstretch the normal.
  Vector3f sample_wm_heitz(const Vector3f& w, Point2f u) const {
    Vector3f wh = stretch(w);
    Float len2 = wh.x * wh.x + wh.y * wh.y;
    Vector3f t1 = len2 > 0 ? Vector3f(-wh.y, wh.x, 0) / std::sqrt(len2) : Vector3f(1, 0, 0);
    Vector3f t2 = cross(wh, t1);
    Float r = std::sqrt(u.x), phi = 2 * pi * u.y;
    Float p1 = r * std::cos(phi), p2 = r * std::sin(phi);
    Float s = (1 + wh.z) / 2;
    p2 = (1 - s) * safe_sqrt(1 - p1 * p1) + s * p2;
    Float pz = safe_sqrt(1 - p1 * p1 - p2 * p2);
    Vector3f nh = t1 * p1 + t2 * p2 + wh * pz;
    return unstretch(nh);
  }

  // Dupuy & Benyoub 2023: in the stretched configuration, the visible normals
  // are the half vectors wh + c of wh and a point c uniform on the spherical
  // cap z > -wh.z of the unit sphere. No basis, one square root fewer.
  Vector3f sample_wm_spherical_caps(const Vector3f& w, Point2f u) const {
    Vector3f wh = stretch(w);
    Float phi = 2 * pi * u.x;
    Float z = std::fma(1 - u.y, 1 + wh.z, -wh.z);
    Float sin_theta = safe_sqrt((1 - z) * (1 + z));
    Vector3f h(sin_theta * std::cos(phi) + wh.x, sin_theta * std::sin(phi) + wh.y, z + wh.z);
    return unstretch(h);
  }

 private:
  static Float sanitize(Float a) { return a >= 0 ? a : 0; }  // NaN and negatives -> 0
  // w (flipped to the upper hemisphere) in the alpha = 1 configuration.
  Vector3f stretch(const Vector3f& w) const {
    Float sgn = w.z < 0 ? Float(-1) : Float(1);
    Vector3f v(m_ax * w.x * sgn, m_ay * w.y * sgn, w.z * sgn);
    Float l2 = length_squared(v);
    return l2 > 0 ? v / std::sqrt(l2) : Vector3f(0, 0, 1);
  }
  // Back from the alpha = 1 configuration: normals scale by (ax, ay, 1) and
  // are renormalised; a degenerate (zero) normal becomes +z.
  Vector3f unstretch(const Vector3f& h) const {
    Vector3f m(m_ax * h.x, m_ay * h.y, std::max(Float(0), h.z));
    Float l2 = length_squared(m);
    return l2 > 0 ? m / std::sqrt(l2) : Vector3f(0, 0, 1);
  }

  Float m_ax = 0, m_ay = 0;
};

// The cosine-weighted hemispherical average 2 int_0^1 f(mu) mu dmu by
// 8-point Gauss–Legendre on [0, 1], for a smooth f (a Fresnel reflectance
// seen from the less dense side) returning a Float or a spectrum: the F_avg
// of the multiple-scattering compensations (ms_compensation.hpp,
// dielectric.hpp).
template <class F>
auto cosine_weighted_average(F&& f) {
  static constexpr double x[8] = {-0.9602898564975363, -0.7966664774136267, -0.5255324099163290,
                                  -0.1834346424956498, 0.1834346424956498,  0.5255324099163290,
                                  0.7966664774136267,  0.9602898564975363};
  static constexpr double w[8] = {0.1012285362903763, 0.2223810344533745, 0.3137066458778873,
                                  0.3626837833783620, 0.3626837833783620, 0.3137066458778873,
                                  0.2223810344533745, 0.1012285362903763};
  decltype(f(Float(0)) * Float(1)) sum{};
  for (int i = 0; i < 8; ++i) {
    Float mu = Float((x[i] + 1) / 2);
    sum = sum + f(mu) * Float(w[i] * mu);  // 2 * (w / 2) * f mu
  }
  return sum;
}

// Mirror reflection of wo about the unit normal n (either side).
inline Vector3f reflect(const Vector3f& wo, const Vector3f& n) { return -wo + n * (2 * dot(wo, n)); }

}  // namespace prism
