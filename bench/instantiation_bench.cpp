// instantiation_bench: what a compiled-in but unused feature costs
// (DESIGN.md: under 2% of render time; docs/instantiation.md).
//
// A diffuse-only scene (the Cornell box without prism, gold and glass) is
// rendered by renderers instantiated with growing BxDF sets: the minimal
// {diffuse}, then {diffuse} plus one more BxDF (conductor; dielectric, which
// carries dispersion; thin dielectric; metal_rough, which carries the
// textures, normal maps and alpha), then the full set, in RGB and in
// spectral mode. Likewise a metal_rough-only scene (what glTF files load
// as) in {metal_rough} and in the full set. For each:
//  - wall clock: the configurations alternate run by run (so that a slow
//    phase of a loaded machine hits all alike), one thread; median and best;
//  - callgrind: the instructions executed by one small render (valgrind
//    --tool=callgrind, instrumentation on around render() only), which do
//    not depend on the machine's load; run on instantiation_bench_callgrind,
//    this program built without AVX-512 (valgrind 3.19 cannot decode it),
//    found beside this one;
//  - whether the image is bitwise that of the minimal instantiation.
// Writes bench/results/instantiation.csv (or argv's --csv path).
// Spectral callgrind runs are off by default: under valgrind the RGB-to-
// spectrum table, fitted before counting starts, takes minutes per run.
// Usage: instantiation_bench [--runs N] [--csv PATH] [--no-callgrind] [--callgrind-spectral]
//        instantiation_bench --one SCENE COLOUR SET   (one render, for callgrind)
#if __has_include(<valgrind/callgrind.h>)
#include <valgrind/callgrind.h>
#else
#define CALLGRIND_START_INSTRUMENTATION
#define CALLGRIND_STOP_INSTRUMENTATION
#endif
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>
#include <prism/prism.hpp>

namespace {

using namespace prism;

// Timed renders: 1 thread; callgrind renders: smaller.
constexpr int width = 128, height = 128, spp = 16;
constexpr int cg_width = 48, cg_height = 48, cg_spp = 4;

// A diffuse-only or metal_rough-only box: the Cornell box's walls, light,
// tall box and a sphere, every material from `mat`.
template <class SceneT, class MakeMaterial>
void build_plain_box(SceneT& scene, MakeMaterial mat) {
  auto add = [&](RGB c) {
    const typename SceneT::material_type m = mat(c);
    return scene.add_material(m);
  };
  uint32_t white = add(RGB(0.73f)), red = add(RGB(0.65f, 0.05f, 0.05f)), green = add(RGB(0.12f, 0.45f, 0.15f)),
           black = add(RGB(0.f));
  TriangleMesh whites;
  append_quad(whites, {-1, -1, -1}, {0, 0, 2}, {2, 0, 0});
  append_quad(whites, {-1, 1, -1}, {2, 0, 0}, {0, 0, 2});
  append_quad(whites, {-1, -1, -1}, {2, 0, 0}, {0, 2, 0});
  scene.add_mesh_instance(std::move(whites), white);
  TriangleMesh left;
  append_quad(left, {-1, -1, -1}, {0, 2, 0}, {0, 0, 2});
  scene.add_mesh_instance(std::move(left), red);
  TriangleMesh right;
  append_quad(right, {1, -1, -1}, {0, 0, 2}, {0, 2, 0});
  scene.add_mesh_instance(std::move(right), green);
  TriangleMesh lamp;
  append_quad(lamp, {-0.25f, 0.998f, -0.25f}, {0.5f, 0, 0}, {0, 0, 0.5f});
  scene.add_mesh_instance(std::move(lamp), black, AreaEmission{RGB(17.f, 12.f, 4.f), 1.f, false});
  uint32_t box = scene.add_mesh(make_box({-0.3f, -1, -0.3f}, {0.3f, 0.2f, 0.3f}));
  scene.add_instance(box, white, translate({-0.35f, 0, -0.3f}) * rotate(radians(18), {0, 1, 0}));
  scene.add_sphere(Sphere{{0.4f, -0.6f, 0.35f}, 0.4f}, white);
}

template <class SceneT>
void build_scene(SceneT& scene, const std::string& which) {
  using M = typename SceneT::material_type;
  if (which == "diffuse") {
    if constexpr (std::is_constructible_v<M, DiffuseMaterial>) build_cornell_box(scene, diffuse_cornell_box_options());
  } else {
    if constexpr (std::is_constructible_v<M, MetalRoughMaterial>)
      build_plain_box(scene, [](RGB c) {
        MetalRoughMaterial m;
        m.base_color = c;
        m.metallic = 0;
        m.roughness = 0.5f;
        return m;
      });
  }
  scene.build();
}

struct Result {
  RenderStats stats;
  std::vector<RGB> pixels;
};

template <class S, class Set>
Result render_one(const std::string& scene_name, int w, int h, int samples, bool callgrind) {
  Scene<S, Set> scene;
  build_scene(scene, scene_name);
  Film film(w, h);
  RenderOptions opt;
  opt.spp = samples;
  opt.seed = 7;
  opt.threads = 1;
  PerspectiveCamera cam = default_camera(w, h);
  Result r;
  if (callgrind) CALLGRIND_START_INSTRUMENTATION;
  r.stats = render(scene, cam, PathIntegrator{}, film, opt);
  if (callgrind) CALLGRIND_STOP_INSTRUMENTATION;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) r.pixels.push_back(film.pixel(x, y));
  return r;
}

