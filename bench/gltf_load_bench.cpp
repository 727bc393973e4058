// Time to first pixel of a glTF file: load (parse, decode images, build
// meshes) + BVH build + one camera sample, and the process's peak memory.
// Run once per configuration (peak memory is per process); restrict the cores
// with taskset to measure one thread: `taskset -c 0 gltf_load_bench file 1`.
// Usage: gltf_load_bench FILE [THREADS] [TEXTURE_FILTER]
// (TEXTURE_FILTER trilinear or ewa also builds every image's MIP pyramid.)
#include <sys/resource.h>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <prism/io/gltf.hpp>
#include <prism/prism.hpp>

int main(int argc, char** argv) {
  using namespace prism;
  if (argc < 2) {
    std::fprintf(stderr, "usage: gltf_load_bench FILE [THREADS] [TEXTURE_FILTER]\n");
    return 2;
  }
  int threads = argc > 2 ? std::atoi(argv[2]) : 0;
  auto t0 = std::chrono::steady_clock::now();
  GltfOptions gopt;
  if (argc > 3) {
    auto f = parse_texture_filter(argv[3]);
    if (!f) {
      std::fprintf(stderr, "unknown texture filter '%s'\n", argv[3]);
      return 2;
    }
    gopt.texture_filter = *f;
  }
  auto g = load_gltf<RGB>(argv[1], gopt);
  auto t1 = std::chrono::steady_clock::now();
  g.scene.add_light(UniformInfiniteLight<RGB>(RGB(1)));
  BVHBuildOptions bopt;
  bopt.threads = threads;
  g.scene.build(bopt);
  auto t2 = std::chrono::steady_clock::now();
  Point3f c = g.bounds.min + (g.bounds.max - g.bounds.min) * Float(0.5);
  Float r = length(g.bounds.max - g.bounds.min) / 2;
  PerspectiveCamera cam(look_at_camera_to_world(c + Vector3f(0, 0, 3 * r), c, Vector3f(0, 1, 0)), Float(0.7), 1, 1);
  Film film(1, 1);
  RenderOptions opt;
  opt.spp = 1;
  opt.threads = 1;
  render(g.scene, cam, PathIntegrator(), film, opt);
  auto t3 = std::chrono::steady_clock::now();
  size_t mesh_bytes = 0;
  for (const auto& m : g.scene.accel().meshes())
    mesh_bytes += m.positions.size() * sizeof(Point3f) + m.indices.size() * 4 + m.normals.size() * sizeof(Normal3f) +
                  m.uvs.size() * sizeof(Point2f) + m.uvs1.size() * sizeof(Point2f) + m.tangents.size() * 16 +
                  m.colors.size() * 16;
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  auto s = [](auto a, auto b) { return std::chrono::duration<double>(b - a).count(); };
  std::printf("%s: threads %d: load %.3f s, build %.3f s, first pixel %.3f s (total); peak RSS %.1f MB; file %.1f MB; "
              "prism mesh data %.1f MB; images %.1f MB; %zu triangles in %zu meshes\n",
              std::filesystem::path(argv[1]).filename().c_str(), threads, s(t0, t1), s(t1, t2), s(t0, t3),
              double(ru.ru_maxrss) / 1024, double(std::filesystem::file_size(argv[1])) / 1e6, double(mesh_bytes) / 1e6,
              double(g.image_bytes) / 1e6, g.scene_triangles, g.scene.accel().meshes().size());
}
