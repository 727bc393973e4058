// Analytic checks of the path integrators: scenes whose radiance is known in
// closed form. Tolerances are z standard errors of the estimate, from the
// film's per-pixel variance, with z from Sidak's correction over the m
// comparisons of each test case at a family-wise false-alarm rate of 10^-3
// (sidak_z, tests/support/reference_physics.hpp): a test case fails by chance
// once in a thousand re-rolls of its random numbers, however many pixels it
// checks.
#include <catch2/catch.hpp>
#include "support/reference_physics.hpp"
#include <cmath>
#include <prism/prism.hpp>

namespace analytic_test {

using namespace prism;

namespace {

struct Estimate {
  double mean = 0, var = 0;  // of the mean
};

// Mean over all pixels of channel c, with the variance of that mean.
Estimate image_mean(const Film& film, int c, int x0 = 0, int y0 = 0, int x1 = -1, int y1 = -1) {
  if (x1 < 0) x1 = film.width();
  if (y1 < 0) y1 = film.height();
  Estimate e;
  double n = double(x1 - x0) * double(y1 - y0);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      e.mean += film.pixel(x, y)[c];
      e.var += film.variance(x, y)[c];
    }
  e.mean /= n;
  e.var /= n * n;
  return e;
}

using reference_physics::sidak_z;

// The albedos of the closed-sphere cases, and the comparisons each case makes
// (every pixel of the 8 x 8 image, and the image mean).
constexpr float closed_sphere_rhos[] = {0.2f, 0.5f, 0.8f};
constexpr int closed_sphere_checks = 3 * (8 * 8 + 1);

// The inside of a closed sphere that emits Le from both sides and reflects
// diffusely with albedo rho: every point sees L = Le + rho L, so L = Le / (1 - rho).
template <class S, class Integrator>
void check_closed_sphere(float rho, const Integrator& integrator) {
  const double z = sidak_z(1e-3, closed_sphere_checks);
  const float Le = 0.5f;
  Scene<S> scene;
  uint32_t m = scene.add_material(DiffuseMaterial{RGB(rho)});
  scene.add_sphere(Sphere{{0, 0, 0}, 1}, m, AreaEmission{RGB(Le), 1, true});
  scene.build();
  const int w = 8, h = 8;
  PerspectiveCamera cam(look_at_camera_to_world({0.1f, 0.2f, 0.3f}, {0, 0, -1}, {0, 1, 0}), radians(60), w, h);
  Film film(w, h);
  RenderOptions opt;
  opt.spp = 1024;
  opt.seed = 7;
  RenderStats st = render(scene, cam, integrator, film, opt);
  REQUIRE(st.dropped == 0);
  const double expected = Le / (1 - rho);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double sigma = std::sqrt(double(film.variance(x, y).g));
      REQUIRE(sigma > 0);
      INFO("pixel " << x << "," << y << " rho " << rho << " mean " << film.pixel(x, y).g << " sigma " << sigma);
      CHECK(std::abs(film.pixel(x, y).g - expected) <= z * sigma);
    }
  Estimate e = image_mean(film, 1);
  INFO("image mean " << e.mean << " expected " << expected << " sigma " << std::sqrt(e.var));
  CHECK(std::abs(e.mean - expected) <= z * std::sqrt(e.var));
}

}  // namespace

TEST_CASE("closed emitting sphere with NEE and MIS", "[integrators][analytic]") {
  for (float rho : closed_sphere_rhos) check_closed_sphere<RGB>(rho, PathIntegrator{});
}

TEST_CASE("closed emitting sphere with BSDF sampling only", "[integrators][analytic]") {
  for (float rho : closed_sphere_rhos) check_closed_sphere<RGB>(rho, BSDFPathIntegrator{});
}

// Spectral: emission RGB(Le) is Le times D65 (Y = 1), gray albedos are flat
// spectra, so the film's linear sRGB is again Le / (1 - rho) per channel.
TEST_CASE("closed emitting sphere with NEE and MIS, spectral", "[integrators][analytic][spectral]") {
  for (float rho : closed_sphere_rhos) check_closed_sphere<Spectral>(rho, PathIntegrator{});
}

TEST_CASE("closed emitting sphere with BSDF sampling only, spectral", "[integrators][analytic][spectral]") {
  for (float rho : closed_sphere_rhos) check_closed_sphere<Spectral>(rho, BSDFPathIntegrator{});
}

