// The light-tracing pass for caustics (PathIntegrator with
// light_traced_caustics) must give the same image, in expectation, as path
// tracing alone. Scene: a glass sphere over a diffuse floor lit from the side
// by a large square light, so that plain path tracing also converges on the
// caustic, and the camera sees the caustic, not the sphere's shadow.
// The splats carry no per-pixel variance, so each method is rendered with
// 32 seeds (batch means: 32 renders of a quarter of the samples, rather than
// 8 of them all, for 31 degrees of freedom at the same cost) and the spread
// of the renders gives the standard errors. The difference over its
// estimated sigma follows Student's t with Welch's degrees of freedom; the
// bound is its quantile with Sidak's correction over the 48 region-channels
// at a family-wise false-alarm rate of 10^-3 (about 5.0 at 31 degrees of
// freedom; tests/support/reference_physics.hpp).
#include <catch2/catch.hpp>
#include "support/reference_physics.hpp"
#include <cmath>
#include <vector>
#include <prism/prism.hpp>

namespace caustics_test {

using namespace prism;

namespace {

template <class S>
void build_caustic_scene(Scene<S>& scene) {
  uint32_t floor_m = scene.add_material(DiffuseMaterial{RGB(0.8f)});
  uint32_t black = scene.add_material(DiffuseMaterial{RGB(0.f)});
  uint32_t glass = scene.add_material(DielectricMaterial{IOR(1.5f), "glass"});
  TriangleMesh floor;
  append_quad(floor, {-2, 0, -2}, {0, 0, 4}, {4, 0, 0});  // normal +y
  scene.add_mesh_instance(std::move(floor), floor_m);
  TriangleMesh lamp;
  append_quad(lamp, {-2.f, 3, -0.5f}, {1.f, 0, 0}, {0, 0, 1.f});  // normal -y
  scene.add_mesh_instance(std::move(lamp), black, AreaEmission{RGB(4.f, 3.f, 2.f), 1, false});
  scene.add_sphere(Sphere{{0, 1, 0}, 0.5f}, glass);
  scene.build();
}

struct RegionStats {
  std::vector<double> mean, se;  // per region and channel
};

// Renders `runs` images with consecutive seeds and returns, per 8x8 region and
// channel, the mean over runs of the region's mean and its standard error.
template <class S>
RegionStats render_runs(const PathIntegrator& integrator, uint64_t seed0, int runs, int spp, bool ortho = false) {
  Scene<S> scene;
  build_caustic_scene(scene);
  const int w = 32, h = 32, region = 8;
  // Looks down on the caustic, which the sphere throws around (0.75, 0, 0).
  PerspectiveCamera cam(look_at_camera_to_world({1.2f, 4, 1.5f}, {0.7f, 0, 0}, {0, 1, 0}), radians(25), w, h);
  OrthographicCamera ortho_cam(look_at_camera_to_world({1.2f, 4, 1.5f}, {0.7f, 0, 0}, {0, 1, 0}), 1.8f, w, h);
  const int regions = (w / region) * (h / region);
  std::vector<std::vector<double>> per_run(size_t(runs), std::vector<double>(size_t(regions) * 3, 0.0));
  for (int r = 0; r < runs; ++r) {
    Film film(w, h);
    RenderOptions opt;
    opt.spp = spp;
    opt.seed = seed0 + uint64_t(r);
    RenderStats st = ortho ? render(scene, ortho_cam, integrator, film, opt) : render(scene, cam, integrator, film, opt);
    REQUIRE(st.dropped == 0);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        int k = (y / region) * (w / region) + x / region;
        RGB c = film.pixel(x, y);
        for (int ch = 0; ch < 3; ++ch) per_run[size_t(r)][size_t(k) * 3 + size_t(ch)] += c[ch] / (region * region);
      }
  }
  RegionStats out;
  for (size_t i = 0; i < size_t(regions) * 3; ++i) {
    double m = 0, v = 0;
    for (int r = 0; r < runs; ++r) m += per_run[size_t(r)][i] / runs;
    for (int r = 0; r < runs; ++r) v += (per_run[size_t(r)][i] - m) * (per_run[size_t(r)][i] - m) / (runs - 1);
    out.mean.push_back(m);
    out.se.push_back(std::sqrt(v / runs));
  }
  return out;
}

template <class S>
void check_caustics_match(bool ortho = false) {
  PathOptions lt, pt;
  pt.light_traced_caustics = false;
  // Path tracing alone finds the caustic by BSDF sampling: it gets 4x the
  // samples so that both sides' errors are of a size.
  const int runs = 32;
  RegionStats a = render_runs<S>(PathIntegrator(lt), 100, runs, 32, ortho);
  RegionStats b = render_runs<S>(PathIntegrator(pt), 200, runs, 128, ortho);
  int compared = 0;
  double worst = 0;
  const int m = int(a.mean.size());
  for (size_t i = 0; i < a.mean.size(); ++i) {
    double va = a.se[i] * a.se[i], vb = b.se[i] * b.se[i];
    double sigma = std::sqrt(va + vb);
    double t = sigma > 0 ? std::abs(a.mean[i] - b.mean[i]) / sigma : 0;
    worst = std::max(worst, t);
    // Welch-Satterthwaite: between runs - 1 and 2 (runs - 1).
    double df = va + vb > 0 ? (va + vb) * (va + vb) / (va * va / (runs - 1) + vb * vb / (runs - 1)) : runs - 1;
    double bound = reference_physics::sidak_t(1e-3, m, df);
    INFO("region " << i / 3 << " channel " << i % 3 << ": light-traced caustics " << a.mean[i] << " +- " << a.se[i]
                   << ", path tracing only " << b.mean[i] << " +- " << b.se[i] << "; t " << t << ", bound " << bound
                   << " at " << df << " degrees of freedom");
    CHECK(t <= bound);
    ++compared;
  }
  WARN("caustic scene: largest |difference| / sigma over " << compared << " region-channels: " << worst);
  CHECK(compared == 48);
}

}  // namespace

