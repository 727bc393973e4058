// Optical and spectral laws against independent references
// (support/reference_physics.hpp): the Fresnel equations (dielectric both
// ways with total internal reflection, conductor with a complex index),
// Snell's law, the white rough conductor's albedo against its double
// quadrature (two-sided, with 1 - ln 2 at alpha = 1 and normal incidence),
// Fujii's Oren-Nayar, the power heuristic, Beer-Lambert, N-BK7 against
// SCHOTT's catalogue, the CIE 1931 colour-matching functions, Planck's law,
// and the spawned ray origin's offset (pbrt-v4 book, 6.8.6).
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <prism/bxdfs/conductor.hpp>
#include <prism/bxdfs/dielectric.hpp>
#include <prism/bxdfs/volume.hpp>
#include <prism/geometry/ray.hpp>
#include <prism/sampling/pcg32.hpp>
#include <prism/sampling/warps.hpp>
#include <prism/spectra/dispersion.hpp>
#include <prism/spectra/spectrum.hpp>
#include "oren_nayar.hpp"
#include "support/reference_physics.hpp"

namespace laws_reference_test {

using namespace prism;
namespace ref = reference_physics;
using ref::float_tol;  // gamma(64): the tolerance of a float closed form

namespace {
constexpr double u = ref::unit_roundoff;

// Directional albedo of bxdf at wo: mean and standard error of f |cos| / pdf
// over its own samples (failures count 0).
template <class B>
std::pair<double, double> albedo(const B& bxdf, const Vector3f& wo, int n, PCG32& rng) {
  double s = 0, s2 = 0;
  for (int i = 0; i < n; ++i) {
    auto bs = bxdf.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()}, TransportMode::radiance);
    if (!bs || !(bs->pdf > 0)) continue;
    double v = double(bs->f[0]) * std::abs(bs->wi.z) / bs->pdf;
    s += v;
    s2 += v * v;
  }
  double mean = s / n;
  return {mean, std::sqrt(std::max(0.0, s2 / n - mean * mean) / (n - 1))};
}
Vector3f at_theta(double deg) {
  double t = deg * ref::pi / 180;
  return {Float(std::sin(t)), 0, Float(std::cos(t))};
}
}  // namespace

TEST_CASE("Fresnel reflectance equals the s and p Fresnel equations, dielectric and conductor", "[reference][fresnel]") {
  // Dielectric: both sides, through the critical angle (arcsin(1/eta) from inside).
  double worst = 0;
  for (double eta : {1.0001, 1.33, 1.5, 2.4, 1 / 1.5})
    for (int i = -1000; i <= 1000; ++i) {
      Float c = Float(i) / 1000;
      double e = double(Float(eta)), want = ref::fresnel_dielectric(c, e);
      double got = fresnel_dielectric(c, Float(eta));
      // Within 1e-6 of the critical cosine R's derivative is unbounded:
      // compare the reflectances there only as "total or not".
      double s_t = (c < 0 ? e : 1 / e) * std::sqrt(std::max(0.0, 1 - double(c) * c));
      INFO("eta " << eta << " cos " << c << ": " << got << " vs " << want);
      if (std::abs(s_t - 1) < 1e-6) continue;
      CHECK(std::abs(got - want) <= float_tol);
      worst = std::max(worst, std::abs(got - want));
    }
  // Conductor: the complex Snell law and amplitudes in std::complex.
  for (double eta : {0.0, 0.05, 0.2, 0.5, 1.0, 1.5, 3.0})
    for (double k : {0.0, 0.1, 1.0, 3.0, 10.0, 100.0}) {
      if (eta == 0 && k == 0) continue;
      for (int deg = 0; deg <= 90; ++deg) {
        Float c = std::cos(Float(deg) * Float(ref::pi) / 180);
        double want = ref::fresnel_conductor(c, double(Float(eta)), double(Float(k)));
        double got = fresnel_complex(c, Float(eta), Float(k));
        INFO("eta " << eta << " k " << k << " theta " << deg << ": " << got << " vs " << want);
        CHECK(std::abs(got - want) <= float_tol);
        worst = std::max(worst, std::abs(got - want));
      }
    }
  WARN("Fresnel: max |prism - reference| " << worst);
}

