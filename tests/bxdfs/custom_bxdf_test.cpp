// A BxDF defined outside include/prism, joined to a renderer by specialising
// prism::bxdf_traits: the extension point works without editing prism.
#include <catch2/catch.hpp>
#include <prism/prism.hpp>
#include "support/chi2.hpp"

namespace user {
using namespace prism;

// Lambertian reflection sampled uniformly over the hemisphere (a different
// strategy from prism's diffuse, so that its own sampling is exercised).
template <class S>
struct UniformLambert {
  S albedo;
  S eval(Vector3f wo, Vector3f wi, TransportMode) const { return same_hemisphere(wo, wi) ? albedo * inv_pi : S{}; }
  Float pdf(Vector3f wo, Vector3f wi, TransportMode) const { return same_hemisphere(wo, wi) ? inv_2pi : 0; }
  std::optional<BSDFSample<S>> sample(Vector3f wo, Float, Point2f u, TransportMode) const {
    Vector3f wi = sample_uniform_hemisphere(u);
    if (wo.z < 0) wi.z = -wi.z;
    return BSDFSample<S>{albedo * inv_pi, wi, inv_2pi, BxDFFlags::diffuse_reflection};
  }
  BxDFFlags flags() const { return BxDFFlags::diffuse_reflection; }
};
struct UniformLambertMaterial {
  RGB albedo;
};
}  // namespace user

template <class S>
struct prism::bxdf_traits<user::UniformLambert<S>> {
  static constexpr std::string_view name = "uniform-lambert";
  static constexpr BxDFFlags flags = BxDFFlags::diffuse_reflection;
  using material_type = user::UniformLambertMaterial;
  template <class W>
  static user::UniformLambert<S> make(const user::UniformLambertMaterial& m, const SurfaceInteraction&, const W& l) {
    return {spectrum_traits<S>::albedo(m.albedo, l)};
  }
};

using namespace prism;
using UserSet = default_bxdf_set<RGB>::with<user::UniformLambert<RGB>>;
static_assert(BxDFLike<user::UniformLambert<RGB>, RGB>);
static_assert(BxDFLike<DiffuseBxDF<RGB>, RGB>);
static_assert(UserSet::size == default_bxdf_set<RGB>::size + 1);

TEST_CASE("a user BxDF renders the closed emitting sphere exactly", "[bxdfs][extension]") {
  // Inside a closed diffuse emitter L = Le / (1 - rho), whichever diffuse BxDF.
  const float rho = 0.6f, Le = 0.4f;
  Scene<RGB, UserSet> scene;
  uint32_t m = scene.add_material(user::UniformLambertMaterial{RGB(rho)});
  scene.add_sphere(Sphere{{0, 0, 0}, 1}, m, AreaEmission{RGB(Le), 1, true});
  scene.build();
  PerspectiveCamera cam(look_at_camera_to_world({0, 0, 0}, {0, 0, -1}, {0, 1, 0}), radians(60), 4, 4);
  Film film(4, 4);
  RenderOptions opt;
  opt.spp = 2048;
  render(scene, cam, PathIntegrator{}, film, opt);
  double mean = 0, var = 0;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      mean += film.pixel(x, y).g / 16.0;
      var += film.variance(x, y).g / 256.0;
    }
  INFO("mean " << mean << " expected " << Le / (1 - rho) << " sigma " << std::sqrt(var));
  // z = 4 for this one comparison: a false-alarm rate of 6.3e-5, inside the suite's 1e-3 (sidak_z(1e-3, 1) = 3.29)
  CHECK(std::abs(mean - Le / (1 - rho)) <= 4 * std::sqrt(var));
}

TEST_CASE("a scene mixes built-in and user BxDFs by material", "[bxdfs][extension]") {
  Scene<RGB, UserSet> scene;
  uint32_t a = scene.add_material(DiffuseMaterial{RGB(0.5f)});
  uint32_t b = scene.add_material(user::UniformLambertMaterial{RGB(0.5f)});
  scene.add_sphere(Sphere{{-2, 0, 0}, 1}, a);
  scene.add_sphere(Sphere{{2, 0, 0}, 1}, b);
  scene.build();
  auto si_a = scene.intersect(Ray{{-2, 0, 5}, {0, 0, -1}});
  auto si_b = scene.intersect(Ray{{2, 0, 5}, {0, 0, -1}});
  REQUIRE(si_a);
  REQUIRE(si_b);
  CHECK(scene.bsdf(*si_a, RGBWavelengths{}).bxdf().index() == 0);
  CHECK(scene.bsdf(*si_b, RGBWavelengths{}).bxdf().index() == UserSet::size - 1);
  CHECK(bxdf_traits<user::UniformLambert<RGB>>::name == "uniform-lambert");
}

TEST_CASE("the user BxDF's sampling matches its pdf", "[bxdfs][extension][chi2]") {
  user::UniformLambert<RGB> bxdf{RGB(0.5f)};
  PCG32 rng(5, 5);
  Vector3f wo = normalize(Vector3f{0.3f, 0.1f, 0.8f});
  auto sample = [&]() -> std::optional<std::array<double, 3>> {
    auto bs = bxdf.sample(wo, 0, {rng.next_float(), rng.next_float()}, TransportMode::radiance);
    if (!bs) return std::nullopt;
    return std::array<double, 3>{bs->wi.x, bs->wi.y, bs->wi.z};
  };
  auto pdf = [&](const std::array<double, 3>& w) {
    return double(bxdf.pdf(wo, Vector3f{Float(w[0]), Float(w[1]), Float(w[2])}, TransportMode::radiance));
  };
  auto r = prism_test::chi2_test_directions(sample, pdf, 100000, 16, 32);
  CHECK(r.p_value >= 1e-3);  // one χ² test at the suite's false-alarm rate 1e-3
}
