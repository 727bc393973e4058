// The rough DielectricBxDF and ThinDielectricBxDF (bxdfs/dielectric.hpp):
// sampling against pdf on both lobes (chi-squared, windows fitted to narrow
// lobes), the white furnace in importance transport (<= 1 rough, = 1 smooth
// and thin), reciprocity of reflection and the adjoint relation of
// transmission, sample/eval/pdf agreement, convergence to the smooth
// interface, finiteness at grazing angles, dispersion with roughness, the
// thin slab's reflectance against its explicit series, and the materials.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <prism/bxdfs/bsdf.hpp>
#include <prism/bxdfs/dielectric.hpp>
#include <prism/spectra/traits.hpp>
#include <sstream>
#include <vector>
#include "bxdfs/bxdf_check.hpp"
#include "support/reference_physics.hpp"

namespace rough_dielectric_test {

using namespace prism;
using namespace bxdf_check;

namespace {
using S4 = SampledSpectrum<4>;
using W4 = SampledWavelengths<4>;
static_assert(BxDFLike<DielectricBxDF<S4>, S4>);
static_assert(BxDFLike<ThinDielectricBxDF<RGB>, RGB>);
static_assert(BxDFLike<ThinDielectricBxDF<S4>, S4>);

const Float test_alphas[] = {0.001f, 0.05f, 0.3f, 1.0f};
const double test_angles[] = {0.0, 45.0, 80.0, 89.9};

W4 fixed_wavelengths() { return W4::from({480, 550, 620, 700}, {1 / 470.f, 1 / 470.f, 1 / 470.f, 1 / 470.f}); }

// RGB mode: a constant eta 1.5. Spectral mode: N-BK7, dispersive, built
// through make() with the path's (non-const) wavelengths: eta at the hero.
template <class S>
DielectricBxDF<S> sweep_dielectric(MicrofacetRoughness r) {
  SurfaceInteraction si;
  if constexpr (std::is_same_v<S, RGB>) {
    RGBWavelengths l;
    return bxdf_traits<DielectricBxDF<S>>::make(DielectricMaterial{1.5f, "glass", r}, si, l);
  } else {
    W4 l = fixed_wavelengths();
    auto b = bxdf_traits<DielectricBxDF<S>>::make(DielectricMaterial{SellmeierIOR::glass("N-BK7"), "bk7", r}, si, l);
    REQUIRE(l.secondary_terminated());
    return b;
  }
}

constexpr int chi2_tests = 4 * 4 * 2 * 2 * 2;  // alphas x angles x sides x modes x lobes
const double chi2_level = prism_test::sidak_alpha(1e-3, chi2_tests);
double chi2_min_p = 1, chi2_max_p = 0;
int chi2_run = 0;

template <class S>
void chi2_sweep(PCG32& rng) {
  for (Float a : test_alphas) {
    auto bxdf = sweep_dielectric<S>(a);
    const Float eta = bxdf.eta();
    for (double side : {1.0, -1.0})
      for (double theta : test_angles) {
        Vector3f wo = direction_at(theta, 0.7, side);
        auto sample = [&]() -> std::optional<Vector3f> {
          auto bs = bxdf.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()}, TransportMode::radiance);
          if (!bs) return std::nullopt;
          return bs->wi;
        };
        auto pdf = [&](const Vector3f& wi) { return bxdf.pdf(wo, wi, TransportMode::radiance); };
        // Reflection lobe about the mirror direction.
        auto reflected = [&](const Vector3f& m) -> std::optional<Vector3f> {
          Vector3f wi = reflect(wo, m);
          return same_hemisphere(wo, wi) ? std::optional<Vector3f>(wi) : std::nullopt;
        };
        auto refracted = [&](const Vector3f& m) -> std::optional<Vector3f> {
          auto t = refract_dielectric(wo, m, eta);
          return t ? std::optional<Vector3f>(t->wt) : std::nullopt;
        };
        std::vector<std::pair<const char*, Window>> windows;
        windows.push_back({"reflection", lobe_window(reflected, Vector3f(-wo.x, -wo.y, wo.z), a, a)});
        // Transmission lobe about the macro refraction; beyond the critical
        // angle (no macro refraction) the whole far hemisphere. Either way
        // not closer to the horizon than the feasible edge:
        // |wi.z| >= |wo.z| / eta' (eta' = eta entering, 1 / eta leaving).
        const double z_min = std::abs(wo.z) / (side > 0 ? eta : 1 / eta);
        if (auto t = refract_dielectric(wo, Vector3f(0, 0, 1), eta))
          windows.push_back({"transmission", lobe_window(refracted, t->wt, a, a, z_min)});
        else
          windows.push_back({"transmission", hemisphere_window(side > 0 ? -1 : 1, z_min)});
        // Enough samples for >= 4000 in a weak lobe (outside reflection is
        // ~4%), judged by the smooth interface's R.
        const double R = fresnel_dielectric(wo.z, eta);
        for (const auto& [lobe, w] : windows) {
          double share = std::clamp(lobe[0] == 'r' ? R : 1 - R, 0.1, 1.0);
          auto r = chi2_window(sample, pdf, w, Chi2Config{size_t(40000 / share), 24, 24});
          INFO((is_spectral_v<S> ? "spectral" : "RGB") << " alpha " << a << " theta " << theta << " side " << side
                                                        << " " << lobe << ": " << r.summary());
          CHECK(r.p_value >= chi2_level);
          if (std::getenv("PRISM_CHI2_VERBOSE"))
            std::printf("%s a=%g th=%g side=%g %s: %s\n", is_spectral_v<S> ? "S" : "RGB", double(a), theta, side, lobe,
                        r.summary().c_str());
          chi2_min_p = std::min(chi2_min_p, r.p_value);
          chi2_max_p = std::max(chi2_max_p, r.p_value);
          ++chi2_run;
        }
      }
  }
}

