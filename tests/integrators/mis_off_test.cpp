// PathOptions::mis = false: next-event estimation without MIS weights (light
// samples count in full, BSDF-sampled hits on lights only where a light
// sample cannot reach). It must converge to the same image as NEE with MIS:
// an analytic scene, the default Cornell box (area lights, the caustic split)
// and an environment map with a sun (the escaped-ray path). Tolerances are z
// standard errors from the films' per-pixel variance, z from Sidak's
// correction over each test case's comparisons at a family-wise false-alarm
// rate of 10^-3 (support/film_checks.hpp).
#include <catch2/catch.hpp>
#include <cmath>
#include <prism/prism.hpp>
#include "support/film_checks.hpp"

namespace mis_off_test {

using namespace prism;
using namespace prism_test;

namespace {

PathIntegrator nee_without_mis() {
  PathOptions o;
  o.mis = false;
  return PathIntegrator(o);
}

// Renders the scene with NEE + MIS (seed) and without MIS (seed + 1) and
// checks that the two films agree region by region.
void check_mis_off_agrees(const Scene<RGB>& scene, const PerspectiveCamera& cam, int w, int h, int spp,
                          uint64_t seed) {
  Film a(w, h), b(w, h);
  RenderOptions opt;
  opt.spp = spp;
  opt.seed = seed;
  render(scene, cam, PathIntegrator{}, a, opt);
  opt.seed = seed + 1;
  render(scene, cam, nee_without_mis(), b, opt);
  check_regions_agree(a, b, 8, "MIS", "no MIS");
}

}  // namespace

TEST_CASE("MIS is on by default", "[integrators][mis]") {
  CHECK(PathOptions{}.mis);
  CHECK(PathIntegrator{}.options().mis);
  CHECK_FALSE(nee_without_mis().options().mis);
}

// Inside a closed sphere emitting Le from both sides with albedo rho, L = Le / (1 - rho).
TEST_CASE("NEE without MIS: closed emitting sphere gives Le over 1 minus rho", "[integrators][mis][analytic]") {
  const float Le = 0.5f, rho = 0.6f;
  Scene<RGB> scene;
  const Scene<RGB>::material_type mat = DiffuseMaterial{RGB(rho)};
  uint32_t m = scene.add_material(mat);
  scene.add_sphere(Sphere{{0, 0, 0}, 1}, m, AreaEmission{RGB(Le), 1, true});
  scene.build();
  const int w = 8, h = 8;
  PerspectiveCamera cam(look_at_camera_to_world({0.1f, 0.2f, 0.3f}, {0, 0, -1}, {0, 1, 0}), radians(60), w, h);
  Film film(w, h);
  RenderOptions opt;
  opt.spp = 1024;
  opt.seed = 31;
  RenderStats st = render(scene, cam, nee_without_mis(), film, opt);
  REQUIRE(st.dropped == 0);
  auto [mean, var] = region_mean(film, 1, 0, 0, w);
  const double expected = Le / (1 - rho);
  INFO("image mean " << mean << " expected " << expected << " sigma " << std::sqrt(var));
  REQUIRE(var > 0);
  CHECK(std::abs(mean - expected) <= reference_physics::sidak_z(1e-3, 1) * std::sqrt(var));  // one comparison
}

TEST_CASE("NEE without MIS agrees with NEE with MIS on the Cornell box", "[integrators][mis][cornell]") {
  Scene<RGB> scene;
  build_cornell_box(scene, diffuse_cornell_box_options());  // no caustics: the films' variance is complete
  scene.build();
  const int w = 32, h = 32;
  check_mis_off_agrees(scene, default_camera(w, h), w, h, 256, 41);
}

TEST_CASE("NEE without MIS agrees with NEE with MIS under an environment map with a sun",
          "[integrators][mis][environment]") {
  EnvironmentImage env = sky_with_sun();
  Scene<RGB> scene;
  const Scene<RGB>::material_type diffuse = DiffuseMaterial{RGB(0.7f)};
  const Scene<RGB>::material_type glossy =
      ConductorMaterial::from_reflectance(RGB(0.9f), MicrofacetRoughness(0.2f), "glossy");
  scene.add_sphere(Sphere{{-1.1f, 0, 0}, 1}, scene.add_material(diffuse));
  scene.add_sphere(Sphere{{1.1f, 0, 0}, 1}, scene.add_material(glossy));
  scene.add_light(ImageInfiniteLight<RGB>(env, 1.f));
  scene.build();
  const int w = 32, h = 16;
  PerspectiveCamera cam(look_at_camera_to_world({0, 0, 6}, {0, 0, 0}, {0, 1, 0}), radians(30), w, h);
  check_mis_off_agrees(scene, cam, w, h, 512, 51);
}

}  // namespace mis_off_test
