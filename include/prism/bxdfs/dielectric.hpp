// prism/bxdfs/dielectric.hpp — dielectric interfaces (glass, water):
// - DielectricBxDF, smooth or rough. Smooth: one specular reflection and one
//   specular refraction, chosen in proportion to the Fresnel reflectance R and
//   transmittance T = 1 - R (pbrt-v4 book, 9.5). Rough: the same two lobes on
//   Trowbridge–Reitz microfacets (microfacet.hpp), reflection about and
//   refraction through the microfacet normal, which for a refraction is the
//   generalised half vector (pbrt-v4 book, 9.7; Walter et al. 2007).
// - ThinDielectricBxDF: a thin slab (a window pane, a soap film without
//   interference), whose two parallel interfaces reflect light back and forth.
//
// Conventions (local shading frame, +z = shading normal = outside):
// - eta is the IOR of the inside relative to the outside; wo.z < 0 means wo is
//   inside, where the relative IOR seen by the light is 1 / eta.
// - Smooth: both lobes are deltas: eval and pdf return 0. sample() returns
//   f = R/|cos| (or T/|cos|) with pdf R/(R+T) (or T/(R+T)), so f |cos| / pdf
//   is 1 in importance transport, and on refraction 1/eta'^2 in radiance
//   transport, eta' being the relative IOR across the crossing (eta entering,
//   1/eta leaving): radiance is compressed into the smaller solid angle when
//   it enters a denser medium (pbrt-v4 book, 9.5.2). BSDFSample::eta is eta'.
// - Rough: glossy lobes; the same 1/eta'^2 factor on the transmitted f in
//   radiance transport, none in importance transport, so that
//   f_radiance(wo, wi) = f_importance(wi, wo). sample() returns the f and pdf
//   that eval() and pdf() give at (wo, wi) (both recomputed from the rounded
//   wi), so MIS sees one density. Single scattering only: a rough interface
//   loses the energy of light that would bounce between microfacets.
// - Total internal reflection (of the interface, or of a microfacet): R = 1,
//   so every sample reflects.
// - Roughness below TrowbridgeReitz::smooth_alpha (and eta = 1) takes the
//   smooth path exactly.
//
// The material (DielectricMaterial) holds an IOR law (spectra/dispersion.hpp)
// and a roughness; bxdf_traits<DielectricBxDF<S>>::make resolves the law to
// one eta for the path's wavelengths with path_eta(), which terminates the
// secondary wavelengths when the law disperses (rough or smooth: either way
// the refracted direction depends on the wavelength).
#pragma once
#include <algorithm>
#include <cmath>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include "prism/bxdfs/bxdf.hpp"
#include "prism/bxdfs/microfacet.hpp"
#include "prism/bxdfs/volume.hpp"
#include "prism/geometry/interaction.hpp"
#include "prism/spectra/dispersion.hpp"