// Reflectance of a slab summed bounce by bounce (double): R, then T R T,
// T R^3 T, ... ; the reference for ThinDielectricBxDF.
double thin_slab_series(double R) {
  double T = 1 - R, sum = R, term = T * R * T;
  for (int i = 0; i < 2000 && term > 1e-18; ++i) {
    sum += term;
    term *= R * R;
  }
  return sum;
}
}  // namespace

TEST_CASE("rough dielectric sample matches pdf on both lobes by chi-squared in RGB and spectral mode", "[bxdfs][dielectric][rough][chi2]") {
  PCG32 rng(71, 3);
  chi2_sweep<RGB>(rng);
  chi2_sweep<S4>(rng);
  CHECK(chi2_run == chi2_tests);
  WARN("rough dielectric chi2: " << chi2_run << " tests, p in [" << chi2_min_p << ", " << chi2_max_p << "], level "
                                 << chi2_level);
}

TEST_CASE("rough dielectric white furnace in importance transport is at most 1, smooth exactly 1", "[bxdfs][dielectric][rough][furnace]") {
  PCG32 rng(81, 4);
  // 2 sides x 4 angles x 4 alphas x RGB and spectral = 64 one-sided bounds,
  // one family at 10^-3 (Sidak): z = sidak_z(1e-3, 64) = 4.32.
  const double z = reference_physics::sidak_z(1e-3, 64);
  std::ostringstream out;
  out << "rough dielectric (eta 1.5) directional albedo R + T, importance transport:";
  for (double side : {1.0, -1.0})
    for (double theta : test_angles) {
      Vector3f wo = direction_at(theta, 0.7, side);
      // Smooth: every sample weighs exactly 1.
      for (Float a : {0.f, 1e-4f}) {
        Albedo s = albedo(sweep_dielectric<RGB>(a), wo, TransportMode::importance, 0, 2000, rng);
        // 1e-5, σ < 1e-6: each weight is 1 up to ~10 float roundings (6e-7)
        CHECK(s.mean == Approx(1).margin(1e-5));
        CHECK(s.sigma < 1e-6);
      }
      out << "\n  " << (side > 0 ? "outside" : "inside") << ", theta " << theta << ":";
      for (Float a : test_alphas) {
        Albedo r = albedo(sweep_dielectric<RGB>(a), wo, TransportMode::importance, 0, 60000, rng);
        Albedo s = albedo(sweep_dielectric<S4>(a), wo, TransportMode::importance, 0, 20000, rng);
        INFO("alpha " << a << " theta " << theta << " side " << side << ": " << r.mean << " +- " << r.sigma);
        CHECK(r.mean <= 1 + z * r.sigma + 1e-6);  // + float rounding of weights that are all 1
        CHECK(s.mean <= 1 + z * s.sigma + 1e-6);
        out << " alpha " << a << ": " << r.mean << " (+-" << r.sigma << ")";
      }
    }
  WARN(out.str());
}

