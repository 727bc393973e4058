// tests/bxdfs/bxdf_check.hpp — shared checks for the BxDF tests: chi-squared
// of sample() against pdf() on windows fitted to narrow lobes, the white
// furnace (directional albedo with its standard error), and the NaN/Inf sweep.
//
// Chi-squared on narrow lobes. A rough lobe with alpha = 0.001 is ~0.002 rad
// wide: on a whole-sphere (theta, phi) grid it falls in one cell, where the
// test has no power and the quadrature of the expected counts misses the
// peak. So each lobe is tested on a window of the usual (theta, phi) grid
// about the macro normal: theta and phi within 10 times the lobe's extent
// along each (theta clipped to the lobe's hemisphere, so the horizon, where
// the density is discontinuous, is a grid edge). Samples outside the window (the other lobe, the far tail, failed
// samples) go to chi2_test_2d's extra cell, whose expected count is n times
// (1 - the pdf's integral over the window): so the test also checks how much
// mass the sampler puts outside. The lobe's extent is how far the scattered
// direction moves when the microfacet normal
// tilts by alpha (lobe_window), so the window holds ~99% of a GGX lobe.
// The chi-squared tests print every result when PRISM_CHI2_VERBOSE is set.
#pragma once
#include <catch2/catch.hpp>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <optional>
#include <vector>
#include <prism/bxdfs/bxdf.hpp>
#include <prism/bxdfs/microfacet.hpp>
#include <prism/sampling/pcg32.hpp>
#include <prism/sampling/warps.hpp>
#include "support/chi2.hpp"

