// tests/support/reference_physics.hpp — independent references for the
// physics prism implements, written in double from the papers and books they
// come from, without calling any prism function: a test that compares prism
// with these catches a wrong model, where a test that compares prism with
// itself (a sampler against its own pdf, an albedo against a bound) only
// catches an inconsistent one. Each formula names its source; where the
// algebra differs from prism's (tan/cos forms against prism's rational
// forms, std::complex against prism's real arithmetic) that is on purpose.
//
// Directions are unit vectors in the local shading frame, +z the normal.
// docs/testing.md lists these references and the tests that use them.
#pragma once
#include <algorithm>
#include <array>
#include <vector>
#include <cmath>
#include <complex>
#include <functional>

namespace reference_physics {

constexpr double pi = 3.14159265358979323846;
// Comparing prism's float evaluation of a closed form with these: prism
// rounds each quantity at most ~30 times, by u = 2^-24 relative, in sums of
// positive terms (no cancellation), so its relative error is below
// gamma(64) = 64 u / (1 - 64 u) ~ 3.8e-6, with a factor-2 margin. Where a
// quantity is ill-conditioned, the tests add its condition number times u.
constexpr double unit_roundoff = 0x1p-24;
constexpr double float_tol = 64 * unit_roundoff / (1 - 64 * unit_roundoff);

struct Dir {
  double x = 0, y = 0, z = 1;
};
inline double dot(const Dir& a, const Dir& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Dir normalized(const Dir& a) {
  double l = std::sqrt(dot(a, a));
  return {a.x / l, a.y / l, a.z / l};
}
inline Dir from_angles(double theta, double phi) {
  return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
}
inline Dir mirror_about(const Dir& wo, const Dir& m) {
  double c = 2 * dot(wo, m);
  return {c * m.x - wo.x, c * m.y - wo.y, c * m.z - wo.z};
}
inline double theta_of(const Dir& w) { return std::atan2(std::hypot(w.x, w.y), w.z); }
inline double phi_of(const Dir& w) { return std::atan2(w.y, w.x); }

// ---- Gauss-Legendre nodes on [-1, 1] (Newton on P_n; Golub-Welsch accuracy) --
template <int N>
struct GaussLegendre {
  std::array<double, N> x{}, w{};
  GaussLegendre() {
    for (int i = 0; i < N; ++i) {
      double z = std::cos(pi * (i + 0.75) / (N + 0.5)), dp = 0;
      for (int it = 0; it < 100; ++it) {
        double p0 = 1, p1 = 0;
        for (int j = 0; j < N; ++j) {
          double p2 = p1;
          p1 = p0;
          p0 = ((2 * j + 1) * z * p1 - j * p2) / (j + 1);
        }
        dp = N * (z * p0 - p1) / (z * z - 1);
        double dz = p0 / dp;
        z -= dz;
        if (std::abs(dz) < 1e-16) break;  // Newton's step below double's resolution of |z| ≤ 1
      }
      x[size_t(i)] = z;
      w[size_t(i)] = 2 / ((1 - z * z) * dp * dp);
    }
  }
};
// The integral of f over [a, b] by `panels` panels of N-point Gauss-Legendre.
template <int N = 16, class F>
double integrate(F&& f, double a, double b, int panels = 1) {
  static const GaussLegendre<N> gl;
  double h = (b - a) / panels, sum = 0;
  for (int p = 0; p < panels; ++p) {
    double c = a + (p + 0.5) * h;
    for (int i = 0; i < N; ++i) sum += gl.w[size_t(i)] * f(c + h / 2 * gl.x[size_t(i)]);
  }
  return sum * h / 2;
}

// ---- Trowbridge-Reitz (GGX) ------------------------------------------------
// D: Trowbridge & Reitz 1975, as GGX in Walter et al. 2007 ("Microfacet
// models for refraction through rough surfaces", EGSR), eq. 33, in its
// anisotropic form (Heitz 2014, "Understanding the masking-shadowing
// function in microfacet-based BRDFs", JCGT 3(2), eq. 85):
//   D(m) = 1 / (pi ax ay cos^4 theta_m (1 + tan^2 theta_m (cos^2 phi_m / ax^2
//          + sin^2 phi_m / ay^2))^2),  0 for cos theta_m <= 0.
inline double ggx_D(double ax, double ay, const Dir& m) {
  if (!(m.z > 0)) return 0;
  double theta = theta_of(m), phi = phi_of(m);
  double t2 = std::tan(theta) * std::tan(theta), c4 = std::pow(std::cos(theta), 4);
  double e = t2 * (std::cos(phi) * std::cos(phi) / (ax * ax) + std::sin(phi) * std::sin(phi) / (ay * ay));
  return 1 / (pi * ax * ay * c4 * (1 + e) * (1 + e));
}
// Smith's Lambda for GGX: Heitz 2014, eq. 86 with eq. 80's anisotropic
// roughness alpha_o = sqrt(cos^2 phi ax^2 + sin^2 phi ay^2):
//   a = 1 / (alpha_o tan theta_o),  Lambda = (-1 + sqrt(1 + 1 / a^2)) / 2.
// Lambda(-w) = Lambda(w) (the masking of a direction seen from below).
inline double ggx_lambda(double ax, double ay, const Dir& w) {
  double theta = theta_of(w.z < 0 ? Dir{-w.x, -w.y, -w.z} : w), phi = phi_of(w);
  if (theta == 0) return 0;
  double alpha_o = std::sqrt(std::cos(phi) * std::cos(phi) * ax * ax + std::sin(phi) * std::sin(phi) * ay * ay);
  double a = 1 / (alpha_o * std::tan(theta));
  return (-1 + std::sqrt(1 + 1 / (a * a))) / 2;
}
// Smith masking G1 = 1 / (1 + Lambda) (Heitz 2014, eq. 43).
inline double smith_G1(double ax, double ay, const Dir& w) { return 1 / (1 + ggx_lambda(ax, ay, w)); }
// Height-correlated masking-shadowing for reflection and transmission
// (Heitz 2014, eq. 99; wo, wi on either side):
//   G2 = 1 / (1 + Lambda(wo) + Lambda(wi)).
// Not the separable G1(wo) G1(wi) (eq. 98), which overestimates the
// correlation's loss.
inline double smith_G2(double ax, double ay, const Dir& wo, const Dir& wi) {
  return 1 / (1 + ggx_lambda(ax, ay, wo) + ggx_lambda(ax, ay, wi));
}
// The distribution of visible normals (Heitz & d'Eon 2014, eq. 2; Heitz
// 2018, "Sampling the GGX distribution of visible normals", JCGT 7(4), eq. 1):
//   D_wo(m) = G1(wo) max(0, wo.m) D(m) / wo.z,  for wo above the surface.
inline double ggx_vndf(double ax, double ay, const Dir& wo, const Dir& m) {
  return smith_G1(ax, ay, wo) * std::max(0.0, dot(wo, m)) * ggx_D(ax, ay, m) / wo.z;
}

// ---- Fresnel -----------------------------------------------------------------
// The Fresnel equations for the amplitude reflection coefficients of s (TE)
// and p (TM) polarisation (Born & Wolf, Principles of Optics, 7th ed., 1.5.2,
// eq. 21a; Hecht, Optics, 4.6.2) from a medium of index n1 into n2, with
// cos_t from Snell's law n1 sin_i = n2 sin_t; complex n2 = eta + i k for a
// conductor (Born & Wolf 14.2; pbrt-v4 book, 9.3.6), the principal root of
// cos_t = sqrt(1 - (n1 sin_i / n2)^2). Unpolarised reflectance:
// (|r_s|^2 + |r_p|^2) / 2.
inline double fresnel_unpolarised(std::complex<double> n1, std::complex<double> n2, double cos_i) {
  double sin2_i = 1 - cos_i * cos_i;
  std::complex<double> ratio = n1 / n2;
  std::complex<double> cos_t = std::sqrt(1.0 - ratio * ratio * sin2_i);
  std::complex<double> rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
  std::complex<double> rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
  return (std::norm(rs) + std::norm(rp)) / 2;
}
// A dielectric interface, eta = inside / outside; cos_i < 0 means the light
// arrives from inside (n1 = eta, n2 = 1). Total internal reflection where
// (n1 / n2) sin_i > 1: R = 1 (Born & Wolf 1.5.4).
inline double fresnel_dielectric(double cos_i, double eta) {
  double n1 = 1, n2 = eta, c = cos_i;
  if (c < 0) {
    std::swap(n1, n2);
    c = -c;
  }
  double s = n1 / n2 * std::sqrt(std::max(0.0, 1 - c * c));
  if (s >= 1) return 1;
  return fresnel_unpolarised(n1, n2, c);
}
// A conductor eta + i k seen from air.
inline double fresnel_conductor(double cos_i, double eta, double k) {
  if (!(cos_i > 0)) return 1;  // grazing: r_s, r_p -> -1 (0 / 0 when eta = 1, k = 0)
  return fresnel_unpolarised(1.0, std::complex<double>(eta, k), std::clamp(cos_i, 0.0, 1.0));
}
// A thin film on a substrate by the characteristic-matrix method (Born &
// Wolf, Principles of Optics, section 1.6.2; Macleod, Thin-Film Optical
// Filters, chapter 2), a derivation independent of the Airy summation:
// light from index n1 at cos_i meets a film (n2, thickness d) on a substrate
// n3. With the tilted admittances eta_j = n_j cos_j (s) or n_j / cos_j (p)
// and the film's phase thickness b = 2 pi n2 d cos_2 / lambda,
//   [B; C] = [[cos b, i sin b / eta2], [i eta2 sin b, cos b]] [1; eta3],
//   r = (eta1 B - C) / (eta1 B + C),
// and R = (|r_s|^2 + |r_p|^2) / 2.
inline double thin_film_tmm(double cos_i, double n1, double n2, double d, double n3, double lambda) {
  using C = std::complex<double>;
  const double s1 = n1 * std::sqrt(std::max(0.0, 1 - cos_i * cos_i));  // n sin, the same in every layer
  auto cos_in = [&](double n) { return std::sqrt(C(1 - (s1 / n) * (s1 / n), 0)); };
  const C c1 = cos_i, c2 = cos_in(n2), c3 = cos_in(n3);
  const C b = 2 * pi * n2 * d * c2 / lambda;
  auto r_of = [&](C e1, C e2, C e3) {
    C B = std::cos(b) + C(0, 1) * std::sin(b) / e2 * e3;
    C Cc = C(0, 1) * e2 * std::sin(b) + std::cos(b) * e3;
    return std::norm((e1 * B - Cc) / (e1 * B + Cc));
  };
  return (r_of(n1 * c1, n2 * c2, n3 * c3) + r_of(n1 / c1, n2 / c2, n3 / c3)) / 2;
}

// Schlick 1994 ("An inexpensive BRDF model for physically-based rendering",
// eq. 24), the glTF 2.0 specification's Fresnel: F0 + (1 - F0)(1 - c)^5.
inline double fresnel_schlick(double f0, double c) { return f0 + (1 - f0) * std::pow(1 - c, 5); }

// ---- Charlie sheen (Estevez & Kulla 2017) -----------------------------------
// "Production Friendly Microfacet Sheen BRDF" (Sony Imageworks, 2017), as
// KHR_materials_sheen uses it. Distribution, section 2, with r = alpha:
//   D(h) = (2 + 1/r) sin(theta_h)^(1/r) / (2 pi).
inline double charlie_D(double alpha, const Dir& h) {
  if (!(h.z > 0)) return 0;
  return (2 + 1 / alpha) * std::pow(std::sin(theta_of(h)), 1 / alpha) / (2 * pi);
}
// Its shadowing, section 3: Lambda(theta) = exp(L(cos theta)) for theta >
// 60 deg (cos < 1/2), exp(2 L(1/2) - L(1 - cos theta)) below, with the fit
// L(x) = a / (1 + b x^c) + d x + e, the table's two rows (roughness 0 and
// 1) blended by t = (1 - r)^2: p = t p(0) + (1 - t) p(1).
inline double charlie_lambda(double alpha, double cos_theta) {
  const double row0[5] = {25.3245, 3.32435, 0.16801, -1.27393, -4.85967};
  const double row1[5] = {21.5473, 3.82987, 0.19823, -1.97760, -4.32054};
  const double t = (1 - alpha) * (1 - alpha);
  double q[5];
  for (int i = 0; i < 5; ++i) q[i] = t * row0[i] + (1 - t) * row1[i];
  auto L = [&](double x) { return q[0] / (1 + q[1] * std::pow(x, q[2])) + q[3] * x + q[4]; };
  return cos_theta < 0.5 ? std::exp(L(cos_theta)) : std::exp(2 * L(0.5) - L(1 - cos_theta));
}
// The white lobe D G / (4 mu_o mu_i), G = 1 / (1 + Lambda(wo) + Lambda(wi)),
// both directions above the surface.
// prism takes the cosines in G and the denominator as at least mu_min =
// 1e-3 (sheen.hpp: the fit's albedo diverges at the horizon); so does this.
inline double charlie_sheen(double alpha, const Dir& wo, const Dir& wi, double mu_min = 1e-3) {
  if (!(wo.z > 0 && wi.z > 0)) return 0;
  Dir h = normalized({wo.x + wi.x, wo.y + wi.y, wo.z + wi.z});
  const double mo = std::max(wo.z, mu_min), mi = std::max(wi.z, mu_min);
  double G = 1 / (1 + charlie_lambda(alpha, mo) + charlie_lambda(alpha, mi));
  return charlie_D(alpha, h) * G / (4 * mo * mi);
}
// Its directional albedo at cos theta_o = mu: Gauss-Legendre in theta_i
// (panels x 16 points on [0, pi/2]) and phi_i (2 n_phi points on [0, 2 pi]).
inline double charlie_albedo(double alpha, double mu, int panels = 8, int n_phi = 4) {
  Dir wo{std::sqrt(std::max(0.0, 1 - mu * mu)), 0, mu};
  return integrate(
      [&](double th) {
        double row = integrate(
            [&](double ph) { return charlie_sheen(alpha, wo, from_angles(th, ph)); }, 0, 2 * pi, n_phi);
        return row * std::cos(th) * std::sin(th);
      },
      0, pi / 2, panels);
}

// ---- Microfacet BSDFs (Walter et al. 2007) ----------------------------------
// Reflection (Walter 2007, eq. 20 with the half vector of eq. 13):
//   f_r = F(wo.h) G2 D(h) / (4 |wo.n| |wi.n|),  h = normalize(wo + wi),
// wo and wi above the surface. F is given as a function of wo.h.
template <class Fresnel>
double torrance_sparrow(double ax, double ay, const Dir& wo, const Dir& wi, Fresnel&& F) {
  if (!(wo.z > 0 && wi.z > 0)) return 0;
  Dir h = normalized({wo.x + wi.x, wo.y + wi.y, wo.z + wi.z});
  return F(dot(wo, h)) * smith_G2(ax, ay, wo, wi) * ggx_D(ax, ay, h) / (4 * wo.z * wi.z);
}
// Its sampling density through the visible normals (Heitz 2018, section 2,
// with the reflection Jacobian 1 / (4 |wo.h|) of Walter 2007, eq. 14):
//   pdf(wi) = D_wo(h) / (4 wo.h).
inline double torrance_sparrow_pdf(double ax, double ay, const Dir& wo, const Dir& wi) {
  if (!(wo.z > 0 && wi.z > 0)) return 0;
  Dir h = normalized({wo.x + wi.x, wo.y + wi.y, wo.z + wi.z});
  return ggx_vndf(ax, ay, wo, h) / (4 * dot(wo, h));
}
// Transmission (Walter 2007, eq. 21, with its generalised half vector of
// eq. 16, h = -(n_o wo + n_i wi) turned to +z), for radiance transport:
//   f_t = |wi.h| |wo.h| / (|wi.n| |wo.n|) n_o^2 (1 - F(wo.h)) G2 D(h)
//         / (n_i (wi.h) + n_o (wo.h))^2,
// n_o the index on wo's side, n_i on wi's; eta = inside / outside, the
// outside above the surface. Importance transport (the adjoint) swaps the
// roles: f_imp(wo, wi) = f_rad(wi, wo) (Veach 1997, 5.2). 0 when the two
// directions are on the same side or a microfacet is seen from behind.
inline double walter_transmission(double ax, double ay, double eta, const Dir& wo, const Dir& wi, bool radiance = true) {
  if (!radiance) return walter_transmission(ax, ay, eta, wi, wo, true);
  if (!(wo.z * wi.z < 0)) return 0;
  double n_o = wo.z > 0 ? 1 : eta, n_i = wi.z > 0 ? 1 : eta;
  Dir h{n_o * wo.x + n_i * wi.x, n_o * wo.y + n_i * wi.y, n_o * wo.z + n_i * wi.z};
  h = normalized(h);
  if (h.z < 0) h = {-h.x, -h.y, -h.z};
  double dwo = dot(wo, h), dwi = dot(wi, h);
  // Both directions must see h from the side they are on (Walter 2007, eq. 21's chi+).
  if (!(dwo * wo.z > 0 && dwi * wi.z > 0)) return 0;
  double F = fresnel_dielectric(dwo, eta);
  double denom = n_i * dwi + n_o * dwo;
  return std::abs(dwi * dwo / (wi.z * wo.z)) * n_o * n_o * (1 - F) * smith_G2(ax, ay, wo, wi) * ggx_D(ax, ay, h) /
         (denom * denom);
}

// ---- Directional albedo of the white (F = 1) GGX conductor -----------------
// E(theta_o, alpha) = int f_r cos_i d wi with F = 1, isotropic alpha, by
// quadrature over the microfacet normals: with d wi = 4 |wo.h| d h,
//   E = int D(h) cos theta_h G2(wo, wi) (wo.h) / (cos theta_o cos theta_h) d h,
// and D cos theta_h d h = d xi d phi / (2 pi) for xi = tan^2 / (alpha^2 +
// tan^2) (the GGX projected-area CDF, Walter 2007 eq. 35). wi = reflect(wo,
// h) is above the surface iff theta_h < (delta + pi/2) / 2 with tan delta =
// sin theta_o cos phi / cos theta_o (wi.z = R cos(2 theta_h - delta)), so
// each phi integrates xi over [0, xi_max(phi)]: the integrand is smooth
// inside, and phi (periodic) goes round the circle by the midpoint rule,
// which converges geometrically for it. xi = xi_max (1 - (1 - t)^2) clusters
// points towards xi_max, where tan theta_h grows like 1 / sqrt(1 - xi) at
// grazing incidence. Resolution: n_phi x (panels x 16) points; the default
// agrees with twice as many to < 1e-7 for theta_o <= 89.9 deg, alpha >= 1e-3
// (docs/testing.md), and gives 1 - ln 2 at alpha = 1, theta_o = 0 to 1e-12.
inline double conductor_albedo_aniso(double theta_o, double phi_o, double ax, double ay, int n_u = 256,
                                     int panels = 8);
inline double conductor_albedo(double theta_o, double alpha, int n_phi = 64, int panels = 8) {
  // The isotropic case of conductor_albedo_aniso (below): its midpoints in
  // u over the whole circle are these n_phi over [0, pi] and their mirror
  // images, which the even integrand weighs alike.
  return conductor_albedo_aniso(theta_o, 0, alpha, alpha, 2 * n_phi, panels);
}
// The same albedo for an anisotropic lobe (alpha_x along x, alpha_y along
// y) and wo at azimuth phi_o. The normals' projected-area measure D cos
// theta_h d h is du d xi for phi(u) = atan2(alpha_y sin 2 pi u, alpha_x cos
// 2 pi u) and xi = tan^2 / (alpha(phi)^2 + tan^2), alpha(phi)^-2 =
// cos^2 phi / alpha_x^2 + sin^2 phi / alpha_y^2 (the stretched GGX, Heitz
// 2014 section 5.4): the isotropic change of variables with u in place of
// phi / (2 pi). The horizon limit on each phi is conductor_albedo's with
// phi - phi_o. u on [0, 1) by the midpoint rule (smooth and periodic in u).
inline double conductor_albedo_aniso(double theta_o, double phi_o, double ax, double ay, int n_u, int panels) {
  Dir wo{std::sin(theta_o) * std::cos(phi_o), std::sin(theta_o) * std::sin(phi_o), std::cos(theta_o)};
  double sum = 0;
  for (int j = 0; j < n_u; ++j) {
    double u = (j + 0.5) / n_u;
    double phi = std::atan2(ay * std::sin(2 * pi * u), ax * std::cos(2 * pi * u));
    double a = 1 / std::sqrt(std::pow(std::cos(phi) / ax, 2) + std::pow(std::sin(phi) / ay, 2));
    double delta = std::atan2(std::sin(theta_o) * std::cos(phi - phi_o), std::cos(theta_o));
    double th_max = (delta + pi / 2) / 2;
    double xi_max = th_max >= pi / 2 ? 1 : std::pow(std::tan(th_max), 2) / (a * a + std::pow(std::tan(th_max), 2));
    auto g = [&](double t) {
      double xi = xi_max * (1 - (1 - t) * (1 - t)), dxi = xi_max * 2 * (1 - t);
      double th = std::atan(a * std::sqrt(xi / (1 - xi)));
      Dir h = from_angles(th, phi);
      Dir wi = mirror_about(wo, h);
      if (!(wi.z > 0)) return 0.0;
      return dxi * smith_G2(ax, ay, wo, wi) * dot(wo, h) / (wo.z * h.z);
    };
    sum += integrate(g, 0, 1, panels);
  }
  return sum / n_u;
}

// Kulla & Conty 2017 ("Revisiting physically based shading at Imageworks",
// SIGGRAPH course), the average albedo E_avg = 2 int_0^1 E(mu) mu dmu, by
// Gauss-Legendre in mu.
inline double conductor_average_albedo(double alpha) {
  return 2 * integrate<16>([&](double mu) { return conductor_albedo(std::acos(mu), alpha, 32, 4) * mu; }, 0, 1, 2);
}

// ---- Directional albedo of the rough dielectric -------------------------------
// The energy that one microfacet event sends anywhere (reflection plus
// transmission, importance transport: no 1/eta'^2), for light from wo above
// an interface of relative index eta (the side below / wo's side; eta < 1
// is light from the denser side, with total internal reflection):
//   E = int D_wo(h) [F(wo.h) G2(wo, wr) [wr.z > 0] + (1 - F) G2(wo, wt) [wt.z < 0]] / G1(wo) dh
// (Walter 2007, eqs. 20-21, with the sampling density of Heitz 2018), wr the
// mirror direction, wt the refraction by Snell's law in vector form,
//   wt = -wo / eta + (c / eta - sqrt(1 - (1 - c^2) / eta^2)) h,  c = wo.h.
// Same variables as conductor_albedo; on each phi the xi interval stops
// where h turns its back to wo, and is split where wr and wt cross the
// horizon and where total internal reflection starts (found by bisection),
// so that every piece has a smooth integrand.
inline double dielectric_albedo(double theta_o, double alpha, double eta, int n_phi = 128, int panels = 8) {
  Dir wo{std::sin(theta_o), 0, std::cos(theta_o)};
  // q = 1 - xi = alpha^2 cos^2 / (alpha^2 cos^2 + sin^2), computed without
  // cancellation: near the horizon xi rounds to 1 and would lose theta.
  auto q_of = [&](double th) {
    double a2c2 = alpha * alpha * std::cos(th) * std::cos(th);
    return th >= pi / 2 ? 0.0 : a2c2 / (a2c2 + std::sin(th) * std::sin(th));
  };
  double sum = 0;
  for (int j = 0; j < n_phi; ++j) {
    double phi = pi * (j + 0.5) / n_phi;
    double delta = std::atan2(std::sin(theta_o) * std::cos(phi), std::cos(theta_o));
    auto normal = [&](double th) { return from_angles(th, phi); };
    auto reflected_up = [&](double th) { return mirror_about(wo, normal(th)).z > 0; };
    auto transmits = [&](double th) {  // refraction exists and goes below
      Dir h = normal(th);
      double c = dot(wo, h), k = 1 - (1 - c * c) / (eta * eta);
      if (!(k > 0)) return false;
      double a = c / eta - std::sqrt(k);
      return -wo.z / eta + a * h.z < 0;
    };
    double th_vis = std::min(pi / 2, delta + pi / 2);  // wo.h > 0 below it
    // Breakpoints: where a predicate changes along theta (bisection to 1e-13).
    // A vector, not a std::array: GCC 12's -Warray-bounds misreads std::sort's
    // insertion-sort threshold (16) against an 8-element array at -O2.
    std::vector<double> cuts(8, 0.0);
    int n_cuts = 0;
    cuts[size_t(n_cuts++)] = 0;
    for (auto pred : {std::function<bool(double)>(reflected_up), std::function<bool(double)>(transmits)}) {
      const int scan = 256;
      for (int k = 0; k < scan; ++k) {
        double a = th_vis * k / scan, b = th_vis * (k + 1) / scan;
        if (pred(a) == pred(b)) continue;
        for (int it = 0; it < 60; ++it) {
          double m = (a + b) / 2;
          (pred(m) == pred(a) ? a : b) = m;
        }
        if (n_cuts < 7) cuts[size_t(n_cuts++)] = (a + b) / 2;
      }
    }
    cuts[size_t(n_cuts++)] = th_vis;
    std::sort(cuts.begin(), cuts.begin() + n_cuts);
    for (int c = 0; c + 1 < n_cuts; ++c) {
      double q0 = q_of(cuts[size_t(c)]), q1 = q_of(cuts[size_t(c + 1)]);
      if (!(q0 > q1)) continue;
      auto g = [&](double t) {
        // Points cluster at both ends (t -> q0 - (q0 - q1)(3t^2 - 2t^3)).
        double s = t * t * (3 - 2 * t), ds = 6 * t * (1 - t);
        double q = q0 - (q0 - q1) * s;
        double th = std::atan2(alpha * std::sqrt(1 - q), std::sqrt(q));
        Dir h = normal(th);
        double cwh = dot(wo, h);
        if (!(cwh > 0)) return 0.0;
        double F = fresnel_dielectric(cwh, eta), v = 0;
        Dir wr = mirror_about(wo, h);
        if (wr.z > 0) v += F * smith_G2(alpha, alpha, wo, wr);
        double k = 1 - (1 - cwh * cwh) / (eta * eta);
        if (k > 0) {
          double a = cwh / eta - std::sqrt(k);
          Dir wt{-wo.x / eta + a * h.x, -wo.y / eta + a * h.y, -wo.z / eta + a * h.z};
          if (wt.z < 0) v += (1 - F) * smith_G2(alpha, alpha, wo, wt);
        }
        return (q0 - q1) * ds * v * cwh / (wo.z * h.z);
      };
      sum += integrate(g, 0, 1, panels);
    }
  }
  return sum / n_phi;
}

// ---- Oren-Nayar in Fujii's improved form -------------------------------------
// Y. Fujii, "A tiny improvement of Oren-Nayar reflectance model" (2013; the
// qualitative model of Oren & Nayar 1994, SIGGRAPH, made energy
// conserving):  s = wi.wo - cos_i cos_o,  t = max(cos_i, cos_o) if s > 0 else 1,
//   f = rho (A + B s / t),  A = 1 / (pi + (pi/2 - 2/3) sigma),  B = sigma A.
// Its albedo at normal incidence is A pi rho (s = 0 for every wi).
struct OrenNayarFujii {
  double rho, sigma;
  double A() const { return 1 / (pi + (pi / 2 - 2.0 / 3.0) * sigma); }
  double B() const { return sigma / (pi + (pi / 2 - 2.0 / 3.0) * sigma); }
  double f(const Dir& wo, const Dir& wi) const {
    if (!(wo.z * wi.z > 0)) return 0;
    double co = std::abs(wo.z), ci = std::abs(wi.z);
    double s = dot(wo, wi) - wo.z * wi.z;
    double t = s > 0 ? std::max(co, ci) : 1;
    return rho * (A() + B() * s / t);
  }
  // The directional albedo at theta_o by quadrature, split where the
  // integrand has kinks (theta_i = theta_o, where t switches, and
  // cos(phi) = 0, where s changes sign).
  double albedo(double theta_o) const {
    Dir wo = from_angles(theta_o, 0);
    auto over_theta = [&](double phi) {
      auto g = [&](double th) { return f(wo, from_angles(th, phi)) * std::cos(th) * std::sin(th); };
      return integrate(g, 0, theta_o, 2) + integrate(g, theta_o, pi / 2, 4);
    };
    return 2 * (integrate(over_theta, 0, pi / 2, 2) + integrate(over_theta, pi / 2, pi, 2));
  }
};

// ---- Other laws --------------------------------------------------------------
// Veach 1997 (PhD thesis, 9.2.4, eq. 9.13): the power heuristic with beta = 2
// for one sample from each of two techniques.
inline double power_heuristic(double f_pdf, double g_pdf) {
  return f_pdf * f_pdf / (f_pdf * f_pdf + g_pdf * g_pdf);
}
// Beer-Lambert: transmittance exp(-sigma_a t) through a homogeneous absorber
// (e.g. Bohren & Huffman 1983, 2.8; glTF KHR_materials_volume:
// sigma_a = -ln(attenuation_color) / attenuation_distance).
inline double beer_lambert(double sigma_a, double t) { return std::exp(-sigma_a * t); }
// Lambert: f = rho / pi.
inline double lambert(double rho) { return rho / pi; }

// SCHOTT's N-BK7 data sheet (optical glass catalogue, 2017): refractive
// indices at the Fraunhofer lines, which its Sellmeier fit reproduces to
// the catalogue's 1e-5.
struct CatalogueIndex {
  double lambda_nm, n;
};
constexpr CatalogueIndex nbk7_catalogue[] = {
    {435.8343, 1.52668},  // g
    {486.1327, 1.52238},  // F
    {546.0740, 1.51872},  // e
    {587.5618, 1.51680},  // d
    {656.2725, 1.51432},  // C
    {706.5188, 1.51289},  // r
};

// The CIE 1931 2-degree colour-matching functions at a few wavelengths, from
// the CIE's 1 nm table (CIE 015:2018, table 1; ../shared/data holds the
// whole table, which the tests also read where it is present).
struct CmfSample {
  double lambda_nm, x, y, z;
};
constexpr CmfSample cie1931_samples[] = {
    {450, 0.336200, 0.038000, 1.772110},
    {500, 0.004900, 0.323000, 0.272000},
    {555, 0.512050, 1.000000, 0.005750},
    {600, 1.062200, 0.631000, 0.000800},
    {650, 0.283500, 0.107000, 0.000000},
};

// ---- Statistics ----------------------------------------------------------------
// The z such that |N(0,1)| > z has probability p (two-sided), by bisection
// on erfc.
inline double normal_quantile_two_sided(double p) {
  double lo = 0, hi = 40;
  for (int i = 0; i < 200; ++i) {
    double mid = (lo + hi) / 2;
    (std::erfc(mid / std::sqrt(2.0)) > p ? lo : hi) = mid;
  }
  return (lo + hi) / 2;
}
// The regularized incomplete beta function I_x(a, b), by its continued
// fraction (evaluated by the modified Lentz method; Press et al., Numerical
// Recipes, 3rd ed., 2007, section 6.4), using the symmetry
// I_x(a, b) = 1 - I_{1-x}(b, a) where the fraction converges slowly.
inline double incomplete_beta(double x, double a, double b) {
  if (x <= 0) return 0;
  if (x >= 1) return 1;
  if (x > (a + 1) / (a + b + 2)) return 1 - incomplete_beta(1 - x, b, a);
  auto fraction = [&]() {
    const double tiny = 1e-300;  // Lentz's guard against a zero divisor (Numerical Recipes, 6.4)
    double c = 1, d = 1 - (a + b) * x / (a + 1);
    if (std::abs(d) < tiny) d = tiny;
    d = 1 / d;
    double h = d;
    for (int m = 1; m <= 300; ++m) {
      for (int pass = 0; pass < 2; ++pass) {
        double num = pass == 0 ? m * (b - m) * x / ((a + 2 * m - 1) * (a + 2 * m))
                               : -(a + m) * (a + b + m) * x / ((a + 2 * m) * (a + 2 * m + 1));
        d = 1 + num * d;
        if (std::abs(d) < tiny) d = tiny;
        c = 1 + num / c;
        if (std::abs(c) < tiny) c = tiny;
        d = 1 / d;
        h *= d * c;
      }
    }
    return h;
  };
  double front = std::exp(std::lgamma(a + b) - std::lgamma(a) - std::lgamma(b) + a * std::log(x) + b * std::log(1 - x)) / a;
  return front * fraction();
}
// The t such that |T| > t has probability p for Student's t with df degrees
// of freedom (two-sided): P(|T| > t) = I_{df / (df + t^2)}(df / 2, 1 / 2),
// solved by bisection.
inline double student_t_quantile_two_sided(double p, double df) {
  double lo = 0, hi = 1e4;
  for (int i = 0; i < 200; ++i) {
    double mid = (lo + hi) / 2;
    (incomplete_beta(df / (df + mid * mid), df / 2, 0.5) > p ? lo : hi) = mid;
  }
  return (lo + hi) / 2;
}
// As sidak_z, for differences over an estimated standard error with df
// degrees of freedom.
inline double sidak_t(double family_alpha, int m, double df) {
  return student_t_quantile_two_sided(1 - std::pow(1 - family_alpha, 1.0 / m), df);
}
// How many standard errors a Monte Carlo estimate may stray from the true
// value when m such comparisons should all pass with probability
// 1 - family_alpha: Sidak's per-comparison level 1 - (1 - family_alpha)^(1/m)
// as a two-sided normal quantile (the estimators here average >= 10^4
// bounded samples, so the central limit theorem holds to well within that).
// family_alpha = 1e-3: m = 1 gives 3.29, m = 32 gives 4.17.
inline double sidak_z(double family_alpha, int m) {
  return normal_quantile_two_sided(1 - std::pow(1 - family_alpha, 1.0 / m));
}
// The standard error of a mean of n samples that lie in [0, 1] and whose
// true mean is E: at most sqrt(E (1 - E) / n) whatever their distribution
// (the Bhatia-Davis inequality, Var <= (1 - E)(E - 0)). A white conductor's
// furnace weights G2 / G1 are such samples, and the sample variance is no
// substitute where the loss comes from rare samples (at alpha = 0.0025 and
// 80 deg, about 1 in 10^4 reflects below the horizon and weighs 0: 20000
// samples may hold none, and their sample sigma, 2e-7, misses the 5e-5
// those events are worth).
inline double bounded_sigma(double E, long n) { return std::sqrt(std::max(0.0, E * (1 - E)) / double(n)); }

}  // namespace reference_physics