namespace prism {

namespace detail {
// cos^2 of the refraction angle by Snell's law, for an incidence cosine c in
// [0, 1] and the relative IOR etap (transmitted side / incident side);
// <= 0 means total internal reflection. In double: close to the critical
// angle cos^2 is a small difference of numbers near 1; rounding 1/eta to
// float alone would move it by ~1e-7, i.e. R by ~1e-4 there.
inline double cos2_refracted(double c, double etap) {
  double sin2_i = (1 - c) * (1 + c);
  return 1 - sin2_i / (etap * etap);
}
}  // namespace detail

// Fresnel reflectance of a smooth dielectric interface for unpolarised light
// (the mean of the s and p power reflectances). cos_theta_i is the cosine of
// the incident direction with the normal, which points to the outside;
// negative means the light arrives from the inside. eta: inside / outside.
// Same total-internal-reflection decision as refract_dielectric.
inline Float fresnel_dielectric(Float cos_theta_i, Float eta) {
  double c = std::clamp(double(cos_theta_i), -1.0, 1.0), e = eta;
  if (c < 0) {  // from the inside: the light sees 1 / eta
    e = 1 / e;
    c = -c;
  }
  double cos2_t = detail::cos2_refracted(c, e);
  if (!(cos2_t > 0)) return 1;  // total internal reflection
  double cos_t = std::sqrt(cos2_t);
  double r_parallel = (e * c - cos_t) / (e * c + cos_t);
  double r_perpendicular = (c - e * cos_t) / (c + e * cos_t);
  return Float((sqr(r_parallel) + sqr(r_perpendicular)) / 2);
}

struct Refraction {
  Vector3f wt;   // the refracted direction (unit), pointing away on the other side
  Float etap;    // relative IOR across the crossing: eta entering, 1/eta leaving
};
// Refracts wi (unit, pointing away from the surface) through the interface
// with unit normal n (pointing outside) and relative IOR eta (inside /
// outside); wi may be on either side. nullopt on total internal reflection.
inline std::optional<Refraction> refract_dielectric(const Vector3f& wi, Vector3f n, Float eta) {
  double c = double(wi.x) * n.x + double(wi.y) * n.y + double(wi.z) * n.z, e = eta;
  if (c < 0) {  // wi is inside: flip the interface
    e = 1 / e;
    c = -c;
    n = -n;
  }
  c = std::min(c, 1.0);
  double cos2_t = detail::cos2_refracted(c, e);
  if (!(cos2_t > 0)) return std::nullopt;
  // The tangential part of wi flips and shrinks by 1/eta'; the normal part
  // becomes -cos_t n.
  double k = c / e - std::sqrt(cos2_t);
  Vector3f wt(Float(-wi.x / e + k * n.x), Float(-wi.y / e + k * n.y), Float(-wi.z / e + k * n.z));
  return Refraction{wt, Float(e)};
}

template <class S>
class DielectricBxDF {
 public:
  DielectricBxDF() = default;
  explicit DielectricBxDF(Float eta) : m_eta(eta) {}
  DielectricBxDF(Float eta, const TrowbridgeReitz& distrib) : m_eta(eta), m_distrib(distrib) {}

  // Specular lobes when the microfacets are effectively smooth, and when
  // eta = 1 (light passes straight through; no half vector exists).
  bool is_smooth() const { return m_eta == 1 || m_distrib.effectively_smooth(); }

  S eval(Vector3f wo, Vector3f wi, TransportMode mode) const {
    if (is_smooth()) return S{};
    auto r = rough(wo, wi, mode);
    return r ? S(r->f) : S{};
  }
  Float pdf(Vector3f wo, Vector3f wi, TransportMode mode) const {
    if (is_smooth()) return 0;
    auto r = rough(wo, wi, mode);
    return r ? r->pdf : 0;
  }

  // Smooth: uc < R picks the reflection, otherwise the refraction (u is
  // unused). Rough: a visible normal wm from u, then uc < R(wo.wm) reflects
  // about wm, otherwise refracts through it.
  std::optional<BSDFSample<S>> sample(Vector3f wo, Float uc, Point2f u, TransportMode mode) const {
    if (wo.z == 0) return std::nullopt;
    if (is_smooth()) return sample_smooth(wo, uc, mode);
    Vector3f wm = m_distrib.sample_wm(wo, u);
    Float R = fresnel_dielectric(dot(wo, wm), m_eta);
    Vector3f wi;
    if (uc < R) {
      wi = reflect(wo, wm);
      if (!same_hemisphere(wo, wi)) return std::nullopt;
    } else {
      auto t = refract_dielectric(wo, wm, m_eta);
      if (!t) return std::nullopt;  // rounding: R < 1 excludes TIR
      wi = t->wt;
      if (wi.z * wo.z >= 0) return std::nullopt;
    }
    auto r = rough(wo, wi, mode);
    if (!r || !(r->pdf > 0) || !(r->f > 0)) return std::nullopt;
    return BSDFSample<S>{S(r->f), wi, r->pdf,
                         r->is_reflection ? BxDFFlags::glossy_reflection : BxDFFlags::glossy_transmission, r->etap};
  }

