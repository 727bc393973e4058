// Convergence harness (issue 8, item 1, first step): error against time for
// each rendering method on a few scenes, against a cached high-spp reference.
//
// Scenes: the default scene (Cornell box with the SF11 prism, gold and frosted
// spheres; in RGB and in spectral mode), the many-lights scene (1000 small
// emitters) and, when the shared scenes are present, MetalRoughSpheresNoTextures
// under the chinese_garden HDR environment. Methods: integrator (path = NEE +
// MIS, bsdf = BSDF sampling only) x sampler (independent, Owen-scrambled
// Sobol) x light selection (power, BVH; many-lights scene only) x colour model
// (RGB, spectral; default scene only).
//
// Each scene and colour model has one reference: the path integrator with the
// independent sampler at a high sample count, the mean of two halves with
// independent seeds no method uses (their difference estimates the
// reference's own relMSE, the noise floor every measured relMSE includes),
// stored as bench/convergence/cache/<scene>_<model>_<W>x<H>_spp<N>_seed<S>.exr
// (the spp and first seed in the name; a sidecar .txt repeats them with the
// render time and the noise floor) and reused when present. Spectral methods are measured against the
// spectral reference, RGB ones against the RGB reference: each converges to
// its own colour model's image (RGB refracts at the d line only, so its limit
// differs from the spectral one where the prism disperses; the program prints
// that difference).
//
// Each method renders at 1, 2, 4, ..., 256 spp; below 16 spp the error is the
// mean over 16/spp seeds (one seed is too noisy there) and the time the best
// of those renders. Errors: relMSE = mean over pixels and channels of
// (v - ref)^2 / (ref^2 + 1e-2), and relMAE = sum |v - ref| / sum ref.
// Writes bench/results/convergence.csv (scene, method, spp, seconds, relmse,
// relmae) and bench/results/convergence_slopes.csv: per method the
// least-squares slope of log relMSE against log seconds (ideal -1 for an
// unbiased Monte Carlo estimator at constant cost per sample), the same with
// the reference's noise floor subtracted, the same against log spp, the slope of log relMAE against log seconds (ideal -1/2),
// and relMSE x seconds at 256 spp (lower is better at equal time).
//
// With a fifth argument `adaptive`, it runs only the adaptive-sampling
// comparison (docs/adaptive.md) on the default scene, RGB and spectral:
// path/independent and path/sobol uniform at 1..256 spp against the same
// with adaptive sampling (min 4 spp, at most 1024) at targets 1.6, 1.13,
// 0.8, ..., 0.1 (relative error per pixel; the mean over 2 seeds while the
// target is 0.8 or more), all in the same run so that their times compare,
// into bench/results/convergence_adaptive.csv (the same columns, plus the
// target and the mean spp) and convergence_adaptive_slopes.csv.
//
// Usage: convergence_bench [out_dir=bench/results] [shared=../shared]
//        [cache=bench/convergence/cache] [ref_spp=8192] [adaptive]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>
#include <prism/io/gltf.hpp>
#include <prism/io/image_io.hpp>
#include <prism/prism.hpp>
#include <prism/render/many_lights_scene.hpp>

using namespace prism;

namespace {

constexpr int W = 64, H = 64;
constexpr uint64_t ref_seed = 987654321;
constexpr int max_spp = 256;

using Pixels = std::vector<float>;  // 3 floats per pixel, row-major

enum class Integrator { path, bsdf };

// target > 0: adaptive sampling to that relative error, spp the cap; the
// samples taken go to *samples.
template <class Scene, class Camera>
Pixels render_image(const Scene& scene, const Camera& cam, Integrator integ, SamplerKind k, int spp, uint64_t seed,
                    double* seconds, double target = 0, uint64_t* samples = nullptr) {
  Film film(W, H);
  RenderOptions opt;
  opt.spp = spp;
  opt.seed = seed;
  opt.sampler = k;
  opt.adaptive_target = target;
  opt.adaptive_min_spp = 4;
  RenderStats st = integ == Integrator::path ? render(scene, cam, PathIntegrator{}, film, opt)
                                             : render(scene, cam, BSDFPathIntegrator{}, film, opt);
  if (seconds) *seconds = st.seconds;
  if (samples) *samples = st.samples;
  Pixels px(size_t(W * H * 3));
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      RGB c = film.pixel(x, y);
      for (int i = 0; i < 3; ++i) px[size_t((y * W + x) * 3 + i)] = c[i];
    }
  return px;
}

// relMSE of a against b with the denominators of ref.
double rel_mse_between(const Pixels& a, const Pixels& b, const Pixels& ref) {
  double s = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    double d = double(a[i]) - double(b[i]);
    s += d * d / (double(ref[i]) * double(ref[i]) + 1e-2);
  }
  return s / double(a.size());
}

