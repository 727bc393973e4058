// Light selection on the 1,000-light scene (render/many_lights_scene.hpp):
// next-event estimates of the direct light reflected at points the camera
// sees, with lights chosen uniformly, by power and by the light BVH. All three
// are unbiased, so their means agree within z sigma of the difference, z
// from Sidak's correction over the m comparisons of each test case at a
// family-wise false-alarm rate of 10^-3 (sidak_z,
// tests/support/reference_physics.hpp); the BVH, which favours the lights
// near and facing each point, must have the lowest variance per sample. The
// factors are reported (WARN).
#include <catch2/catch.hpp>
#include <chrono>
#include <prism/prism.hpp>
#include "support/reference_physics.hpp"

namespace many_lights_test {

using namespace prism;

namespace {

struct Stats {
  double mean = 0, var = 0, seconds = 0;
};

// n one-sample estimates of the direct light leaving si towards the camera
// (luminance): light chosen by the scene, sampled by sample_li, shadow ray.
Stats nee_estimates(const Scene<RGB>& scene, const SurfaceInteraction& si, int n, uint64_t seed) {
  using S = RGB;
  wavelengths_t<S> lambda{};
  auto bsdf = scene.bsdf(si, lambda);
  LightSampleContext ctx(si);
  PCG32 rng(seed, 99);
  double sum = 0, sum2 = 0;
  auto t0 = std::chrono::steady_clock::now();
  for (int i = 0; i < n; ++i) {
    Float ul = rng.next_float();
    Point2f u{rng.next_float(), rng.next_float()};
    double v = 0;
    if (auto sl = scene.sample_light(ctx, ul)) {
      const auto& light = scene.lights()[sl->index];
      auto ls = std::visit([&](const auto& l) { return l.sample_li(ctx, u, lambda); }, light);
      if (ls && !ls->L.is_black() && ls->pdf > 0) {
        S f = bsdf.eval(si.wo, ls->wi) * abs_dot(ls->wi, si.ns);
        if (!f.is_black() && !scene.occluded(si.spawn_ray_to(ls->p_light), 1, ls->instance, ls->primitive))
          v = double((f * ls->L).luminance()) / double(sl->pmf * ls->pdf);
      }
    }
    sum += v;
    sum2 += v * v;
  }
  Stats s;
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  s.mean = sum / n;
  s.var = std::max(0.0, sum2 / n - s.mean * s.mean) * n / (n - 1);
  return s;
}

}  // namespace

TEST_CASE("light BVH agrees with uniform selection and has lower variance on 1000 lights",
          "[integrators][many_lights][light_bvh]") {
  constexpr LightSelection kinds[3] = {LightSelection::uniform, LightSelection::power, LightSelection::bvh};
  Scene<RGB> scenes[3];
  for (int k = 0; k < 3; ++k) {
    build_many_lights_scene(scenes[k], ManyLightsOptions{});
    scenes[k].set_light_selection(kinds[k]);
    scenes[k].build();
    REQUIRE(scenes[k].lights().size() == 1000);
    REQUIRE(scenes[k].light_selection() == kinds[k]);
  }
  CHECK(scenes[0].light_selection() == LightSelection::uniform);
  // The automatic choice for 1000 lights is the BVH.
  Scene<RGB> automatic;
  build_many_lights_scene(automatic, ManyLightsOptions{});
  automatic.build();
  CHECK(automatic.light_selection() == LightSelection::bvh);

  // Points where camera rays through pixels of a fixed pseudo-random
  // sequence meet the floor or a box (not an emitter, which is black).
  const int w = 64, h = 64;
  PerspectiveCamera cam = many_lights_camera(w, h);
  std::vector<SurfaceInteraction> points;
  PCG32 pixels(8, 88);
  while (points.size() < 6) {
    Point2f px{pixels.next_float() * w, pixels.next_float() * h};
    auto si = scenes[0].intersect(cam.generate_ray(CameraSample{px, {0.5f, 0.5f}}));
    if (si && si->area_light < 0) points.push_back(*si);
  }
  constexpr int n = 20000;
  double var_sum[3] = {0, 0, 0}, seconds[3] = {0, 0, 0};
  for (size_t p = 0; p < points.size(); ++p) {
    Stats st[3];
    for (int k = 0; k < 3; ++k) {
      st[k] = nee_estimates(scenes[k], points[p], n, 1000 + p);
      var_sum[k] += st[k].var;
      seconds[k] += st[k].seconds;
    }
    INFO("point " << p << ": means uniform " << st[0].mean << ", power " << st[1].mean << ", bvh " << st[2].mean
                  << "; variances " << st[0].var << ", " << st[1].var << ", " << st[2].var);
    REQUIRE(st[0].mean > 0);
    // The BVH and power selections agree with uniform selection within z
    // sigma of the difference: 6 points x 2 = 12 comparisons, one family at
    // 10^-3 (Sidak): z = sidak_z(1e-3, 12) = 3.93.
    const double z = reference_physics::sidak_z(1e-3, 12);
    for (int k = 1; k < 3; ++k) {
      double sigma = std::sqrt(st[0].var / n + st[k].var / n);
      CHECK(std::abs(st[k].mean - st[0].mean) <= z * sigma);
    }
  }
  INFO("variance per sample summed over the points: uniform " << var_sum[0] << ", power " << var_sum[1] << ", bvh "
                                                               << var_sum[2]);
  CHECK(var_sum[2] < var_sum[0]);
  CHECK(var_sum[2] < var_sum[1]);
  WARN("1000-light scene, NEE variance per sample (sum over " << points.size() << " points): uniform " << var_sum[0]
                                                               << ", power " << var_sum[1] << ", bvh " << var_sum[2]
                                                               << "; bvh is " << var_sum[0] / var_sum[2]
                                                               << "x better than uniform, " << var_sum[1] / var_sum[2]
                                                               << "x than power; time per sample bvh/uniform "
                                                               << seconds[2] / seconds[0]);
}

TEST_CASE("path tracing the many-lights scene: BVH matches power selection", "[integrators][many_lights][light_bvh]") {
  // The whole integrator (NEE + MIS, whose weights evaluate the BVH pmf at
  // the previous vertex) on a 64-light scene: camera samples at uniformly
  // random film positions estimate the image mean; with the BVH it agrees
  // with the one with power selection within z sigma of the difference, one
  // comparison at 10^-3: z = sidak_z(1e-3, 1) = 3.29.
  LightSelection kinds[2] = {LightSelection::power, LightSelection::bvh};
  const int w = 32, h = 32, n = 12000;
  PerspectiveCamera cam = many_lights_camera(w, h);
  Stats st[2];
  for (int k = 0; k < 2; ++k) {
    Scene<RGB> scene;
    build_many_lights_scene(scene, ManyLightsOptions{64, 5, 64});
    scene.set_light_selection(kinds[k]);
    scene.build();
    PathIntegrator integrator;
    IndependentSampler sampler(uint64_t(31 + k));
    PCG32 film_rng(uint64_t(5 + k), 3);
    RayCounter rays;
    double sum = 0, sum2 = 0;
    for (int i = 0; i < n; ++i) {
      sampler.start_pixel_sample(i % w, i / w, 0);
      Point2f pf{film_rng.next_float() * w, film_rng.next_float() * h};
      Ray ray = cam.generate_ray(CameraSample{pf, {0.5f, 0.5f}});
      wavelengths_t<RGB> lambda{};
      double v = double(integrator.Li(scene, ray, lambda, sampler, rays).luminance());
      REQUIRE(std::isfinite(v));
      sum += v;
      sum2 += v * v;
    }
    st[k].mean = sum / n;
    st[k].var = std::max(0.0, sum2 / n - sqr(st[k].mean)) * n / (n - 1);
  }
  double sigma = std::sqrt(st[0].var / n + st[1].var / n);
  INFO("image mean: power " << st[0].mean << ", bvh " << st[1].mean << ", sigma of the difference " << sigma
                            << "; variance per sample " << st[0].var << ", " << st[1].var);
  CHECK(st[0].mean > 0);
  CHECK(std::abs(st[0].mean - st[1].mean) <= reference_physics::sidak_z(1e-3, 1) * sigma);
}

}  // namespace many_lights_test
