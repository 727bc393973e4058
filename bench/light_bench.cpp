// light_bench: light selection (uniform, power, light BVH) at equal time.
// For the default scene (RGB) and the many-lights scene with 4 to 1000 lights
// (render/many_lights_scene.hpp), a 64x64 reference is rendered at high spp;
// then each selection renders at the spp that fills a fixed time budget on one
// thread (calibrated by short renders), for several seeds, and its relMSE
// against the reference, mean over pixels and channels of
// (x - ref)^2 / (ref^2 + 0.01), is averaged over the seeds. relMSE x seconds
// (the inverse efficiency) corrects for budgets not met exactly; the last
// column is its ratio to uniform selection's (below 1: better). The same
// over the pixels that see no emitter (surface_pixels) follows. Writes
// bench/results/light_selection.csv. Run from the project root.
// Each case is measured with full paths (max depth 64) and with direct light
// only (max depth 1: a light sample and a BSDF sample at the first surface,
// combined by MIS), where the selection's effect is not diluted by the noise
// of indirect light.
// Usage: light_bench [out.csv] [budget seconds] [reference spp]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>
#include <prism/prism.hpp>

namespace {

using namespace prism;

constexpr int width = 64, height = 64, seeds = 3;

struct Case {
  std::string name;
  int lights = 0;  // many-lights count; 0 for the default scene
};

void build_case(Scene<RGB>& scene, const Case& c) {
  if (c.lights == 0) build_cornell_box(scene);
  else build_many_lights_scene(scene, ManyLightsOptions{c.lights, 7, 64});
}
PerspectiveCamera camera_for(const Case& c) {
  return c.lights == 0 ? default_camera(width, height) : many_lights_camera(width, height);
}

using Pixels = std::vector<float>;  // RGB, row-major

Pixels render_image(const Scene<RGB>& scene, const Case& c, int spp, uint64_t seed, int threads, int max_depth,
                    double* seconds) {
  Film film(width, height);
  RenderOptions opt;
  opt.spp = spp;
  opt.seed = seed;
  opt.threads = threads;
  PathOptions popt;
  popt.max_depth = max_depth;
  RenderStats st = render(scene, camera_for(c), PathIntegrator(popt), film, opt);
  if (seconds) *seconds = st.seconds;
  return film.rgb_buffer();
}

// relMSE over the pixels whose mask entry is set (all when the mask is empty).
double rel_mse(const Pixels& img, const Pixels& ref, const std::vector<uint8_t>& mask = {}) {
  double sum = 0;
  size_t count = 0;
  for (size_t i = 0; i < ref.size(); ++i) {
    if (!mask.empty() && !mask[i / 3]) continue;
    sum += sqr(double(img[i]) - double(ref[i])) / (sqr(double(ref[i])) + 0.01);
    ++count;
  }
  return count ? sum / double(count) : 0;
}

// The pixels in which no camera ray of a 4x4 grid meets an emitter: their
// noise is that of the light reflected by surfaces, which light selection
// changes, not that of a bright light's edge crossing the pixel, which it
// does not.
std::vector<uint8_t> surface_pixels(const Scene<RGB>& scene, const Case& c) {
  PerspectiveCamera cam = camera_for(c);
  std::vector<uint8_t> mask(size_t(width) * height, 1);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      for (int j = 0; j < 16; ++j) {
        Point2f p{Float(x) + (Float(j % 4) + 0.5f) / 4, Float(y) + (Float(j / 4) + 0.5f) / 4};
        auto si = scene.intersect(cam.generate_ray(CameraSample{p, {0.5f, 0.5f}}));
        if (si && si->area_light >= 0) mask[size_t(y) * width + size_t(x)] = 0;
      }
  return mask;
}

}  // namespace