  BxDFFlags flags() const {
    BxDFFlags lobes = m_eta == 1 ? BxDFFlags::transmission : BxDFFlags::reflection | BxDFFlags::transmission;
    return lobes | (is_smooth() ? BxDFFlags::specular : BxDFFlags::glossy);
  }
  Float eta() const { return m_eta; }
  const TrowbridgeReitz& distribution() const { return m_distrib; }

 private:
  std::optional<BSDFSample<S>> sample_smooth(const Vector3f& wo, Float uc, TransportMode mode) const {
    Float R = fresnel_dielectric(wo.z, m_eta), T = 1 - R;
    if (uc < R || !(T > 0)) {
      Vector3f wi(-wo.x, -wo.y, wo.z);
      return BSDFSample<S>{S(R / abs_cos_theta(wi)), wi, R, BxDFFlags::specular_reflection};
    }
    auto r = refract_dielectric(wo, Vector3f(0, 0, 1), m_eta);
    if (!r || r->wt.z == 0) return std::nullopt;  // T > 0 excludes TIR; guards rounding
    Float ft = T / abs_cos_theta(r->wt);
    if (mode == TransportMode::radiance) ft /= sqr(r->etap);
    return BSDFSample<S>{S(ft), r->wt, T, BxDFFlags::specular_transmission, r->etap};
  }

  struct RoughValue {
    Float f, pdf;
    bool is_reflection;
    Float etap;  // relative IOR across the crossing (1 for a reflection)
  };
  // The rough lobes at (wo, wi), with the generalised half vector
  // wm ~ etap wi + wo (etap = eta if wo is outside, 1 / eta inside; 1 for a
  // reflection), turned to +z. nullopt where f and pdf are 0: a grazing
  // direction, a degenerate half vector, or a microfacet seen from behind by
  // wo or wi (a real microsurface has both on its front side).
  //   reflection:   f = D G R / (4 |cos_o cos_i|),
  //                 pdf = D_wo(wm) / (4 |wo.wm|) R;
  //   transmission: f = D G T |wi.wm| |wo.wm| / (|cos_o cos_i| (wi.wm + wo.wm / etap)^2),
  //                 divided by etap^2 in radiance transport,
  //                 pdf = D_wo(wm) |wi.wm| / (wi.wm + wo.wm / etap)^2 T,
  // R = fresnel_dielectric(wo.wm), T = 1 - R, the lobe probabilities of sample().
  std::optional<RoughValue> rough(const Vector3f& wo, const Vector3f& wi, TransportMode mode) const {
    Float co = wo.z, ci = wi.z;
    if (co == 0 || ci == 0) return std::nullopt;
    bool is_reflection = co * ci > 0;
    Float etap = is_reflection ? Float(1) : (co > 0 ? m_eta : 1 / m_eta);
    Vector3f wm = wi * etap + wo;
    Float l2 = length_squared(wm);
    if (!(l2 > 0)) return std::nullopt;
    wm = wm / std::sqrt(l2);
    if (wm.z < 0) wm = -wm;
    Float dwo = dot(wo, wm), dwi = dot(wi, wm);
    if (!(dwo * co > 0) || !(dwi * ci > 0)) return std::nullopt;
    Float R = fresnel_dielectric(dwo, m_eta), T = 1 - R;
    Float d = m_distrib.D(wm);
    Float pdf_wm = m_distrib.D_visible(wo, wm);
    if (is_reflection) {
      Float f = d * m_distrib.G(wo, wi) * R / std::abs(4 * co * ci);
      return RoughValue{f, pdf_wm / (4 * std::abs(dwo)) * R, true, 1};
    }
    Float denom = sqr(dwi + dwo / etap);
    if (!(denom > 0)) return std::nullopt;
    Float f = d * m_distrib.G(wo, wi) * T * std::abs(dwi * dwo / (co * ci * denom));
    if (mode == TransportMode::radiance) f /= sqr(etap);
    return RoughValue{f, pdf_wm * std::abs(dwi) / denom * T, false, etap};
  }

