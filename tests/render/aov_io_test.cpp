// AOVs (film/aov.hpp): a diffuse plane seen by an orthographic camera gives
// its reflectance as albedo (exactly in RGB: cosine sampling makes f cos / pdf
// the reflectance; in spectral mode within t standard errors from the
// per-pixel spread, t = sidak_t(1e-3, 1, pixels - 1), one comparison at 10^-3),
// its normal towards the camera and its distance as depth; pixels that miss
// give zeros; a mirror passes on the albedo of what it reflects times its
// reflectance; the image does not change when AOVs are on; the EXR holds
// the named layers and they read back.
#include <catch2/catch.hpp>
#include <filesystem>
#include <prism/io/image_io.hpp>
#include <prism/prism.hpp>
#include "support/reference_physics.hpp"

namespace aov_io_test {

using namespace prism;

namespace {

// A plane z = 2 covering x < 0.5 (the rest of the view misses), seen from
// z = 0 looking down +z; optionally a mirror instead of the camera's view.
template <class S>
void build_plane(Scene<S>& scene, RGB reflectance) {
  uint32_t m = scene.add_material(DiffuseMaterial{reflectance});
  TriangleMesh plane;
  plane.positions = {{-4, -4, 2}, {0.5f, -4, 2}, {0.5f, 4, 2}, {-4, 4, 2}};
  plane.indices = {0, 1, 2, 0, 2, 3};
  scene.add_mesh_instance(std::move(plane), m);
  scene.add_light(UniformInfiniteLight<S>(RGB(1)));
  scene.build();
}

OrthographicCamera plane_camera(int w, int h) {
  return OrthographicCamera(look_at_camera_to_world({0, 0, 0}, {0, 0, 1}, {0, 1, 0}), 2, w, h);
}

// 1 if pixel (x, y) sees only the plane, -1 if it sees none of it, else 0.
int pixel_on_plane(const OrthographicCamera& cam, int x, int y) {
  CameraSample a, b;
  a.p_film = {Float(x), Float(y)};
  b.p_film = {Float(x + 1), Float(y)};
  Float xa = cam.generate_ray(a).o.x, xb = cam.generate_ray(b).o.x;
  if (std::max(xa, xb) < 0.5f) return 1;
  if (std::min(xa, xb) > 0.5f) return -1;
  return 0;
}

template <class S>
void render_with_aovs(const Scene<S>& scene, Film& film, AovFilm* aovs, uint64_t seed = 3) {
  RenderOptions opt;
  opt.spp = 16;
  opt.seed = seed;
  opt.aovs = aovs;
  render(scene, plane_camera(film.width(), film.height()), PathIntegrator{}, film, opt);
}

}  // namespace

TEST_CASE("AOVs of a diffuse plane: albedo, normal and depth, zeros where nothing is hit", "[render][aov]") {
  Scene<RGB> scene;
  const RGB rho(0.3f, 0.5f, 0.7f);
  build_plane(scene, rho);
  const int w = 32, h = 16;
  Film film(w, h);
  AovFilm aovs(w, h);
  render_with_aovs(scene, film, &aovs);
  OrthographicCamera cam = plane_camera(w, h);
  int hit = 0, miss = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      int on = pixel_on_plane(cam, x, y);
      if (on == 1) {
        ++hit;
        RGB al = aovs.albedo(x, y);
        // 1e-5: the AOV averages the same float albedo over the pixel's samples in double and rounds once
        CHECK(al.r == Approx(rho.r).margin(1e-5));
        CHECK(al.g == Approx(rho.g).margin(1e-5));
        CHECK(al.b == Approx(rho.b).margin(1e-5));
        Vector3f n = aovs.normal(x, y);
        // 1e-6: a few ulps of a unit component; 1e-5: depth 2 through a float ray (ulp(2) = 2.4e-7, ~10 roundings, averaged)
        CHECK(n.z == Approx(-1).margin(1e-6));  // towards the camera
        CHECK(aovs.depth(x, y) == Approx(2).margin(1e-5));
      } else if (on == -1) {
        ++miss;
        CHECK(aovs.albedo(x, y).max_component() == 0);
        CHECK(length(aovs.normal(x, y)) == 0);
        CHECK(aovs.depth(x, y) == 0);
      }
    }
  CHECK(hit > 100);
  CHECK(miss > 100);
  // The image is the same with and without AOVs.
  Film plain(w, h);
  render_with_aovs(scene, plain, nullptr);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      RGB p = plain.pixel(x, y), q = film.pixel(x, y);
      CHECK((p.r == q.r && p.g == q.g && p.b == q.b));
    }
}