TEST_CASE("refraction obeys Snell's law: n1 sin_i = n2 sin_t, in the plane of incidence, on the other side", "[reference][fresnel][snell]") {
  PCG32 rng(1621, 1);
  for (double eta : {1.33, 1.5, 2.4})
    for (int i = 0; i < 500; ++i) {
      Vector3f w = sample_uniform_sphere({rng.next_float(), rng.next_float()});
      auto t = refract_dielectric(w, Vector3f(0, 0, 1), Float(eta));
      double n1 = w.z > 0 ? 1 : eta, n2 = w.z > 0 ? eta : 1;
      double sin_i = std::hypot(double(w.x), double(w.y));
      bool tir = n1 / n2 * sin_i > 1;
      INFO("eta " << eta << " w " << w.x << " " << w.y << " " << w.z);
      if (std::abs(n1 / n2 * sin_i - 1) < 1e-5) continue;  // rounding decides at the critical angle
      REQUIRE(t.has_value() == !tir);
      if (tir) continue;
      double sin_t = std::hypot(double(t->wt.x), double(t->wt.y));
      // 8u: float refraction rounds each component ~8 times (u = 2^-24), relative to sin ≤ 1 (times n2 for n2 sin_t)
      CHECK(std::abs(n1 * sin_i - n2 * sin_t) <= 8 * u * n2);
      CHECK(t->wt.z * w.z < 0);
      // The tangential parts are opposite (wi and wt both point away).
      CHECK(double(t->wt.x) * w.x + double(t->wt.y) * w.y <= 0);
      CHECK(std::abs(double(t->wt.x) * w.y - double(t->wt.y) * w.x) <= 8 * u);
      // 1e-6 ≈ 16u: η' is the float η or one float division of it
      CHECK(t->etap == Approx(n2 / n1).epsilon(1e-6));
    }
}

TEST_CASE("white rough conductor albedo equals its double quadrature, 1 - ln 2 at alpha = 1, normal incidence", "[reference][conductor][furnace]") {
  // F = 1 exactly (eta = 0, k = 1). alpha is the GGX width itself (not
  // glTF's roughness, alpha = roughness^2: docs/metal_rough.md). Each estimate
  // averages f |cos| / pdf = G2 / G1 in [0, 1] over n samples; it may miss
  // ref::conductor_albedo (quadrature error < 5e-5, added) by z sigma, with
  // sigma = ref::bounded_sigma (the bound for samples in [0, 1]) and
  // z = sidak_z(1e-3, m) for the m comparisons (3.95 for m = 13): a correct
  // model fails this test with probability 1e-3 at most.
  const double alphas[] = {0.05, 0.3, 1.0};
  const double angles[] = {0.0, 45.0, 80.0, 89.9};
  const int m = 3 * 4 + 1;
  const double z = ref::sidak_z(1e-3, m);
  PCG32 rng(1969, 7);
  double worst = 0;
  for (double alpha : alphas)
    for (double theta : angles) {
      ConductorBxDF<RGB> b{TrowbridgeReitz(Float(alpha), Float(alpha)), RGB(0), RGB(1)};
      Vector3f wo = at_theta(theta);
      double want = ref::conductor_albedo(std::acos(double(wo.z)), alpha, 128, 16);
      double mean = albedo(b, wo, 40000, rng).first, sigma = ref::bounded_sigma(want, 40000);
      INFO("alpha " << alpha << " theta " << theta << ": " << mean << " +- " << sigma << " vs " << want);
      // 5e-5: the quadrature's own error at 89.9° (< 5e-5 against twice its resolution; docs/testing.md)
      CHECK(std::abs(mean - want) <= z * sigma + 5e-5);
      worst = std::max(worst, std::abs(mean - want) / sigma);
    }
  // The closed form (docs/microfacets.md): at normal incidence and alpha = 1,
  // E = int_0^{1/2} (1 - 2 xi) / (1 - xi) d xi = 1 - ln 2.
  // 1e-12: the quadrature's error at α = 1, θo = 0 (docs/testing.md), far above double rounding
  CHECK(ref::conductor_albedo(0, 1) == Approx(1 - std::log(2.0)).epsilon(1e-12));
  ConductorBxDF<RGB> b(TrowbridgeReitz(1, 1), RGB(0), RGB(1));
  double mean = albedo(b, Vector3f(0, 0, 1), 100000, rng).first;
  double sigma = ref::bounded_sigma(1 - std::log(2.0), 100000);
  INFO("alpha 1, normal incidence: " << mean << " +- " << sigma << " vs 1 - ln 2 = " << 1 - std::log(2.0));
  CHECK(std::abs(mean - (1 - std::log(2.0))) <= z * sigma);
  WARN("white conductor furnace: " << m << " comparisons, max |albedo - reference| / sigma " << worst << ", z " << z
                                   << "; alpha 1 at 0 deg: " << mean << " +- " << sigma);
}