double rel_mse(const Pixels& v, const Pixels& ref) { return rel_mse_between(v, ref, ref); }

double rel_mae(const Pixels& v, const Pixels& ref) {
  double s = 0, r = 0;
  for (size_t i = 0; i < v.size(); ++i) {
    s += std::abs(double(v[i]) - double(ref[i]));
    r += std::abs(double(ref[i]));
  }
  return r > 0 ? s / r : 0;
}

// Least-squares slope of log y against log x.
double loglog_slope(const std::vector<double>& x, const std::vector<double>& y) {
  double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    if (!(x[i] > 0) || !(y[i] > 0)) continue;
    double lx = std::log(x[i]), ly = std::log(y[i]);
    n += 1, sx += lx, sy += ly, sxx += lx * lx, sxy += lx * ly;
  }
  double d = n * sxx - sx * sx;
  return n >= 2 && d > 0 ? (n * sxy - sx * sy) / d : std::nan("");
}

struct Harness {
  std::string cache_dir;
  int ref_spp = 8192;
  std::ofstream csv, slopes;

  // The reference of `key` (scene and colour model): read from the cache, or
  // rendered (path integrator, independent sampler) and cached. It is the mean
  // of two halves of ref_spp / 2 spp with independent seeds; their relMSE
  // against each other estimates the reference's own noise: E (A - B)^2 is
  // twice a half's variance, four times the whole's, so the reference adds
  // about relMSE(A, B) / 4 to every relMSE measured against it (`floor`).
  struct Reference {
    Pixels px;
    double floor = 0;  // the reference's own relMSE, estimated
  };
  template <class Scene, class Camera>
  Reference reference(const std::string& key, const Scene& scene, const Camera& cam) {
    const std::string stem = cache_dir + "/" + key + "_" + std::to_string(W) + "x" + std::to_string(H) + "_spp" +
                             std::to_string(ref_spp) + "_seed" + std::to_string(ref_seed);
    Reference r;
    if (std::filesystem::exists(stem + ".exr") && std::filesystem::exists(stem + ".txt")) {
      Image img = read_exr(stem + ".exr");
      std::ifstream side(stem + ".txt");
      std::string word;
      bool have_floor = false;
      while (side >> word)
        if (word == "floor_relmse") have_floor = bool(side >> r.floor);
      if (img.width == W && img.height == H && have_floor) {
        std::printf("%s: reference from %s.exr (noise floor relMSE %.3g)\n", key.c_str(), stem.c_str(), r.floor);
        r.px = std::move(img.rgb);
        return r;
      }
    }
    std::printf("%s: rendering the reference at %d spp (two halves)...\n", key.c_str(), ref_spp);
    std::fflush(stdout);
    double sec_a = 0, sec_b = 0;
    const int half = std::max(1, ref_spp / 2);
    Pixels a = render_image(scene, cam, Integrator::path, SamplerKind::independent, half, ref_seed, &sec_a);
    Pixels b = render_image(scene, cam, Integrator::path, SamplerKind::independent, half, ref_seed + 1, &sec_b);
    r.px.resize(a.size());
    for (size_t i = 0; i < a.size(); ++i) r.px[i] = 0.5f * (a[i] + b[i]);
    r.floor = rel_mse_between(a, b, r.px) / 4;
    std::filesystem::create_directories(cache_dir);
    write_exr(stem + ".exr", Image{W, H, r.px});
    std::ofstream side(stem + ".txt");
    side << "scene " << key << "\nwidth " << W << "\nheight " << H << "\nspp " << 2 * half << "\nseeds " << ref_seed
         << " " << ref_seed + 1 << "\nintegrator path\nsampler independent\nseconds " << sec_a + sec_b
         << "\nfloor_relmse " << r.floor << "\n";
    std::printf("%s: reference in %.1f s, noise floor relMSE %.3g\n", key.c_str(), sec_a + sec_b, r.floor);
    return r;
  }