TEST_CASE("rough dielectric albedo agrees between its own sampling and uniform sphere sampling", "[bxdfs][dielectric][rough][furnace]") {
  PCG32 rng(91, 5);
  // 2 alphas x 2 sides x 3 angles x 2 modes = 24 comparisons, one family at
  // 10^-3 (Sidak): z = sidak_z(1e-3, 24) = 4.10.
  const double z = reference_physics::sidak_z(1e-3, 24);
  for (Float a : {0.3f, 1.0f})
    for (double side : {1.0, -1.0})
      for (double theta : {0.0, 45.0, 80.0}) {
        auto bxdf = sweep_dielectric<RGB>(a);
        Vector3f wo = direction_at(theta, 0.7, side);
        for (auto mode : {TransportMode::radiance, TransportMode::importance}) {
          Albedo own = albedo(bxdf, wo, mode, 0, 100000, rng);
          const int n = 400000;
          double s = 0, s2 = 0;
          for (int i = 0; i < n; ++i) {
            Vector3f wi = sample_uniform_sphere({rng.next_float(), rng.next_float()});
            double v = double(bxdf.eval(wo, wi, mode)[0]) * std::abs(wi.z) / pdf_uniform_sphere();
            s += v;
            s2 += v * v;
          }
          double mean = s / n, sigma = std::sqrt((s2 / n - mean * mean) / (n - 1));
          INFO("alpha " << a << " theta " << theta << " side " << side << " mode " << int(mode) << ": own " << own.mean
                        << " +- " << own.sigma << ", uniform " << mean << " +- " << sigma);
          CHECK(std::abs(own.mean - mean) <= z * std::sqrt(own.sigma * own.sigma + sigma * sigma));
        }
      }
}

TEST_CASE("rough dielectric: reflection is reciprocal, transmission adjoint, sample agrees with eval and pdf", "[bxdfs][dielectric][rough][reciprocity]") {
  PCG32 rng(101, 6);
  for (Float a : test_alphas) {
    auto bxdf = sweep_dielectric<S4>(MicrofacetRoughness(a, a * 0.7f));
    const Float eta = bxdf.eta();
    int transmissions = 0, compared = 0;
    for (int i = 0; i < 400; ++i) {
      Vector3f x = sample_uniform_sphere({rng.next_float(), rng.next_float()});
      Vector3f y = sample_uniform_sphere({rng.next_float(), rng.next_float()});
      auto rad = [&](Vector3f o, Vector3f in) { return bxdf.eval(o, in, TransportMode::radiance)[0]; };
      auto imp = [&](Vector3f o, Vector3f in) { return bxdf.eval(o, in, TransportMode::importance)[0]; };
      INFO("alpha " << a << " x " << x.x << " " << x.y << " " << x.z << " y " << y.x << " " << y.y << " " << y.z);
      if (same_hemisphere(x, y)) {
        // 1e-4 relative: both orders share the float half vector; a few u in wo·h vs wi·h times Fresnel's conditioning
        CHECK(rad(x, y) == Approx(rad(y, x)).epsilon(1e-4).margin(1e-30));
        CHECK(rad(x, y) == imp(x, y));
      } else {
        // f_radiance(wo, wi) = f_importance(wi, wo); radiance carries the
        // 1/eta'^2 of the crossing (eta' = eta when wo is outside).
        Float etap = x.z > 0 ? eta : 1 / eta;
        // 1e-5 relative: one float division by η'² plus the eval's own roundings
        CHECK(rad(x, y) == Approx(imp(x, y) / (etap * etap)).epsilon(1e-5).margin(1e-30));
        // Both sides evaluate the same Fresnel T from their own cosine with
        // the microfacet; near the critical angle T has an infinite slope and
        // float cosines decide, so compare where both cosines exceed 0.05.
        Vector3f wm = normalize(y * etap + x);
        // cos > 0.05 bounds Fresnel T's condition number by ~1/cos² = 400: 400 × a few u ≈ 1e-4
        if (std::abs(dot(x, wm)) > 0.05f && std::abs(dot(y, wm)) > 0.05f) {
          CHECK(rad(x, y) == Approx(imp(y, x)).epsilon(1e-4).margin(1e-30));
          ++compared;
        }
      }
      for (auto mode : {TransportMode::radiance, TransportMode::importance}) {
        auto bs = bxdf.sample(x, rng.next_float(), {rng.next_float(), rng.next_float()}, mode);
        if (!bs) continue;
        CHECK_FALSE(bs->is_specular());
        CHECK(bs->pdf == bxdf.pdf(x, bs->wi, mode));
        CHECK(bs->f == bxdf.eval(x, bs->wi, mode));
        if (bs->is_transmission()) {
          ++transmissions;
          CHECK(bs->wi.z * x.z < 0);
          CHECK(bs->eta == (x.z > 0 ? eta : 1 / eta));
          CHECK(bs->flags == BxDFFlags::glossy_transmission);
        } else {
          CHECK(bs->wi.z * x.z > 0);
          CHECK(bs->eta == 1);
          CHECK(bs->flags == BxDFFlags::glossy_reflection);
        }
      }
    }
    CHECK(transmissions > 100);
    CHECK(compared > 50);
  }
}

