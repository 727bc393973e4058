// Samplers at equal time: independent (PCG32), stratified (multi-jittered)
// and Owen-scrambled Sobol, on the default scene and on an environment-lit
// glTF model (MetalRoughSpheresNoTextures under the shared HDR map; skipped
// when ../shared is absent). For each scene a reference is rendered with the
// independent sampler at a high sample count and another seed; each sampler
// then renders at 4 to 256 spp (mean over 3 seeds), and the bench records
// the relative MSE against the reference, mean over pixels and channels of
// (v - ref)^2 / (ref^2 + 1e-2), the relative mean absolute error
// sum |v - ref| / sum ref (robust to the rare fireflies of caustic paths,
// which dominate the MSE of both scenes), and the time. Error x seconds is
// the figure of merit at equal time for an error falling as 1/spp (MSE) or
// 1/sqrt(spp) (MAE: its square times seconds). RGB, 64 x 64, all threads.
// Writes bench/results/samplers.csv.
#include <cstdio>
#include <string>
#include <vector>
#include <prism/prism.hpp>
#include <prism/io/gltf.hpp>
#include <prism/io/image_io.hpp>

using namespace prism;

namespace {

constexpr int W = 64, H = 64;

template <class Scene, class Camera>
std::pair<std::vector<RGB>, double> render_image(const Scene& scene, const Camera& cam, SamplerKind k, int spp,
                                                 uint64_t seed) {
  Film film(W, H);
  RenderOptions opt;
  opt.spp = spp;
  opt.seed = seed;
  opt.sampler = k;
  RenderStats st = render(scene, cam, PathIntegrator{}, film, opt);
  std::vector<RGB> px(size_t(W * H));
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) px[size_t(y * W + x)] = film.pixel(x, y);
  return {px, st.seconds};
}

double rel_mse(const std::vector<RGB>& v, const std::vector<RGB>& ref) {
  double s = 0;
  for (size_t i = 0; i < v.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      double d = double(v[i][c]) - double(ref[i][c]);
      s += d * d / (double(ref[i][c]) * double(ref[i][c]) + 1e-2);
    }
  return s / double(3 * v.size());
}

double rel_mae(const std::vector<RGB>& v, const std::vector<RGB>& ref) {
  double s = 0, r = 0;
  for (size_t i = 0; i < v.size(); ++i)
    for (int c = 0; c < 3; ++c) {
      s += std::abs(double(v[i][c]) - double(ref[i][c]));
      r += std::abs(double(ref[i][c]));
    }
  return r > 0 ? s / r : 0;
}

template <class Scene, class Camera>
void run_scene(FILE* f, const char* name, const Scene& scene, const Camera& cam, int ref_spp) {
  std::printf("%s: reference at %d spp...\n", name, ref_spp);
  auto ref = render_image(scene, cam, SamplerKind::independent, ref_spp, 987654321).first;
  const std::pair<SamplerKind, const char*> kinds[] = {
      {SamplerKind::independent, "independent"}, {SamplerKind::stratified, "stratified"}, {SamplerKind::sobol, "sobol"}};
  std::printf("%-14s %5s %12s %10s %9s %14s %14s\n", "sampler", "spp", "relMSE", "relMAE", "seconds", "relMSE x s",
              "relMAE^2 x s");
  for (int spp : {4, 16, 64, 256})
    for (auto [k, kname] : kinds) {
      // Three seeds: the relMSE is their mean, the time the best.
      double e = 0, a = 0, best = 1e30;
      for (uint64_t seed : {1, 2, 3}) {
        auto [img, sec] = render_image(scene, cam, k, spp, seed);
        e += rel_mse(img, ref) / 3;
        a += rel_mae(img, ref) / 3;
        best = std::min(best, sec);
      }
      std::printf("%-14s %5d %12.5g %10.5f %9.3f %14.5g %14.5g\n", kname, spp, e, a, best, e * best, a * a * best);
      std::fprintf(f, "%s,%s,%d,%g,%g,%.4f\n", name, kname, spp, e, a, best);
    }
}

}  // namespace

int main(int argc, char** argv) {
  std::string out = argc > 1 ? argv[1] : "bench/results/samplers.csv";
  std::string shared = argc > 2 ? argv[2] : "../shared";
  FILE* f = std::fopen(out.c_str(), "w");
  if (!f) {
    std::fprintf(stderr, "sampler_bench: cannot write %s\n", out.c_str());
    return 1;
  }
  std::fprintf(f, "scene,sampler,spp,rel_mse,rel_mae,seconds\n");
  {
    Scene<RGB> scene;
    build_cornell_box(scene);
    scene.build();
    run_scene(f, "default", scene, default_camera(W, H), 4096);
  }
  const std::string model = shared + "/scenes/MetalRoughSpheresNoTextures/glTF/MetalRoughSpheresNoTextures.gltf";
  const std::string env = shared + "/scenes/envmaps/chinese_garden_1k.hdr";
  if (std::FILE* probe = std::fopen(model.c_str(), "rb")) {
    std::fclose(probe);
    auto g = load_gltf<RGB>(model);
    g.scene.add_light(ImageInfiniteLight<RGB>(read_environment(env), 1));
    g.scene.build();
    run_scene(f, "env_metal_rough_spheres", g.scene, gltf_framing_camera(g.bounds, W, H), 4096);
  } else {
    std::printf("sampler_bench: %s not found: the environment-lit case is skipped\n", model.c_str());
  }
  std::fclose(f);
  return 0;
}