TEST_CASE("closed sphere estimate detects a wrong albedo", "[integrators][analytic]") {
  // The same check must fail when the expectation is off by 5%: the test has
  // power. One estimate, one comparison each way.
  Scene<RGB> scene;
  uint32_t m = scene.add_material(DiffuseMaterial{RGB(0.5f)});
  scene.add_sphere(Sphere{{0, 0, 0}, 1}, m, AreaEmission{RGB(0.5f), 1, true});
  scene.build();
  PerspectiveCamera cam(look_at_camera_to_world({0, 0, 0}, {0, 0, -1}, {0, 1, 0}), radians(60), 8, 8);
  Film film(8, 8);
  RenderOptions opt;
  opt.spp = 1024;
  render(scene, cam, PathIntegrator{}, film, opt);
  Estimate e = image_mean(film, 1);
  const double z = sidak_z(1e-3, 1);
  CHECK(std::abs(e.mean - 1.0) <= z * std::sqrt(e.var));
  CHECK(std::abs(e.mean - 1.05) > z * std::sqrt(e.var));
}

namespace {
template <class S>
void white_furnace() {
  Scene<S> scene;
  uint32_t m = scene.add_material(DiffuseMaterial{RGB(1.f)});
  scene.add_sphere(Sphere{{0, 0, 0}, 1}, m);
  scene.add_infinite_light(UniformInfiniteLight<S>(RGB(1.f)));
  scene.build();
  const int w = 8, h = 8;
  PerspectiveCamera cam(look_at_camera_to_world({0, 0, 3}, {0, 0, 0}, {0, 1, 0}), radians(40), w, h);
  const double z = sidak_z(1e-3, 2 * w * h);  // every pixel, two integrators
  for (int which = 0; which < 2; ++which) {
    Film film(w, h);
    RenderOptions opt;
    opt.spp = 256;
    opt.seed = 3;
    RenderStats st = which == 0 ? render(scene, cam, PathIntegrator{}, film, opt)
                                : render(scene, cam, BSDFPathIntegrator{}, film, opt);
    REQUIRE(st.dropped == 0);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        double v = film.pixel(x, y).g, sigma = std::sqrt(double(film.variance(x, y).g));
        INFO("integrator " << which << " pixel " << x << "," << y << " value " << v << " sigma " << sigma);
        // A pixel may be exactly 1 with zero variance (it sees only the environment).
        // 1e-5 where σ is 0 (a pixel that sees only the environment): values 1 up to a few u, averaged in double
        CHECK(std::abs(v - 1.0) <= std::max(z * sigma, 1e-5));
      }
  }
}
}  // namespace

TEST_CASE("white furnace: albedo-1 sphere in a uniform environment", "[integrators][analytic][furnace]") {
  white_furnace<RGB>();
}

TEST_CASE("white furnace: albedo-1 sphere in a uniform environment, spectral",
          "[integrators][analytic][furnace][spectral]") {
  white_furnace<Spectral>();
}

// The default Cornell box, with its prism and glass sphere. The caustic pass
// is off for the NEE + MIS render: its light paths splat onto the film,
// where Film::variance does not see them, so with it the per-pixel variance
// would understate the estimate's. Without it both integrators estimate the
// same radiance by path tracing alone.
TEST_CASE("NEE with MIS agrees with BSDF sampling on the Cornell box", "[integrators][cornell]") {
  Scene<RGB> scene;
  build_cornell_box(scene);
  scene.build();
  const int w = 64, h = 64, region = 16;
  PerspectiveCamera cam = default_camera(w, h);
  Film a(w, h), b(w, h);
  RenderOptions opt;
  opt.spp = 128;
  opt.seed = 11;
  PathOptions no_splats;
  no_splats.light_traced_caustics = false;
  RenderStats st = render(scene, cam, PathIntegrator{no_splats}, a, opt);
  REQUIRE(st.light_paths == 0);
  opt.seed = 12;
  render(scene, cam, BSDFPathIntegrator{}, b, opt);
  int compared = 0;
  const double z = sidak_z(1e-3, (w / region) * (h / region) * 3);  // 48 regions x channels
  for (int ry = 0; ry < h; ry += region)
    for (int rx = 0; rx < w; rx += region)
      for (int c = 0; c < 3; ++c) {
        Estimate ea = image_mean(a, c, rx, ry, rx + region, ry + region);
        Estimate eb = image_mean(b, c, rx, ry, rx + region, ry + region);
        double sigma = std::sqrt(ea.var + eb.var);
        INFO("region " << rx << "," << ry << " channel " << c << ": MIS " << ea.mean << " BSDF " << eb.mean
                       << " sigma " << sigma);
        CHECK(std::abs(ea.mean - eb.mean) <= z * sigma);
        ++compared;
      }
  CHECK(compared == 48);
}