TEST_CASE("nearly smooth rough dielectric converges to the smooth interface", "[bxdfs][dielectric][rough][smooth]") {
  // At alpha = 0.001 the reflected fraction is the smooth Fresnel R (up to
  // O(alpha^2) and the few samples masking turns away), and the transmitted
  // directions are within a few alpha of Snell's.
  PCG32 rng(111, 7);
  // The reflected fractions: 2 sides x 4 angles = 8 binomial comparisons, one
  // family at 10^-3 (Sidak): z = sidak_z(1e-3, 8) = 3.84.
  const double z = reference_physics::sidak_z(1e-3, 8);
  // The transmitted directions: a microfacet tilted by d in the plane of
  // incidence turns the refracted direction by c d, c = |1 - eta_i cos_i /
  // (eta_t cos_t)| (out of that plane by less), and GGX tilts have P(tan
  // theta_m > s) = alpha^2 / (alpha^2 + s^2): median alpha, with a sample
  // median's standard error alpha / sqrt(n). So the median deviation is at
  // most c alpha (1 + z_dev / sqrt(n)), and the fraction beyond 10 alpha at
  // most p = c^2 / (c^2 + 100), binomial. (A maximum over the samples has no
  // useful bound: GGX's tail reaches the critical angle from inside.) 6
  // transmitting cases x 2 checks, one family at 10^-3.
  const double alpha = 0.001, z_dev = reference_physics::sidak_z(1e-3, 12);
  for (double side : {1.0, -1.0})
    for (double theta : {0.0, 30.0, 45.0, 60.0}) {
      auto rough = sweep_dielectric<RGB>(0.001f);
      Vector3f wo = direction_at(theta, 0.7, side);
      Float R = fresnel_dielectric(wo.z, 1.5f);
      const int n = 20000;
      int reflected = 0;
      std::vector<double> dev;  // transmitted samples' angles from Snell's direction
      auto snell = refract_dielectric(wo, Vector3f(0, 0, 1), 1.5f);
      int failed = 0;
      for (int i = 0; i < n; ++i) {
        auto bs = rough.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()}, TransportMode::radiance);
        if (!bs) {  // a microfacet sends it below the surface: rare at this roughness
          ++failed;
          continue;
        }
        if (!bs->is_transmission())
          ++reflected;
        else if (snell)
          dev.push_back(angle_between(bs->wi, snell->wt));
      }
      double sigma = std::sqrt(n * double(R) * (1 - R));
      INFO("theta " << theta << " side " << side << ": reflected " << reflected << " of " << n << ", R " << R);
      CHECK(failed < n / 500);
      // 0.002·n: up to n/500 samples may fail (checked above), plus the O(α²) = 1e-6 model error
      CHECK(std::abs(reflected - n * double(R)) <= z * sigma + 0.002 * n);
      if (snell && R < 1) {
        REQUIRE(!dev.empty());
        const double eta_i = side > 0 ? 1.0 : 1.5, eta_t = side > 0 ? 1.5 : 1.0;
        const double c = std::abs(1 - eta_i * std::abs(double(wo.z)) / (eta_t * std::abs(double(snell->wt.z))));
        const double m = double(dev.size()), p = c * c / (c * c + 100);
        std::nth_element(dev.begin(), dev.begin() + std::ptrdiff_t(dev.size() / 2), dev.end());
        const double median = dev[dev.size() / 2];
        const double beyond = double(std::count_if(dev.begin(), dev.end(), [&](double d) { return d > 10 * alpha; }));
        INFO("deviation: c " << c << ", median " << median / alpha << " alpha, beyond 10 alpha " << beyond << " of " << m
                             << " (bound " << m * p << ")");
        CHECK(median <= c * alpha * (1 + z_dev / std::sqrt(m)));
        CHECK(beyond <= m * p + z_dev * std::sqrt(m * p * (1 - p)));
      }
    }
  // The smooth path is taken exactly below the threshold, and for eta = 1.
  for (Float a : {0.f, 1e-8f, 1e-4f}) {
    auto b = sweep_dielectric<RGB>(a);
    CHECK(b.is_smooth());
    CHECK(b.flags() == (BxDFFlags::specular_reflection | BxDFFlags::specular_transmission));
    auto bs = b.sample(direction_at(30), 0.99f, {0.2f, 0.3f}, TransportMode::radiance);
    REQUIRE(bs);
    CHECK(bs->flags == BxDFFlags::specular_transmission);
  }
  CHECK(sweep_dielectric<RGB>(TrowbridgeReitz::smooth_alpha).flags() ==
        (BxDFFlags::glossy_reflection | BxDFFlags::glossy_transmission));
  DielectricBxDF<RGB> matched(1.0f, TrowbridgeReitz(0.3f, 0.3f));
  CHECK(matched.flags() == BxDFFlags::specular_transmission);
  auto through = matched.sample(direction_at(40), 0.5f, {0.5f, 0.5f}, TransportMode::radiance);
  REQUIRE(through);
  // bare Approx: Catch's 100·FLT_EPSILON relative, a few float roundings of a unit direction
  CHECK(through->wi.x == Approx(-direction_at(40).x));
  CHECK(through->wi.z == Approx(-direction_at(40).z));
}

