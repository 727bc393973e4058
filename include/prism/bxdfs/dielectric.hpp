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
//   wi), so MIS sees one density. Single scattering by default: a rough
//   interface loses the energy of light that would bounce between
//   microfacets; enable_multiple_scattering() (DielectricMaterial::
//   multiple_scattering) adds Kulla and Conty's compensation lobe
//   (DielectricMultipleScattering below).
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
#include <chrono>
#include <cmath>
#include <optional>
#include <sstream>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>
#include "prism/bxdfs/bxdf.hpp"
#include "prism/bxdfs/hooks.hpp"
#include "prism/bxdfs/microfacet.hpp"
#include "prism/bxdfs/volume.hpp"
#include "prism/geometry/interaction.hpp"
#include "prism/sampling/warps.hpp"
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

// The single-scattering directional albedo E (reflection + transmission, in
// importance transport: the fraction of the energy arriving along wo that
// leaves after one microfacet event) of the rough dielectric on the isotropic
// Trowbridge–Reitz distribution, tabulated once (on first use, thread-safe)
// for Kulla and Conty's energy compensation (DielectricBxDF's
// enable_multiple_scattering(); docs/microfacets.md).
// Axes: mu = |cos theta_o| uniform on [0, 1]; alpha = t^2 and the IOR by
// x = (eta - 1) / (eta + 1) = x_max t^2 (eta from 1 to 4; F0 = x^2), t
// uniform on [0, 1], denser where E changes fastest (small alpha, eta near
// 1). Two sides: 0, light arriving from the side where the relative IOR is
// eta >= 1 (entering the denser medium); 1, from the other side (1 / eta,
// with total internal reflection). Each entry is a deterministic quadrature
// over the visible normals of R G / G1 (reflection) plus T G / G1
// (refraction): a Fibonacci lattice of 377 points on the quintic warp
// MicrofacetAlbedoTable uses (the integrand jumps along curves, where TIR
// starts and where a direction crosses the horizon: there a lattice's error
// is far smaller than a grid's of as many points; docs/microfacets.md).
// E_avg = 2 int E mu dmu is the exact integral of the piecewise-linear E(mu),
// so the compensated lobe's albedo is 1 for the tabulated E exactly.
class DielectricAlbedoTable {
 public:
  // Chosen by measuring against a 75025-point quadrature at off-grid points
  // (tests/bxdfs/ms_dielectric_test.cpp prints the error; docs/microfacets.md).
  static constexpr int default_n_mu = 32, default_n_alpha = 16, default_n_eta = 8;
  static constexpr long default_points = 377;
  static constexpr double x_max = 0.6;  // eta = 4

  DielectricAlbedoTable(int n_mu, int n_alpha, int n_eta, long points)
      : m_nmu(n_mu),
        m_na(n_alpha),
        m_ne(n_eta),
        m_E(size_t(2 * n_eta * n_alpha * n_mu)),
        m_avg(size_t(2 * n_eta * n_alpha)),
        m_favg(size_t(n_eta)) {
    auto t0 = std::chrono::steady_clock::now();
    // F_avg entering (no total internal reflection: a smooth integrand).
    for (int e = 0; e < m_ne; ++e) {
      Float eta = Float(eta_at(e));
      m_favg[size_t(e)] = cosine_weighted_average([&](Float mu) { return fresnel_dielectric(mu, eta); });
    }
    for (int side = 0; side < 2; ++side)
      for (int e = 0; e < m_ne; ++e)
        for (int a = 0; a < m_na; ++a) {
          double avg = 0;
          for (int m = 0; m < m_nmu; ++m) {
            m_E[index(side, e, a, m)] = Float(albedo(side, grid(m, m_nmu), sqr(grid(a, m_na)), eta_at(e), points));
            if (m > 0) {
              double m0 = grid(m - 1, m_nmu), m1 = grid(m, m_nmu);
              avg += (m1 - m0) / 6 * (double(m_E[index(side, e, a, m - 1)]) * (2 * m0 + m1) +
                                      double(m_E[index(side, e, a, m)]) * (m0 + 2 * m1));
            }
          }
          m_avg[size_t((side * m_ne + e) * m_na + a)] = Float(std::min(1.0, 2 * avg));
        }
    m_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }

  static const DielectricAlbedoTable& get() {
    static const DielectricAlbedoTable table(default_n_mu, default_n_alpha, default_n_eta, default_points);
    return table;
  }

  // A position along the alpha or eta axis: the lower grid index and the
  // fraction towards the next.
  struct Cell {
    int i = 0;
    Float f = 0;
  };
  Cell alpha_cell(Float alpha) const { return cell(std::sqrt(std::clamp(alpha, Float(0), Float(1))), m_na); }
  // eta >= 1 (clamped into [1, 4]).
  Cell eta_cell(Float eta) const {
    double x = (double(std::max(eta, Float(1))) - 1) / (double(std::max(eta, Float(1))) + 1);
    return cell(Float(std::sqrt(x / x_max)), m_ne);
  }
  // E at mu for a (alpha, eta) position: linear in each axis.
  Float E(int side, Float mu, Cell a, Cell e) const {
    Cell m = cell(mu, m_nmu);
    auto at = [&](int ei, int ai) {
      return m_E[index(side, ei, ai, m.i)] * (1 - m.f) + m_E[index(side, ei, ai, m.i + 1)] * m.f;
    };
    return lerp2(at, a, e);
  }
  // The cosine-weighted mean Fresnel reflectance entering (side 0).
  Float F_avg(Cell e) const { return m_favg[size_t(e.i)] * (1 - e.f) + m_favg[size_t(e.i + 1)] * e.f; }
  Float E_avg(int side, Cell a, Cell e) const {
    auto at = [&](int ei, int ai) { return m_avg[size_t((side * m_ne + ei) * m_na + ai)]; };
    return lerp2(at, a, e);
  }
  // Convenience for tests: E at (mu, alpha, eta).
  Float E(int side, Float mu, Float alpha, Float eta) const { return E(side, mu, alpha_cell(alpha), eta_cell(eta)); }
  double build_seconds() const { return m_seconds; }
  int entries() const { return int(m_E.size()); }

  // The quadrature itself (a Fibonacci lattice of at least `points` visible
  // normals), for the table and for the tests' high-resolution reference.
  // side as above; eta >= 1.
  static double albedo(int side, double mu, double alpha, double eta, long points) {
    TrowbridgeReitz d(std::max(Float(alpha), TrowbridgeReitz::smooth_alpha),
                      std::max(Float(alpha), TrowbridgeReitz::smooth_alpha));
    mu = std::max(mu, 1e-8);  // mu = 0: the grazing limit
    Float s = side == 0 ? 1.0f : -1.0f;
    Vector3f wo{Float(std::sqrt(std::max(0.0, 1 - mu * mu))), 0, s * Float(mu)};
    const double g1 = d.G1(wo);
    // The Fibonacci lattice (i / F_k, i F_(k-1) / F_k mod 1), F_k the
    // smallest Fibonacci number >= points.
    long n = 1, g = 1;
    while (n < points) {
      long next = n + g;
      g = n;
      n = next;
    }
    double sum = 0;
    for (long i = 0; i < n; ++i) {
      auto [ux, wx] = warp((double(i) + 0.5) / double(n));
      auto [uy, wy] = warp((double((i * g) % n) + 0.5) / double(n));
      Vector3f wm = d.sample_wm(wo, {Float(ux), Float(uy)});
      double R = fresnel_dielectric(dot(wo, wm), Float(eta)), v = 0;
      Vector3f wr = reflect(wo, wm);
      if (wr.z * wo.z > 0) v += R * double(d.G(wo, wr));
      if (R < 1)
        if (auto t = refract_dielectric(wo, wm, Float(eta)); t && t->wt.z * wo.z < 0)
          v += (1 - R) * double(d.G(wo, t->wt));
      sum += wx * wy * v / g1;
    }
    return std::clamp(sum / double(n), 0.0, 1.0);
  }