  // Every integrator x sampler on one scene object; `suffix` names the rest of
  // the method (light selection, colour model).
  template <class Scene, class Camera>
  void run_methods(const std::string& scene_name, const std::string& suffix, const Scene& scene, const Camera& cam,
                   const Reference& reference, bool with_bsdf = true) {
    const Pixels& ref = reference.px;
    const std::pair<Integrator, const char*> integrators[] = {{Integrator::path, "path"}, {Integrator::bsdf, "bsdf"}};
    const std::pair<SamplerKind, const char*> samplers[] = {{SamplerKind::independent, "independent"},
                                                            {SamplerKind::sobol, "sobol"}};
    for (auto [integ, iname] : integrators) {
      if (integ == Integrator::bsdf && !with_bsdf) continue;
      for (auto [k, kname] : samplers) {
        const std::string method = std::string(iname) + "/" + kname + suffix;
        std::vector<double> secs, mses, maes, spps, corrected;
        for (int spp = 1; spp <= max_spp; spp *= 2) {
          const int seeds = std::max(1, 16 / spp);
          double e = 0, a = 0, best = 1e30;
          for (int s = 0; s < seeds; ++s) {
            double sec = 0;
            Pixels img = render_image(scene, cam, integ, k, spp, uint64_t(1 + s), &sec);
            e += rel_mse(img, ref) / seeds;
            a += rel_mae(img, ref) / seeds;
            best = std::min(best, sec);
          }
          csv << scene_name << "," << method << "," << spp << "," << best << "," << e << "," << a << "\n";
          secs.push_back(best), mses.push_back(e), maes.push_back(a), spps.push_back(spp);
          corrected.push_back(e - reference.floor);
        }
        csv.flush();
        const double s_time = loglog_slope(secs, mses), s_spp = loglog_slope(spps, mses),
                     s_corr = loglog_slope(secs, corrected),
                     s_mae = loglog_slope(secs, maes), merit = mses.back() * secs.back();
        std::printf("  %-28s slope relMSE/s %6.3f (less floor %6.3f) /spp %6.3f  relMAE/s %6.3f  256 spp: %.3f s "
                    "relMSE %.4g relMAE %.4f relMSE x s %.4g\n",
                    method.c_str(), s_time, s_corr, s_spp, s_mae, secs.back(), mses.back(), maes.back(), merit);
        std::fflush(stdout);
        slopes << scene_name << "," << method << "," << s_time << "," << s_corr << "," << s_spp << "," << s_mae << ","
               << reference.floor << "," << secs.back()
               << "," << mses.back() << "," << maes.back() << "," << merit << "\n";
        slopes.flush();
      }
    }
  }
};

// Uniform against adaptive sampling on one scene, in one run (see the top).
template <class Scene, class Camera>
void run_adaptive(Harness& h, std::ofstream& csv, std::ofstream& slopes, const std::string& scene_name,
                  const std::string& suffix, const Scene& scene, const Camera& cam, const Harness::Reference& reference) {
  const Pixels& ref = reference.px;
  const std::pair<SamplerKind, const char*> samplers[] = {{SamplerKind::independent, "independent"},
                                                          {SamplerKind::sobol, "sobol"}};
  for (auto [k, kname] : samplers)
    for (bool adaptive : {false, true}) {
      const std::string method = std::string("path/") + kname + suffix + (adaptive ? "/adaptive" : "");
      std::vector<double> secs, mses;
      constexpr int points = 9;
      for (int j = 0; j < points; ++j) {
        const int spp = adaptive ? 1024 : 1 << j;
        const double target = adaptive ? 1.6 * std::pow(2.0, -0.5 * j) : 0;
        const int seeds = adaptive ? (target >= 0.79 ? 2 : 1) : std::max(1, 16 / spp);
        double e = 0, a = 0, best = 1e30, mean_spp = 0;
        for (int s = 0; s < seeds; ++s) {
          double sec = 0;
          uint64_t taken = 0;
          Pixels img = render_image(scene, cam, Integrator::path, k, spp, uint64_t(1 + s), &sec, target, &taken);
          e += rel_mse(img, ref) / seeds;
          a += rel_mae(img, ref) / seeds;
          mean_spp += double(adaptive ? taken : uint64_t(spp) * W * H) / (double(W) * H) / seeds;
          best = std::min(best, sec);
        }
        csv << scene_name << "," << method << "," << spp << "," << best << "," << e << "," << a << "," << target
            << "," << mean_spp << "\n";
        csv.flush();
        secs.push_back(best), mses.push_back(e);
        std::printf("  %-36s %s %-6.3g mean spp %7.1f  %.3f s  relMSE %.4g relMAE %.4f relMSE x s %.4g\n",
                    method.c_str(), adaptive ? "target" : "spp   ", adaptive ? target : double(spp), mean_spp, best,
                    e, a, e * best);
        std::fflush(stdout);
      }
      slopes << scene_name << "," << method << "," << loglog_slope(secs, mses) << "\n";
      slopes.flush();
    }
  (void)h;
}

template <class S>
void default_scene(Harness& h, const char* model, Harness::Reference* ref_out) {
  Scene<S> scene;
  build_cornell_box(scene);
  scene.build();
  const auto cam = default_camera(W, H);
  Harness::Reference ref = h.reference(std::string("default_") + model, scene, cam);
  h.run_methods("default", std::string("/") + model, scene, cam, ref);
  *ref_out = std::move(ref);
}

}  // namespace