TEST_CASE("rough dielectric is finite at grazing angles, roughness 0, 1e-4, the threshold and 1, eta near 1", "[bxdfs][dielectric][rough][finite]") {
  PCG32 rng(121, 8);
  // The albedo bounds: 3 etas x 5 alphas x 2 cosines x 2 sides = 60, one
  // family at 10^-3 (Sidak): z = sidak_z(1e-3, 60) = 4.31.
  const double z = reference_physics::sidak_z(1e-3, 60);
  for (Float eta : {1.5f, 1.0001f, 2.4f})
    for (Float a : {0.f, 1e-4f, TrowbridgeReitz::smooth_alpha, 0.001f, 1.f})
      for (Float cz : {1e-8f, 1e-4f})
        for (Float side : {1.f, -1.f}) {
          DielectricBxDF<RGB> b(eta, TrowbridgeReitz(a, a));
          Vector3f wo(std::sqrt(1 - cz * cz) * 0.6f, std::sqrt(1 - cz * cz) * 0.8f, side * cz);
          INFO("eta " << eta << " alpha " << a << " cos " << cz << " side " << side);
          for (const Vector3f& wi : {Vector3f(-wo.x, -wo.y, wo.z), Vector3f(-wo.x, -wo.y, -wo.z), -wo,
                                     Vector3f(0, 0, side), Vector3f(0, 0, -side), Vector3f(0.6f, -0.8f, 1e-8f),
                                     Vector3f(-0.8f, 0.6f, -1e-4f)})
            check_finite<DielectricBxDF<RGB>, RGB>(b, wo, wi, rng);
          Albedo al = albedo(b, wo, TransportMode::importance, 0, 2000, rng);
          CHECK(std::isfinite(al.mean));
          // +1e-5: float rounding of weights ≤ 1 at degenerate inputs (a few u, with room for 1/cos near grazing)
          CHECK(al.mean <= 1 + z * al.sigma + 1e-5);
        }
}

