// PathOptions::mis = false: next-event estimation without MIS weights (light
// samples count in full, BSDF-sampled hits on lights only where a light
// sample cannot reach). It must converge to the same image as NEE with MIS:
// an analytic scene, the default Cornell box (area lights, the caustic split)
// and an environment map with a sun (the escaped-ray path). Tolerances are 4
// standard errors from the films' per-pixel variance.
#include <catch2/catch.hpp>
#include <cmath>
#include <prism/prism.hpp>

using namespace prism;

namespace {

PathIntegrator nee_without_mis() {
  PathOptions o;
  o.mis = false;
  return PathIntegrator(o);
}

// The mean of channel c over a region of a film and the variance of that mean.
std::pair<double, double> region_mean(const Film& f, int c, int x0, int y0, int size) {
  double m = 0, v = 0, n = double(size) * double(size);
  for (int y = y0; y < y0 + size; ++y)
    for (int x = x0; x < x0 + size; ++x) {
      m += double(f.pixel(x, y)[c]) / n;
      v += double(f.variance(x, y)[c]) / (n * n);
    }
  return {m, v};
}

// Compares two films region by region, channel by channel, at 4 sigma.
void check_regions_agree(const Film& a, const Film& b, int region) {
  int compared = 0;
  for (int ry = 0; ry < a.height(); ry += region)
    for (int rx = 0; rx < a.width(); rx += region)
      for (int c = 0; c < 3; ++c) {
        auto [ma, va] = region_mean(a, c, rx, ry, region);
        auto [mb, vb] = region_mean(b, c, rx, ry, region);
        double sigma = std::sqrt(va + vb);
        INFO("region " << rx << "," << ry << " channel " << c << ": MIS " << ma << " no MIS " << mb << " sigma "
                       << sigma);
        CHECK(std::abs(ma - mb) <= 4 * sigma);
        ++compared;
      }
  CHECK(compared == 3 * (a.width() / region) * (a.height() / region));
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
  CHECK(std::abs(mean - expected) <= 4 * std::sqrt(var));
}

TEST_CASE("NEE without MIS agrees with NEE with MIS on the Cornell box", "[integrators][mis][cornell]") {
  Scene<RGB> scene;
  build_cornell_box(scene, diffuse_cornell_box_options());  // no caustics: the films' variance is complete
  scene.build();
  const int w = 32, h = 32;
  PerspectiveCamera cam = default_camera(w, h);
  Film a(w, h), b(w, h);
  RenderOptions opt;
  opt.spp = 256;
  opt.seed = 41;
  render(scene, cam, PathIntegrator{}, a, opt);
  opt.seed = 42;
  render(scene, cam, nee_without_mis(), b, opt);
  check_regions_agree(a, b, 8);
}

TEST_CASE("NEE without MIS agrees with NEE with MIS under an environment map with a sun",
          "[integrators][mis][environment]") {
  EnvironmentImage env;
  env.width = 64;
  env.height = 32;
  env.rgb.resize(size_t(env.width) * size_t(env.height) * 3);
  for (int y = 0; y < env.height; ++y)
    for (int x = 0; x < env.width; ++x) {
      float sky = 0.2f + 0.8f * float(env.height - y) / float(env.height);
      bool sun = x >= 40 && x < 44 && y >= 8 && y < 12;
      for (int c = 0; c < 3; ++c)
        env.rgb[(size_t(y) * size_t(env.width) + size_t(x)) * 3 + size_t(c)] = sun ? 20.f : sky * (c == 2 ? 1.f : 0.7f);
    }
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
  Film a(w, h), b(w, h);
  RenderOptions opt;
  opt.spp = 512;
  opt.seed = 51;
  render(scene, cam, PathIntegrator{}, a, opt);
  opt.seed = 52;
  render(scene, cam, nee_without_mis(), b, opt);
  check_regions_agree(a, b, 8);
}
