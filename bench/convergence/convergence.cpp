// Convergence harness (issue 8, item 1): error against time for each
// rendering method on scenes where methods differ, against a cached high-spp
// reference.
//
// Scenes (names for --scenes=):
//   default      the default scene (Cornell box with the SF11 prism, gold and
//                frosted spheres), in RGB and in spectral mode;
//   many_lights  1000 small emitters (render/many_lights_scene.hpp);
//   env_spheres  MetalRoughSpheresNoTextures under the chinese_garden HDR;
//   tiny_light   a sphere light of radius 1e-3 of the scene with a normal
//                light's power, over diffuse, glossy and rough surfaces;
//   caustic      a smooth and a rough glass sphere focusing a small light onto
//                a diffuse floor;
//   env_sun      DamagedHelmet under the chinese_garden HDR plus a distant sun
//                light, over a diffuse ground;
//   prism        spectral only: a small white lamp, a slit, an N-SF11 prism
//                and a screen that receives the spectrum.
// (bench/convergence/scenes.hpp builds tiny_light, caustic and prism; the
// shared-scene ones are skipped cleanly when the shared directory is absent.)
//
// Methods: integrator x sampler x light selection x colour model. Integrators:
// `path` (NEE + MIS), `nomis` (the same path integrator with NEE but without
// MIS weights, PathOptions::mis = false) and `bsdf` (BSDF sampling only).
// Samplers: independent (PCG32), stratified (multi-jittered) and sobol
// (Owen-scrambled). Per scene: path with all three samplers, nomis and bsdf
// with independent and sobol (bsdf not on env_sun, whose delta sun BSDF
// sampling can never hit); on many_lights also path with power and uniform
// light selection next to the BVH.
//
// Each scene and colour model has one reference: the path integrator with the
// independent sampler at a high sample count, the mean of two halves with
// independent seeds no method uses (their difference estimates the
// reference's own relMSE, the noise floor every measured relMSE includes),
// stored as bench/convergence/cache/<scene>_<model>_<W>x<H>_spp<N>_seed<S>.exr
// (the spp and first seed in the name; the EXR header holds prism.* string
// attributes: scene, size, spp, both seeds, integrator, sampler, render time
// and the noise floor, repeated in a sidecar .txt for reading by eye; a .png
// preview next to them) and reused when its header matches the run. Spectral methods are measured against the spectral reference,
// RGB ones against the RGB reference.
//
// Each method renders at 1, 2, 4, ..., 256 spp, each budget with
// max(seeds, 16 / spp) independent seeds (seeds = 3 unless --seeds=N): the
// CSV has the mean error over those renders and its standard deviation (the
// spread of one render's error), and the best and the median time. Errors:
// relMSE = mean over pixels and channels of (v - ref)^2 / (ref^2 + 1e-2), and
// relMAE = sum |v - ref| / sum ref.
// Writes bench/results/convergence.csv (scene, method, spp, renders, seconds
// (best), seconds_median, relmse, relmse_sd, relmae, relmae_sd) and
// bench/results/convergence_slopes.csv: per method the least-squares slope of
// log mean relMSE against log best seconds (ideal -1 for an unbiased Monte
// Carlo estimator at constant cost per sample) with the standard deviation of
// the same slope fitted to each seed's renders alone, the slope with the
// reference's noise floor subtracted, the slope against log spp, the slope of
// log relMAE against log seconds (ideal -1/2), and relMSE x seconds at 256
// spp (lower is better at equal time).
//
// --scenes=a,b,... runs only those scenes; their rows replace the same
// scenes' rows in the existing CSVs (other scenes' rows are kept, if the files
// have the current columns), so scenes can be run one at a time.
//
// With the word `adaptive` as fifth argument, it runs only the
// adaptive-sampling comparison (docs/adaptive.md) on the default scene, RGB
// and spectral: path/independent and path/sobol uniform at 1..256 spp against
// the same with adaptive sampling (min 4 spp, at most 1024) at targets 1.6,
// 1.13, 0.8, ..., 0.1 (relative error per pixel; the mean over 2 seeds while
// the target is 0.8 or more), all in the same run so that their times compare,
// into bench/results/convergence_adaptive.csv (scene, method, spp, seconds,
// relmse, relmae, target, mean_spp) and convergence_adaptive_slopes.csv.
//
// Usage: convergence_bench [out_dir=bench/results] [shared=../shared]
//        [cache=bench/convergence/cache] [ref_spp=0] [adaptive]
//        [--scenes=a,b,...] [--seeds=N] [--references-only]
// --references-only renders (or loads) the selected scenes' references and
// measures no method (for checking a scene; the CSVs keep only the header and
// the rows of the scenes not selected).
// ref_spp 0 (or absent) takes each scene's own reference spp (8192 for the
// default, many-lights and env_spheres scenes; the others are listed in
// main()); a positive value overrides them all.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>
#include <prism/io/gltf.hpp>
#include <prism/io/image_io.hpp>
#include <prism/prism.hpp>
#include <prism/render/many_lights_scene.hpp>
#include "scenes.hpp"