TEST_CASE("rough dispersive dielectric terminates secondary wavelengths, the material validates roughness", "[bxdfs][dielectric][rough][dispersion][validate]") {
  SurfaceInteraction si;
  using T4 = bxdf_traits<DielectricBxDF<S4>>;
  DielectricMaterial frosted{SellmeierIOR::glass("N-SF11"), "frosted", {0.2f, 0.1f}};
  W4 w = W4::sample(0.4f);
  auto b = T4::make(frosted, si, w);
  CHECK(w.secondary_terminated());
  CHECK(b.eta() == frosted.ior(w[0]));
  CHECK(b.flags() == (BxDFFlags::glossy_reflection | BxDFFlags::glossy_transmission));
  CHECK(b.distribution().alpha_x() == 0.2f);
  CHECK(b.distribution().alpha_y() == 0.1f);
  CHECK(T4::needs_spectral(frosted));
  CHECK_FALSE(T4::has_specular(frosted));
  CHECK(T4::has_specular(DielectricMaterial{}));
  CHECK(DielectricMaterial{}.roughness.alpha_u == 0);
  CHECK((T4::flags & BxDFFlags::glossy_transmission) == BxDFFlags::glossy_transmission);
  W4 w2 = W4::sample(0.4f);
  T4::make(DielectricMaterial{1.5f, "rough_window", 0.3f}, si, w2);
  CHECK_FALSE(w2.secondary_terminated());

  CHECK_NOTHROW(T4::validate(frosted, "scene: material 0"));
  CHECK_THROWS_WITH(T4::validate(DielectricMaterial{1.5f, "etched", {std::nanf(""), 0.1f}}, "scene: material 2"),
                    Catch::StartsWith("scene: material 2: ") && Catch::Contains("'etched'") &&
                        Catch::Contains("roughness"));
  CHECK_THROWS_WITH(T4::validate(DielectricMaterial{1.5f, "negative", -0.1f}, "m"), Catch::Contains("'negative'"));
  CHECK_THROWS_WITH(T4::validate(DielectricMaterial{1.5f, "infinite", infinity}, "m"), Catch::Contains("'infinite'"));
}

TEST_CASE("thin dielectric reflectance equals the summed bounce series, furnace exactly 1", "[bxdfs][dielectric][thin]") {
  PCG32 rng(131, 9);
  // The reflected frequencies: 3 etas x 2 sides x 6 angles = 36 binomial
  // comparisons, one family at 10^-3 (Sidak): z = sidak_z(1e-3, 36) = 4.19.
  const double z = reference_physics::sidak_z(1e-3, 36);
  for (Float eta : {1.33f, 1.5f, 2.4f}) {
    ThinDielectricBxDF<RGB> thin(eta);
    for (double side : {1.0, -1.0})
      for (double theta : {0.0, 20.0, 45.0, 60.0, 80.0, 89.9}) {
        Vector3f wo = direction_at(theta, 0.7, side);
        double R = fresnel_dielectric(abs_cos_theta(wo), eta);
        RGB Rt = thin.reflectance(abs_cos_theta(wo));
        INFO("eta " << eta << " theta " << theta << " side " << side);
        CHECK(Rt.g == Approx(thin_slab_series(R)).margin(1e-6));  // 1e-6: R + T²R/(1 − R²) in float, ~8 roundings of values ≤ 1
        CHECK(Rt.g >= R);  // the slab reflects more than one interface
        // Sampled lobes: directions, weights and frequencies.
        const int n = 20000;
        int reflected = 0, failed = 0, bad_weight = 0, bad_direction = 0;
        double max_weight_err = 0;
        for (int i = 0; i < n; ++i) {
          for (auto mode : {TransportMode::radiance, TransportMode::importance}) {
            auto bs = thin.sample(wo, rng.next_float(), {0.5f, 0.5f}, mode);
            if (!bs || !bs->is_specular() || bs->eta != 1) {
              ++failed;
              continue;
            }
            // Furnace: every sample weighs 1.
            double err = std::abs(double(bs->f.g) * abs_cos_theta(bs->wi) / bs->pdf - 1);
            max_weight_err = std::max(max_weight_err, err);
            if (err > 1e-5) ++bad_weight;  // 1e-5: f·|cos|/pdf in float, a few roundings (≲ 6e-7)
            if (bs->is_transmission()) {
              if (!(bs->wi == -wo)) ++bad_direction;
            } else {
              if (!(bs->wi == Vector3f(-wo.x, -wo.y, wo.z))) ++bad_direction;
              if (mode == TransportMode::radiance) ++reflected;
            }
          }
        }
        INFO("max |weight - 1| " << max_weight_err);
        CHECK(failed == 0);
        CHECK(bad_weight == 0);
        CHECK(bad_direction == 0);
        double sigma = std::sqrt(n * double(Rt.g) * (1 - Rt.g));
        // z: Šidák as above; +1 for the integer count
        CHECK(std::abs(reflected - n * double(Rt.g)) <= z * sigma + 1);
      }
  }
  // Normal incidence, eta 1.5: R = 0.04, R' = 0.08 / 1.04.
  // 1e-7 ≈ 13 ulps of 0.077: a few float roundings of the slab series
  CHECK(ThinDielectricBxDF<RGB>(1.5f).reflectance(1).g == Approx(0.08 / 1.04).margin(1e-7));
  ThinDielectricBxDF<RGB> thin(1.5f);
  CHECK(thin.eval(direction_at(30), direction_at(30, 3.8), TransportMode::radiance).is_black());
  CHECK(thin.pdf(direction_at(30), direction_at(30, 3.8), TransportMode::radiance) == 0);
  CHECK(thin.flags() == (BxDFFlags::specular_reflection | BxDFFlags::specular_transmission));
  CHECK(ThinDielectricBxDF<RGB>(1.0f).flags() == BxDFFlags::specular_transmission);
  CHECK_FALSE(thin.sample({1, 0, 0}, 0.5f, {0.5f, 0.5f}, TransportMode::radiance));
  for (Float cz : {1e-8f, 1e-4f}) {
    Vector3f wo(std::sqrt(1 - cz * cz), 0, cz);
    check_finite<ThinDielectricBxDF<RGB>, RGB>(thin, wo, -wo, rng);
    check_finite<ThinDielectricBxDF<S4>, S4>(ThinDielectricBxDF<S4>(1.5f), wo, -wo, rng);
  }
}

