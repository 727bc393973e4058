// DielectricBxDF (bxdfs/dielectric.hpp): a dispersing prism's deviation
// against Snell's law in double precision, the Fresnel reflectance against the
// textbook s/p amplitude formulas (R + T = 1, normal incidence, Brewster, total
// internal reflection), the sampled lobe frequencies against Fresnel, the
// 1/eta^2 radiance scale and its absence in importance transport, and the rule
// that a dispersive material terminates the secondary wavelengths.
#include <catch2/catch.hpp>
#include <cmath>
#include <optional>
#include "prism/bxdfs/bsdf.hpp"
#include "prism/bxdfs/dielectric.hpp"
#include "prism/sampling/pcg32.hpp"
#include "prism/spectra/sampled.hpp"
#include "support/reference_physics.hpp"

namespace dielectric_test {

using namespace prism;

namespace {
using S4 = SampledSpectrum<4>;
using W4 = SampledWavelengths<4>;

static_assert(BxDFLike<DielectricBxDF<RGB>, RGB>);
static_assert(BxDFLike<DielectricBxDF<S4>, S4>);

constexpr double pi_d = 3.14159265358979323846;

// N-SF11 (SCHOTT catalogue), typed in here so that the reference does not go
// through prism's tables or SellmeierIOR.
double n_sf11(double lambda_nm) {
  const double B[3] = {1.73759695, 0.313747346, 1.89878101};
  const double C[3] = {0.013188707, 0.0623068142, 155.23629};
  double l2 = (lambda_nm / 1000) * (lambda_nm / 1000), n2 = 1;
  for (int i = 0; i < 3; ++i) n2 += B[i] * l2 / (l2 - C[i]);
  return std::sqrt(n2);
}

// Deviation of a ray through a prism of apex angle A (rad) at incidence theta1
// (rad) on the first face, by Snell's law twice.
double prism_deviation_reference(double n, double A, double theta1) {
  double r1 = std::asin(std::sin(theta1) / n);
  double r2 = A - r1;
  double theta2 = std::asin(n * std::sin(r2));
  return theta1 + theta2 - A;
}

// Unpolarised Fresnel reflectance and transmittance from the s and p amplitude
// coefficients, light going from index n1 into index n2 (double precision).
struct FresnelRef {
  double R, T;
};
FresnelRef fresnel_reference(double cos_i, double n1, double n2) {
  double sin_t = n1 / n2 * std::sqrt(std::max(0.0, 1 - cos_i * cos_i));
  if (sin_t >= 1) return {1, 0};
  double cos_t = std::sqrt(1 - sin_t * sin_t);
  double rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
  double rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
  double ts = 2 * n1 * cos_i / (n1 * cos_i + n2 * cos_t);
  double tp = 2 * n1 * cos_i / (n2 * cos_i + n1 * cos_t);
  // Power transmittance carries the ratio of beam cross-sections and impedances.
  double k = (n2 * cos_t) / (n1 * cos_i);
  return {(rs * rs + rp * rp) / 2, k * (ts * ts + tp * tp) / 2};
}

Vector3f direction_at(double theta_deg, double phi = 0.7, double side = 1) {
  double t = theta_deg * pi_d / 180;
  return {Float(std::sin(t) * std::cos(phi)), Float(std::sin(t) * std::sin(phi)), Float(side * std::cos(t))};
}

template <class S>
Float weight(const BSDFSample<S>& bs) {
  return bs.f[0] * abs_cos_theta(bs.wi) / bs.pdf;
}

// Traces a ray through the prism: apex at the origin pointing +y, faces in the
// xy plane with outward normals n1 (left) and n2 (right). Each refraction is a
// sample of the material's BxDF built at that face (its normal as the shading
// frame), the transmitted lobe chosen by uc. Returns the deviation (rad) and
// leaves lambda as the BxDF's make left it.
std::optional<double> trace_prism(const DielectricMaterial& m, W4& lambda, double A, double theta1) {
  using Set = bxdf_set<DielectricBxDF<S4>>;
  SurfaceInteraction si;
  Vector3f n1(Float(-std::cos(A / 2)), Float(std::sin(A / 2)), 0);
  Vector3f n2(Float(std::cos(A / 2)), Float(std::sin(A / 2)), 0);
  double phi = -A / 2 + theta1;  // -n1 rotated by theta1 towards the apex
  Vector3f d0(Float(std::cos(phi)), Float(std::sin(phi)), 0);
  const Float uc = 0.999f;  // above R at both faces: the transmitted lobe

  BSDF<S4, Set> face1(Frame::from_z(n1), bxdf_traits<DielectricBxDF<S4>>::make(m, si, lambda));
  auto in = face1.sample(-d0, uc, {0.5f, 0.5f}, TransportMode::radiance);
  if (!in || !in->is_transmission() || !in->is_specular()) return std::nullopt;
  BSDF<S4, Set> face2(Frame::from_z(n2), bxdf_traits<DielectricBxDF<S4>>::make(m, si, lambda));
  if (!(face2.frame().to_local(-in->wi).z < 0)) return std::nullopt;  // wo must be inside
  auto out = face2.sample(-in->wi, uc, {0.5f, 0.5f}, TransportMode::radiance);
  if (!out || !out->is_transmission()) return std::nullopt;
  // Unsigned angle between the incoming and outgoing directions.
  double ax = d0.x, ay = d0.y, bx = out->wi.x, by = out->wi.y;
  return std::atan2(std::abs(ax * by - ay * bx), ax * bx + ay * by);
}
}  // namespace

TEST_CASE("prism deviation at 10 wavelengths matches Snell's law with Sellmeier N-SF11", "[bxdfs][dielectric][dispersion][prism]") {
  const double A = 60 * pi_d / 180, theta1 = 65 * pi_d / 180;
  DielectricMaterial glass{SellmeierIOR::glass("N-SF11"), "prism"};
  double max_err = 0, prev = 1e9;
  for (int i = 0; i < 10; ++i) {
    Float lambda = Float(400 + 40 * i);
    W4 w = W4::from({lambda, 500, 600, 700}, {1 / 470.f, 1 / 470.f, 1 / 470.f, 1 / 470.f});
    auto dev = trace_prism(glass, w, A, theta1);
    REQUIRE(dev);
    double ref = prism_deviation_reference(n_sf11(double(lambda)), A, theta1);
    double err = std::abs(*dev - ref);
    max_err = std::max(max_err, err);
    INFO("lambda " << lambda << " nm: deviation " << *dev << " rad, reference " << ref << ", error " << err);
    // 1e-5 rad: two float refractions (~10 roundings of unit components each, ≤ 6e-7) amplified ≤ ~5 at the 65° entry, plus float Sellmeier n (dδ/dn ≈ 3 rad × 1e-7)
    CHECK(err < 1e-5);
    CHECK(w.secondary_terminated());  // dispersive: only the hero goes on
    CHECK(ref < prev);                // blue bends more than red
    prev = ref;
  }
  // The spread is what makes a rainbow: about 10.5 degrees from 400 to 760 nm.
  // 1e-3 rad ≈ 0.06°: the spread is quoted as "about 10.5 degrees" (0.1831 rad to 4 digits); double arithmetic, no rounding to speak of
  CHECK(prism_deviation_reference(n_sf11(400), A, theta1) - prism_deviation_reference(n_sf11(760), A, theta1) ==
        Approx(0.1831).margin(1e-3));
  WARN("prism deviation: max |error| " << max_err << " rad over 10 wavelengths");
}

TEST_CASE("Fresnel reflectance: textbook s/p formulas, R + T = 1, normal incidence, Brewster, TIR", "[bxdfs][dielectric][fresnel]") {
  double max_err = 0;
  // The reference gets the same (float) eta and cosines as the function.
  for (double eta : {double(1.0001f), double(1.33f), double(1.5f), double(1.78472f), double(2.42f)}) {
    INFO("eta " << eta);
    // Normal incidence from either side.
    double r0 = ((eta - 1) / (eta + 1)) * ((eta - 1) / (eta + 1));
    // 1e-7: float Fresnel at normal incidence, ~6 roundings of r0 ≤ 0.17: 6·2^-24·0.17 ≈ 6e-8
    CHECK(fresnel_dielectric(1, Float(eta)) == Approx(r0).margin(1e-7));
    CHECK(fresnel_dielectric(-1, Float(eta)) == Approx(r0).margin(1e-7));
    for (int deg = 0; deg < 90; ++deg) {
      double c = double(Float(std::cos(deg * pi_d / 180)));
      INFO("theta " << deg);
      // Outside in.
      FresnelRef o = fresnel_reference(c, 1, eta);
      Float R = fresnel_dielectric(Float(c), Float(eta));
      // 1e-12: the double reference's own rounding (~20 roundings of 2^-53 ≈ 2e-15), with room for cancellation near grazing
      CHECK(o.R + o.T == Approx(1).margin(1e-12));
      // 1e-6: float Fresnel, ~15 roundings of terms ≤ 1: 15·2^-24 ≈ 9e-7
      CHECK(double(R) + o.T == Approx(1).margin(1e-6));
      max_err = std::max(max_err, std::abs(double(R) - o.R));
      // Inside out (cos < 0).
      FresnelRef i = fresnel_reference(c, eta, 1);
      Float Ri = fresnel_dielectric(Float(-c), Float(eta));
      CHECK(double(Ri) + i.T == Approx(1).margin(1e-6));
      max_err = std::max(max_err, std::abs(double(Ri) - i.R));
      double sin_i = std::sqrt(1 - c * c);
      if (eta * sin_i > 1) CHECK(Ri == 1);  // beyond the critical angle
      if (eta * sin_i < 0.99999) CHECK(Ri < 1);
    }
    // Brewster's angle tan(theta_B) = eta: p is not reflected, R = R_s / 2.
    double tb = std::acos(double(Float(std::cos(std::atan(eta)))));
    FresnelRef b = fresnel_reference(std::cos(tb), 1, eta);
    double ct = std::cos(std::asin(std::sin(tb) / eta));
    double rs = (std::cos(tb) - eta * ct) / (std::cos(tb) + eta * ct);
    // 1e-12: double rounding of both references; 1e-6 as above (float Fresnel, ~15 roundings)
    CHECK(b.R == Approx(rs * rs / 2).margin(1e-12));
    CHECK(fresnel_dielectric(Float(std::cos(tb)), Float(eta)) == Approx(rs * rs / 2).margin(1e-6));
  }
  INFO("max |R - reference| " << max_err);
  // 1e-6: the float Fresnel bound above, over all angles and etas
  CHECK(max_err < 1e-6);
  WARN("Fresnel: max |R - double reference| " << max_err);
  // Critical angle of eta = 1.5 from inside: 41.81 degrees.
  CHECK(fresnel_dielectric(-std::cos(radians(41.7f)), 1.5f) < 1);
  CHECK(fresnel_dielectric(-std::cos(radians(41.9f)), 1.5f) == 1);
}

TEST_CASE("sampled lobes: reflect/transmit frequencies match Fresnel (Sidak z), directions obey Snell", "[bxdfs][dielectric][sampling]") {
  PCG32 rng(5, 20240611);
  const int n = 100000;
  for (Float eta : {1.33f, 1.5f, 2.42f}) {
    DielectricBxDF<RGB> bxdf(eta);
    for (double side : {1.0, -1.0})
      for (double theta : {0.0, 20.0, 40.0, 50.0, 70.0, 85.0}) {
        Vector3f wo = direction_at(theta, 0.7, side);
        Float R = fresnel_dielectric(wo.z, eta);
        int reflected = 0, failed = 0, other = 0;
        for (int k = 0; k < n; ++k) {
          Float uc = rng.next_float();
          auto bs = bxdf.sample(wo, uc, {rng.next_float(), rng.next_float()}, TransportMode::importance);
          if (!bs) {
            ++failed;
            continue;
          }
          if (bs->flags == BxDFFlags::specular_reflection) {
            ++reflected;
            if (k < 50) {
              CHECK(bs->wi.x == -wo.x);
              CHECK(bs->wi.y == -wo.y);
              CHECK(bs->wi.z == wo.z);
              // bare Approx: Catch's 100·FLT_EPSILON ≈ 1.2e-5 relative, a few float roundings of the pdf and eta
              CHECK(bs->pdf == Approx(R));
              CHECK(bs->eta == 1);
            }
          } else if (bs->flags != BxDFFlags::specular_transmission) {
            ++other;
          } else {
            if (k < 50) {
              Float etap = side > 0 ? eta : 1 / eta;
              CHECK(bs->eta == Approx(etap));
              CHECK(bs->wi.z * wo.z < 0);
              // 1e-6: float refraction, ~8 roundings of unit components: 8·2^-24 ≈ 5e-7
              CHECK(length(bs->wi) == Approx(1).margin(1e-6));
              // Snell: the tangential part flips and shrinks by 1/eta'.
              CHECK(bs->wi.x == Approx(-wo.x / etap).margin(1e-6));
              CHECK(bs->wi.y == Approx(-wo.y / etap).margin(1e-6));
              CHECK(bs->pdf == Approx(1 - R));
            }
          }
        }
        CHECK(failed == 0);
        CHECK(other == 0);
        double mean = n * double(R), sigma = std::sqrt(n * double(R) * (1 - double(R)));
        INFO("eta " << eta << " side " << side << " theta " << theta << ": R " << R << ", reflected " << reflected
                    << " of " << n << ", expected " << mean << " +- " << sigma);
        if (R == 1)
          CHECK(reflected == n);  // total internal reflection
        else
          // z: Šidák over at most 36 comparisons (3 η × 2 sides × 6 angles); σ the binomial one; +1 for the integer count
          CHECK(std::abs(reflected - mean) <= reference_physics::sidak_z(1e-3, 36) * sigma + 1);
      }
  }
}

TEST_CASE("radiance transport scales refraction by 1/eta squared, importance transport does not", "[bxdfs][dielectric][reciprocity]") {
  for (Float eta : {1.33f, 1.5f, 1.78f}) {
    DielectricBxDF<S4> bxdf(eta);
    for (double side : {1.0, -1.0})
      for (double theta : {0.0, 15.0, 30.0, 40.0, 60.0, 80.0}) {
        Vector3f wo = direction_at(theta, 2.1, side);
        Float R = fresnel_dielectric(wo.z, eta);
        INFO("eta " << eta << " side " << side << " theta " << theta);
        // Reflection: weight 1 in both modes.
        for (auto mode : {TransportMode::radiance, TransportMode::importance}) {
          auto r = bxdf.sample(wo, 0, {0.5f, 0.5f}, mode);
          REQUIRE(r);
          CHECK(r->flags == BxDFFlags::specular_reflection);
          // 1e-5 relative: f·|cos|/pdf in float, ~10 roundings (6e-7) with room for the η'² scale
          CHECK(weight(*r) == Approx(1).epsilon(1e-5));
        }
        if (R == 1) continue;  // total internal reflection: no refraction
        auto t_rad = bxdf.sample(wo, 0.9999f, {0.5f, 0.5f}, TransportMode::radiance);
        auto t_imp = bxdf.sample(wo, 0.9999f, {0.5f, 0.5f}, TransportMode::importance);
        REQUIRE(t_rad);
        REQUIRE(t_imp);
        REQUIRE(t_rad->is_transmission());
        Float etap = side > 0 ? eta : 1 / eta;
        CHECK(t_rad->eta == Approx(etap));
        CHECK(weight(*t_imp) == Approx(1).epsilon(1e-5));
        CHECK(weight(*t_rad) == Approx(1 / (etap * etap)).epsilon(1e-5));
        CHECK(t_rad->wi == t_imp->wi);
        // Every wavelength of a non-dispersive glass carries the same value.
        for (int k = 1; k < 4; ++k) CHECK(t_rad->f[k] == t_rad->f[0]);
        // The reverse crossing retraces the path with the same Fresnel T, and
        // the radiance scales of the two crossings cancel.
        auto back = bxdf.sample(t_rad->wi, 0.9999f, {0.5f, 0.5f}, TransportMode::radiance);
        REQUIRE(back);
        REQUIRE(back->is_transmission());
        // 2e-6: two float refractions (~8 roundings of unit components each: 2 × 5e-7) and the η' rescaling between them
        CHECK(back->wi.x == Approx(wo.x).margin(2e-6));
        CHECK(back->wi.y == Approx(wo.y).margin(2e-6));
        CHECK(back->wi.z == Approx(wo.z).margin(2e-6));
        // 1e-6: 1 − R by float Fresnel (~15 roundings ≤ 9e-7) at cosines that differ by a few ulps
        CHECK(back->pdf == Approx(t_rad->pdf).margin(1e-6));
        CHECK(weight(*back) * weight(*t_rad) == Approx(1).epsilon(1e-5));
        // Expected weight over uc: R + T (importance, energy conserved) and
        // R + T / eta'^2 (radiance).
        Float T = 1 - R;
        auto mean_weight = [&](TransportMode mode) {
          double s = 0;
          const int m = 1000;
          for (int k = 0; k < m; ++k)
            if (auto bs = bxdf.sample(wo, (k + Float(0.5)) / m, {0.5f, 0.5f}, mode)) s += weight(*bs);
          return s / m;
        };
        // 2e-3: midpoint rule on a step: the reflected fraction is off by ≤ 1/(2m) = 5e-4, times the step |1 − 1/η'²| ≤ 2.2: ≤ 1.1e-3
        CHECK(mean_weight(TransportMode::importance) == Approx(1).margin(2e-3));
        CHECK(mean_weight(TransportMode::radiance) == Approx(R + T / (etap * etap)).margin(2e-3));
      }
  }
}

TEST_CASE("dielectric is specular: eval and pdf are 0, flags are the two specular lobes", "[bxdfs][dielectric]") {
  DielectricBxDF<RGB> glass(1.5f);
  Vector3f wo = direction_at(30), wi = direction_at(30, 0.7 + pi_d);
  CHECK(glass.eval(wo, wi, TransportMode::radiance).is_black());
  CHECK(glass.pdf(wo, wi, TransportMode::radiance) == 0);
  CHECK(glass.flags() == (BxDFFlags::specular_reflection | BxDFFlags::specular_transmission));
  CHECK((bxdf_traits<DielectricBxDF<RGB>>::flags & glass.flags()) == glass.flags());  // smooth: a subset of the lobes it may have
  CHECK(bxdf_traits<DielectricBxDF<RGB>>::name == "dielectric");
  CHECK(DielectricBxDF<RGB>(1.0f).flags() == BxDFFlags::specular_transmission);
  CHECK_FALSE(glass.sample({0, 1, 0}, 0.5f, {0.5f, 0.5f}, TransportMode::radiance));  // grazing wo
}

TEST_CASE("a dispersive material terminates secondary wavelengths, a non-dispersive one does not, RGB uses eta_d", "[bxdfs][dielectric][dispersion][wavelengths]") {
  SurfaceInteraction si;
  using Traits4 = bxdf_traits<DielectricBxDF<S4>>;
  const DielectricMaterial bk7{SellmeierIOR::glass("N-BK7"), "bk7"};
  const DielectricMaterial abbe{AbbeIOR::from_abbe_number(1.5f, 40), "abbe"};
  const DielectricMaterial constant{1.5f, "constant"};
  const DielectricMaterial abbe_flat{AbbeIOR{1.6f, 0}, "abbe_flat"};

  for (const DielectricMaterial* m : {&bk7, &abbe}) {
    INFO(m->name);
    W4 w = W4::sample(0.37f);
    Float pdf0 = w.pdf()[0];
    REQUIRE_FALSE(w.secondary_terminated());
    auto b = Traits4::make(*m, si, w);
    CHECK(w.secondary_terminated());
    // bare Approx: Catch's 100·FLT_EPSILON relative; dividing by 4 is exact in float
    CHECK(w.pdf()[0] == Approx(pdf0 / 4));
    for (int k = 1; k < 4; ++k) CHECK(w.pdf()[k] == 0);
    CHECK(b.eta() == m->ior(w[0]));
    // Building again at the next vertex keeps the hero's density.
    Traits4::make(*m, si, w);
    CHECK(w.pdf()[0] == Approx(pdf0 / 4));
    // Const wavelengths: the hero's eta, nothing terminated.
    const W4 cw = W4::sample(0.37f);
    auto bc = Traits4::make(*m, si, cw);
    CHECK(bc.eta() == m->ior(cw[0]));
    CHECK_FALSE(cw.secondary_terminated());
  }
  for (const DielectricMaterial* m : {&constant, &abbe_flat}) {
    INFO(m->name);
    W4 w = W4::sample(0.37f);
    auto before = w.pdf();
    auto b = Traits4::make(*m, si, w);
    CHECK_FALSE(w.secondary_terminated());
    CHECK(w.pdf() == before);
    CHECK(b.eta() == m->ior.eta_d());
  }

  // Through BSDF::from_material with the integrator's non-const wavelengths.
  using Set = bxdf_set<DielectricBxDF<S4>>;
  W4 w = W4::sample(0.81f);
  auto bsdf = BSDF<S4, Set>::from_material(Set::material_variant{bk7}, si, w);
  CHECK(w.secondary_terminated());
  CHECK(std::get<0>(bsdf.bxdf()).eta() == bk7.ior(w[0]));
  W4 w2 = W4::sample(0.81f);
  BSDF<S4, Set>::from_material(Set::material_variant{constant}, si, w2);
  CHECK_FALSE(w2.secondary_terminated());

  // RGB: eta at the d line (N-BK7 n_d = 1.51680; an Abbe law's eta_d).
  RGBWavelengths rgb;
  using TraitsRGB = bxdf_traits<DielectricBxDF<RGB>>;
  // 1e-5: SCHOTT quotes n_d to 5 decimals (±5e-6), plus float Sellmeier (~10 roundings of 1.5: 1e-6); 2e-6 ≈ 16 ulps of 1.5 for the Abbe law
  CHECK(TraitsRGB::make(bk7, si, rgb).eta() == Approx(1.51680).margin(1e-5));
  CHECK(TraitsRGB::make(abbe, si, rgb).eta() == Approx(1.5).margin(2e-6));
  CHECK(TraitsRGB::make(constant, si, rgb).eta() == 1.5f);
  const RGBWavelengths crgb;
  CHECK(TraitsRGB::make(bk7, si, crgb).eta() == bk7.ior.eta_d());
}

TEST_CASE("DielectricMaterial validation names the material, and dispersion asks for spectral rendering", "[bxdfs][dielectric][validate]") {
  CHECK_NOTHROW(DielectricMaterial{SellmeierIOR::glass("water_20C"), "pool"}.validate());
  CHECK_THROWS_WITH((DielectricMaterial{AbbeIOR{1.02f, 300.f}, "flint_typo"}.validate()),
                    Catch::Contains("flint_typo"));
  CHECK_THROWS_AS((DielectricMaterial{1.0f, "index_matched"}.validate()), Error);
  // The bxdf_traits hooks Scene::build and Scene::needs_spectral call.
  using Traits = bxdf_traits<DielectricBxDF<RGB>>;
  CHECK_NOTHROW(Traits::validate(DielectricMaterial{SellmeierIOR::glass("N-BK7"), "lens"}, "scene: material 2"));
  CHECK_THROWS_WITH(Traits::validate(DielectricMaterial{AbbeIOR{1.02f, 300.f}, "flint_typo"}, "scene: material 2"),
                    Catch::StartsWith("scene: material 2: ") && Catch::Contains("'flint_typo'"));
  CHECK(Traits::needs_spectral(DielectricMaterial{SellmeierIOR::glass("N-BK7"), "lens"}));
  CHECK(Traits::needs_spectral(DielectricMaterial{AbbeIOR{1.5f, 0.5f}, "abbe"}));
  CHECK_FALSE(Traits::needs_spectral(DielectricMaterial{1.5f, "window"}));
  CHECK_FALSE(Traits::needs_spectral(DielectricMaterial{AbbeIOR{1.5f, 0}, "abbe_flat"}));
}

}  // namespace dielectric_test
