// prism/bxdfs/sheen.hpp — the "Charlie" sheen lobe of KHR_materials_sheen
// (Estevez and Kulla 2017, "Production Friendly Microfacet Sheen BRDF"):
// the retro- and grazing reflection of a layer of fibres (velvet, cloth,
// dust), a microfacet lobe with the inverted-Gaussian-like distribution
//   D(h) = (2 + 1/alpha) sin(theta_h)^(1/alpha) / (2 pi),   alpha = roughness^2,
// which is normalised (integral of D cos(theta_h) over the hemisphere = 1)
// and puts the fibres' normals near the horizon; and the paper's fitted
// shadowing, with Lambda(mu) = exp(L(mu)) for mu < 1/2 and exp(2 L(1/2) -
// L(1 - mu)) above,
//   L(x) = a / (1 + b x^c) + d x + e,  (a, b, c, d, e) = mix(p1, p0, (1 - alpha)^2),
//   p0 = (25.3245, 3.32435, 0.16801, -1.27393, -4.85967)   (alpha = 0),
//   p1 = (21.5473, 3.82987, 0.19823, -1.97760, -4.32054)   (alpha = 1),
// giving the height-correlated visibility the extension writes
//   V(mu_o, mu_i) = 1 / ((1 + Lambda(mu_o) + Lambda(mu_i)) 4 mu_o mu_i)
// and the lobe f = sheen_colour D(h) V (without the cosine). The paper's
// "terminator softening" of Lambda is left out, as in the extension.
//
// The extension layers the sheen over the material and scales the material
// by what the sheen does not reflect, reciprocally:
//   sheen_layer(wo, wi) = f_sheen + material * min(1 - c E(mu_o), 1 - c E(mu_i)),
// c the sheen colour's largest channel and E(mu) the lobe's directional
// albedo for a white sheen (SheenAlbedoTable). The sheen reflects c' E(mu_o)
// <= c E(mu_o) (c' its channel) and the material at most 1 - c E(mu_o), so
// the layer never scatters more than 1 when the material does not.
//
// Roughness below sheen_min_roughness (0.05, alpha = 0.0025) is clamped to
// it: at 0 the distribution is a delta on the horizon and the lobe vanishes,
// while the extension's default roughness is 0 (a colour with roughness 0 is
// rendered as the sharpest sheen prism models).
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <vector>
#include "prism/bxdfs/ms_compensation.hpp"
#include "prism/math/float.hpp"
#include "prism/math/vector.hpp"

