// render_bench: samples/s of the built-in default scene at 1 and 2 threads, in
// RGB and in spectral mode (median of several runs), written to
// bench/results/render.csv with the 2-thread speedup and the cost of a
// spectral sample relative to an RGB one. Run from the project root
// (scripts/bench.sh does).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>
#include <prism/prism.hpp>

namespace {

constexpr int width = 256, height = 256, spp = 32, runs = 9;

struct Row {
  const char* colour;
  int threads;
  double seconds, msamples, mrays;
};

// 1- and 2-thread runs alternate so that a slow phase of the (virtual) machine
// hits both alike; each figure is the median of its runs.
template <class S>
void bench(const char* colour, std::vector<Row>& rows) {
  using namespace prism;
  Scene<S> scene;
  build_cornell_box(scene);
  scene.build();
  PerspectiveCamera cam = default_camera(width, height);
  std::vector<RenderStats> st[2];
  for (int r = 0; r < runs; ++r)
    for (int t = 0; t < 2; ++t) {
      Film film(width, height);
      RenderOptions opt;
      opt.spp = spp;
      opt.threads = t + 1;
      st[t].push_back(render(scene, cam, PathIntegrator{}, film, opt));
    }
  for (int t = 0; t < 2; ++t) {
    std::sort(st[t].begin(), st[t].end(), [](const auto& a, const auto& b) { return a.seconds < b.seconds; });
    const RenderStats& m = st[t][st[t].size() / 2];
    rows.push_back({colour, t + 1, m.seconds, double(m.samples) / m.seconds * 1e-6, double(m.rays) / m.seconds * 1e-6});
  }
}

}  // namespace

int main(int argc, char** argv) {
  const char* out_path = argc > 1 ? argv[1] : "bench/results/render.csv";
  std::vector<Row> rows;
  bench<prism::RGB>("rgb", rows);
  bench<prism::Spectral>("spectral", rows);
  std::filesystem::create_directories(std::filesystem::path(out_path).parent_path());
  std::ofstream csv(out_path);
  const char* header =
      "scene,colour,integrator,threads,width,height,spp,seconds,msamples_per_s,mrays_per_s,speedup,"
      "cost_vs_rgb\n";
  csv << header;
  std::printf("%s", header);
  for (const Row& r : rows) {
    const Row& one = std::string(r.colour) == "rgb" ? rows[0] : rows[2];
    const Row& rgb_same_threads = rows[size_t(r.threads - 1)];
    char line[256];
    std::snprintf(line, sizeof line, "default,%s,path,%d,%d,%d,%d,%.4f,%.4f,%.4f,%.3f,%.3f\n", r.colour, r.threads,
                  width, height, spp, r.seconds, r.msamples, r.mrays, one.seconds / r.seconds,
                  r.seconds / rgb_same_threads.seconds);
    csv << line;
    std::fputs(line, stdout);
  }
  return 0;
}
