// prism/bxdfs/ms_compensation.hpp — energy compensation for the light a
// single-scattering microfacet lobe loses (Kulla and Conty 2017, "Revisiting
// Physically Based Shading at Imageworks").
//
// A Torrance–Sparrow lobe counts only light that leaves after one bounce on
// the microsurface; at roughness 1 a white (F = 1) conductor reflects only
// ~60-90% of the light (docs/microfacets.md). Kulla and Conty add a lobe
//   f_ms(wo, wi) = (1 - E(mu_o)) (1 - E(mu_i)) / (pi (1 - E_avg)),
// where E(mu) is the single-scattering lobe's directional albedo for F = 1 and
// E_avg = 2 int E(mu) mu dmu its cosine-weighted average: with F = 1 the sum
// reflects exactly 1 at every angle. With a Fresnel term the lobe is scaled by
//   F_ms = F_avg^2 E_avg / (1 - F_avg (1 - E_avg)),
// F_avg = 2 int F(mu) mu dmu, the light that survives the extra bounces.
//
// E is tabulated once (on first use, thread-safe) for the isotropic
// Trowbridge–Reitz distribution on a 32 x 32 grid of (alpha, mu), by a
// deterministic 64 x 64 quadrature of G2 / G1 over the visible normals (about
// 0.2 s, once); an anisotropic lobe uses alpha = sqrt(alpha_x alpha_y).
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <utility>
#include "prism/bxdfs/microfacet.hpp"

namespace prism {

namespace detail {
// The cell of a uniform grid of n nodes over [0, 1] that holds x (clamped),
// and x's fraction of the way across it: for bilinear lookups in tables.
struct GridCell {
  int i0, i1;
  Float f;
};
inline GridCell unit_grid_cell(Float x, int n) {
  Float t = std::clamp(x, Float(0), Float(1)) * Float(n - 1);
  int i0 = std::min(int(t), n - 2);
  return {i0, i0 + 1, t - Float(i0)};
}
}  // namespace detail

class MicrofacetAlbedoTable {
 public:
  static constexpr int n = 32;

  // The single-scattering albedo E(mu, alpha) for F = 1, bilinear in the grid.
  Float E(Float mu, Float alpha) const { return bilinear(m_E, mu, alpha); }
  Float E_avg(Float alpha) const { return linear(m_avg, alpha); }
  // The part of E weighted by 1 - s(c), Schlick's s(c) = (1 - c)^5 at
  // c = wo.wm: a Schlick Fresnel F = F0 (1 - s) + F90 s gives the albedo
  // F0 A + F90 (E - A) (the metal-rough material's layer, metal_rough.hpp).
  Float A(Float mu, Float alpha) const { return bilinear(m_A, mu, alpha); }
  Float A_avg(Float alpha) const { return linear(m_A_avg, alpha); }

  static const MicrofacetAlbedoTable& get() {
    static const MicrofacetAlbedoTable table;  // C++ guarantees one thread builds it
    return table;
  }

 private:
  MicrofacetAlbedoTable() {
    const int strata = 64;
    for (int a = 0; a < n; ++a) {
      Float alpha = std::max(grid(a), TrowbridgeReitz::smooth_alpha);
      TrowbridgeReitz d(alpha, alpha);
      for (int m = 0; m < n; ++m) {
        Float mu = std::max(grid(m), Float(1e-4));
        Vector3f wo{std::sqrt(std::max(Float(0), 1 - mu * mu)), 0, mu};
        // The integrand steps to 0 where the reflected direction falls below
        // the horizon, at the far tail of the visible normals (u within
        // ~alpha^2 of 1): the midpoints of a quintic warp u = t^3 (10 - 15 t
        // + 6 t^2) reach within 5e-6 of either end, weighted by du/dt.
        double sum = 0, sum_a = 0;
        for (int i = 0; i < strata; ++i)
          for (int j = 0; j < strata; ++j) {
            auto [ux, wx] = warp((double(i) + 0.5) / strata);
            auto [uy, wy] = warp((double(j) + 0.5) / strata);
            Vector3f wm = d.sample_wm(wo, {Float(ux), Float(uy)});
            Vector3f wi = reflect(wo, wm);
            if (wi.z > 0) {
              double v = wx * wy * double(d.G(wo, wi)) / double(d.G1(wo));
              double c = 1 - std::clamp(double(dot(wo, wm)), 0.0, 1.0), c2 = c * c;
              sum += v;
              sum_a += v * (1 - c2 * c2 * c);
            }
          }
        m_E[a][m] = Float(std::clamp(sum / (strata * strata), 0.0, 1.0));
        m_A[a][m] = std::min(m_E[a][m], Float(std::clamp(sum_a / (strata * strata), 0.0, 1.0)));
      }
      // E_avg = 2 int_0^1 E(mu) mu dmu, exactly for the piecewise-linear E
      // the lookups interpolate (so the compensated albedo is 1 for the
      // tabulated E): h/6 (E0 (2 mu0 + mu1) + E1 (mu0 + 2 mu1)) per interval.
      m_avg[a] = average(m_E[a]);
      m_A_avg[a] = std::min(m_avg[a], average(m_A[a]));
    }
  }
  static Float average(const std::array<Float, n>& e) {
    double avg = 0;
    for (int m = 0; m + 1 < n; ++m) {
      double mu0 = grid(m), mu1 = grid(m + 1);
      avg += (mu1 - mu0) / 6 * (double(e[m]) * (2 * mu0 + mu1) + double(e[m + 1]) * (mu0 + 2 * mu1));
    }
    return Float(std::min(1.0, 2 * avg));
  }
  static Float grid(int i) { return Float(i) / Float(n - 1); }
  static Float bilinear(const std::array<std::array<Float, n>, n>& t, Float mu, Float alpha) {
    auto [a0, a1, fa] = cell(alpha);
    auto [m0, m1, fm] = cell(mu);
    Float e0 = t[a0][m0] * (1 - fm) + t[a0][m1] * fm;
    Float e1 = t[a1][m0] * (1 - fm) + t[a1][m1] * fm;
    return e0 * (1 - fa) + e1 * fa;
  }
  static Float linear(const std::array<Float, n>& t, Float alpha) {
    auto [a0, a1, fa] = cell(alpha);
    return t[a0] * (1 - fa) + t[a1] * fa;
  }
  // The quintic warp of [0, 1] and its derivative.
  static std::pair<double, double> warp(double t) {
    return {t * t * t * (10 - 15 * t + 6 * t * t), 30 * t * t * (1 - t) * (1 - t)};
  }
  static detail::GridCell cell(Float x) { return detail::unit_grid_cell(x, n); }