int main(int argc, char** argv) {
  const std::string out = argc > 1 ? argv[1] : "bench/results";
  const std::string shared = argc > 2 ? argv[2] : "../shared";
  Harness h;
  h.cache_dir = argc > 3 ? argv[3] : "bench/convergence/cache";
  if (argc > 4) h.ref_spp = std::max(1, std::atoi(argv[4]));
  std::filesystem::create_directories(out);
  if (argc > 5 && std::string(argv[5]) == "adaptive") {
    std::ofstream csv(out + "/convergence_adaptive.csv"), slopes(out + "/convergence_adaptive_slopes.csv");
    if (!csv || !slopes) {
      std::fprintf(stderr, "convergence_bench: cannot write into %s\n", out.c_str());
      return 1;
    }
    csv << "scene,method,spp,seconds,relmse,relmae,target,mean_spp\n";
    slopes << "scene,method,slope_relmse_seconds\n";
    const auto t0 = std::chrono::steady_clock::now();
    std::printf("adaptive against uniform sampling, default scene, %dx%d\n", W, H);
    auto one = [&](auto model_tag, const char* model) {
      using S = decltype(model_tag);
      Scene<S> scene;
      build_cornell_box(scene);
      scene.build();
      const auto cam = default_camera(W, H);
      Harness::Reference ref = h.reference(std::string("default_") + model, scene, cam);
      run_adaptive(h, csv, slopes, "default", std::string("/") + model, scene, cam, ref);
    };
    one(RGB{}, "rgb");
    one(Spectral{}, "spectral");
    std::printf("total %.0f s\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    return 0;
  }
  h.csv.open(out + "/convergence.csv");
  h.slopes.open(out + "/convergence_slopes.csv");
  if (!h.csv || !h.slopes) {
    std::fprintf(stderr, "convergence_bench: cannot write into %s\n", out.c_str());
    return 1;
  }
  h.csv << "scene,method,spp,seconds,relmse,relmae\n";
  h.slopes << "scene,method,slope_relmse_seconds,slope_relmse_less_floor_seconds,slope_relmse_spp,slope_relmae_seconds,"
              "ref_floor_relmse,seconds_256,relmse_256,"
              "relmae_256,relmse_x_seconds_256\n";
  const auto t0 = std::chrono::steady_clock::now();

  // The default scene, RGB and spectral.
  std::printf("default scene, %dx%d\n", W, H);
  Harness::Reference ref_rgb, ref_spectral;
  default_scene<RGB>(h, "rgb", &ref_rgb);
  default_scene<Spectral>(h, "spectral", &ref_spectral);
  std::printf("  RGB reference against the spectral one: relMSE %.4g relMAE %.4f (the colour model's bias)\n",
              rel_mse(ref_rgb.px, ref_spectral.px), rel_mae(ref_rgb.px, ref_spectral.px));

  // The many-lights scene: power against BVH light selection (the BSDF
  // integrator never selects a light, so it runs once).
  {
    std::printf("many-lights scene (1000 lights), %dx%d\n", W, H);
    Scene<RGB> power, bvh;
    build_many_lights_scene(power);
    build_many_lights_scene(bvh);
    power.set_light_selection(LightSelection::power);
    bvh.set_light_selection(LightSelection::bvh);
    power.build();
    bvh.build();
    const auto cam = many_lights_camera(W, H);
    Harness::Reference ref = h.reference("many_lights_rgb", bvh, cam);
    h.run_methods("many_lights", "/bvh", bvh, cam, ref);
    h.run_methods("many_lights", "/power", power, cam, ref, false);
  }

  // MetalRoughSpheresNoTextures under the shared HDR environment.
  const std::string model = shared + "/scenes/MetalRoughSpheresNoTextures/glTF/MetalRoughSpheresNoTextures.gltf";
  const std::string env = shared + "/scenes/envmaps/chinese_garden_1k.hdr";
  if (std::filesystem::exists(model) && std::filesystem::exists(env)) {
    std::printf("environment-lit MetalRoughSpheresNoTextures, %dx%d\n", W, H);
    auto g = load_gltf<RGB>(model);
    g.scene.add_light(ImageInfiniteLight<RGB>(read_environment(env), 1));
    g.scene.build();
    const auto cam = gltf_framing_camera(g.bounds, W, H);
    Harness::Reference ref = h.reference("env_spheres_rgb", g.scene, cam);
    h.run_methods("env_spheres", "/rgb", g.scene, cam, ref);
  } else {
    std::printf("convergence_bench: %s or %s not found: the environment-lit scene is skipped\n", model.c_str(),
                env.c_str());
  }
  std::printf("total %.0f s\n",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  return 0;
}