TEST_CASE("Oren-Nayar equals Fujii's form pointwise and in albedo", "[reference][oren_nayar]") {
  PCG32 rng(2013, 9);
  for (double sigma : {0.0, 0.3, 0.7, 1.0}) {
    example::OrenNayarBxDF<RGB> b(RGB(0.8f), Float(sigma));
    ref::OrenNayarFujii on{double(0.8f), double(Float(sigma))};
    for (int i = 0; i < 500; ++i) {
      Vector3f wo = sample_uniform_sphere({rng.next_float(), rng.next_float()});
      Vector3f wi = sample_uniform_sphere({rng.next_float(), rng.next_float()});
      double got = b.eval(wo, wi, TransportMode::radiance)[0], want = on.f({wo.x, wo.y, wo.z}, {wi.x, wi.y, wi.z});
      INFO("sigma " << sigma << " wo.z " << wo.z << " wi.z " << wi.z << ": " << got << " vs " << want);
      // float_tol relative (gamma(64)); 1e-12 absolute where f vanishes (double rounding of the reference)
      CHECK(std::abs(got - want) <= float_tol * want + 1e-12);
    }
  }
  // Albedo (rho = 1): A pi at normal incidence, the quadrature elsewhere; 12
  // comparisons at family-wise 1e-3 (z = 3.9).
  const double z = ref::sidak_z(1e-3, 12);
  for (double sigma : {0.3, 0.7, 1.0})
    for (double theta : {0.0, 30.0, 60.0, 80.0}) {
      example::OrenNayarBxDF<RGB> b(RGB(1), Float(sigma));
      ref::OrenNayarFujii on{1, double(Float(sigma))};
      Vector3f wo = at_theta(theta);
      auto [mean, sd] = albedo(b, wo, 40000, rng);
      double want = theta == 0 ? on.A() * ref::pi : on.albedo(std::acos(double(wo.z)));
      INFO("sigma " << sigma << " theta " << theta << ": " << mean << " +- " << sd << " vs " << want);
      // +1e-6: the quadrature's error (Gauss–Legendre on kink-free pieces of a smooth integrand); z from Šidák above
      CHECK(std::abs(mean - want) <= z * sd + 1e-6);
    }
}

TEST_CASE("the power heuristic, Beer-Lambert and Lambert's cosine density are the textbook ones", "[reference][mis][volume]") {
  for (double f : {0.0, 0.1, 1.0, 3.0, 100.0})
    for (double g : {0.1, 0.5, 1.0, 7.0}) {
      INFO("pdfs " << f << ", " << g);
      CHECK(std::abs(power_heuristic(Float(f), Float(g)) - ref::power_heuristic(f, g)) <= float_tol);
    }
  for (double sigma : {0.0, 0.01, 0.5, 2.0, 30.0})
    for (double t : {0.0, 0.1, 1.0, 4.0}) {
      INFO("sigma " << sigma << " t " << t);
      double want = ref::beer_lambert(sigma, t);
      // float_tol relative; 1e-30 absolute only so that exp underflow to 0 compares as equal
      CHECK(std::abs(transmittance(RGB(Float(sigma)), Float(t))[1] - want) <= float_tol * want + 1e-30);
    }
  for (double c : {0.0, 0.2, 0.7, 1.0}) CHECK(std::abs(pdf_cosine_hemisphere(Float(c)) - c / ref::pi) <= float_tol);
}