TEST_CASE("thin dielectric material: per-wavelength eta without termination, validation, traits", "[bxdfs][dielectric][thin][material]") {
  SurfaceInteraction si;
  using T4 = bxdf_traits<ThinDielectricBxDF<S4>>;
  using TR = bxdf_traits<ThinDielectricBxDF<RGB>>;
  ThinDielectricMaterial pane{SellmeierIOR::glass("N-SF11"), "pane"};
  W4 w = fixed_wavelengths();
  auto b = T4::make(pane, si, w);
  CHECK_FALSE(w.secondary_terminated());  // the directions do not depend on eta
  for (int i = 0; i < 4; ++i) CHECK(b.eta()[i] == pane.ior(w[i]));
  S4 R = b.reflectance(0.8f);
  CHECK(R[0] > R[3]);  // blue: higher index, higher reflectance
  // The furnace is 1 per wavelength on average: E[f cos / pdf] = R' + T'
  // (stratified uc: the two lobes in proportion).
  for (double side : {1.0, -1.0})
    for (double theta : {0.0, 45.0, 80.0, 89.9}) {
      double sum[4] = {0, 0, 0, 0};
      const int n = 4000;
      for (int k = 0; k < n; ++k) {
        auto bs = b.sample(direction_at(theta, 0.7, side), (k + 0.5f) / n, {0.5f, 0.5f}, TransportMode::radiance);
        REQUIRE(bs);
        for (int i = 0; i < 4; ++i) sum[i] += bs->f[i] * abs_cos_theta(bs->wi) / bs->pdf / n;
      }
      INFO("theta " << theta << " side " << side);
      // 2e-3: midpoint rule over n = 4000 on a step: the fraction is off by ≤ 1/(2n) = 1.25e-4, times the
      // weights' spread across wavelengths (≲ 10 at 89.9°, where T' → 0)
      for (int i = 0; i < 4; ++i) CHECK(sum[i] == Approx(1).margin(2e-3));
    }
  CHECK(TR::make(pane, si, RGBWavelengths{}).eta() == RGB(pane.ior.eta_d()));
  CHECK(T4::needs_spectral(pane));
  CHECK_FALSE(T4::needs_spectral(ThinDielectricMaterial{1.5f, "window"}));
  CHECK(T4::name == "thin_dielectric");
  CHECK_NOTHROW(T4::validate(pane, "scene: material 5"));
  CHECK_THROWS_WITH(T4::validate(ThinDielectricMaterial{0.9f, "soap"}, "scene: material 5"),
                    Catch::StartsWith("scene: material 5: ") && Catch::Contains("'soap'"));
  // Through BSDF::from_material with the thin slab in a set.
  using Set = bxdf_set<DielectricBxDF<S4>, ThinDielectricBxDF<S4>>;
  SurfaceInteraction hit;
  hit.n = hit.ns = Normal3f(0, 0, 1);
  hit.dpdu = Vector3f(1, 0, 0);
  W4 w2 = fixed_wavelengths();
  auto bsdf = BSDF<S4, Set>::from_material(Set::material_variant{pane}, hit, w2);
  CHECK(bsdf.bxdf().index() == 1);
  CHECK_FALSE(w2.secondary_terminated());
}

}  // namespace rough_dielectric_test
