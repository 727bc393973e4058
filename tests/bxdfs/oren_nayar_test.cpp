// The user-defined Oren–Nayar BxDF of examples/oren_nayar.hpp, tested from
// outside include/: its sampling against its pdf (chi-squared), its furnace
// (albedo <= 1, = rho at sigma = 0 and at grazing incidence), reciprocity,
// validation through its bxdf_traits, and scenes built with
// default_bxdf_set<S>::with<OrenNayarBxDF<S>> in RGB and spectral mode.
#include <catch2/catch.hpp>
#include <cmath>
#include <prism/prism.hpp>
#include <sstream>
#include "bxdfs/bxdf_check.hpp"
#include "oren_nayar.hpp"
#include "support/reference_physics.hpp"

namespace oren_nayar_test {

using namespace prism;
using namespace bxdf_check;
using example::OrenNayarBxDF;
using example::OrenNayarMaterial;

namespace {
using S4 = SampledSpectrum<4>;
static_assert(BxDFLike<OrenNayarBxDF<RGB>, RGB>);
static_assert(BxDFLike<OrenNayarBxDF<S4>, S4>);
template <class S>
using ONSet = typename default_bxdf_set<S>::template with<OrenNayarBxDF<S>>;
static_assert(ONSet<RGB>::size == default_bxdf_set<RGB>::size + 1);

const Float test_sigmas[] = {0.f, 0.3f, 0.7f, 1.f};
const double test_angles[] = {0.0, 45.0, 80.0, 89.9};
}  // namespace

TEST_CASE("Oren-Nayar sampling matches its pdf by chi-squared, both sides", "[bxdfs][oren_nayar][extension][chi2]") {
  PCG32 rng(404, 2);
  const int tests = 2 * 4;
  const double level = prism_test::sidak_alpha(1e-3, tests);
  double min_p = 1;
  for (double side : {1.0, -1.0})
    for (double theta : test_angles) {
      OrenNayarBxDF<RGB> b(RGB(0.7f), 1.0f);
      Vector3f wo = direction_at(theta, 0.7, side);
      auto sample = [&]() -> std::optional<Vector3f> {
        auto bs = b.sample(wo, rng.next_float(), {rng.next_float(), rng.next_float()}, TransportMode::radiance);
        if (!bs) return std::nullopt;
        return bs->wi;
      };
      auto pdf = [&](const Vector3f& wi) { return b.pdf(wo, wi, TransportMode::radiance); };
      auto r = chi2_window(sample, pdf, hemisphere_window(side > 0 ? 1 : -1), Chi2Config{40000, 16, 24});
      INFO("theta " << theta << " side " << side << ": " << r.summary());
      CHECK(r.p_value >= level);
      min_p = std::min(min_p, r.p_value);
    }
  WARN("Oren-Nayar chi2: " << tests << " tests, smallest p " << min_p);
}

TEST_CASE("Oren-Nayar furnace: albedo at most rho, exactly rho at sigma 0 and at grazing incidence", "[bxdfs][oren_nayar][extension][furnace]") {
  PCG32 rng(505, 3);
  std::ostringstream out;
  out << "Oren-Nayar directional albedo, rho = 1:";
  for (Float sigma : test_sigmas) {
    OrenNayarBxDF<RGB> b(RGB(1.f), sigma);
    out << "\n  sigma " << sigma << ":";
    for (double theta : test_angles) {
      Albedo a = albedo(b, direction_at(theta), TransportMode::radiance, 0, 100000, rng);
      INFO("sigma " << sigma << " theta " << theta << ": " << a.mean << " +- " << a.sigma);
      // z = 4: two-sided 6.3e-5 per estimate, ≤ 1e-3 family-wise over these 16 (Šidák); +1e-6 for float rounding
      CHECK(a.mean <= 1 + 4 * a.sigma + 1e-6);
      if (sigma == 0) {
        // 1e-5, σ < 1e-6: each weight is ρ up to ~10 float roundings
        CHECK(a.mean == Approx(1).margin(1e-5));  // Lambert: every sample weighs rho
        CHECK(a.sigma < 1e-6);
      }
      // rho at grazing: at 89.9 deg Fujii's albedo is 1 - 4.4e-4 at worst (sigma 1, by the quadrature of
      // reference_physics::OrenNayarFujii), so 5e-4 rather than a bare 0.01; z = 4 as above.
      if (theta == 89.9) CHECK(std::abs(a.mean - 1) <= 4 * a.sigma + 5e-4);
      out << " " << theta << " deg: " << a.mean << " (+-" << a.sigma << ")";
    }
    // At normal incidence s = 0 for every wi: the albedo is A pi exactly,
    // with A from Fujii's paper (reference_physics.hpp), not from the BxDF;
    // 4 sigma (family-wise 2.5e-4 over these 4 estimates, Sidak).
    Albedo normal = albedo(b, direction_at(0), TransportMode::radiance, 0, 100000, rng);
    double a_fujii = reference_physics::OrenNayarFujii{1, double(sigma)}.A();
    CHECK(normal.mean == Approx(a_fujii * pi_d).margin(4 * normal.sigma + 1e-6));
  }
  // A coloured rho scales every channel; spectral: per wavelength.
  OrenNayarBxDF<RGB> coloured(RGB(0.9f, 0.5f, 0.1f), 1.f);
  for (int c = 0; c < 3; ++c) {
    Albedo a = albedo(coloured, direction_at(45), TransportMode::radiance, c, 50000, rng);
    // z = 4 as above, 3 estimates
    CHECK(a.mean <= coloured.reflectance()[c] + 4 * a.sigma);
  }
  WARN(out.str());
}

TEST_CASE("Oren-Nayar is reciprocal, symmetric across the surface and finite at grazing angles", "[bxdfs][oren_nayar][extension][reciprocity]") {
  PCG32 rng(606, 4);
  OrenNayarBxDF<RGB> b(RGB(0.6f), 1.f);
  for (int i = 0; i < 1000; ++i) {
    Vector3f x = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    Vector3f y = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    RGB fxy = b.eval(x, y, TransportMode::radiance), fyx = b.eval(y, x, TransportMode::importance);
    INFO("x " << x.x << " " << x.y << " " << x.z << " y " << y.x << " " << y.y << " " << y.z);
    // 1e-5 relative: the swapped arguments run the same float operations in another order (a few u)
    CHECK(fxy.g == Approx(fyx.g).epsilon(1e-5));
    CHECK(b.eval(-x, -y, TransportMode::radiance).g == Approx(fxy.g).epsilon(1e-5));
    if (!same_hemisphere(x, y)) CHECK(fxy.is_black());
    auto bs = b.sample(x, 0.5f, {rng.next_float(), rng.next_float()}, TransportMode::radiance);
    if (bs) {
      CHECK(bs->f == b.eval(x, bs->wi, TransportMode::radiance));
      CHECK(bs->pdf == b.pdf(x, bs->wi, TransportMode::radiance));
      CHECK(bs->flags == BxDFFlags::diffuse_reflection);
    }
  }
  for (Float sigma : test_sigmas)
    for (Float cz : {1e-8f, 1e-4f}) {
      Vector3f wo(std::sqrt(1 - cz * cz), 0, cz);
      OrenNayarBxDF<RGB> g(RGB(1.f), sigma);
      for (const Vector3f& wi : {Vector3f(-wo.x, -wo.y, wo.z), wo, Vector3f(0, 0, 1), Vector3f(0.6f, 0.8f, 1e-8f)})
        check_finite<OrenNayarBxDF<RGB>, RGB>(g, wo, wi, rng);
    }
  CHECK(OrenNayarBxDF<RGB>(RGB(0.f), 1).flags() == BxDFFlags::none);
}

TEST_CASE("Oren-Nayar traits validate the material and make it in RGB and spectral mode", "[bxdfs][oren_nayar][extension][validate]") {
  using T = bxdf_traits<OrenNayarBxDF<RGB>>;
  CHECK(T::name == "oren_nayar");
  CHECK_NOTHROW(T::validate(OrenNayarMaterial{RGB(0.5f), 0.5f, "clay"}, "scene: material 1"));
  CHECK_THROWS_WITH(T::validate(OrenNayarMaterial{RGB(1.5f, 0.2f, 0.2f), 0.5f, "hot clay"}, "scene: material 1"),
                    Catch::StartsWith("scene: material 1: ") && Catch::Contains("'hot clay'") &&
                        Catch::Contains("reflectance"));
  CHECK_THROWS_WITH(T::validate(OrenNayarMaterial{RGB(0.5f), -1, "negative"}, "m"), Catch::Contains("sigma"));
  CHECK_THROWS_WITH(T::validate(OrenNayarMaterial{RGB(0.5f), 1.5f, "too rough"}, "m"), Catch::Contains("sigma"));
  CHECK_THROWS_WITH(T::validate(OrenNayarMaterial{RGB(0.5f), std::nanf(""), "nan"}, "m"), Catch::Contains("sigma"));
  SurfaceInteraction si;
  auto rgb = T::make(OrenNayarMaterial{RGB(0.2f, 0.4f, 0.6f), 1, "c"}, si, RGBWavelengths{});
  CHECK(rgb.reflectance() == RGB(0.2f, 0.4f, 0.6f));
  auto w = SampledWavelengths<4>::sample(0.3f);
  auto spectral = bxdf_traits<OrenNayarBxDF<S4>>::make(OrenNayarMaterial{RGB(0.5f), 1, "grey"}, si, w);
  // 1e-5: the grey uplift returns 0.5 within 1e-6 relative (tests/spectra/uplift_test.cpp), plus float
  for (int i = 0; i < 4; ++i) CHECK(spectral.reflectance()[i] == Approx(0.5f).margin(1e-5));
  // A scene validates it when built.
  Scene<RGB, ONSet<RGB>> scene;
  scene.add_sphere(Sphere{{0, 0, 0}, 1}, scene.add_material(OrenNayarMaterial{RGB(2.f), 1, "overbright"}));
  CHECK_THROWS_WITH(scene.build(), Catch::Contains("scene: material 0") && Catch::Contains("'overbright'"));
}

namespace {
// A sphere lit from the camera's direction by a distant light, rendered with
// a material of the extended set; returns the image.
template <class S>
Film render_sphere(const typename ONSet<S>::material_variant& material, int spp) {
  Scene<S, ONSet<S>> scene;
  scene.add_sphere(Sphere{{0, 0, 0}, 1}, scene.add_material(material));
  scene.add_light(DistantLight<S>(Vector3f(0, 0, -1), RGB(3.f)));
  scene.build();
  const int n = 24;
  OrthographicCamera cam(look_at_camera_to_world({0, 0, 5}, {0, 0, 0}, {0, 1, 0}), 2.2f, n, n);
  Film film(n, n);
  RenderOptions opt;
  opt.spp = spp;
  opt.seed = 9;
  RenderStats st = render(scene, cam, PathIntegrator{}, film, opt);
  REQUIRE(st.dropped == 0);
  return film;
}
}  // namespace

TEST_CASE("a scene with the extended set renders Oren-Nayar: Lambert at sigma 0, flatter when rough", "[bxdfs][oren_nayar][extension][render]") {
  // sigma = 0 is Lambert: the image equals DiffuseMaterial's (same sampling,
  // same f up to rounding). Rough: the limb is brighter relative to the
  // centre (the "flattening" under light from the viewer).
  Film lambert = render_sphere<RGB>(DiffuseMaterial{RGB(0.7f)}, 16);
  Film on0 = render_sphere<RGB>(OrenNayarMaterial{RGB(0.7f), 0, "smooth"}, 16);
  Film on2 = render_sphere<RGB>(OrenNayarMaterial{RGB(0.7f), 1, "rough"}, 16);
  Film on2s = render_sphere<Spectral>(OrenNayarMaterial{RGB(0.7f), 1, "rough"}, 16);
  double max_diff = 0;
  for (int y = 0; y < lambert.height(); ++y)
    for (int x = 0; x < lambert.width(); ++x)
      max_diff = std::max(max_diff, double(std::abs(lambert.pixel(x, y).g - on0.pixel(x, y).g)));
  // 1e-4: the same paths with f equal up to a few u (≲ 1e-6 relative) on pixel values ≲ 1
  CHECK(max_diff < 1e-4);
  // Centre pixel and a pixel near the limb (the sphere's radius is 1 in a
  // 2.2-wide view: pixel 3 from the edge is at ~0.83 of the radius).
  const int c = 12, limb = 2;
  double ratio_lambert = lambert.pixel(limb, c).g / lambert.pixel(c, c).g;
  double ratio_rough = on2.pixel(limb, c).g / on2.pixel(c, c).g;
  INFO("limb / centre: Lambert " << ratio_lambert << ", Oren-Nayar sigma 1 " << ratio_rough);
  CHECK(ratio_lambert > 0);
  // With wi = wo Fujii's f is rho A (1 + sigma sin^2 / cos): 2.2x Lambert's relative to the centre at
  // 0.83 of the radius; 1.2 only asks for the direction of the effect.
  CHECK(ratio_rough > 1.2 * ratio_lambert);
  // Spectral mode agrees with RGB on a grey material (a flat spectrum): one
  // bounce, deterministic light; only the wavelength sampling differs.
  double sum_rgb = 0, sum_spectral = 0, var = 0;
  for (int y = 0; y < on2.height(); ++y)
    for (int x = 0; x < on2.width(); ++x) {
      sum_rgb += on2.pixel(x, y).g;
      sum_spectral += on2s.pixel(x, y).g;
      var += double(on2.variance(x, y).g) + double(on2s.variance(x, y).g);
    }
  // The sums' difference within z sigma (pixels independent; the renders share their camera samples,
  // which only lowers the difference's variance) plus 1e-3 for the 1 nm tables against the renderer's
  // interpolated ones and the uplift (tests/integrators/volume_test.cpp); it was a bare 2%.
  INFO("RGB " << sum_rgb << " spectral " << sum_spectral << " sigma " << std::sqrt(var));
  CHECK(std::abs(sum_spectral - sum_rgb) <= reference_physics::sidak_z(1e-3, 1) * std::sqrt(var) + 1e-3 * sum_rgb);
}

}  // namespace oren_nayar_test
