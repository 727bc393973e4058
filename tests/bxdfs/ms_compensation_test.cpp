// Kulla-Conty multiple-scattering compensation of rough conductors
// (bxdfs/ms_compensation.hpp): with F = 1 the lobe pair reflects 1 at every
// angle and roughness, up to the albedo table's own error, which the test
// measures against a fresh estimate; sample() matches pdf() (chi-squared);
// eval stays reciprocal; a coloured metal gains energy but stays below 1.
#include <catch2/catch.hpp>
#include <prism/prism.hpp>
#include "bxdfs/bxdf_check.hpp"
#include "support/reference_physics.hpp"

namespace ms_compensation_test {

using namespace prism;
using namespace bxdf_check;

namespace {

// eta = 0, k = 1: a lossless plasma, F = 1 at every angle.
ConductorBxDF<RGB> white(Float alpha, bool ms) {
  ConductorBxDF<RGB> b(TrowbridgeReitz(alpha, alpha), RGB(0), RGB(1));
  if (ms) b.enable_multiple_scattering();
  return b;
}

// The single-scattering albedo for F = 1 at (mu, alpha), independently of
// the table: 256 x 256 strata of the visible normals.
double reference_E(double theta_deg, Float alpha) { return microfacet_reference(direction_at(theta_deg), alpha).E; }

}  // namespace

TEST_CASE("multiple scattering: a white rough conductor reflects 1 at every angle", "[bxdfs][conductor][furnace][ms]") {
  PCG32 rng(5, 17);
  // 4 alphas x 3 angles x 3 comparisons (the compensated albedo, the gain's
  // lower bound, and the gain where the loss exceeds twice the noise): m = 36,
  // one family at 10^-3 (Sidak): z = sidak_z(1e-3, 36) = 4.19.
  const double z = reference_physics::sidak_z(1e-3, 36);
  std::ostringstream report;
  report << "F = 1 directional albedo, single / with compensation:";
  for (Float alpha : {0.05f, 0.3f, 0.6f, 1.0f})
    for (double theta : {0.0, 45.0, 80.0}) {
      Vector3f wo = direction_at(theta);
      Albedo ss = albedo(white(alpha, false), wo, TransportMode::radiance, 1, 100000, rng);
      Albedo ms = albedo(white(alpha, true), wo, TransportMode::radiance, 1, 100000, rng);
      // The identity holds for the tabulated E: the result is 1 + E - E_table.
      double table_err = std::abs(reference_E(theta, alpha) - MicrofacetAlbedoTable::get().E(wo.z, alpha));
      INFO("alpha " << alpha << " theta " << theta << ": single " << ss.mean << " +- " << ss.sigma << ", with ms "
                    << ms.mean << " +- " << ms.sigma << ", table error " << table_err);
      CHECK(std::abs(ms.mean - 1) <= z * ms.sigma + table_err);
      // The compensation adds energy: never less beyond the noise, and more
      // wherever the single-scattering loss exceeds it.
      double noise = z * std::sqrt(ss.sigma * ss.sigma + ms.sigma * ms.sigma);
      CHECK(ms.mean - ss.mean >= -noise);
      if (1 - ss.mean > 2 * noise) CHECK(ms.mean > ss.mean);
      report << "\n  alpha " << alpha << " theta " << theta << ": " << ss.mean << " / " << ms.mean << " (+-"
             << ms.sigma << ", table error " << table_err << ")";
    }
  WARN(report.str());
}

TEST_CASE("multiple scattering: sample matches pdf, eval is reciprocal, coloured metals stay below 1",
          "[bxdfs][conductor][chi2][ms]") {
  PCG32 rng(9, 3);
  // One family at 10^-3 (Sidak) over the 6 chi-squared tests (2 alphas x 3
  // angles) and the 18 albedo bounds (x 3 channels): m = 24, z = 4.10.
  const int m = 6 + 18;
  const double level = prism_test::sidak_alpha(1e-3, m);
  const double z = reference_physics::sidak_z(1e-3, m);
  for (Float alpha : {0.3f, 1.0f})
    for (double theta : {0.0, 45.0, 80.0}) {
      ConductorBxDF<RGB> b(TrowbridgeReitz(alpha, alpha), RGB(0.2f, 0.9f, 1.2f), RGB(3.0f, 2.5f, 2.0f));
      b.enable_multiple_scattering();
      REQUIRE(b.multiple_scattering());
      Vector3f wo = direction_at(theta);
      auto sample = [&]() -> std::optional<Vector3f> {
        auto bs = b.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()}, TransportMode::radiance);
        if (!bs) return std::nullopt;
        return bs->wi;
      };
      auto pdf = [&](const Vector3f& wi) { return b.pdf(wo, wi, TransportMode::radiance); };
      auto r = chi2_window(sample, pdf, hemisphere_window(1), Chi2Config{100000, 32, 64});
      INFO("alpha " << alpha << " theta " << theta << ": " << r.summary());
      CHECK(r.p_value >= level);
      // Reciprocity and the energy bound.
      for (int k = 0; k < 100; ++k) {
        Vector3f wi = sample_cosine_hemisphere({rng.next_float(), rng.next_float()});
        RGB a = b.eval(wo, wi, TransportMode::radiance), c = b.eval(wi, wo, TransportMode::radiance);
        // 1e-4 relative: both orders share the float half vector; a few u in wo·h vs wi·h through Fresnel, and symmetric table lookups
        for (int ch = 0; ch < 3; ++ch) CHECK(a[ch] == Approx(c[ch]).epsilon(1e-4));
      }
      for (int ch = 0; ch < 3; ++ch) {
        Albedo al = albedo(b, wo, TransportMode::radiance, ch, 50000, rng);
        CHECK(al.mean <= 1 + z * al.sigma);
      }
    }
}

TEST_CASE("multiple scattering through ConductorMaterial, off by default", "[bxdfs][conductor][ms]") {
  ConductorMaterial m = ConductorMaterial::metal("Au", MicrofacetRoughness{0.5f, 0.5f});
  SurfaceInteraction si;
  CHECK_FALSE(bxdf_traits<ConductorBxDF<RGB>>::make(m, si, RGBWavelengths{}).multiple_scattering());
  m.multiple_scattering = true;
  CHECK(bxdf_traits<ConductorBxDF<RGB>>::make(m, si, RGBWavelengths{}).multiple_scattering());
  // Smooth conductors have nothing to compensate.
  m.roughness = MicrofacetRoughness{0, 0};
  CHECK_FALSE(bxdf_traits<ConductorBxDF<RGB>>::make(m, si, RGBWavelengths{}).multiple_scattering());
}

}  // namespace ms_compensation_test