// RGB and spectral rendering of the diffuse-only Cornell box: products of
// uplifted spectra are not the spectra of RGB products, so the two models may
// differ by a little; the bound is 2% of each channel's image mean.
TEST_CASE("diffuse Cornell box: RGB and spectral means agree within 2% per channel",
          "[integrators][cornell][spectral]") {
  // 2M samples per model: the difference's standard error is ~0.3% per channel,
  // small beside the 2% bound.
  const int w = 32, h = 32;
  PerspectiveCamera cam = default_camera(w, h);
  RenderOptions opt;
  opt.spp = 2048;
  opt.seed = 5;
  Film a(w, h), b(w, h);
  {
    Scene<RGB> scene;
    build_cornell_box(scene, CornellBoxOptions{.prism = false, .gold_sphere = false});
    scene.build();
    render(scene, cam, PathIntegrator{}, a, opt);
  }
  {
    Scene<Spectral> scene;
    build_cornell_box(scene, CornellBoxOptions{.prism = false, .gold_sphere = false});
    scene.build();
    render(scene, cam, PathIntegrator{}, b, opt);
  }
  for (int c = 0; c < 3; ++c) {
    Estimate ea = image_mean(a, c), eb = image_mean(b, c);
    double rel = std::abs(eb.mean - ea.mean) / ea.mean;
    WARN("channel " << c << ": RGB " << ea.mean << " spectral " << eb.mean << " relative difference " << rel
                    << " (sigma of the difference " << std::sqrt(ea.var + eb.var) / ea.mean << ")");
    CHECK(rel <= 0.02);
  }
}

// A smooth dispersive glass sphere (SF11, Sellmeier) loses no energy, so in a
// uniform white environment every pixel is 1 whatever the wavelengths, even
// after the secondary wavelengths are terminated at the first refraction.
TEST_CASE("spectral white furnace around a dispersive smooth glass sphere", "[integrators][furnace][spectral][dispersion]") {
  Scene<Spectral> scene;
  uint32_t m = scene.add_material(DielectricMaterial{SellmeierIOR::glass("N-SF11"), "SF11 sphere"});
  scene.add_sphere(Sphere{{0, 0, 0}, 1}, m);
  scene.add_infinite_light(UniformInfiniteLight<Spectral>(RGB(1.f)));
  scene.build();
  REQUIRE(scene.needs_spectral());
  const int w = 8, h = 8;
  PerspectiveCamera cam(look_at_camera_to_world({0, 0, 3}, {0, 0, 0}, {0, 1, 0}), radians(40), w, h);
  Film film(w, h);
  RenderOptions opt;
  opt.spp = 512;
  opt.seed = 9;
  RenderStats st = render(scene, cam, PathIntegrator{}, film, opt);
  REQUIRE(st.dropped == 0);
  REQUIRE(st.light_paths == 0);  // no area light: no caustic pass
  const double z = sidak_z(1e-3, w * h * 3 + 1);  // every pixel and channel, and the mean
  double sum = 0, var = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        double v = film.pixel(x, y)[c], sigma = std::sqrt(double(film.variance(x, y)[c]));
        INFO("pixel " << x << "," << y << " channel " << c << " value " << v << " sigma " << sigma);
        CHECK(std::abs(v - 1.0) <= z * sigma + 2e-3);  // 2e-3: D65 through the 1 nm tables and the sRGB matrix (≤ 1.2e-3 from its 4-digit chromaticity)
        sum += v / (w * h * 3);
        var += double(film.variance(x, y)[c]) / double(w * h * 3) / double(w * h * 3);
      }
  INFO("image mean " << sum << " sigma " << std::sqrt(var));
  CHECK(std::abs(sum - 1.0) <= z * std::sqrt(var) + 2e-3);
}

TEST_CASE("a glass whose Sellmeier law gives eta at most 1 is rejected when the scene is built", "[integrators][dispersion][validate]") {
  Scene<Spectral> scene;
  // B = 0 everywhere: eta = 1 at every wavelength.
  uint32_t m = scene.add_material(
      DielectricMaterial{SellmeierIOR({0.0, 0.0, 0.0, 0.0}, {0.01, 0.02, 100.0, 0.0}), "index-matched test glass"});
  scene.add_sphere(Sphere{{0, 0, 0}, 1}, m);
  try {
    scene.build();
    FAIL("build() accepted eta = 1");
  } catch (const Error& e) {
    std::string msg = e.what();
    INFO(msg);
    CHECK(msg.find("index-matched test glass") != std::string::npos);
    CHECK(msg.find("material 0") != std::string::npos);
  }
}

}  // namespace analytic_test
