// render_bench: samples/s of the built-in default scene at 1 and 2 threads, in
// RGB and in spectral mode (median of several runs), written to
// bench/results/render.csv with the 2-thread speedup and the cost of a
// spectral sample relative to an RGB one. Run from the project root
// (scripts/bench.sh does).
//
// The last column, pair_speedup, is what the machine itself gives two
// threads at that moment: two 1-thread renders run side by side, each with
// its own film and nothing shared but the (read-only) scene, against one
// alone (2 x its median time / the pair's median wall time). On a virtual
// machine whose second vCPU is slower or busier at times, this is the
// ceiling of the 2-thread speedup: the render loop's own cost of going
// parallel is the gap between the two.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>
#include <prism/prism.hpp>

namespace {

constexpr int width = 256, height = 256, spp = 32, runs = 9;

struct Row {
  const char* colour;
  int threads;
  double seconds, msamples, mrays;
};

// One render of the default scene in colour model S.
template <class S>
prism::RenderStats render_once(const prism::Scene<S>& scene, int threads) {
  using namespace prism;
  PerspectiveCamera cam = default_camera(width, height);
  Film film(width, height);
  RenderOptions opt;
  opt.spp = spp;
  opt.threads = threads;
  return render(scene, cam, PathIntegrator{}, film, opt);
}

// Wall seconds of two 1-thread renders of the scene run at once.
template <class S>
double pair_seconds(const prism::Scene<S>& scene) {
  auto t0 = std::chrono::steady_clock::now();
  std::thread other([&] { render_once(scene, 1); });
  render_once(scene, 1);
  other.join();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

Row median_row(const char* colour, int threads, std::vector<prism::RenderStats> st) {
  std::sort(st.begin(), st.end(), [](const auto& a, const auto& b) { return a.seconds < b.seconds; });
  const prism::RenderStats& m = st[st.size() / 2];
  return {colour, threads, m.seconds, double(m.samples) / m.seconds * 1e-6, double(m.rays) / m.seconds * 1e-6};
}

}  // namespace

int main(int argc, char** argv) {
  const char* out_path = argc > 1 ? argv[1] : "bench/results/render.csv";
  prism::Scene<prism::RGB> rgb_scene;
  prism::build_cornell_box(rgb_scene);
  rgb_scene.build();
  prism::Scene<prism::Spectral> spectral_scene;
  prism::build_cornell_box(spectral_scene);
  spectral_scene.build();
  (void)prism::srgb_to_spectrum_table();  // fitted once, before any timing
  // RGB and spectral, 1 and 2 threads, alternate run by run so that a slow
  // phase of the (virtual) machine hits every configuration alike; each
  // figure is the median of its runs.
  std::vector<prism::RenderStats> st[2][2];
  std::vector<double> pair[2];
  for (int r = 0; r < runs; ++r) {
    for (int t = 0; t < 2; ++t) {
      st[0][t].push_back(render_once(rgb_scene, t + 1));
      st[1][t].push_back(render_once(spectral_scene, t + 1));
    }
    pair[0].push_back(pair_seconds(rgb_scene));
    pair[1].push_back(pair_seconds(spectral_scene));
  }
  std::vector<Row> rows;
  for (int c = 0; c < 2; ++c)
    for (int t = 0; t < 2; ++t) rows.push_back(median_row(c == 0 ? "rgb" : "spectral", t + 1, st[c][t]));
  std::filesystem::create_directories(std::filesystem::path(out_path).parent_path());
  std::ofstream csv(out_path);
  const char* header =
      "scene,colour,integrator,threads,width,height,spp,seconds,msamples_per_s,mrays_per_s,speedup,"
      "cost_vs_rgb,pair_speedup\n";
  csv << header;
  std::printf("%s", header);
  for (const Row& r : rows) {
    const Row& one = std::string(r.colour) == "rgb" ? rows[0] : rows[2];
    const Row& rgb_same_threads = rows[size_t(r.threads - 1)];
    const double pair_speedup = r.threads == 1 ? 1.0 : 2 * one.seconds / median(pair[&one == &rows[0] ? 0 : 1]);
    char line[256];
    std::snprintf(line, sizeof line, "default,%s,path,%d,%d,%d,%d,%.4f,%.4f,%.4f,%.3f,%.3f,%.3f\n", r.colour,
                  r.threads, width, height, spp, r.seconds, r.msamples, r.mrays, one.seconds / r.seconds,
                  r.seconds / rgb_same_threads.seconds, pair_speedup);
    csv << line;
    std::fputs(line, stdout);
  }
  return 0;
}