// One configuration: a scene, a colour model, a BxDF set and what it adds.
struct Config {
  std::string scene, colour, set, adds;
  std::function<Result(int, int, int, bool)> run;
  bool minimal = false;  // the reference of its (scene, colour) group
  std::vector<double> seconds;
  bool bitwise = false;
  double max_rel_diff = 0;
  unsigned long long ir = 0;
};

template <class S, class Set>
Config make_config(std::string scene, std::string colour, std::string set, std::string adds, bool minimal) {
  Config c;
  c.scene = scene;
  c.colour = colour;
  c.set = set;
  c.adds = adds;
  c.run = [scene](int w, int h, int n, bool cg) { return render_one<S, Set>(scene, w, h, n, cg); };
  c.minimal = minimal;
  return c;
}

template <class S>
void add_configs(std::vector<Config>& out, const std::string& colour) {
  out.push_back(make_config<S, bxdf_set<DiffuseBxDF<S>>>("diffuse", colour, "diffuse", "-", true));
  out.push_back(make_config<S, bxdf_set<DiffuseBxDF<S>, ConductorBxDF<S>>>("diffuse", colour, "diffuse+conductor",
                                                                            "conductor", false));
  out.push_back(make_config<S, bxdf_set<DiffuseBxDF<S>, DielectricBxDF<S>>>(
      "diffuse", colour, "diffuse+dielectric", "dielectric (dispersion)", false));
  out.push_back(make_config<S, bxdf_set<DiffuseBxDF<S>, ThinDielectricBxDF<S>>>(
      "diffuse", colour, "diffuse+thin_dielectric", "thin dielectric", false));
  out.push_back(make_config<S, bxdf_set<DiffuseBxDF<S>, MetalRoughBxDF<S>>>(
      "diffuse", colour, "diffuse+metal_rough", "metal_rough (textures, normal maps, alpha)", false));
  out.push_back(make_config<S, default_bxdf_set<S>>("diffuse", colour, "default", "conductor+dielectric+thin", false));
  out.push_back(make_config<S, full_bxdf_set<S>>("diffuse", colour, "full", "all", false));
  out.push_back(make_config<S, metal_rough_bxdf_set<S>>("metal_rough", colour, "metal_rough", "-", true));
  out.push_back(make_config<S, full_bxdf_set<S>>("metal_rough", colour, "full", "all", false));
}

std::vector<Config> all_configs() {
  std::vector<Config> c;
  add_configs<RGB>(c, "rgb");
  add_configs<Spectral>(c, "spectral");
  return c;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  size_t n = v.size();
  return n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}
double best(const std::vector<double>& v) { return *std::min_element(v.begin(), v.end()); }

