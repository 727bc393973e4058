// render_bench: samples/s of the built-in default scene at 1 and 2 threads
// (median of several runs), written to bench/results/render.csv together with
// the 2-thread speedup. Run from the project root (scripts/bench.sh does).
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <vector>
#include <prism/prism.hpp>

int main(int argc, char** argv) {
  using namespace prism;
  const char* out_path = argc > 1 ? argv[1] : "bench/results/render.csv";
  const int width = 256, height = 256, spp = 32, runs = 9;
  Scene<RGB> scene;
  build_cornell_box(scene);
  scene.build();
  PerspectiveCamera cam = default_camera(width, height);

  struct Row {
    int threads;
    double seconds, msamples, mrays;
  };
  // 1- and 2-thread runs alternate so that a slow phase of the (virtual) machine
  // hits both alike; each figure is the median of its runs.
  std::vector<RenderStats> st[2];
  for (int r = 0; r < runs; ++r)
    for (int t = 0; t < 2; ++t) {
      RGBFilm film(width, height);
      RenderOptions opt;
      opt.spp = spp;
      opt.threads = t + 1;
      st[t].push_back(render(scene, cam, PathIntegrator{}, film, opt));
    }
  std::vector<Row> rows;
  for (int t = 0; t < 2; ++t) {
    std::sort(st[t].begin(), st[t].end(), [](const auto& a, const auto& b) { return a.seconds < b.seconds; });
    const RenderStats& m = st[t][st[t].size() / 2];
    rows.push_back({t + 1, m.seconds, double(m.samples) / m.seconds * 1e-6, double(m.rays) / m.seconds * 1e-6});
  }
  std::filesystem::create_directories(std::filesystem::path(out_path).parent_path());
  std::ofstream csv(out_path);
  csv << "scene,colour,integrator,threads,width,height,spp,seconds,msamples_per_s,mrays_per_s,speedup\n";
  std::printf("scene,colour,integrator,threads,width,height,spp,seconds,msamples_per_s,mrays_per_s,speedup\n");
  for (const Row& r : rows) {
    double speedup = rows[0].seconds / r.seconds;
    char line[256];
    std::snprintf(line, sizeof line, "default,rgb,path,%d,%d,%d,%d,%.4f,%.4f,%.4f,%.3f\n", r.threads, width, height, spp,
                  r.seconds, r.msamples, r.mrays, speedup);
    csv << line;
    std::fputs(line, stdout);
  }
  return 0;
}