namespace bxdf_check {
using namespace prism;
constexpr double pi_d = 3.14159265358979323846;

// A unit direction at polar angle theta (degrees) and azimuth phi (rad);
// side -1 puts it below the surface.
inline Vector3f direction_at(double theta_deg, double phi = 0.7, double side = 1) {
  double t = theta_deg * pi_d / 180;
  return {Float(std::sin(t) * std::cos(phi)), Float(std::sin(t) * std::sin(phi)), Float(side * std::cos(t))};
}
inline std::array<double, 3> to_array(const Vector3f& v) { return {v.x, v.y, v.z}; }
inline Vector3f to_vec(const std::array<double, 3>& w) { return {Float(w[0]), Float(w[1]), Float(w[2])}; }
inline double angle_between(const Vector3f& a, const Vector3f& b) {
  double d = double(a.x) * b.x + double(a.y) * b.y + double(a.z) * b.z;
  double la = std::sqrt(double(a.x) * a.x + double(a.y) * a.y + double(a.z) * a.z);
  double lb = std::sqrt(double(b.x) * b.x + double(b.y) * b.y + double(b.z) * b.z);
  return std::acos(std::clamp(d / (la * lb), -1.0, 1.0));
}

// A (theta, phi) rectangle, theta from +z; phi in [p0, p1] (phi taken modulo
// 2 pi into [p0, p0 + 2 pi)).
struct Window {
  double t0 = 0, t1 = pi_d, p0 = 0, p1 = 2 * pi_d;
};
// The whole hemisphere of side (+1 above, -1 below) or the whole sphere (0),
// without the band |z| < z_min next to the horizon (see lobe_window).
inline Window hemisphere_window(int side, double z_min = 0) {
  double t = std::acos(std::clamp(z_min, 0.0, 1.0));
  if (side > 0) return {0, t, 0, 2 * pi_d};
  if (side < 0) return {pi_d - t, pi_d, 0, 2 * pi_d};
  return {0, pi_d, 0, 2 * pi_d};
}
// The cap of angular radius `radius` about c, clipped to c's hemisphere.
inline Window cap_window(const Vector3f& c, double radius) {
  double tc = std::acos(std::clamp(double(c.z), -1.0, 1.0)), pc = std::atan2(double(c.y), double(c.x));
  bool upper = c.z > 0;
  double h0 = upper ? 0 : pi_d / 2, h1 = upper ? pi_d / 2 : pi_d;
  Window w;
  w.t0 = std::max(h0, tc - radius);
  w.t1 = std::min(h1, tc + radius);
  double s = std::sin(tc);
  bool pole = upper ? tc - radius <= 0 : tc + radius >= pi_d;
  if (pole || std::sin(radius) >= s) {
    if (upper && pole) w.t0 = 0;
    if (!upper && pole) w.t1 = pi_d;
    w.p0 = pc - pi_d;
    w.p1 = pc + pi_d;
  } else {
    double dp = std::asin(std::sin(radius) / s);
    w.p0 = pc - dp;
    w.p1 = pc + dp;
  }
  return w;
}

struct Chi2Config {
  size_t n = 60000;
  int n_theta = 20, n_phi = 24;
};

// The integral of f over a rectangle by 5x5 Gauss-Legendre on 1x1 and 2x2
// sub-cells, split in four where the two differ by more than tol (an absolute
// error in probability), down to `depth` levels. Narrow lobes (a reflection
// near grazing is ~2 alpha^2 wide in phi at the horizon) need it: a fixed rule
// misses them or counts them twice.
template <class F>
double integrate_adaptive(F& f, double x0, double x1, double y0, double y1, double tol, int depth) {
  double coarse = prism_test::integrate_2d(f, x0, x1, y0, y1, 1);
  double fine = prism_test::integrate_2d(f, x0, x1, y0, y1, 2);
  if (depth == 0 || std::abs(fine - coarse) <= tol) return fine;
  double xm = (x0 + x1) / 2, ym = (y0 + y1) / 2, t = tol / 2;
  return integrate_adaptive(f, x0, xm, y0, ym, t, depth - 1) + integrate_adaptive(f, xm, x1, y0, ym, t, depth - 1) +
         integrate_adaptive(f, x0, xm, ym, y1, t, depth - 1) + integrate_adaptive(f, xm, x1, ym, y1, t, depth - 1);
}

// Chi-squared of sample() (returning an optional direction) against pdf (per
// solid angle) on a window: chi2_test_2d's procedure (tests/support/chi2.hpp)
// with the expected counts from integrate_adaptive, to 1e-7 per cell.
template <class Sample, class Pdf>
prism_test::Chi2Result chi2_window(Sample&& sample, Pdf&& pdf, const Window& w, const Chi2Config& cfg) {
  prism_test::Grid2D g{w.t0, w.t1, cfg.n_theta, w.p0, w.p1, cfg.n_phi, 0};
  auto density = [&](double theta, double phi) {
    double st = std::sin(theta);
    Vector3f v(Float(st * std::cos(phi)), Float(st * std::sin(phi)), Float(std::cos(theta)));
    return double(pdf(v)) * st;
  };
  const size_t cells = size_t(g.nx) * size_t(g.ny);
  std::vector<double> observed(cells + 1, 0.0), expected(cells + 1, 0.0);
  double integral = 0, dx = (g.x1 - g.x0) / g.nx, dy = (g.y1 - g.y0) / g.ny;
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i) {
      // 1e-7 per cell: an expected count off by n·1e-7 = 0.006, negligible against a cell's Poisson σ √(np)
      double p = integrate_adaptive(density, g.x0 + i * dx, g.x0 + (i + 1) * dx, g.y0 + j * dy, g.y0 + (j + 1) * dy,
                                    1e-7, 6);
      expected[size_t(j) * size_t(g.nx) + size_t(i)] = p * double(cfg.n);
      integral += p;
    }
  // below 1 − 1e-6 the missing mass n(1 − integral) < 0.06 counts: quadrature error, not a lobe outside the window
  expected.back() = integral > 1 - 1e-6 ? 0.0 : (1 - integral) * double(cfg.n);
  size_t outside = 0;
  for (size_t k = 0; k < cfg.n; ++k) {
    std::optional<Vector3f> v = sample();
    long c = -1;
    if (v) {
      double len = std::sqrt(double(v->x) * v->x + double(v->y) * v->y + double(v->z) * v->z);
      double theta = std::acos(std::clamp(double(v->z) / len, -1.0, 1.0)), phi = std::atan2(double(v->y), double(v->x));
      phi = w.p0 + std::fmod(std::fmod(phi - w.p0, 2 * pi_d) + 2 * pi_d, 2 * pi_d);
      c = prism_test::grid_cell(g, theta, phi);
    }
    if (c < 0) {
      ++outside;
      observed.back() += 1;
    } else {
      observed[size_t(c)] += 1;
    }
  }
  prism_test::Chi2Result r = prism_test::chi2_from_counts(observed, expected);
  r.integral = integral;
  r.outside = outside;
  return r;
}

