// TrowbridgeReitz (bxdfs/microfacet.hpp): D against the textbook tan/cos
// formula, Lambda against its closed form, D normalised over the projected
// area, the visible-normal distribution normalised, both VNDF samplers
// (Heitz 2018, spherical caps) against D_visible by chi-squared, the smooth
// threshold, and finiteness at grazing angles and tiny alphas.
#include <catch2/catch.hpp>
#include <cmath>
#include <prism/bxdfs/microfacet.hpp>
#include <vector>
#include "bxdfs/bxdf_check.hpp"

namespace microfacet_test {

using namespace prism;
using namespace bxdf_check;

namespace {
struct Alphas {
  Float ax, ay;
};
const Alphas test_alphas[] = {{0.001f, 0.001f}, {0.05f, 0.05f}, {0.3f, 0.3f}, {1.0f, 1.0f},
                              {0.05f, 0.3f},    {0.6f, 0.1f}};
const double test_angles[] = {0.0, 45.0, 80.0, 89.9};

// The integral over the upper hemisphere of f(theta, phi) sin(theta), on
// theta intervals growing geometrically from a * 1e-3 (so that a lobe of
// width a is resolved) and 128 phi intervals, 5x5 Gauss-Legendre points each.
template <class F>
double integrate_hemisphere(F&& f, double a) {
  std::vector<double> edges{0};
  for (double t = a * 1e-3; t < pi_d / 2; t *= 1.15) edges.push_back(t);
  edges.push_back(pi_d / 2);
  double sum = 0;
  auto g = [&](double theta, double phi) { return f(theta, phi) * std::sin(theta); };
  const int n_phi = 128;
  for (size_t i = 0; i + 1 < edges.size(); ++i)
    for (int j = 0; j < n_phi; ++j)
      sum += prism_test::integrate_2d(g, edges[i], edges[i + 1], 2 * pi_d * j / n_phi, 2 * pi_d * (j + 1) / n_phi, 1);
  return sum;
}
Vector3f sph(double theta, double phi) {
  return {Float(std::sin(theta) * std::cos(phi)), Float(std::sin(theta) * std::sin(phi)), Float(std::cos(theta))};
}

// The textbook forms, in double (pbrt-v4 book, eqs. 9.16 and 9.19).
double D_reference(double ax, double ay, double theta, double phi) {
  double t2 = std::tan(theta) * std::tan(theta), c4 = std::pow(std::cos(theta), 4);
  double e = t2 * (std::cos(phi) * std::cos(phi) / (ax * ax) + std::sin(phi) * std::sin(phi) / (ay * ay));
  return 1 / (pi_d * ax * ay * c4 * (1 + e) * (1 + e));
}
double lambda_reference(double ax, double ay, double theta, double phi) {
  double a2 = std::cos(phi) * std::cos(phi) * ax * ax + std::sin(phi) * std::sin(phi) * ay * ay;
  double t2 = std::tan(theta) * std::tan(theta);
  return (std::sqrt(1 + a2 * t2) - 1) / 2;
}
}  // namespace

TEST_CASE("Trowbridge-Reitz D and Lambda match the textbook formulas", "[bxdfs][microfacet]") {
  double max_rel_d = 0, max_rel_l = 0;
  for (const Alphas& a : test_alphas) {
    TrowbridgeReitz d(a.ax, a.ay);
    for (double theta : {0.0, 1e-4, 0.001, 0.01, 0.1, 0.5, 1.0, 1.4, 1.55}) {
      for (double phi : {0.0, 0.3, 1.2, 2.5, 4.0}) {
        Vector3f w = sph(theta, phi);
        // Reference at the float direction actually passed.
        double th = std::atan2(std::hypot(double(w.x), double(w.y)), double(w.z));
        double ph = std::atan2(double(w.y), double(w.x));
        double dr = D_reference(a.ax, a.ay, th, ph), lr = lambda_reference(a.ax, a.ay, th, ph);
        INFO("alpha (" << a.ax << ", " << a.ay << ") theta " << theta << " phi " << phi);
        // 2e-5 relative: D and Λ in float (~30 roundings: γ(64) = 3.8e-6) at θ up to 1.55, where tan θ ≈ 48 amplifies
        // the rounding of the direction's components (a few u times d ln D/d ln tan θ ≤ 4); 1e-12 absolute where Λ ≈ 0
        CHECK(d.D(w) == Approx(dr).epsilon(2e-5));
        CHECK(d.lambda(w) == Approx(lr).epsilon(2e-5).margin(1e-12));
        max_rel_d = std::max(max_rel_d, std::abs(d.D(w) / dr - 1));
        if (lr > 1e-6) max_rel_l = std::max(max_rel_l, std::abs(d.lambda(w) / lr - 1));
        // Masking is symmetric under w -> -w, and G1 in (0, 1].
        CHECK(d.lambda(-w) == d.lambda(w));
        CHECK(d.G1(w) > 0);
        CHECK(d.G1(w) <= 1);
      }
    }
    // Height-correlated G: between the product of the G1s and their minimum.
    PCG32 rng(9, 9);
    for (int i = 0; i < 200; ++i) {
      Vector3f wo = sample_uniform_hemisphere({rng.next_float(), rng.next_float()});
      Vector3f wi = sample_uniform_hemisphere({rng.next_float(), rng.next_float()});
      Float g = d.G(wo, wi);
      // 1e-6 relative: G, G1 in float (a few roundings of 1/(1 + Λ)), ~16u
      CHECK(g >= d.G1(wo) * d.G1(wi) * (1 - 1e-6f));
      CHECK(g <= std::min(d.G1(wo), d.G1(wi)) * (1 + 1e-6f));
    }
    // The horizon: D and G1 vanish there.
    CHECK(d.D(Vector3f(1, 0, 0)) == 0);
    CHECK(d.G1(Vector3f(0, 1, 0)) == 0);
    CHECK(d.D(Vector3f(0, 0, -1)) == 0);  // below: not a microfacet normal
  }
  WARN("D: max relative error " << max_rel_d << ", Lambda: " << max_rel_l << " (vs double tan/cos forms)");
}

TEST_CASE("D integrates to 1 over the projected area, D_visible to 1 over the hemisphere", "[bxdfs][microfacet][normalisation]") {
  double worst_d = 0, worst_v = 0;
  std::vector<Alphas> alphas(std::begin(test_alphas), std::end(test_alphas));
  alphas.push_back({1e-4f, 1e-4f});  // below the smooth threshold: still a finite, normalised D
  alphas.push_back({0.0003f, 0.0003f});
  for (const Alphas& a : alphas) {
    TrowbridgeReitz d(a.ax, a.ay);
    double amin = std::min(d.alpha_x(), d.alpha_y());
    double proj = integrate_hemisphere([&](double t, double p) { return double(d.D(sph(t, p))) * std::cos(t); }, amin);
    INFO("alpha (" << a.ax << ", " << a.ay << "): integral of D cos " << proj);
    // 2e-4: the Gauss–Legendre quadrature's and float D's error. Float D is off by ≤ float_tol + 8u/α per point,
    // which exceeds 2e-4 only below α ≈ 0.003 and averages out over the lobe (measured: 7.6e-8 for D cos, 3.4e-6 for D_visible)
    CHECK(proj == Approx(1).margin(2e-4));
    worst_d = std::max(worst_d, std::abs(proj - 1));
    for (double side : {1.0, -1.0})
      for (double theta : test_angles) {
        Vector3f wo = direction_at(theta, 0.7, side);
        double v = integrate_hemisphere([&](double t, double p) { return double(d.D_visible(wo, sph(t, p))); }, amin);
        INFO("wo theta " << theta << " side " << side << ": integral of D_visible " << v);
        CHECK(v == Approx(1).margin(2e-4));
        worst_v = std::max(worst_v, std::abs(v - 1));
      }
  }
  WARN("normalisation: max |integral - 1| " << worst_d << " (D cos), " << worst_v << " (D_visible)");
}

TEST_CASE("both VNDF samplers match D_visible by chi-squared", "[bxdfs][microfacet][chi2]") {
  const int tests = int(std::size(test_alphas)) * 4 * 2 * 2;
  const double level = prism_test::sidak_alpha(1e-3, tests);
  double min_p = 1, max_p = 0;
  PCG32 rng(11, 2024);
  for (const Alphas& a : test_alphas) {
    TrowbridgeReitz d(a.ax, a.ay);
    double amax = std::max(a.ax, a.ay);
    // Narrow distributions: a cap about +z of radius 10 alpha.
    Window w = amax < 0.1 ? cap_window(Vector3f(0, 0, 1), 10 * amax) : hemisphere_window(1);
    for (VNDFMethod m : {VNDFMethod::heitz2018, VNDFMethod::spherical_caps})
      for (double side : {1.0, -1.0})
        for (double theta : test_angles) {
          Vector3f wo = direction_at(theta, 0.7, side);
          auto sample = [&]() -> std::optional<Vector3f> {
            return d.sample_wm(wo, {rng.next_float(), rng.next_float()}, m);
          };
          auto pdf = [&](const Vector3f& wm) { return d.D_visible(wo, wm); };
          auto r = chi2_window(sample, pdf, w, Chi2Config{40000, 20, 24});
          INFO("alpha (" << a.ax << ", " << a.ay << ") method " << int(m) << " theta " << theta << " side " << side
                         << ": " << r.summary());
          CHECK(r.p_value >= level);
          if (std::getenv("PRISM_CHI2_VERBOSE"))
            std::printf("a=(%g,%g) m=%d th=%g side=%g: %s\n", double(a.ax), double(a.ay), int(m), theta, side,
                        r.summary().c_str());
          min_p = std::min(min_p, r.p_value);
          max_p = std::max(max_p, r.p_value);
        }
  }
  WARN("VNDF chi2: " << tests << " tests, p in [" << min_p << ", " << max_p << "], level " << level);
}

TEST_CASE("the two VNDF samplers return unit upper-hemisphere normals visible from wo", "[bxdfs][microfacet]") {
  PCG32 rng(3, 4);
  for (const Alphas& a : test_alphas)
    for (double side : {1.0, -1.0})
      for (double theta : test_angles) {
        TrowbridgeReitz d(a.ax, a.ay);
        Vector3f wo = direction_at(theta, 0.7, side);
        for (int i = 0; i < 500; ++i) {
          Point2f u{rng.next_float(), rng.next_float()};
          for (VNDFMethod m : {VNDFMethod::heitz2018, VNDFMethod::spherical_caps}) {
            Vector3f wm = d.sample_wm(wo, u, m);
            // 1e-6: float normalisation, a few ulps of 1; -1e-6: a visible normal at the horizon of wo rounds to either side
            CHECK(length(wm) == Approx(1).margin(1e-6));
            CHECK(wm.z >= 0);
            CHECK(dot(wo, wm) * Float(side) >= -1e-6f);
          }
        }
        // Corners of the unit square.
        for (Point2f u : {Point2f{0, 0}, Point2f{0, one_minus_epsilon}, Point2f{one_minus_epsilon, 0},
                          Point2f{one_minus_epsilon, one_minus_epsilon}})
          for (VNDFMethod m : {VNDFMethod::heitz2018, VNDFMethod::spherical_caps}) {
            Vector3f wm = d.sample_wm(wo, u, m);
            CHECK(std::isfinite(wm.x));
            CHECK(std::isfinite(wm.y));
            CHECK(std::isfinite(wm.z));
          }
      }
}

TEST_CASE("smooth threshold: alpha below the threshold is a delta, above it a finite lobe", "[bxdfs][microfacet][smooth]") {
  CHECK(TrowbridgeReitz().effectively_smooth());
  CHECK(TrowbridgeReitz(0, 0).effectively_smooth());
  CHECK(TrowbridgeReitz(1e-4f, 1e-4f).effectively_smooth());
  CHECK(TrowbridgeReitz(1e-8f, 1e-8f).effectively_smooth());
  CHECK(TrowbridgeReitz(std::nextafter(TrowbridgeReitz::smooth_alpha, 0.f), 0).effectively_smooth());
  CHECK_FALSE(TrowbridgeReitz(TrowbridgeReitz::smooth_alpha, TrowbridgeReitz::smooth_alpha).effectively_smooth());
  CHECK_FALSE(TrowbridgeReitz(0.001f, 0.001f).effectively_smooth());
  // Half smooth, half rough: the smooth axis is raised to the threshold.
  TrowbridgeReitz half(0, 0.2f);
  CHECK_FALSE(half.effectively_smooth());
  CHECK(half.alpha_x() == TrowbridgeReitz::smooth_alpha);
  CHECK(half.alpha_y() == 0.2f);
  // NaN and negative alphas are taken as 0.
  CHECK(TrowbridgeReitz(std::nanf(""), -1).effectively_smooth());
  CHECK(TrowbridgeReitz(MicrofacetRoughness::from_perceptual(0.5f)).alpha_x() == 0.25f);
  // The threshold is sqrt of the unit roundoff: cos(theta) of a microfacet
  // tilted by less rounds to 1.
  CHECK(TrowbridgeReitz::smooth_alpha == std::sqrt(machine_epsilon));
  CHECK(Float(std::cos(0.9 * TrowbridgeReitz::smooth_alpha)) == 1.0f);
  CHECK(Float(std::cos(1.5 * TrowbridgeReitz::smooth_alpha)) < 1.0f);
  // alpha = 0: D is 0 (a delta has no density), Lambda 0, and sampling
  // returns the macro normal.
  TrowbridgeReitz zero;
  CHECK(zero.D(Vector3f(0, 0, 1)) == 0);
  CHECK(zero.lambda(direction_at(60)) == 0);
  CHECK(zero.sample_wm(direction_at(60), {0.3f, 0.7f}) == Vector3f(0, 0, 1));
}

TEST_CASE("microfacet functions are finite at grazing angles and tiny alphas", "[bxdfs][microfacet][finite]") {
  PCG32 rng(5, 6);
  for (Float a : {0.f, 1e-8f, 1e-4f, 0.001f, 1.f, 4.f})
    for (Float cz : {1e-8f, 1e-4f, 0.5f, 1.f})
      for (Float side : {1.f, -1.f}) {
        TrowbridgeReitz d(a, a);
        Vector3f w(std::sqrt(1 - cz * cz), 0, side * cz);
        INFO("alpha " << a << " cos " << cz << " side " << side);
        CHECK(std::isfinite(d.lambda(w)));
        CHECK(std::isfinite(d.G1(w)));
        for (int i = 0; i < 50; ++i) {
          Point2f u{rng.next_float(), rng.next_float()};
          for (VNDFMethod m : {VNDFMethod::heitz2018, VNDFMethod::spherical_caps}) {
            Vector3f wm = d.sample_wm(w, u, m);
            CHECK(std::isfinite(wm.x + wm.y + wm.z));
            CHECK(std::isfinite(d.D(wm)));
            CHECK(std::isfinite(d.D_visible(w, wm)));
            CHECK(d.D_visible(w, wm) >= 0);
          }
          Vector3f wi = sample_uniform_sphere(u);
          CHECK(std::isfinite(d.G(w, wi)));
          CHECK(std::isfinite(d.D(wi)));
        }
      }
}

}  // namespace microfacet_test
