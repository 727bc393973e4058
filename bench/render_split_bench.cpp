// render_split_bench: does the render loop lose anything by going parallel?
// The default scene (256x256, 32 spp, RGB) is rendered four ways in each
// round, alternated so that a slow phase of the (virtual) machine hits all
// of them alike:
//   1. render() on 1 thread;
//   2. render() on 2 threads: tiles from a shared counter into one film;
//   3. two threads, each a 1-thread render() of half the samples of every
//      pixel (RenderOptions::first_sample, sample_count) into its own film,
//      the films merged at the end;
//   4. two threads, each a 1-thread render() of every other tile
//      (tile_stride 2) into its own film, merged at the end.
// Ways 3 and 4 share nothing while they run but the read-only scene, as two
// independent renders do; if way 2 scales less than they do, the loop's
// shared state (film, tile counter, the caustic pass's splat image) costs
// something. Prints each round and, per way, the 2-thread speedup as the
// ratio of the medians and as the median of the rounds' ratios; with a path
// argument, writes those to a CSV too. Not run by scripts/bench.sh (about 14
// seconds per round); docs/performance.md (twenty-eighth step) has its
// figures.
//   render_split_bench [rounds = 15] [out.csv]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <thread>
#include <vector>
#include <prism/prism.hpp>

namespace {

constexpr int width = 256, height = 256, spp = 32;
constexpr int ways = 4;
const char* const way_names[ways] = {"1 thread", "2 threads", "2 x half the samples", "2 x every other tile"};

prism::RenderOptions options(int threads) {
  prism::RenderOptions opt;
  opt.spp = spp;
  opt.threads = threads;
  return opt;
}

// Seconds to render the scene way `way` (0-3, above), films merged included.
double render_way(const prism::Scene<prism::RGB>& scene, int way) {
  using namespace prism;
  const PerspectiveCamera cam = default_camera(width, height);
  const auto start = std::chrono::steady_clock::now();
  if (way < 2) {
    Film film(width, height);
    render(scene, cam, PathIntegrator{}, film, options(way + 1));
  } else {
    Film film0(width, height), film1(width, height);
    RenderOptions opt0 = options(1), opt1 = options(1);
    if (way == 2) {
      opt0.sample_count = spp / 2;
      opt1.first_sample = spp / 2;
    } else {
      opt0.tile_stride = opt1.tile_stride = 2;
      opt1.tile_offset = 1;
    }
    std::thread other([&] { render(scene, cam, PathIntegrator{}, film1, opt1); });
    render(scene, cam, PathIntegrator{}, film0, opt0);
    other.join();
    film0.merge(film1);
  }
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  const int rounds = argc > 1 ? std::atoi(argv[1]) : 15;
  if (rounds < 1) {
    std::fprintf(stderr, "render_split_bench: rounds must be a positive number, not '%s'\n", argv[1]);
    return 1;
  }
  prism::Scene<prism::RGB> scene;
  prism::build_cornell_box(scene);
  scene.build();
  std::vector<double> seconds[ways];
  for (int r = 0; r < rounds; ++r) {
    for (int w = 0; w < ways; ++w) seconds[w].push_back(render_way(scene, w));
    std::printf("round %2d: seconds", r);
    for (int w = 0; w < ways; ++w) std::printf(" %.3f", seconds[w].back());
    std::printf("; speedups");
    for (int w = 1; w < ways; ++w) std::printf(" %.3f", seconds[0].back() / seconds[w].back());
    std::printf("\n");
    std::fflush(stdout);
  }
  std::FILE* csv = argc > 2 ? std::fopen(argv[2], "w") : nullptr;
  if (argc > 2 && !csv) {
    std::fprintf(stderr, "render_split_bench: cannot write '%s'\n", argv[2]);
    return 1;
  }
  if (csv) std::fprintf(csv, "way,rounds,median_seconds,speedup_of_medians,median_speedup\n");
  for (int w = 0; w < ways; ++w) {
    std::vector<double> ratios;
    for (int r = 0; r < rounds; ++r) ratios.push_back(seconds[0][size_t(r)] / seconds[w][size_t(r)]);
    const double of_medians = median(seconds[0]) / median(seconds[w]), of_rounds = median(ratios);
    std::printf("%-22s median %.3f s, speedup: ratio of medians %.3f, median of rounds %.3f\n", way_names[w],
                median(seconds[w]), of_medians, of_rounds);
    if (csv)
      std::fprintf(csv, "%s,%d,%.4f,%.3f,%.3f\n", way_names[w], rounds, median(seconds[w]), of_medians, of_rounds);
  }
  if (csv) std::fclose(csv);
  return 0;
}