// A window fitted to a lobe: `scatter` maps a microfacet normal to the
// scattered direction (nullopt if none); the normal is tilted by alpha_x, by
// alpha_y and by both (8 probes), and the largest changes of theta and of phi
// of the scattered direction from `centre` give the lobe's extent along each
// coordinate. The window reaches k times that (clipped to centre's
// hemisphere; all of phi when it reaches the pole or half a turn). alpha >=
// 0.2: the whole hemisphere. Both
// extents matter: near grazing incidence a reflected lobe is ~2 alpha tall in
// theta but only ~2 alpha (alpha + cos theta_o) wide in phi.
// z_min: the lobe's density is 0 for |z| < z_min and jumps there (a
// refraction: |wi.z| >= |wo.z| / eta', else the generalised half vector would
// lie below the horizon); the window stops at that edge, so that no cell
// straddles the jump.
inline Window lobe_window(const std::function<std::optional<Vector3f>(const Vector3f&)>& scatter,
                          const Vector3f& centre, double ax, double ay, double z_min = 0, double k = 10) {
  double tc = std::acos(std::clamp(double(centre.z), -1.0, 1.0)), pc = std::atan2(double(centre.y), double(centre.x));
  double st = 0, sp = 0;
  for (int i = -1; i <= 1; ++i)
    for (int j = -1; j <= 1; ++j) {
      if (i == 0 && j == 0) continue;
      Vector3f m(Float(std::tan(i * ax)), Float(std::tan(j * ay)), 1);
      auto d = scatter(normalize(m));
      if (!d || d->z * centre.z <= 0) continue;
      double t = std::acos(std::clamp(double(d->z), -1.0, 1.0)), p = std::atan2(double(d->y), double(d->x));
      double dp = std::remainder(p - pc, 2 * pi_d);
      st = std::max(st, std::abs(t - tc));
      sp = std::max(sp, std::abs(dp));
    }
  bool upper = centre.z > 0;
  // Broad lobes (and lobes whose probes all leave the hemisphere): all of it.
  if (std::max(ax, ay) >= 0.2 || st == 0) return hemisphere_window(upper ? 1 : -1, z_min);
  Window w, h = hemisphere_window(upper ? 1 : -1, z_min);
  w.t0 = std::max(h.t0, tc - k * st);
  w.t1 = std::min(h.t1, tc + k * st);
  bool pole = upper ? w.t0 <= 0 : w.t1 >= pi_d;
  if (pole || k * sp >= pi_d) {
    w.p0 = pc - pi_d;
    w.p1 = pc + pi_d;
  } else {
    w.p0 = pc - k * sp;
    w.p1 = pc + k * sp;
  }
  return w;
}

// Directional albedo: mean and standard error of f |cos| / pdf over the
// BxDF's own samples (failures count as 0), for one spectral channel.
struct Albedo {
  double mean = 0, sigma = 0;
};
template <class B>
Albedo albedo(const B& bxdf, const Vector3f& wo, TransportMode mode, int channel, size_t n, PCG32& rng) {
  double s = 0, s2 = 0;
  for (size_t i = 0; i < n; ++i) {
    Float uc = rng.next_float();
    Point2f u{rng.next_float(), rng.next_float()};
    auto bs = bxdf.sample(wo, uc, u, mode);
    if (!bs || !(bs->pdf > 0)) continue;
    double v = double(bs->f[channel]) * abs_cos_theta(bs->wi) / bs->pdf;
    s += v;
    s2 += v * v;
  }
  double mean = s / double(n), var = std::max(0.0, s2 / double(n) - mean * mean) / double(n - 1);
  return {mean, std::sqrt(var)};
}

// The single-scattering albedo of the Trowbridge–Reitz reflection lobe for
// F = 1 at wo (E) and its part weighted by 1 - (1 - wo.wm)^5 (A, the F0 part
// of a Schlick Fresnel), independently of MicrofacetAlbedoTable: m x m
// strata of the visible normals.
struct MicrofacetReference {
  double E = 0, A = 0;
};
inline MicrofacetReference microfacet_reference(const Vector3f& wo, Float alpha, int m = 256) {
  TrowbridgeReitz d(alpha, alpha);
  MicrofacetReference r;
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) {
      Vector3f wm = d.sample_wm(wo, {(Float(i) + 0.5f) / Float(m), (Float(j) + 0.5f) / Float(m)});
      Vector3f wi = reflect(wo, wm);
      if (!(wi.z > 0)) continue;
      double v = double(d.G(wo, wi)) / double(d.G1(wo));
      r.E += v;
      r.A += v * (1 - std::pow(1 - std::clamp(double(dot(wo, wm)), 0.0, 1.0), 5));
    }
  r.E /= double(m) * m;
  r.A /= double(m) * m;
  return r;
}

// eval, pdf and sample at (and from) the given directions are finite and
// non-negative, and a sample's f and pdf are too.
template <class B, class S>
void check_finite(const B& bxdf, const Vector3f& wo, const Vector3f& wi, PCG32& rng) {
  for (auto mode : {TransportMode::radiance, TransportMode::importance}) {
    S f = bxdf.eval(wo, wi, mode);
    Float p = bxdf.pdf(wo, wi, mode);
    CHECK(f.is_finite());
    for (int c = 0; c < S::size; ++c) CHECK(f[c] >= 0);
    CHECK(std::isfinite(p));
    CHECK(p >= 0);
    for (int k = 0; k < 8; ++k) {
      auto bs = bxdf.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()}, mode);
      if (!bs) continue;
      CHECK(bs->f.is_finite());
      for (int c = 0; c < S::size; ++c) CHECK(bs->f[c] >= 0);
      CHECK(std::isfinite(bs->pdf));
      CHECK(bs->pdf >= 0);
      CHECK(std::isfinite(bs->wi.x));
      CHECK(std::isfinite(bs->wi.y));
      CHECK(std::isfinite(bs->wi.z));
      CHECK(std::isfinite(bs->eta));
      if (!bs->is_specular()) {
        CHECK(bxdf.eval(wo, bs->wi, mode).is_finite());
        CHECK(std::isfinite(bxdf.pdf(wo, bs->wi, mode)));
      }
    }
  }
}

}  // namespace bxdf_check