TEST_CASE("a spawned ray origin leaves the error box: offset d = |n| . p_error along n (pbrt-v4 6.8.6)", "[reference][geometry]") {
  // The plane through p with normal n, moved by d = sum |n_i| err_i, just
  // clears the box p +- err; the origin must lie at least that far along
  // +-n (the side w leaves on), and at most one float step per axis beyond.
  PCG32 rng(68, 6);
  for (int i = 0; i < 1000; ++i) {
    double scale = std::pow(10.0, 8 * rng.next_float() - 4);
    Point3f p(Float(scale * (2 * rng.next_float() - 1)), Float(scale * (2 * rng.next_float() - 1)),
              Float(scale * (2 * rng.next_float() - 1)));
    Vector3f err(Float(scale * 1e-6 * rng.next_float()), Float(scale * 1e-6 * rng.next_float()),
                 Float(scale * 1e-6 * rng.next_float()));
    Vector3f nv = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    Vector3f w = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    Normal3f n(nv.x, nv.y, nv.z);
    Point3f o = offset_ray_origin(p, err, n, w);
    double d = std::abs(double(n.x)) * err.x + std::abs(double(n.y)) * err.y + std::abs(double(n.z)) * err.z;
    double side = double(w.x) * n.x + double(w.y) * n.y + double(w.z) * n.z < 0 ? -1 : 1;
    double moved = side * ((double(o.x) - p.x) * n.x + (double(o.y) - p.y) * n.y + (double(o.z) - p.z) * n.z);
    INFO("scale " << scale << " d " << d << " moved " << moved);
    CHECK(moved >= d * (1 - 8 * u));
  }
}

TEST_CASE("N-BK7 matches SCHOTT's catalogue, the CIE 1931 functions the CIE table, Planck's law", "[reference][spectra]") {
  // The catalogue gives n to 5 decimals (+-5e-6) and SCHOTT quotes its
  // Sellmeier fit to 1e-5 over the visible: |n - n_cat| <= 1.5e-5.
  SellmeierIOR bk7 = SellmeierIOR::glass("N-BK7");
  for (const auto& s : ref::nbk7_catalogue) {
    INFO(s.lambda_nm << " nm: " << bk7.eval(s.lambda_nm) << " vs " << s.n);
    CHECK(std::abs(bk7.eval(s.lambda_nm) - s.n) <= 1.5e-5);
  }
  // CIE 1931 at a few wavelengths (float storage: relative 2^-24).
  for (const auto& s : ref::cie1931_samples) {
    // 1e-6 ≈ 17u: float storage (2^-24) plus the lookup's ~3 roundings; the 1 gives an absolute 1e-6 where x is 0
    INFO(s.lambda_nm << " nm");
    CHECK(std::abs(cie_x(Float(s.lambda_nm)) - s.x) <= 1e-6 * (1 + s.x));
    CHECK(std::abs(cie_y(Float(s.lambda_nm)) - s.y) <= 1e-6 * (1 + s.y));
    CHECK(std::abs(cie_z(Float(s.lambda_nm)) - s.z) <= 1e-6 * (1 + s.z));
  }
  // The whole 1 nm table where ../shared is present, at the sample points
  // and (linear interpolation) half way between.
  std::ifstream in(std::string(PRISM_SHARED_DIR) + "/data/cie1931_2deg_cmf_1nm.csv");
  if (in) {
    std::string line;
    std::getline(in, line);
    double prev[4] = {-1, 0, 0, 0};
    int rows = 0;
    while (std::getline(in, line)) {
      std::replace(line.begin(), line.end(), ',', ' ');
      std::istringstream row(line);
      double l, x, y, zz;
      if (!(row >> l >> x >> y >> zz) || l > 830) continue;
      ++rows;
      INFO(l << " nm");
      CHECK(std::abs(cie_y(Float(l)) - y) <= 1e-6 * (1 + y));
      CHECK(std::abs(cie_x(Float(l)) - x) <= 1e-6 * (1 + x));
      CHECK(std::abs(cie_z(Float(l)) - zz) <= 1e-6 * (1 + zz));
      if (prev[0] == l - 1) CHECK(std::abs(cie_y(Float(l - 0.5)) - (prev[2] + y) / 2) <= 1e-6 * (1 + y));
      prev[0] = l;
      prev[1] = x;
      prev[2] = y;
      prev[3] = zz;
    }
    CHECK(rows == 471);
  }
  // Planck's law with the CODATA 2018 constants (exact SI values).
  const double h = 6.62607015e-34, c = 299792458, kb = 1.380649e-23;
  for (double T : {1000.0, 2856.0, 6504.0})
    for (double l : {380.0, 555.0, 780.0, 2000.0}) {
      double lm = l * 1e-9, want = 2 * h * c * c / std::pow(lm, 5) / std::expm1(h * c / (lm * kb * T));
      // prism uses the CODATA 2010 h and k_B: relative differences ~1e-7,
      // amplified by the exponent's h c / (l k T) <= 15.
      CHECK(planck(l, T) == Approx(want).epsilon(1e-5));
    }
}

}  // namespace laws_reference_test