 private:
  static double grid(int i, int n) { return double(i) / double(n - 1); }
  double eta_at(int e) const {
    double x = x_max * sqr(grid(e, m_ne));
    return (1 + x) / (1 - x);
  }
  static std::pair<double, double> warp(double t) {
    return {t * t * t * (10 - 15 * t + 6 * t * t), 30 * t * t * (1 - t) * (1 - t)};
  }
  static Cell cell(Float x, int n) {
    Float t = std::clamp(x, Float(0), Float(1)) * Float(n - 1);
    int i0 = std::min(int(t), n - 2);
    return {i0, t - Float(i0)};
  }
  size_t index(int side, int e, int a, int m) const { return size_t(((side * m_ne + e) * m_na + a) * m_nmu + m); }
  template <class At>
  static Float lerp2(At&& at, Cell a, Cell e) {
    Float lo = at(e.i, a.i) * (1 - a.f) + at(e.i, a.i + 1) * a.f;
    Float hi = at(e.i + 1, a.i) * (1 - a.f) + at(e.i + 1, a.i + 1) * a.f;
    return lo * (1 - e.f) + hi * e.f;
  }

  int m_nmu, m_na, m_ne;
  std::vector<Float> m_E, m_avg, m_favg;
  double m_seconds = 0;
};

// The compensation is left off where the cosine-weighted mean loss 1 - E_avg
// is below this, on either side (alpha below ~0.02): the loss is then
// confined to mu within ~alpha of grazing, where the table's first mu
// interval spreads it, and the lobe's peak (1 - E(0)) / (1 - E_avg) would
// make sample weights of hundreds for a gain under 0.1%.
inline constexpr Float ms_min_average_loss = 1e-3f;

// Kulla and Conty's compensation of one rough dielectric interface: its
// constants, made from the tables (DielectricAlbedoTable holds E, E_avg and
// F_avg) whenever DielectricBxDF needs them. With L_s(mu) = 1 -
// E_s(mu) the energy side s loses at mu, the added lobe is, in importance
// transport (the radiance-transport transmission is divided by eta'^2, as
// the single-scattering one),
//   same side s:        (1 - t_s) L_s(mu_o) L_s(mu_i) / (pi (1 - E_avg,s)),
//   from s to side s':   t_s      L_s(mu_o) L_s'(mu_i) / (pi (1 - E_avg,s')),
// whose albedo from side s is L_s(mu_o) (the cosine-weighted integral of
// L_s' is pi (1 - E_avg,s')): each side's sum is 1 for the tabulated E.
// t_s is the transmitted share of the lost energy. Reciprocity, f_imp(0 ->
// 1) = eta^2 f_imp(1 -> 0) (side 0 sees eta >= 1), fixes their ratio:
//   t_0 (1 - E_avg,0) = eta^2 t_1 (1 - E_avg,1).
// t_0 = 1 - F_avg(eta), the cosine-weighted mean transmittance entering
// the denser side (8-point Gauss–Legendre at the table's eta grid,
// interpolated; so that without a difference between the two sides'
// losses, t_1 = 1 - F_avg(1 / eta), the identity of a smooth interface);
// if that made t_1 > 1, t_1 = 1 and t_0 follows from the ratio.
struct DielectricMultipleScattering {
  DielectricAlbedoTable::Cell a, e;
  Float t[2] = {0, 0}, inv_norm[2] = {0, 0};  // inv_norm = 1 / (pi (1 - E_avg))
  bool active = false;
  bool swap = false;  // eta < 1: the outside (+z) is side 1

