// The tile driver: determinism across thread counts, dropped non-finite samples,
// cancellation and progress reporting.
#include <catch2/catch.hpp>
#include <atomic>
#include <fstream>
#include <iterator>
#include <prism/io/image_io.hpp>
#include <prism/prism.hpp>
#include "support/scenes.hpp"

namespace render_test {

using namespace prism;

namespace {
std::vector<char> file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// Returns NaN for the pixels in the left half of the image, the real radiance elsewhere.
struct PoisonIntegrator {
  PathIntegrator inner;
  template <class Scene, class Sampler, class W>
  typename Scene::spectrum_type Li(const Scene& scene, Ray ray, const W& lambda, Sampler& sampler,
                                   RayCounter& counter) const {
    auto L = inner.Li(scene, ray, lambda, sampler, counter);
    if (ray.d.x < 0) L.r = std::numeric_limits<Float>::quiet_NaN();
    return L;
  }
};
}  // namespace

TEST_CASE("default scene is bitwise identical at 1 and 2 threads", "[render][determinism]") {
  const Scene<RGB>& scene = test::cornell_box();
  const int w = 96, h = 80;
  PerspectiveCamera cam = default_camera(w, h);
  std::string paths[2];
  for (int threads = 1; threads <= 2; ++threads) {
    Film film(w, h);
    RenderOptions opt;
    opt.spp = 8;
    opt.seed = 5;
    opt.threads = threads;
    opt.tile_size = 8;
    render(scene, cam, PathIntegrator{}, film, opt);
    paths[threads - 1] = std::string(PRISM_TEST_TMP_DIR) + "/determinism_" + std::to_string(threads) + ".exr";
    write_exr(paths[threads - 1], to_image(film));
  }
  auto a = file_bytes(paths[0]), b = file_bytes(paths[1]);
  REQUIRE(a.size() > size_t(w * h));
  CHECK(a == b);
}

TEST_CASE("a different seed gives a different image", "[render][determinism]") {
  Scene<RGB> scene;
  build_cornell_box(scene);
  scene.build();
  PerspectiveCamera cam = default_camera(32, 32);
  Film a(32, 32), b(32, 32);
  RenderOptions opt;
  opt.spp = 4;
  render(scene, cam, PathIntegrator{}, a, opt);
  opt.seed = 1;
  render(scene, cam, PathIntegrator{}, b, opt);
  CHECK(a.rgb_buffer() != b.rgb_buffer());
}

TEST_CASE("non-finite samples are dropped and counted, never written", "[render][robustness]") {
  Scene<RGB> scene;
  build_cornell_box(scene);
  scene.build();
  const int w = 32, h = 32;
  PerspectiveCamera cam = default_camera(w, h);
  Film film(w, h);
  RenderOptions opt;
  opt.spp = 4;
  RenderStats st = render(scene, cam, PoisonIntegrator{}, film, opt);
  CHECK(st.samples == uint64_t(w * h * 4));
  CHECK(st.dropped > 0);
  CHECK(st.dropped < st.samples);
  for (float v : film.rgb_buffer()) REQUIRE(std::isfinite(v));
  std::string path = std::string(PRISM_TEST_TMP_DIR) + "/poison.pfm";
  write_pfm(path, to_image(film));
  Image back = read_pfm(path);
  for (float v : back.rgb) REQUIRE(std::isfinite(v));
}

TEST_CASE("rendering stops when cancelled and reports progress", "[render]") {
  Scene<RGB> scene;
  build_cornell_box(scene);
  scene.build();
  PerspectiveCamera cam = default_camera(64, 64);
  Film film(64, 64);
  std::atomic<bool> cancel{false};
  int last_done = 0, total_seen = 0;
  RenderOptions opt;
  opt.spp = 1;
  opt.threads = 1;
  opt.cancel = &cancel;
  opt.progress = [&](int done, int total) {
    last_done = done;
    total_seen = total;
    if (done == 3) cancel = true;
  };
  RenderStats st = render(scene, cam, PathIntegrator{}, film, opt);
  CHECK(st.cancelled);
  CHECK(last_done == 3);
  // 16 tiles of 16x16 pixels, and one chunk of 4096 light paths for the
  // caustics of the default scene's glass (64 x 64 pixels x 1 spp).
  CHECK(total_seen == 16 + 1);
}

}  // namespace render_test

TEST_CASE("an area light's emitting side can be given explicitly, whatever the winding", "[render][lights]") {
  using namespace prism;
  // A quad at y = 0 wound to face +y; a receiver point above it and one below.
  for (EmittingSide side : {EmittingSide::front, EmittingSide::back, EmittingSide::both}) {
    Scene<RGB> scene;
    uint32_t m = scene.add_material(DiffuseMaterial{RGB(0.5f)});
    TriangleMesh quad;
    append_quad(quad, {-1, 0, -1}, {0, 0, 2}, {2, 0, 0});  // (0,0,2) x (2,0,0) = +y
    scene.add_mesh_instance(std::move(quad), m, AreaEmission(RGB(1), 1, side));
    scene.build();
    REQUIRE(scene.lights().size() == 2);
    for (Float y : {Float(1), Float(-1)}) {
      LightSampleContext ctx;
      ctx.p = {0.1f, y, 0.2f};
      auto ls = std::visit([&](const auto& l) { return l.sample_li(ctx, {0.3f, 0.6f}, RGBWavelengths{}); },
                           scene.lights()[0]);
      bool lit = ls && !ls->L.is_black();
      bool want = side == EmittingSide::both || (side == EmittingSide::front) == (y > 0);
      INFO("side " << int(side) << " receiver y " << y);
      CHECK(lit == want);
    }
  }
  Scene<RGB> spheres;
  uint32_t m = spheres.add_material(DiffuseMaterial{RGB(0.5f)});
  spheres.add_sphere(Sphere{{0, 0, 0}, 1}, m, AreaEmission(RGB(1), 1, EmittingSide::back));
  CHECK_THROWS_WITH(spheres.build(), Catch::Contains("sphere light") && Catch::Contains("EmittingSide::back"));
}