// Instructions callgrind counted in one --one run of this program.
unsigned long long callgrind_ir(const Config& c, const std::string& self) {
  std::string out = "/tmp/instantiation_bench." + std::to_string(::getpid()) + ".cg";
  std::string cmd = "valgrind --tool=callgrind --instr-atstart=no --callgrind-out-file=" + out + " '" + self +
                    "' --one " + c.scene + " " + c.colour + " " + c.set + " >/dev/null 2>&1";
  if (std::system(cmd.c_str()) != 0) return 0;
  std::ifstream f(out);
  std::string line;
  unsigned long long ir = 0;
  while (std::getline(f, line))
    if (line.rfind("totals:", 0) == 0) ir = std::stoull(line.substr(line.find(':') + 1));
  std::filesystem::remove(out);
  return ir;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<Config> configs = all_configs();
  if (argc == 5 && std::string(argv[1]) == "--one") {
    for (auto& c : configs)
      if (c.scene == argv[2] && c.colour == argv[3] && c.set == argv[4]) {
        if (c.colour == "spectral") (void)srgb_to_spectrum_table();  // fitted before counting starts
        Result r = c.run(cg_width, cg_height, cg_spp, true);
        std::printf("%llu rays\n", (unsigned long long)r.stats.rays);
        return 0;
      }
    std::fprintf(stderr, "instantiation_bench: no configuration %s %s %s\n", argv[2], argv[3], argv[4]);
    return 2;
  }
  int runs = 15;
  std::string csv = "bench/results/instantiation.csv";
  bool callgrind = true, callgrind_spectral = false;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--runs" && i + 1 < argc) runs = std::max(1, std::atoi(argv[++i]));
    else if (a == "--csv" && i + 1 < argc) csv = argv[++i];
    else if (a == "--no-callgrind") callgrind = false;
    else if (a == "--callgrind-spectral") callgrind_spectral = true;
    else {
      std::fprintf(stderr, "usage: instantiation_bench [--runs N] [--csv PATH] [--no-callgrind] [--callgrind-spectral] | --one SCENE COLOUR SET\n");
      return 2;
    }
  }
  (void)srgb_to_spectrum_table();  // fitted once, before any timing

  // Images first (one run each), then the timed rounds, alternating.
  std::vector<Result> images;
  for (auto& c : configs) images.push_back(c.run(width, height, spp, false));
  for (size_t i = 0; i < configs.size(); ++i) {
    size_t ref = i;
    while (!configs[ref].minimal) --ref;
    const auto& a = images[ref].pixels;
    const auto& b = images[i].pixels;
    configs[i].bitwise = std::memcmp(a.data(), b.data(), a.size() * sizeof(RGB)) == 0;
    double m = 0;
    for (size_t p = 0; p < a.size(); ++p)
      for (int k = 0; k < 3; ++k) {
        double x = a[p][k], y = b[p][k];
        if (x != y) m = std::max(m, std::abs(x - y) / std::max(std::abs(x), 1e-6));
      }
    configs[i].max_rel_diff = m;
  }
  for (int r = 0; r < runs; ++r)
    for (auto& c : configs) c.seconds.push_back(c.run(width, height, spp, false).stats.seconds);

  std::filesystem::path self_path = std::filesystem::read_symlink("/proc/self/exe");
  std::string self = (self_path.parent_path() / "instantiation_bench_callgrind").string();
  if (callgrind && !std::filesystem::exists(self)) {
    std::fprintf(stderr, "instantiation_bench: %s not found: no callgrind counts\n", self.c_str());
    callgrind = false;
  }
  if (callgrind)
    for (auto& c : configs)
      if (c.colour == "rgb" || callgrind_spectral) c.ir = callgrind_ir(c, self);

  std::filesystem::create_directories(std::filesystem::path(csv).parent_path());
  std::ofstream out(csv);
  out << "scene,colour,bxdf_set,adds,runs,median_s,best_s,median_ratio,best_ratio,callgrind_ir,ir_ratio,"
         "bitwise_equal,max_rel_diff\n";
  std::printf("%-11s %-8s %-24s %9s %9s %8s %8s %14s %9s %s\n", "scene", "colour", "bxdf set", "median s", "best s",
              "med/min", "best/min", "callgrind Ir", "Ir/min", "image");
  for (size_t i = 0; i < configs.size(); ++i) {
    size_t ref = i;
    while (!configs[ref].minimal) --ref;
    const Config& c = configs[i];
    const Config& m = configs[ref];
    double med = median(c.seconds), bst = best(c.seconds);
    double med_ratio = med / median(m.seconds), best_ratio = bst / best(m.seconds);
    double ir_ratio = m.ir ? double(c.ir) / double(m.ir) : 0;
    char line[512];
    std::snprintf(line, sizeof line, "%s,%s,%s,\"%s\",%d,%.5f,%.5f,%.4f,%.4f,%llu,%.5f,%d,%.3g\n", c.scene.c_str(),
                  c.colour.c_str(), c.set.c_str(), c.adds.c_str(), runs, med, bst, med_ratio, best_ratio, c.ir,
                  ir_ratio, int(c.bitwise), c.max_rel_diff);
    out << line;
    std::printf("%-11s %-8s %-24s %9.4f %9.4f %8.4f %8.4f %14llu %9.5f %s\n", c.scene.c_str(), c.colour.c_str(),
                c.set.c_str(), med, bst, med_ratio, best_ratio, c.ir, ir_ratio,
                c.bitwise ? "bitwise" : ("max rel diff " + std::to_string(c.max_rel_diff)).c_str());
  }
  std::printf("wrote %s (%d alternating runs, %dx%d, %d spp, 1 thread; callgrind %dx%d, %d spp)\n", csv.c_str(), runs,
              width, height, spp, cg_width, cg_height, cg_spp);
  return 0;
}