TEST_CASE("light-traced caustics agree with path tracing alone under a glass sphere", "[integrators][caustics]") {
  check_caustics_match<RGB>();
}

TEST_CASE("light-traced caustics agree with path tracing alone under a glass sphere, spectral",
          "[integrators][caustics][spectral]") {
  check_caustics_match<Spectral>();
}

TEST_CASE("light-traced caustics agree with path tracing alone through an orthographic camera", "[integrators][caustics][orthographic]") {
  check_caustics_match<RGB>(true);
}

TEST_CASE("the caustic pass runs only for scenes with specular materials and area lights", "[integrators][caustics]") {
  Scene<RGB> diffuse_only;
  uint32_t m = diffuse_only.add_material(DiffuseMaterial{RGB(0.5f)});
  diffuse_only.add_sphere(Sphere{{0, 0, 0}, 1}, m, AreaEmission{RGB(1.f), 1, true});
  diffuse_only.build();
  CHECK_FALSE(PathIntegrator{}.caustics_active(diffuse_only));
  Scene<RGB> glass;
  build_caustic_scene(glass);
  CHECK(PathIntegrator{}.caustics_active(glass));
  PathOptions off;
  off.light_traced_caustics = false;
  CHECK_FALSE(PathIntegrator(off).caustics_active(glass));
  PerspectiveCamera cam(look_at_camera_to_world({0, 4, 2.5f}, {0, 0, 0}, {0, 1, 0}), radians(45), 8, 8);
  Film film(8, 8);
  RenderOptions opt;
  opt.spp = 4;
  CHECK(render(diffuse_only, cam, PathIntegrator{}, film, opt).light_paths == 0);
  Film film2(8, 8);
  CHECK(render(glass, cam, PathIntegrator{}, film2, opt).light_paths == 8 * 8 * 4);
}

}  // namespace caustics_test