int main(int argc, char** argv) {
  const char* out_path = argc > 1 ? argv[1] : "bench/results/light_selection.csv";
  const double budget = argc > 2 ? std::atof(argv[2]) : 1.0;
  const int ref_spp = argc > 3 ? std::atoi(argv[3]) : 4096;
  std::vector<Case> cases{{"default", 0}};
  for (int n : {4, 16, 64, 256, 1000}) cases.push_back({"many_lights", n});
  const LightSelection kinds[3] = {LightSelection::uniform, LightSelection::power, LightSelection::bvh};

  std::filesystem::create_directories(std::filesystem::path(out_path).parent_path());
  std::ofstream csv(out_path);
  const char* header =
      "scene,lights,depth,selection,auto_choice,spp,seconds,us_per_sample,relmse,relmse_x_seconds,vs_uniform,"
      "surface_pixels,relmse_surfaces,vs_uniform_surfaces\n";
  csv << header;
  std::printf("%s", header);
  for (const Case& c : cases) {
    for (int max_depth : {64, 1}) {
      // The reference: BVH selection (any unbiased selection would do), 2 threads.
      Scene<RGB> ref_scene;
      build_case(ref_scene, c);
      ref_scene.set_light_selection(LightSelection::bvh);
      ref_scene.build();
      double ref_seconds = 0;
      Pixels ref = render_image(ref_scene, c, ref_spp, 987654321, 2, max_depth, &ref_seconds);
      Scene<RGB> auto_scene;
      build_case(auto_scene, c);
      auto_scene.build();
      const char* auto_choice = light_selection_name(auto_scene.light_selection());
      std::vector<uint8_t> mask = surface_pixels(auto_scene, c);
      size_t surface_count = 0;
      for (uint8_t m : mask) surface_count += m;
      std::fprintf(stderr, "%s %d, max depth %d: %zu lights, reference %d spp in %.1f s, auto: %s\n", c.name.c_str(),
                   c.lights, max_depth, auto_scene.lights().size(), ref_spp, ref_seconds, auto_choice);
      Scene<RGB> scenes[3];
      for (int k = 0; k < 3; ++k) {
        build_case(scenes[k], c);
        scenes[k].set_light_selection(kinds[k]);
        scenes[k].build();
      }
      // Time per spp: the fastest of three short renders per selection,
      // interleaved so that a slow phase of the shared machine hits all alike.
      const int probe_spp = 4;
      double best[3] = {1e30, 1e30, 1e30};
      for (int r = 0; r < 3; ++r)
        for (int k = 0; k < 3; ++k) {
          double t = 0;
          render_image(scenes[k], c, probe_spp, 100 + uint64_t(r), 1, max_depth, &t);
          best[k] = std::min(best[k], t);
        }
      int spp[3];
      double err[3] = {0, 0, 0}, err_s[3] = {0, 0, 0}, seconds[3] = {0, 0, 0};
      for (int k = 0; k < 3; ++k) spp[k] = std::max(1, int(budget / (best[k] / probe_spp) + 0.5));
      for (int s = 0; s < seeds; ++s)
        for (int k = 0; k < 3; ++k) {
          double t = 0;
          Pixels img = render_image(scenes[k], c, spp[k], 1 + uint64_t(s), 1, max_depth, &t);
          err[k] += rel_mse(img, ref) / seeds;
          err_s[k] += rel_mse(img, ref, mask) / seeds;
          seconds[k] += t / seeds;
        }
      for (int k = 0; k < 3; ++k) {
        double inv_eff = err[k] * seconds[k], uniform_inv_eff = err[0] * seconds[0];
        double ratio_s = (err_s[k] * seconds[k]) / (err_s[0] * seconds[0]);
        char line[400];
        std::snprintf(line, sizeof line, "%s,%zu,%s,%s,%s,%d,%.4f,%.4f,%.6g,%.6g,%.4f,%zu,%.6g,%.4f\n", c.name.c_str(),
                      scenes[k].lights().size(), max_depth == 1 ? "direct" : "full", light_selection_name(kinds[k]),
                      auto_choice, spp[k], seconds[k], seconds[k] / (double(spp[k]) * width * height) * 1e6, err[k],
                      inv_eff, inv_eff / uniform_inv_eff, surface_count, err_s[k], ratio_s);
        csv << line;
        std::fputs(line, stdout);
      }
      std::fflush(stdout);
    }
  }
  return 0;
}
