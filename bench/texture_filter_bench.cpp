// Texture filtering at equal time: a checkerboard floor seen at a grazing
// angle (8-texel squares of a 512 x 512 texture repeated 24 times over a
// 200-unit floor, camera 1 unit above it), Lambertian under a uniform sky,
// the horizon near the top of the image, and the shared DamagedHelmet
// under the garden environment. Each filter
// (bilinear, trilinear, EWA) renders at 1, 4 and 16 spp; the error is the
// RMS difference from a 4096-spp bilinear render (the box-filtered pixel:
// enough samples average the texels themselves), of the displayed values
// (clamped to [0, 1], so that the environment's rare fireflies do not
// outweigh the textures), relative to the reference's mean. Prints a CSV on stdout: scene, filter, spp, seconds,
// rms error, error x sqrt(seconds) (lower is better at equal time).
// Usage: texture_filter_bench [HELMET.glb ENV.hdr] [--ref-spp N]
// (TEXTURE_FILTER_PNG_DIR=dir also writes every first render and the references as PNGs.)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>
#include <prism/io/image_io.hpp>
#include <prism/io/gltf.hpp>
#include <prism/prism.hpp>

namespace {
using namespace prism;
using Clock = std::chrono::steady_clock;

template <class SceneT, class Cam>
std::pair<Film, double> render_once(const SceneT& scene, const Cam& cam, int w, int h, int spp, uint64_t seed) {
  Film film(w, h);
  RenderOptions opt;
  opt.spp = spp;
  opt.seed = seed;
  auto t0 = Clock::now();
  render(scene, cam, PathIntegrator(), film, opt);
  return {std::move(film), std::chrono::duration<double>(Clock::now() - t0).count()};
}

double rms_error(const Film& a, const Film& ref) {
  double se = 0, mean = 0;
  const int w = ref.width(), h = ref.height();
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const RGB p = a.pixel(x, y), r = ref.pixel(x, y);
      for (int c = 0; c < 3; ++c) {
        // Displayed values, clamped to [0, 1]: a rare firefly of the
        // environment's sun would otherwise outweigh every texture.
        const double pc = std::clamp(double(p[c]), 0.0, 1.0), rc = std::clamp(double(r[c]), 0.0, 1.0);
        se += (pc - rc) * (pc - rc);
        mean += rc;
      }
    }
  const double n = 3.0 * w * h;
  return std::sqrt(se / n) / (mean / n);
}

// make(filter) builds the scene with every material texture filtered so.
template <class Make, class Cam>
void sweep(const char* name, Make&& make, const Cam& cam, int w, int h, int ref_spp) {
  auto ref_scene = make(TextureFilter::bilinear);
  auto [ref, ref_s] = render_once(ref_scene.scene, cam, w, h, ref_spp, 99);
  std::fprintf(stderr, "%s: reference %d spp in %.1f s\n", name, ref_spp, ref_s);
  for (TextureFilter f : {TextureFilter::bilinear, TextureFilter::trilinear, TextureFilter::ewa}) {
    auto s = make(f);
    for (int spp : {1, 4, 16}) {
      s.scene.set_pixel_footprint(PixelFootprint(cam, spp));
      // Median time of three renders (seeds 1..3), error of the first.
      double secs[3];
      Film first;
      for (int k = 0; k < 3; ++k) {
        auto [film, t] = render_once(s.scene, cam, w, h, spp, uint64_t(k + 1));
        secs[k] = t;
        if (k == 0) first = std::move(film);
      }
      std::sort(secs, secs + 3);
      if (const char* dir = std::getenv("TEXTURE_FILTER_PNG_DIR")) {  // to look at
        std::string base = std::string(dir) + "/" + (name[0] == 'g' ? "checker" : "helmet") + "_" + texture_filter_name(f) + "_" + std::to_string(spp);
        write_image(base + ".png", to_image(first), PngOptions{});
        if (spp == 1 && f == TextureFilter::bilinear) write_image(std::string(dir) + "/" + (name[0] == 'g' ? "checker" : "helmet") + "_reference.png", to_image(ref), PngOptions{});
      }
      const double e = rms_error(first, ref);
      std::printf("%s,%s,%d,%.4f,%.5f,%.5f\n", name, texture_filter_name(f), spp, secs[1], e, e * std::sqrt(secs[1]));
      std::fflush(stdout);
    }
  }
}
}  // namespace

int main(int argc, char** argv) {
  int ref_spp = 4096;
  std::vector<std::string> files;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--ref-spp") && i + 1 < argc) ref_spp = std::atoi(argv[++i]);
    else files.push_back(argv[i]);
  }
  std::printf("scene,filter,spp,seconds,rel_rms_error,error_sqrt_seconds\n");
  using CheckerScene = Scene<RGB, bxdf_set<MetalRoughBxDF<RGB>>>;
  struct Checker {
    CheckerScene scene;
  };
  std::vector<float> v(512 * 512);
  for (int y = 0; y < 512; ++y)
    for (int x = 0; x < 512; ++x) v[size_t(y) * 512 + size_t(x)] = ((x / 8 + y / 8) % 2) ? 0.8f : 0.1f;
  auto image = std::make_shared<const TextureImage>(TextureImage::from_f32(512, 512, 1, std::move(v)));
  auto make_checker = [&](TextureFilter f) {
    auto textures = std::make_shared<MetalRoughTextures>();
    ImageTexture t;
    t.image = image;
    t.transform.scale = {24, 24};
    t.filtering = f;
    t.build_mipmaps();
    textures->base_color = t;
    MetalRoughMaterial m;
    m.metallic = 0;
    m.specular = 0;
    m.textures = textures;
    Checker c;
    TriangleMesh floor;
    append_quad(floor, {-100, 0, -100}, {0, 0, 200}, {200, 0, 0});
    c.scene.add_instance(c.scene.add_mesh(floor), c.scene.add_material(m));
    c.scene.add_light(UniformInfiniteLight<RGB>(RGB(1)));
    c.scene.build();
    return c;
  };
  PerspectiveCamera grazing(look_at_camera_to_world({0, 1, -95}, {0, -20, 0}, {0, 1, 0}), 0.6f, 160, 90);
  sweep("grazing checkerboard", make_checker, grazing, 160, 90, ref_spp);
  if (files.size() >= 2) {
    EnvironmentImage env = read_environment(files[1]);
    auto make_helmet = [&](TextureFilter f) {
      GltfOptions o;
      o.texture_filter = f;
      auto g = load_gltf<RGB>(files[0], o);
      g.scene.add_light(ImageInfiniteLight<RGB>(env, 1));
      g.scene.build();
      return g;
    };
    auto probe = load_gltf<RGB>(files[0]);
    Point3f c = probe.bounds.min + (probe.bounds.max - probe.bounds.min) * Float(0.5);
    Float r = length(probe.bounds.max - probe.bounds.min) / 2;
    PerspectiveCamera cam(look_at_camera_to_world(c + Vector3f(0.4f * r, 0.2f * r, 2.6f * r), c, Vector3f(0, 1, 0)),
                          0.7f, 96, 96);
    sweep("DamagedHelmet", make_helmet, cam, 96, 96, ref_spp);
  }
}