  static DielectricMultipleScattering make(const TrowbridgeReitz& d, Float eta) {
    DielectricMultipleScattering ms;
    if (d.effectively_smooth() || eta == 1 || !(eta > 0) || !std::isfinite(eta)) return ms;
    ms.swap = eta < 1;
    Float e = ms.swap ? 1 / eta : eta;
    const auto& table = DielectricAlbedoTable::get();
    ms.a = table.alpha_cell(std::min(Float(1), std::sqrt(d.alpha_x() * d.alpha_y())));
    ms.e = table.eta_cell(e);
    Float e_avg[2];
    for (int s = 0; s < 2; ++s) {
      e_avg[s] = table.E_avg(s, ms.a, ms.e);
      if (!(1 - e_avg[s] >= ms_min_average_loss)) return ms;
      ms.inv_norm[s] = inv_pi / (1 - e_avg[s]);
    }
    double f_avg = table.F_avg(ms.e);
    double ratio = double(1 - e_avg[0]) / (double(e) * e * (1 - e_avg[1]));  // t_1 / t_0
    double t0 = std::clamp(1 - f_avg, 0.0, 1.0), t1 = t0 * ratio;
    if (t1 > 1) {
      t1 = 1;
      t0 = 1 / ratio;
    }
    ms.t[0] = Float(t0);
    ms.t[1] = Float(t1);
    ms.active = true;
    return ms;
  }
  int side(const Vector3f& w) const { return (w.z > 0) != swap ? 0 : 1; }
  Float loss(int s, Float mu) const {
    return std::max(Float(0), 1 - DielectricAlbedoTable::get().E(s, std::min(mu, Float(1)), a, e));
  }
  // The lobe at (wo, wi) in importance transport (neither may be grazing).
  Float eval(const Vector3f& wo, const Vector3f& wi) const {
    int so = side(wo), si = side(wi);
    Float k = so == si ? 1 - t[so] : t[so];
    return k * loss(so, abs_cos_theta(wo)) * loss(si, abs_cos_theta(wi)) * inv_norm[si];
  }
  // The probability of sampling the lobe from wo: its share of the albedo,
  // L(mu_o), at most 0.9.
  Float probability(const Vector3f& wo) const {
    return active ? std::min(Float(0.9), loss(side(wo), abs_cos_theta(wo))) : Float(0);
  }
  // The share of the lobe's samples that stay on wo's side.
  Float reflect_share(const Vector3f& wo) const { return 1 - t[side(wo)]; }
};

template <class S>
class DielectricBxDF {
 public:
  DielectricBxDF() = default;
  explicit DielectricBxDF(Float eta) : m_eta(eta) {}
  DielectricBxDF(Float eta, const TrowbridgeReitz& distrib) : m_eta(eta), m_distrib(distrib) {}

  // Specular lobes when the microfacets are effectively smooth, and when
  // eta = 1 (light passes straight through; no half vector exists).
  bool is_smooth() const { return m_eta == 1 || m_distrib.effectively_smooth(); }

  // Adds Kulla and Conty's compensation lobe (DielectricMultipleScattering):
  // a rough interface then scatters, reflected plus transmitted, the energy a
  // single microfacet event loses, from either side. Smooth interfaces (and
  // eta = 1) are unchanged.
  // Only a flag is kept: the lobe's constants are recomputed from the tables
  // where they are needed (a few lookups), so that the BxDF, and every BSDF
  // variant holding one, stays as small as without the switch.
  void enable_multiple_scattering() { m_ms = DielectricMultipleScattering::make(m_distrib, m_eta).active; }
  bool multiple_scattering() const { return m_ms; }

  S eval(Vector3f wo, Vector3f wi, TransportMode mode) const {
    if (is_smooth()) return S{};
    if (m_ms) {
      Float f;
      eval_pdf_ms(ms_state(), wo, wi, mode, &f, nullptr);
      return S(f);
    }
    auto r = rough(wo, wi, mode);
    return r ? S(r->f) : S{};
  }
  Float pdf(Vector3f wo, Vector3f wi, TransportMode mode) const {
    if (is_smooth()) return 0;
    if (m_ms) {
      Float p;
      eval_pdf_ms(ms_state(), wo, wi, mode, nullptr, &p);
      return p;
    }
    auto r = rough(wo, wi, mode);
    return r ? r->pdf : 0;
  }