TEST_CASE("spectral AOV albedo of a grey plane is its reflectance within the noise", "[render][aov][spectral]") {
  Scene<Spectral> scene;
  build_plane(scene, RGB(0.5f));
  const int w = 16, h = 16;
  Film film(w, h);
  AovFilm aovs(w, h);
  render_with_aovs(scene, film, &aovs);
  // Pixels fully on the plane are i.i.d. estimates: their spread gives sigma.
  std::vector<double> g;
  OrthographicCamera cam = plane_camera(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (pixel_on_plane(cam, x, y) == 1) g.push_back(aovs.albedo(x, y).g);
  REQUIRE(g.size() > 50);
  double mean = 0, var = 0;
  for (double v : g) mean += v;
  mean /= double(g.size());
  for (double v : g) var += (v - mean) * (v - mean);
  var /= double(g.size() - 1);
  double sigma = std::sqrt(var / double(g.size()));
  // sigma is estimated from the pixels themselves: Student t with
  // pixels - 1 degrees of freedom, one comparison at 10^-3.
  const double t = reference_physics::sidak_t(1e-3, 1, double(g.size() - 1));
  INFO("mean " << mean << " sigma " << sigma << " t " << t << " pixels " << g.size());
  // +1e-6 for the float rounding of each pixel (a few u)
  CHECK(std::abs(mean - 0.5) < t * sigma + 1e-6);
}

TEST_CASE("a mirror passes on the albedo of what it reflects, times its reflectance", "[render][aov]") {
  // The camera looks at a smooth silver mirror at 45 degrees that reflects
  // the view onto a diffuse plane: albedo = F(45 deg) * rho.
  Scene<RGB> scene;
  const Scene<RGB>::material_type silver = ConductorMaterial::from_eta_k(RGB(0.2f), RGB(3.0f), {}, "mirror");
  uint32_t mirror = scene.add_material(silver);
  uint32_t grey = scene.add_material(DiffuseMaterial{RGB(0.6f)});
  TriangleMesh m;  // the plane x + z = 2 (normal towards the camera at the origin)
  m.positions = {{-2, -2, 4}, {4, -2, -2}, {4, 2, -2}, {-2, 2, 4}};
  m.indices = {0, 1, 2, 0, 2, 3};
  scene.add_mesh_instance(std::move(m), mirror);
  TriangleMesh wall;  // x = -3, seen in the mirror
  wall.positions = {{-3, -9, -9}, {-3, -9, 9}, {-3, 9, 9}, {-3, 9, -9}};
  wall.indices = {0, 1, 2, 0, 2, 3};
  scene.add_mesh_instance(std::move(wall), grey);
  scene.add_light(UniformInfiniteLight<RGB>(RGB(1)));
  scene.build();
  const int w = 8, h = 8;
  Film film(w, h);
  AovFilm aovs(w, h);
  RenderOptions opt;
  opt.spp = 4;
  opt.aovs = &aovs;
  OrthographicCamera cam(look_at_camera_to_world({0, 0, 0}, {0, 0, 1}, {0, 1, 0}), 0.5f, w, h);
  render(scene, cam, PathIntegrator{}, film, opt);
  // Reflectance of the conductor at 45 degrees, from its own BxDF.
  ConductorBxDF<RGB> bxdf(TrowbridgeReitz(), RGB(0.2f), RGB(3.0f));
  Vector3f wo = normalize(Vector3f{0, 1, 1});
  auto bs = bxdf.sample(wo, 0.5f, {0.5f, 0.5f}, TransportMode::radiance);
  REQUIRE(bs.has_value());
  RGB F = bs->f * (abs_cos_theta(bs->wi) / bs->pdf);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      RGB a = aovs.albedo(x, y);
      // 1e-4 relative: the conductor's f·cos/pdf in float, evaluated by the integrator at slightly different directions;
      // 1e-5 for the wall's float normal averaged over the pixel
      CHECK(a.r == Approx(0.6f * F.r).epsilon(1e-4));
      CHECK(aovs.normal(x, y).x == Approx(1).margin(1e-5));  // the wall's normal, facing the mirror
      // Depth is the mirror's: it lies at z = 2 - x (linear over the pixel).
      CameraSample c;
      c.p_film = {Float(x) + 0.5f, Float(y) + 0.5f};
      // The mean of samples within the pixel: within half a pixel (1/32) of the centre's depth.
      // +1e-4: float depth (ulp(2) = 2.4e-7) averaged over the pixel's samples
      CHECK(std::abs(aovs.depth(x, y) - (2 - cam.generate_ray(c).o.x)) <= 1.0f / 32 + 1e-4f);
    }
}