  std::array<std::array<Float, n>, n> m_E{}, m_A{};
  std::array<Float, n> m_avg{}, m_A_avg{};
};

// The compensation lobe of one BxDF instance: the white lobe's factors and
// the spectral scale F_ms.
template <class S>
struct MultipleScattering {
  S scale{};         // F_ms per channel / wavelength
  Float alpha = 0;   // the isotropic alpha the table is read at
  Float e_avg = 1;   // E_avg(alpha)
  bool active = false;

  // F_avg = 2 int F(mu) mu dmu by 8-point Gauss–Legendre on [0, 1]
  // (cosine_weighted_average).
  template <class Fresnel>
  static MultipleScattering make(const TrowbridgeReitz& d, Fresnel&& fresnel) {
    MultipleScattering ms;
    if (d.effectively_smooth()) return ms;
    ms.alpha = std::min(Float(1), std::sqrt(d.alpha_x() * d.alpha_y()));
    ms.e_avg = MicrofacetAlbedoTable::get().E_avg(ms.alpha);
    if (!(ms.e_avg < 1)) return ms;
    ms.set_scale(cosine_weighted_average(fresnel));
    return ms;
  }
  // The same with F_avg given per channel (a Schlick Fresnel's closed form
  // F0 + (F90 - F0) / 21, say).
  static MultipleScattering from_f_avg(const TrowbridgeReitz& d, const S& f_avg) {
    MultipleScattering ms;
    if (d.effectively_smooth()) return ms;
    ms.alpha = std::min(Float(1), std::sqrt(d.alpha_x() * d.alpha_y()));
    ms.e_avg = MicrofacetAlbedoTable::get().E_avg(ms.alpha);
    if (!(ms.e_avg < 1)) return ms;
    ms.set_scale(f_avg);
    return ms;
  }
  // F_ms = F_avg^2 E_avg / (1 - F_avg (1 - E_avg)) for one F_avg in [0, 1].
  static Float fms(Float f_avg, Float e_avg) {
    Float fa = std::clamp(f_avg, Float(0), Float(1));
    return fa * fa * e_avg / (1 - fa * (1 - e_avg));
  }
  void set_scale(const S& f_avg) {
    for (int c = 0; c < S::size; ++c) scale[c] = fms(f_avg[c], e_avg);
    active = true;
  }
  // The white lobe (without scale) at cosines mu_o, mu_i.
  Float white(Float mu_o, Float mu_i) const {
    const auto& t = MicrofacetAlbedoTable::get();
    return (1 - t.E(mu_o, alpha)) * (1 - t.E(mu_i, alpha)) / (pi * (1 - e_avg));
  }
  // The probability of sampling the compensation lobe (cosine-weighted) for
  // wo: its share of the reflected energy, averaged over channels.
  Float probability(Float mu_o, const S& f_ss_albedo_hint) const {
    if (!active) return 0;
    Float e = MicrofacetAlbedoTable::get().E(mu_o, alpha);
    Float ms = 0, ss = 0;
    for (int c = 0; c < S::size; ++c) {
      ms += scale[c] * (1 - e);
      ss += f_ss_albedo_hint[c] * e;
    }
    return ms + ss > 0 ? std::clamp(ms / (ms + ss), Float(0), Float(0.9)) : 0;
  }
};

}  // namespace prism