  Float m_eta = 1.5f;
  TrowbridgeReitz m_distrib;
};

// A dielectric material: an IOR law, a name (for error messages) and a
// microfacet roughness (alpha; 0, the default, is the smooth interface).
// Call validate() when the scene is built.
struct DielectricMaterial {
  IOR ior{1.5f};
  std::string name = "dielectric";
  MicrofacetRoughness roughness{};
  VolumeAbsorption volume{};  // absorption inside (closed meshes), none by default

  void validate() const {
    ior.validate(name);
    volume.validate(name);
    if (!roughness.is_finite_non_negative()) {
      std::ostringstream s;
      s << "material '" << name << "': roughness (alpha_u, alpha_v) = (" << roughness.alpha_u << ", "
        << roughness.alpha_v << ") must be finite and >= 0";
      throw Error(s.str());
    }
  }
};

template <class S>
struct bxdf_traits<DielectricBxDF<S>> {
  static constexpr std::string_view name = "dielectric";
  // The lobes it may have: specular when smooth, glossy when rough.
  static constexpr BxDFFlags flags = BxDFFlags::specular_reflection | BxDFFlags::specular_transmission |
                                     BxDFFlags::glossy_reflection | BxDFFlags::glossy_transmission;
  using material_type = DielectricMaterial;
  // W is the path's wavelengths type, const or not. Spectral and dispersive:
  // terminates the secondary wavelengths (non-const W) and uses eta at the
  // hero; otherwise eta at the d line (587.56 nm). See path_eta().
  template <class W>
  static DielectricBxDF<S> make(const DielectricMaterial& m, const SurfaceInteraction&, W& lambda) {
    return DielectricBxDF<S>(path_eta(m.ior, lambda), TrowbridgeReitz(m.roughness));
  }
  // Scene::build: eta must be finite and > 1 over 360-830 nm, the roughness
  // finite and >= 0. `where` (e.g. "scene: material 3") prefixes the
  // message, which names the material.
  static void validate(const DielectricMaterial& m, std::string_view where) {
    try {
      m.validate();
    } catch (const Error& e) {
      throw Error(std::string(where) + ": " + e.what());
    }
  }
  // Dispersion cannot be rendered in RGB (one eta for all three channels).
  static bool needs_spectral(const DielectricMaterial& m) { return m.ior.is_dispersive(); }
  static bool has_specular(const DielectricMaterial& m) { return TrowbridgeReitz(m.roughness).effectively_smooth(); }
  // The absorbing interior, if any (the integrators attenuate inside).
  static const VolumeAbsorption* volume(const DielectricMaterial& m) { return m.volume.active() ? &m.volume : nullptr; }
};

// A thin dielectric slab: two parallel smooth interfaces so close that the
// light leaves where it entered. Light reflected inside bounces between them;
// summing the geometric series of the bounces (each inner reflection is R
// again, by Stokes' relations), the slab reflects
//   R' = R + T^2 R (1 + R^2 + R^4 + ...) = R + T^2 R / (1 - R^2) = 2 R / (1 + R)
// and transmits T' = 1 - R' = (1 - R) / (1 + R), with R the Fresnel
// reflectance of one interface at the incidence angle (no absorption, no
// thin-film interference). Both lobes are deltas: the mirror direction, and
// wi = -wo (the slab displaces the ray by at most its thickness, neglected).
// No 1/eta^2 factor: the light ends up in the medium it started in
// (BSDFSample::eta = 1). eta is per wavelength (per channel in RGB): the
// directions do not depend on it, so a dispersive slab keeps every wavelength.
template <class S>
class ThinDielectricBxDF {
 public:
  ThinDielectricBxDF() : m_eta(Float(1.5f)) {}
  explicit ThinDielectricBxDF(Float eta) : m_eta(eta) {}
  explicit ThinDielectricBxDF(const S& eta) : m_eta(eta) {}