namespace prism {

inline constexpr Float sheen_min_roughness = Float(0.05);
inline constexpr Float sheen_min_cos = Float(1e-3);

// The Charlie distribution D(h) for cos(theta_h) = cos_h and alpha =
// roughness^2 (>= sheen_min_roughness^2).
inline Float charlie_D(Float alpha, Float cos_h) {
  const Float inv = 1 / alpha;
  const Float sin2 = std::max(Float(0), 1 - cos_h * cos_h);
  return (2 + inv) * std::pow(sin2, Float(0.5) * inv) * Float(inv_2pi);
}

// Estevez and Kulla's Lambda(mu) for the Charlie distribution (fitted).
inline Float charlie_lambda(Float alpha, Float mu) {
  const Float t = (1 - alpha) * (1 - alpha);
  auto mix = [&](Float at1, Float at0) { return at1 * (1 - t) + at0 * t; };
  const Float a = mix(21.5473f, 25.3245f), b = mix(3.82987f, 3.32435f), c = mix(0.19823f, 0.16801f),
              d = mix(-1.97760f, -1.27393f), e = mix(-4.32054f, -4.85967f);
  auto L = [&](Float x) { return a / (1 + b * std::pow(x, c)) + d * x + e; };
  mu = std::clamp(mu, Float(0), Float(1));
  return mu < Float(0.5) ? std::exp(L(mu)) : std::exp(2 * L(Float(0.5)) - L(1 - mu));
}

// The white sheen lobe D V at (wo, wi), both in the upper hemisphere of the
// local frame: 0 elsewhere. The cosines in V are taken as at least
// sheen_min_cos (1e-3, 89.94 degrees): the fitted Lambda grows only like
// exp(a + e) towards the horizon, so mu Lambda(mu) -> 0 and the lobe's
// albedo would diverge as mu -> 0 (it is 1.5 at mu = 1e-6 for roughness 1,
// 5.3 for 0.05). Below 1e-3 the lobe keeps its value at 1e-3.
inline Float charlie_sheen(Float alpha, const Vector3f& wo, const Vector3f& wi) {
  if (!(wo.z > 0) || !(wi.z > 0)) return 0;
  Vector3f h = wo + wi;
  const Float l2 = length_squared(h);
  if (!(l2 > 0)) return 0;
  const Float cos_h = h.z / std::sqrt(l2);
  const Float mo = std::max(wo.z, sheen_min_cos), mi = std::max(wi.z, sheen_min_cos);
  const Float v = 1 / ((1 + charlie_lambda(alpha, mo) + charlie_lambda(alpha, mi)) * 4 * mo * mi);
  return charlie_D(alpha, cos_h) * v;
}

// E(mu, r): the directional albedo of the white Charlie lobe, integral of
// D V cos(theta_i) over the hemisphere, at mu = cos(theta_o) and roughness r
// (alpha = r^2), on a 32 x 32 grid of sqrt(mu) in [0, 1] and r in
// [sheen_min_roughness, 1], bilinear in between. Built once on first use
// (thread-safe) by a deterministic midpoint quadrature, 96 steps in mu_i
// (with mu_i = t^2 towards the horizon, where the lobe lives) by 32 in phi
// over the half circle (the lobe is symmetric about wo's plane): ~0.1 s.
// E exceeds 1 at grazing angles for small roughness (up to 4.05 at r =
// 0.05, 2.1 at 0.1, 1.2 at 0.2: the fitted shadowing is not exact there);
// MetalRoughBxDF divides the lobe by max(1, E(mu_o), E(mu_i)). The
// envelope lies at most 0.04 above E where E < 1 and 7% above where E >= 1
// (tests/bxdfs/metal_rough_test.cpp checks 0.05 and 10%).
class SheenAlbedoTable {
 public:
  static constexpr int n = 32;
  Float E(Float mu, Float roughness) const {
    auto [r0, r1, fr] = cell((roughness - sheen_min_roughness) / (1 - sheen_min_roughness));
    auto [m0, m1, fm] = cell(std::sqrt(std::max(mu, Float(0))));
    Float e0 = m_E[r0][m0] * (1 - fm) + m_E[r0][m1] * fm;
    Float e1 = m_E[r1][m0] * (1 - fm) + m_E[r1][m1] * fm;
    return e0 * (1 - fr) + e1 * fr;
  }
  static const SheenAlbedoTable& get() {
    static const SheenAlbedoTable table;  // C++ guarantees one thread builds it
    return table;
  }
  // The grid's mu_m and r_k: uniform in sqrt(mu), which resolves the bump of
  // E near the horizon (mu ~ 0.01).
  static Float mu_grid(int m) { return sqr(Float(m) / Float(n - 1)); }
  static Float roughness_grid(int k) { return sheen_min_roughness + (1 - sheen_min_roughness) * Float(k) / Float(n - 1); }
  // The quadrature the table holds at one (mu, r), exposed for tests.
  static double albedo(Float mu, Float roughness) {
    constexpr int n_mu = 96, n_phi = 32;
    constexpr double pi = 3.14159265358979323846;
    const Float r = std::max(roughness, sheen_min_roughness);
    const Float alpha = r * r;
    mu = std::clamp(mu, Float(1e-4), Float(1));
    const Vector3f wo(std::sqrt(std::max(Float(0), 1 - mu * mu)), 0, mu);
    const double mo = std::max(mu, sheen_min_cos), lambda_o = charlie_lambda(alpha, Float(mo));
    std::array<double, n_phi> cos_phi{}, sin_phi{};
    for (int j = 0; j < n_phi; ++j) {
      cos_phi[size_t(j)] = std::cos(pi * (j + 0.5) / n_phi);
      sin_phi[size_t(j)] = std::sin(pi * (j + 0.5) / n_phi);
    }
    double sum = 0;
    for (int i = 0; i < n_mu; ++i) {
      const double t = (i + 0.5) / n_mu, mi = t * t;  // d mu_i = 2 t dt
      const double si = std::sqrt(std::max(0.0, 1 - mi * mi));
      const double mc = std::max(mi, double(sheen_min_cos));
      const double v = 1 / ((1 + lambda_o + double(charlie_lambda(alpha, Float(mc)))) * 4 * mo * mc);
      double row = 0;
      for (int j = 0; j < n_phi; ++j) {
        const Vector3f h = wo + Vector3f(Float(si * cos_phi[size_t(j)]), Float(si * sin_phi[size_t(j)]), Float(mi));
        const Float l2 = length_squared(h);
        if (l2 > 0) row += double(charlie_D(alpha, h.z / std::sqrt(l2)));
      }
      sum += row * v * mi * 2 * t;
    }
    // Over the half circle, doubled: 2 (pi / n_phi) (1 / n_mu) per cell.
    return sum * 2 * pi / (double(n_phi) * n_mu);
  }