using namespace prism;

namespace {

constexpr int W = 64, H = 64;
constexpr uint64_t ref_seed = 987654321;
constexpr int max_spp = 256;
// Reference spp of the new scenes, each chosen so that its reference takes at
// most about 3 minutes on one thread of the 2-core development machine.
constexpr int tiny_light_ref_spp = 8192, caustic_ref_spp = 4096, env_sun_ref_spp = 4096, prism_ref_spp = 8192;

using Pixels = std::vector<float>;  // 3 floats per pixel, row-major

// path: NEE + MIS; nomis: NEE without MIS weights; bsdf: BSDF sampling only.
enum class Integrator { path, nomis, bsdf };

inline const char* integrator_name(Integrator i) {
  return i == Integrator::path ? "path" : i == Integrator::nomis ? "nomis" : "bsdf";
}
inline const char* sampler_name(SamplerKind k) {
  return k == SamplerKind::independent ? "independent" : k == SamplerKind::stratified ? "stratified" : "sobol";
}

struct Method {
  Integrator integ;
  SamplerKind sampler;
};

// The standard set: path with every sampler, nomis and (when with_bsdf) bsdf
// with independent and sobol.
std::vector<Method> standard_methods(bool with_bsdf = true) {
  std::vector<Method> m = {{Integrator::path, SamplerKind::independent},
                           {Integrator::path, SamplerKind::stratified},
                           {Integrator::path, SamplerKind::sobol},
                           {Integrator::nomis, SamplerKind::independent},
                           {Integrator::nomis, SamplerKind::sobol}};
  if (with_bsdf) {
    m.push_back({Integrator::bsdf, SamplerKind::independent});
    m.push_back({Integrator::bsdf, SamplerKind::sobol});
  }
  return m;
}

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
  PathOptions no_mis;
  no_mis.mis = false;
  RenderStats st = integ == Integrator::path    ? render(scene, cam, PathIntegrator{}, film, opt)
                   : integ == Integrator::nomis ? render(scene, cam, PathIntegrator{no_mis}, film, opt)
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

double mean_of(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0 : s / double(v.size());
}
// Sample standard deviation (0 for fewer than two values).
double sd_of(const std::vector<double>& v) {
  if (v.size() < 2) return 0;
  double m = mean_of(v), ss = 0;
  for (double x : v) ss += (x - m) * (x - m);
  return std::sqrt(ss / double(v.size() - 1));
}
double median_of(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// The lines of an existing CSV whose header is `header` and whose first
// field (the scene) is not in `replaced`: kept when only some scenes run.
std::vector<std::string> kept_rows(const std::string& path, const std::string& header,
                                   const std::set<std::string>& replaced) {
  std::vector<std::string> rows;
  std::ifstream in(path);
  std::string line;
  if (!in || !std::getline(in, line) || line != header) return rows;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    if (!replaced.count(line.substr(0, line.find(',')))) rows.push_back(line);
  }
  return rows;
}

struct Harness {
  std::string cache_dir;
  int ref_spp_override = 0;  // > 0: every scene's reference at this spp
  int seeds = 3;
  bool references_only = false;  // render or load the references, measure no method
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
  Reference reference(const std::string& key, const Scene& scene, const Camera& cam, int scene_ref_spp = 8192) {
    const int ref_spp = ref_spp_override > 0 ? ref_spp_override : scene_ref_spp;
    const std::string stem = cache_dir + "/" + key + "_" + std::to_string(W) + "x" + std::to_string(H) + "_spp" +
                             std::to_string(ref_spp) + "_seed" + std::to_string(ref_seed);
    Reference r;
    // Reused when the EXR's header says it was made as this run would make
    // it (size, spp, seeds); older caches keep that in the sidecar .txt only.
    if (std::filesystem::exists(stem + ".exr")) {
      Image img = read_exr(stem + ".exr");
      std::map<std::string, std::string> meta = read_exr_attributes(stem + ".exr");
      if (meta.empty() && std::filesystem::exists(stem + ".txt")) {
        std::ifstream side(stem + ".txt");
        std::string word, value;
        while (side >> word && std::getline(side >> std::ws, value)) meta["prism." + word] = value;
      }
      const std::string seeds = std::to_string(ref_seed) + " " + std::to_string(ref_seed + 1);
      bool matches = img.width == W && img.height == H && meta["prism.spp"] == std::to_string(2 * std::max(1, ref_spp / 2)) &&
                     meta["prism.seeds"] == seeds && meta.count("prism.floor_relmse") == 1;
      if (matches) {
        r.floor = std::stod(meta["prism.floor_relmse"]);
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
    // How the reference was made, in its EXR header (prism.* string
    // attributes, read_exr_attributes) and, for reading by eye, a sidecar.
    std::ostringstream floor_text;
    floor_text.precision(9);
    floor_text << r.floor;
    ExrAttributes meta = {{"prism.scene", key},
                          {"prism.width", std::to_string(W)},
                          {"prism.height", std::to_string(H)},
                          {"prism.spp", std::to_string(2 * half)},
                          {"prism.seeds", std::to_string(ref_seed) + " " + std::to_string(ref_seed + 1)},
                          {"prism.integrator", "path"},
                          {"prism.sampler", "independent"},
                          {"prism.seconds", std::to_string(sec_a + sec_b)},
                          {"prism.floor_relmse", floor_text.str()}};
    write_exr(stem + ".exr", Image{W, H, r.px}, meta);
    write_png(stem + ".png", Image{W, H, r.px});
    std::ofstream side(stem + ".txt");
    for (const auto& [name, value] : meta) side << name.substr(6) << " " << value << "\n";
    std::printf("%s: reference in %.1f s, noise floor relMSE %.3g\n", key.c_str(), sec_a + sec_b, r.floor);
    return r;
  }

  // Each method on one scene object; `suffix` names the rest of the method
  // (light selection, colour model).
  template <class Scene, class Camera>
  void run_methods(const std::string& scene_name, const std::string& suffix, const Scene& scene, const Camera& cam,
                   const Reference& reference, const std::vector<Method>& methods) {
    const Pixels& ref = reference.px;
    if (references_only) return;
    for (const Method& m : methods) {
      const std::string method = std::string(integrator_name(m.integ)) + "/" + sampler_name(m.sampler) + suffix;
      std::vector<double> secs, mses, maes, spps, corrected;
      // Per seed index s < seeds: that seed's time and relMSE at every budget.
      std::vector<std::vector<double>> seed_secs(static_cast<size_t>(seeds)), seed_mses(static_cast<size_t>(seeds));
      double sd_256 = 0;
      for (int spp = 1; spp <= max_spp; spp *= 2) {
        const int renders = std::max(seeds, 16 / spp);
        std::vector<double> e, a, t;
        for (int s = 0; s < renders; ++s) {
          double sec = 0;
          Pixels img = render_image(scene, cam, m.integ, m.sampler, spp, uint64_t(1 + s), &sec);
          e.push_back(rel_mse(img, ref));
          a.push_back(rel_mae(img, ref));
          t.push_back(sec);
          if (s < seeds) seed_secs[size_t(s)].push_back(sec), seed_mses[size_t(s)].push_back(e.back());
        }
        const double best = *std::min_element(t.begin(), t.end());
        csv << scene_name << "," << method << "," << spp << "," << renders << "," << best << "," << median_of(t)
            << "," << mean_of(e) << "," << sd_of(e) << "," << mean_of(a) << "," << sd_of(a) << "\n";
        secs.push_back(best), mses.push_back(mean_of(e)), maes.push_back(mean_of(a)), spps.push_back(spp);
        corrected.push_back(mean_of(e) - reference.floor);
        sd_256 = sd_of(e);
      }
      csv.flush();
      std::vector<double> seed_slopes;
      for (int s = 0; s < seeds; ++s) seed_slopes.push_back(loglog_slope(seed_secs[size_t(s)], seed_mses[size_t(s)]));
      const double s_time = loglog_slope(secs, mses), s_spp = loglog_slope(spps, mses),
                   s_corr = loglog_slope(secs, corrected), s_mae = loglog_slope(secs, maes),
                   s_sd = sd_of(seed_slopes), merit = mses.back() * secs.back();
      std::printf("  %-32s slope relMSE/s %6.3f +- %.3f (less floor %6.3f) /spp %6.3f  relMAE/s %6.3f  256 spp: "
                  "%.3f s relMSE %.4g +- %.2g relMAE %.4f relMSE x s %.4g\n",
                  method.c_str(), s_time, s_sd, s_corr, s_spp, s_mae, secs.back(), mses.back(), sd_256, maes.back(),
                  merit);
      std::fflush(stdout);
      slopes << scene_name << "," << method << "," << s_time << "," << s_sd << "," << s_corr << "," << s_spp << ","
             << s_mae << "," << reference.floor << "," << secs.back() << "," << mses.back() << "," << sd_256 << ","
             << maes.back() << "," << merit << "\n";
      slopes.flush();
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
  h.run_methods("default", std::string("/") + model, scene, cam, ref, standard_methods());
  *ref_out = std::move(ref);
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> pos;
  std::set<std::string> only;
  int seeds = 3;
  bool references_only = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a.rfind("--scenes=", 0) == 0) {
      std::stringstream ss(a.substr(9));
      std::string name;
      while (std::getline(ss, name, ','))
        if (!name.empty()) only.insert(name);
    } else if (a.rfind("--seeds=", 0) == 0) {
      seeds = std::max(1, std::atoi(a.c_str() + 8));
    } else if (a == "--references-only") {
      references_only = true;
    } else if (a.rfind("--", 0) == 0) {
      std::fprintf(stderr, "convergence_bench: unknown option %s (known: --scenes=a,b,... --seeds=N "
                   "--references-only)\n", a.c_str());
      return 2;
    } else {
      pos.push_back(a);
    }
  }
  const std::string out = pos.size() > 0 ? pos[0] : "bench/results";
  const std::string shared = pos.size() > 1 ? pos[1] : "../shared";
  Harness h;
  h.cache_dir = pos.size() > 2 ? pos[2] : "bench/convergence/cache";
  if (pos.size() > 3) h.ref_spp_override = std::max(0, std::atoi(pos[3].c_str()));
  h.seeds = seeds;
  h.references_only = references_only;
  std::filesystem::create_directories(out);
  const std::set<std::string> known = {"default", "many_lights", "env_spheres", "tiny_light",
                                       "caustic", "env_sun",     "prism"};
  for (const std::string& n : only)
    if (!known.count(n)) {
      std::fprintf(stderr, "convergence_bench: unknown scene '%s' in --scenes (known: default, many_lights, "
                   "env_spheres, tiny_light, caustic, env_sun, prism)\n", n.c_str());
      return 2;
    }
  auto wants = [&](const std::string& n) { return only.empty() || only.count(n) > 0; };
  const bool adaptive_mode = pos.size() > 4 && pos[4] == "adaptive";
  if (adaptive_mode) {
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
  const std::string header = "scene,method,spp,renders,seconds,seconds_median,relmse,relmse_sd,relmae,relmae_sd";
  const std::string slopes_header =
      "scene,method,slope_relmse_seconds,slope_relmse_seconds_sd,slope_relmse_less_floor_seconds,slope_relmse_spp,"
      "slope_relmae_seconds,ref_floor_relmse,seconds_256,relmse_256,relmse_256_sd,relmae_256,relmse_x_seconds_256";
  // With --scenes, the other scenes' rows of the existing files are kept.
  std::vector<std::string> keep_csv, keep_slopes;
  if (!only.empty()) {
    keep_csv = kept_rows(out + "/convergence.csv", header, only);
    keep_slopes = kept_rows(out + "/convergence_slopes.csv", slopes_header, only);
  }
  h.csv.open(out + "/convergence.csv");
  h.slopes.open(out + "/convergence_slopes.csv");
  if (!h.csv || !h.slopes) {
    std::fprintf(stderr, "convergence_bench: cannot write into %s\n", out.c_str());
    return 1;
  }
  h.csv << header << "\n";
  for (const auto& r : keep_csv) h.csv << r << "\n";
  h.slopes << slopes_header << "\n";
  for (const auto& r : keep_slopes) h.slopes << r << "\n";
  h.csv.flush(), h.slopes.flush();
  const auto t0 = std::chrono::steady_clock::now();
  std::printf("%d seed(s) per budget, %dx%d\n", h.seeds, W, H);

  // The default scene, RGB and spectral.
  if (wants("default")) {
    std::printf("default scene\n");
    Harness::Reference ref_rgb, ref_spectral;
    default_scene<RGB>(h, "rgb", &ref_rgb);
    default_scene<Spectral>(h, "spectral", &ref_spectral);
    std::printf("  RGB reference against the spectral one: relMSE %.4g relMAE %.4f (the colour model's bias)\n",
                rel_mse(ref_rgb.px, ref_spectral.px), rel_mae(ref_rgb.px, ref_spectral.px));
  }

  // The many-lights scene: BVH against power and uniform light selection
  // (the BSDF integrator never selects a light, so it runs once, under bvh).
  if (wants("many_lights")) {
    std::printf("many-lights scene (1000 lights)\n");
    Scene<RGB> power, bvh, uniform;
    build_many_lights_scene(power);
    build_many_lights_scene(bvh);
    build_many_lights_scene(uniform);
    power.set_light_selection(LightSelection::power);
    bvh.set_light_selection(LightSelection::bvh);
    uniform.set_light_selection(LightSelection::uniform);
    power.build();
    bvh.build();
    uniform.build();
    const auto cam = many_lights_camera(W, H);
    Harness::Reference ref = h.reference("many_lights_rgb", bvh, cam);
    h.run_methods("many_lights", "/bvh", bvh, cam, ref, standard_methods());
    const std::vector<Method> path_only = {{Integrator::path, SamplerKind::independent},
                                           {Integrator::path, SamplerKind::sobol}};
    h.run_methods("many_lights", "/power", power, cam, ref, path_only);
    h.run_methods("many_lights", "/uniform", uniform, cam, ref, path_only);
  }

  const std::string env = shared + "/scenes/envmaps/chinese_garden_1k.hdr";
  // MetalRoughSpheresNoTextures under the shared HDR environment.
  if (wants("env_spheres")) {
    const std::string model = shared + "/scenes/MetalRoughSpheresNoTextures/glTF/MetalRoughSpheresNoTextures.gltf";
    if (std::filesystem::exists(model) && std::filesystem::exists(env)) {
      std::printf("environment-lit MetalRoughSpheresNoTextures\n");
      auto g = load_gltf<RGB>(model);
      g.scene.add_light(ImageInfiniteLight<RGB>(read_environment(env), 1));
      g.scene.build();
      const auto cam = gltf_framing_camera(g.bounds, W, H);
      Harness::Reference ref = h.reference("env_spheres_rgb", g.scene, cam);
      h.run_methods("env_spheres", "/rgb", g.scene, cam, ref, standard_methods());
    } else {
      std::printf("convergence_bench: %s or %s not found: env_spheres is skipped\n", model.c_str(), env.c_str());
    }
  }

  // The scenes of scenes.hpp: built in code, framed by their own camera.
  auto run_code_scene = [&](auto& scene, const char* name, const char* colour, const auto& cam, int ref_spp) {
    scene.build();
    Harness::Reference ref = h.reference(std::string(name) + "_" + colour, scene, cam, ref_spp);
    h.run_methods(name, std::string("/") + colour, scene, cam, ref, standard_methods());
  };

  // A tiny, very bright sphere light over diffuse and glossy surfaces.
  if (wants("tiny_light")) {
    std::printf("tiny_light: a sphere light of radius 0.004 with a normal light's power\n");
    Scene<RGB> scene;
    convergence::build_tiny_light_scene(scene);
    run_code_scene(scene, "tiny_light", "rgb", convergence::tiny_light_camera(W, H), tiny_light_ref_spp);
  }

  // Caustics through a smooth and a rough glass sphere.
  if (wants("caustic")) {
    std::printf("caustic: smooth and rough glass spheres under a small light\n");
    Scene<RGB> scene;
    convergence::build_caustic_scene(scene);
    run_code_scene(scene, "caustic", "rgb", convergence::caustic_camera(W, H), caustic_ref_spp);
  }

  // A glTF model under the HDR environment plus a distant sun.
  if (wants("env_sun")) {
    const std::string model = shared + "/scenes/DamagedHelmet/glTF-Binary/DamagedHelmet.glb";
    if (std::filesystem::exists(model) && std::filesystem::exists(env)) {
      std::printf("env_sun: DamagedHelmet under the HDR environment and a sun\n");
      auto g = load_gltf<RGB>(model);
      // A diffuse ground just under the model, 3x its extent, to catch its shadow.
      const Bounds3f b = g.bounds;
      const Vector3f ext = b.max - b.min;
      const Float size = 3 * std::max(ext.x, ext.z);
      const Point3f c = b.min + ext * Float(0.5);
      MetalRoughMaterial ground_mr;  // the glTF scene's BxDF set: a dielectric, rough, grey
      ground_mr.base_color = RGB(0.5f), ground_mr.metallic = 0, ground_mr.roughness = 1, ground_mr.name = "ground";
      const typename decltype(g.scene)::material_type ground_m = ground_mr;
      const uint32_t ground = g.scene.add_material(ground_m);
      TriangleMesh plane;
      append_quad(plane, {c.x - size / 2, b.min.y, c.z - size / 2}, {0, 0, size}, {size, 0, 0});
      g.scene.add_mesh_instance(std::move(plane), ground);
      g.scene.add_light(ImageInfiniteLight<RGB>(read_environment(env), 1));
      // The sun: from above, front left; irradiance about twice the
      // environment's on a horizontal surface.
      g.scene.add_light(DistantLight<RGB>(Vector3f{0.5f, -0.8f, -0.35f}, RGB(1.f, 0.95f, 0.85f), 3.f));
      g.scene.build();
      Bounds3f framed = b;
      framed = union_bounds(framed, Point3f{c.x, b.min.y, c.z});
      const auto cam = gltf_framing_camera(framed, W, H);
      Harness::Reference ref = h.reference("env_sun_rgb", g.scene, cam, env_sun_ref_spp);
      h.run_methods("env_sun", "/rgb", g.scene, cam, ref, standard_methods(false));
    } else {
      std::printf("convergence_bench: %s or %s not found: env_sun is skipped\n", model.c_str(), env.c_str());
    }
  }

  // A dispersive prism, spectral only.
  if (wants("prism")) {
    std::printf("prism: a small white lamp, a slit, an N-SF11 prism and a screen (spectral)\n");
    Scene<Spectral> scene;
    convergence::build_prism_scene(scene);
    run_code_scene(scene, "prism", "spectral", convergence::prism_camera(W, H), prism_ref_spp);
  }
  std::printf("total %.0f s\n", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  return 0;
}