  // Smooth: uc < R picks the reflection, otherwise the refraction (u is
  // unused). Rough: a visible normal wm from u, then uc < R(wo.wm) reflects
  // about wm, otherwise refracts through it.
  std::optional<BSDFSample<S>> sample(Vector3f wo, Float uc, Point2f u, TransportMode mode) const {
    if (wo.z == 0) return std::nullopt;
    if (is_smooth()) return sample_smooth(wo, uc, mode);
    if (m_ms) return sample_ms(wo, uc, u, mode);
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

  DielectricMultipleScattering ms_state() const { return DielectricMultipleScattering::make(m_distrib, m_eta); }
  // With the compensation: f (if not null), the single-scattering lobes
  // plus the added one in the given transport mode, and pdf (if not null),
  // the mixture's density; one evaluation of the rough lobes serves both.
  void eval_pdf_ms(const DielectricMultipleScattering& ms, const Vector3f& wo, const Vector3f& wi,
                   TransportMode mode, Float* f, Float* pdf) const {
    auto r = rough(wo, wi, mode);
    if (f) *f = r ? r->f : 0;
    if (pdf) *pdf = 0;
    if (wo.z == 0 || wi.z == 0) return;
    if (f) {
      Float c = ms.eval(wo, wi);
      if (mode == TransportMode::radiance && !same_hemisphere(wo, wi)) c /= sqr(wo.z > 0 ? m_eta : 1 / m_eta);
      *f += c;
    }
    if (pdf) {
      Float pm = ms.probability(wo), share = ms.reflect_share(wo);
      *pdf = (1 - pm) * (r ? r->pdf : 0) +
             pm * (same_hemisphere(wo, wi) ? share : 1 - share) * abs_cos_theta(wi) * inv_pi;
    }
  }
  // With the compensation: uc < its probability picks it (then uc, rescaled,
  // picks the side and a cosine-weighted direction there); otherwise uc,
  // rescaled, drives the single-scattering sampler. Either way the sample
  // carries eval() and pdf() of the whole mixture at its direction.
  std::optional<BSDFSample<S>> sample_ms(const Vector3f& wo, Float uc, Point2f u, TransportMode mode) const {
    const DielectricMultipleScattering ms = ms_state();
    Float pm = ms.probability(wo);
    Vector3f wi;
    if (uc < pm) {
      Float share = ms.reflect_share(wo);
      wi = sample_cosine_hemisphere(u);
      bool stay = uc < pm * share;
      if ((wo.z > 0) != stay) wi.z = -wi.z;
    } else {
      Float u2 = std::min((uc - pm) / (1 - pm), one_minus_epsilon);
      Vector3f wm = m_distrib.sample_wm(wo, u);
      if (u2 < fresnel_dielectric(dot(wo, wm), m_eta)) {
        wi = reflect(wo, wm);
        if (!same_hemisphere(wo, wi)) return std::nullopt;
      } else {
        auto t = refract_dielectric(wo, wm, m_eta);
        if (!t || t->wt.z * wo.z >= 0) return std::nullopt;
        wi = t->wt;
      }
    }
    if (wi.z == 0) return std::nullopt;
    Float fv, p;
    eval_pdf_ms(ms, wo, wi, mode, &fv, &p);
    S f(fv);
    if (!(p > 0) || !(f[0] > 0)) return std::nullopt;
    bool refl = same_hemisphere(wo, wi);
    return BSDFSample<S>{f, wi, p, refl ? BxDFFlags::glossy_reflection : BxDFFlags::glossy_transmission,
                         refl ? Float(1) : (wo.z > 0 ? m_eta : 1 / m_eta)};
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
  bool m_ms = false;  // enable_multiple_scattering()
};

// A dielectric material: an IOR law, a name (for error messages) and a
// microfacet roughness (alpha; 0, the default, is the smooth interface).
// Call validate() when the scene is built.
struct DielectricMaterial {
  IOR ior{1.5f};
  std::string name = "dielectric";
  MicrofacetRoughness roughness{};
  VolumeAbsorption volume{};  // absorption inside (closed meshes), none by default
  // Kulla-Conty energy compensation of a rough interface (dielectric.hpp,
  // DielectricMultipleScattering); off by default.
  bool multiple_scattering = false;

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
  static constexpr BxDFHook hooks = BxDFHook::validate | BxDFHook::needs_spectral | BxDFHook::dispersive |
                                    BxDFHook::has_specular | BxDFHook::volume;
  using material_type = DielectricMaterial;
  // W is the path's wavelengths type, const or not. Spectral and dispersive:
  // terminates the secondary wavelengths (non-const W) and uses eta at the
  // hero; otherwise eta at the d line (587.56 nm). See path_eta().
  template <class W>
  static DielectricBxDF<S> make(const DielectricMaterial& m, const SurfaceInteraction&, W& lambda) {
    DielectricBxDF<S> b(path_eta(m.ior, lambda), TrowbridgeReitz(m.roughness));
    if (m.multiple_scattering) b.enable_multiple_scattering();
    return b;
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
  static bool dispersive(const DielectricMaterial& m) { return m.ior.is_dispersive(); }
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
  static constexpr BxDFHook hooks = BxDFHook::validate | BxDFHook::needs_spectral | BxDFHook::dispersive;
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
  static bool dispersive(const ThinDielectricMaterial& m) { return m.ior.is_dispersive(); }
};

}  // namespace prism
