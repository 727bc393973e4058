// prism/bxdfs/dielectric.hpp — the smooth dielectric interface (glass, water):
// one specular reflection and one specular refraction, chosen in proportion to
// the Fresnel reflectance R and transmittance T = 1 - R (pbrt-v4 book, 9.5).
//
// Conventions (local shading frame, +z = shading normal = outside):
// - eta is the IOR of the inside relative to the outside; wo.z < 0 means wo is
//   inside, where the relative IOR seen by the light is 1 / eta.
// - Both lobes are deltas: eval and pdf return 0. sample() returns f = R/|cos|
//   (or T/|cos|) with pdf R/(R+T) (or T/(R+T)), so f |cos| / pdf is 1 in
//   importance transport, and on refraction 1/eta'^2 in radiance transport,
//   eta' being the relative IOR across the crossing (eta entering, 1/eta
//   leaving): radiance is compressed into the smaller solid angle when it
//   enters a denser medium (pbrt-v4 book, 9.5.2). BSDFSample::eta is eta'.
// - Total internal reflection: R = 1, so every sample reflects.
//
// The material (DielectricMaterial) holds an IOR law (spectra/dispersion.hpp);
// bxdf_traits<DielectricBxDF<S>>::make resolves it to one eta for the path's
// wavelengths with path_eta(), which terminates the secondary wavelengths when
// the law disperses. A rough dielectric can reuse fresnel_dielectric,
// refract_dielectric and path_eta, with its own BxDF and material types.
#pragma once
#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <type_traits>
#include "prism/bxdfs/bxdf.hpp"
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

  // Deltas only.
  S eval(Vector3f, Vector3f, TransportMode) const { return S{}; }
  Float pdf(Vector3f, Vector3f, TransportMode) const { return 0; }

  // uc < R picks the reflection, otherwise the refraction (u is unused).
  std::optional<BSDFSample<S>> sample(Vector3f wo, Float uc, Point2f, TransportMode mode) const {
    if (wo.z == 0) return std::nullopt;
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

  BxDFFlags flags() const {
    return m_eta == 1 ? BxDFFlags::specular_transmission
                      : BxDFFlags::specular_reflection | BxDFFlags::specular_transmission;
  }
  Float eta() const { return m_eta; }

 private:
  Float m_eta = 1.5f;
};

// A smooth dielectric material: an IOR law and a name (for error messages).
// Call validate() when the scene is built.
struct DielectricMaterial {
  IOR ior{1.5f};
  std::string name = "dielectric";

  void validate() const { ior.validate(name); }
};

template <class S>
struct bxdf_traits<DielectricBxDF<S>> {
  static constexpr std::string_view name = "dielectric";
  static constexpr BxDFFlags flags = BxDFFlags::specular_reflection | BxDFFlags::specular_transmission;
  using material_type = DielectricMaterial;
  // W is the path's wavelengths type, const or not. Spectral and dispersive:
  // terminates the secondary wavelengths (non-const W) and uses eta at the
  // hero; otherwise eta at the d line (587.56 nm). See path_eta().
  template <class W>
  static DielectricBxDF<S> make(const DielectricMaterial& m, const SurfaceInteraction&, W& lambda) {
    return DielectricBxDF<S>(path_eta(m.ior, lambda));
  }
  // Scene::build: eta must be finite and > 1 over 360-830 nm. `where` (e.g.
  // "scene: material 3") prefixes the message, which names the material.
  static void validate(const DielectricMaterial& m, std::string_view where) {
    try {
      m.validate();
    } catch (const Error& e) {
      throw Error(std::string(where) + ": " + e.what());
    }
  }
  // Dispersion cannot be rendered in RGB (one eta for all three channels).
  static bool needs_spectral(const DielectricMaterial& m) { return m.ior.is_dispersive(); }
};

}  // namespace prism