TEST_CASE("an EXR with AOVs holds the named layers and they read back", "[render][aov][io]") {
  Scene<RGB> scene;
  build_plane(scene, RGB(0.25f, 0.5f, 0.75f));
  const int w = 12, h = 6;
  Film film(w, h);
  AovFilm aovs(w, h);
  render_with_aovs(scene, film, &aovs);
  std::string path = std::string(PRISM_TEST_TMP_DIR) + "/aovs.exr";
  write_exr_with_aovs(path, film, aovs);
  const char** names = nullptr;
  int n = 0;
  const char* err = nullptr;
  REQUIRE(EXRLayers(path.c_str(), &names, &n, &err) == TINYEXR_SUCCESS);
  std::vector<std::string> layers(names, names + n);
  for (int i = 0; i < n; ++i) std::free(const_cast<char*>(names[i]));
  std::free(names);
  for (const char* want : {"albedo", "N", "variance"})
    CHECK(std::find(layers.begin(), layers.end(), want) != layers.end());
  float* rgba = nullptr;
  int rw = 0, rh = 0;
  REQUIRE(LoadEXRWithLayer(&rgba, &rw, &rh, path.c_str(), "albedo", &err) == TINYEXR_SUCCESS);
  REQUIRE(rw == w);
  REQUIRE(rh == h);
  // The last column sees the plane (the camera's +x is the world's -x).
  size_t last = size_t(w - 1) * 4;
  // 1e-6: a float value stored as float in EXR (exact) after the AOV's float average
  CHECK(rgba[last] == Approx(0.25f).margin(1e-6));
  CHECK(rgba[last + 1] == Approx(0.5f).margin(1e-6));
  CHECK(rgba[last + 2] == Approx(0.75f).margin(1e-6));
  CHECK(rgba[0] == 0);  // the first sees nothing
  std::free(rgba);
  // read_exr reads the root R, G, B: the image, not another layer.
  Image img = read_exr(path);
  REQUIRE(img.width == w);
  for (int x = 0; x < w; ++x) {
    CHECK(img.rgb[size_t(x) * 3] == film.pixel(x, 0).r);
    CHECK(img.rgb[size_t(x) * 3 + 2] == film.pixel(x, 0).b);
  }
  CHECK_THROWS_AS(write_exr_with_aovs(path, film, AovFilm(w + 1, h)), Error);
}

TEST_CASE("EXR string attributes are written to the header and read back", "[io][exr]") {
  std::string path = std::string(PRISM_TEST_TMP_DIR) + "/attributes.exr";
  Image img{3, 2, {}};
  for (int i = 0; i < 18; ++i) img.rgb.push_back(Float(i) * 0.25f);
  ExrAttributes attrs = {{"prism.spp", "8192"}, {"prism.seeds", "987654321 987654322"}, {"prism.note", "x"}};
  write_exr(path, img, attrs);
  Image back = read_exr(path);
  REQUIRE(back.width == 3);
  REQUIRE(back.height == 2);
  CHECK(back.rgb == img.rgb);
  auto got = read_exr_attributes(path);
  for (const auto& [name, value] : attrs) {
    INFO(name);
    REQUIRE(got.count(name) == 1);
    CHECK(got[name] == value);
  }
  // A plain EXR has none of them; a bad name and a non-EXR file are errors.
  write_exr(path, img);
  CHECK(read_exr_attributes(path).count("prism.spp") == 0);
  CHECK_THROWS_AS(write_exr(path, img, ExrAttributes{{"", "x"}}), Error);
  CHECK_THROWS_AS(write_exr(path, img, ExrAttributes{{"prism.empty", ""}}), Error);
  CHECK_THROWS_AS(write_exr(path, img, ExrAttributes{{std::string(300, 'a'), "x"}}), Error);
  std::string png = std::string(PRISM_TEST_TMP_DIR) + "/attributes_not_exr.png";
  write_png(png, img);
  CHECK_THROWS_WITH(read_exr_attributes(png), Catch::Contains("attributes_not_exr.png"));
}

}  // namespace aov_io_test