  S eval(Vector3f, Vector3f, TransportMode) const { return S{}; }
  Float pdf(Vector3f, Vector3f, TransportMode) const { return 0; }

  // uc < mean R' picks the reflection (u unused); f carries R' or T' per
  // wavelength, the pdf their mean. T' is computed as (1 - R) / (1 + R), not
  // 1 - R': near grazing R' is close to 1 and the subtraction would leave T'
  // with a large relative error.
  std::optional<BSDFSample<S>> sample(Vector3f wo, Float uc, Point2f, TransportMode) const {
    if (wo.z == 0) return std::nullopt;
    Float c = abs_cos_theta(wo);
    S R, T;
    for (int i = 0; i < S::size; ++i) {
      Float r = fresnel_dielectric(c, m_eta[i]);
      R[i] = 2 * r / (1 + r);
      T[i] = (1 - r) / (1 + r);
    }
    Float pr = R.average(), pt = T.average();
    if (uc * (pr + pt) < pr || !(pt > 0)) {
      if (!(pr > 0)) return std::nullopt;
      return BSDFSample<S>{R / c, Vector3f(-wo.x, -wo.y, wo.z), pr / (pr + pt), BxDFFlags::specular_reflection};
    }
    return BSDFSample<S>{T / c, -wo, pt / (pr + pt), BxDFFlags::specular_transmission, 1};
  }

  // R' = 2 R / (1 + R) at incidence cosine |cos| (either side).
  S reflectance(Float abs_cos) const {
    S r;
    for (int i = 0; i < S::size; ++i) {
      Float R = fresnel_dielectric(abs_cos, m_eta[i]);
      r[i] = 2 * R / (1 + R);
    }
    return r;
  }

  BxDFFlags flags() const {
    for (int i = 0; i < S::size; ++i)
      if (m_eta[i] != 1) return BxDFFlags::specular_reflection | BxDFFlags::specular_transmission;
    return BxDFFlags::specular_transmission;
  }
  const S& eta() const { return m_eta; }

 private:
  S m_eta;
};

// A thin dielectric slab's material: an IOR law and a name.
struct ThinDielectricMaterial {
  IOR ior{1.5f};
  std::string name = "thin_dielectric";

  void validate() const { ior.validate(name); }
};

template <class S>
struct bxdf_traits<ThinDielectricBxDF<S>> {
  static constexpr std::string_view name = "thin_dielectric";
  static constexpr BxDFFlags flags = BxDFFlags::specular_reflection | BxDFFlags::specular_transmission;
  using material_type = ThinDielectricMaterial;
  // Spectral: eta at every wavelength of the path (none is terminated); RGB:
  // eta at the d line for the three channels.
  template <class W>
  static ThinDielectricBxDF<S> make(const ThinDielectricMaterial& m, const SurfaceInteraction&, const W& lambda) {
    if constexpr (std::remove_cvref_t<W>::is_spectral) {
      S eta;
      for (int i = 0; i < S::size; ++i) eta[i] = m.ior(lambda[i]);
      return ThinDielectricBxDF<S>(eta);
    } else {
      (void)lambda;
      return ThinDielectricBxDF<S>(m.ior.eta_d());
    }
  }
  static void validate(const ThinDielectricMaterial& m, std::string_view where) {
    try {
      m.validate();
    } catch (const Error& e) {
      throw Error(std::string(where) + ": " + e.what());
    }
  }
  // A dispersive slab's reflectance varies with the wavelength, which RGB
  // (eta_d for all channels) does not reproduce exactly.
  static bool needs_spectral(const ThinDielectricMaterial& m) { return m.ior.is_dispersive(); }
};

}  // namespace prism