 private:
  // An upper envelope: E at the nodes and at the midpoints of every cell's
  // edges and centre (a grid twice as fine); each node is raised by the
  // largest amount its cells' bilinear patches fall short of those points,
  // so that the table never underestimates E by more than its quadrature
  // error where it was sampled (E appears in the energy bound: an
  // overestimate only darkens the base by c times it).
  SheenAlbedoTable() {
    constexpr int f = 2 * (n - 1) + 1;
    std::vector<double> fine(size_t(f * f));
    auto at = [&](int k, int m) -> double& { return fine[size_t(k * f + m)]; };
    for (int k = 0; k < f; ++k)
      for (int m = 0; m < f; ++m) {
        const Float x = Float(m) / Float(f - 1), r = sheen_min_roughness + (1 - sheen_min_roughness) * Float(k) / Float(f - 1);
        at(k, m) = albedo(x * x, r);
      }
    std::array<std::array<double, n - 1>, n - 1> deficit{};
    for (int k = 0; k + 1 < n; ++k)
      for (int m = 0; m + 1 < n; ++m) {
        const double c00 = at(2 * k, 2 * m), c01 = at(2 * k, 2 * m + 2), c10 = at(2 * k + 2, 2 * m),
                     c11 = at(2 * k + 2, 2 * m + 2);
        double d = 0;
        for (int a = 0; a <= 2; ++a)
          for (int b = 0; b <= 2; ++b) {
            const double u = a / 2.0, v = b / 2.0;
            const double patch = (c00 * (1 - v) + c01 * v) * (1 - u) + (c10 * (1 - v) + c11 * v) * u;
            d = std::max(d, at(2 * k + a, 2 * m + b) - patch);
          }
        deficit[size_t(k)][size_t(m)] = d;
      }
    for (int k = 0; k < n; ++k)
      for (int m = 0; m < n; ++m) {
        double raise = 0;
        for (int dk = -1; dk <= 0; ++dk)
          for (int dm = -1; dm <= 0; ++dm)
            if (k + dk >= 0 && k + dk < n - 1 && m + dm >= 0 && m + dm < n - 1)
              raise = std::max(raise, deficit[size_t(k + dk)][size_t(m + dm)]);
        m_E[size_t(k)][size_t(m)] = Float(at(2 * k, 2 * m) + raise);
      }
  }
  static detail::GridCell cell(Float x) { return detail::unit_grid_cell(x, n); }
  std::array<std::array<Float, n>, n> m_E{};
};

}  // namespace prism
