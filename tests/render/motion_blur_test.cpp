// Motion blur end to end: a grey square sliding across an orthographic
// camera's view during the shutter, under a white environment. Every sample is
// 1 (background) or 0.5 (the square: albedo 0.5 under unit radiance, exact
// with BSDF sampling), so each pixel's mean is 1 - 0.5 c with c the fraction
// of the pixel's area and of the shutter interval that the square covers,
// computed here by quadrature of the analytic time fraction. The tolerance is
// z sigma of the Bernoulli sample mean, z from Sidak's correction over every
// pixel of the test case's three renders (m = 3 x 80 = 240) at a family-wise
// false-alarm rate of 10^-3: z = sidak_z(1e-3, 240) = 4.60
// (tests/support/reference_physics.hpp).
#include <catch2/catch.hpp>
#include <prism/prism.hpp>
#include "support/reference_physics.hpp"

namespace motion_blur_test {

using namespace prism;

namespace {

constexpr Float kWidth = 0.4f, kStart = -0.6f, kTravel = 0.8f;  // square x in [kStart, kStart + kWidth] + kTravel u
constexpr int kW = 40, kH = 2;  // the film: every pixel is compared
// Each test case renders three times: 3 kW kH comparisons.
const double kZ = reference_physics::sidak_z(1e-3, 3 * kW * kH);

TriangleMesh square() {
  TriangleMesh m;
  m.positions = {{0, -1, 0}, {kWidth, -1, 0}, {kWidth, 1, 0}, {0, 1, 0}};
  m.indices = {0, 1, 2, 0, 2, 3};
  return m;
}

// Fraction of the shutter [s0, s1] (as fractions u of the motion) during
// which world x is inside the square.
double time_fraction(double x, double s0, double s1) {
  double lo = (x - kStart - kWidth) / kTravel, hi = (x - kStart) / kTravel;
  lo = std::max(lo, s0);
  hi = std::min(hi, s1);
  return std::max(0.0, hi - lo) / (s1 - s0);
}

struct Result {
  int checked = 0, failures = 0, partial = 0;
};

Result render_and_compare(Shutter shutter, SamplerKind kind, int spp) {
  Scene<RGB> scene;
  uint32_t grey = scene.add_material(DiffuseMaterial{RGB(0.5f)});
  uint32_t mesh = scene.add_mesh(square());
  scene.add_instance(mesh, grey,
                     AnimatedTransform(TransformKey::trs({kStart, 0, 0}), TransformKey::trs({kStart + kTravel, 0, 0}), 0, 1));
  scene.add_light(UniformInfiniteLight<RGB>(RGB(1)));
  scene.build();
  const int w = kW, h = kH;
  OrthographicCamera cam(look_at_camera_to_world({0, 0, -1}, {0, 0, 0}, {0, 1, 0}), 0.1f, w, h);
  cam.set_shutter(shutter);
  Film film(w, h);
  RenderOptions opt;
  opt.spp = spp;
  opt.seed = 17;
  opt.sampler = kind;
  PathOptions popt;
  popt.rr_min_depth = 1000;  // no Russian roulette: every sample is exactly 0.5 or 1
  RenderStats st = render(scene, cam, BSDFPathIntegrator(popt), film, opt);
  REQUIRE(st.dropped == 0);
  Result r;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      CameraSample a, b;
      a.p_film = {Float(x), Float(y) + 0.5f};
      b.p_film = {Float(x + 1), Float(y) + 0.5f};
      double xa = cam.generate_ray(a).o.x, xb = cam.generate_ray(b).o.x;
      if (xa > xb) std::swap(xa, xb);
      // Coverage: the mean time fraction over the pixel's x extent.
      double s0 = shutter.open, s1 = shutter.close;
      double c = 0;
      constexpr int n = 20000;
      for (int k = 0; k < n; ++k) {
        double xx = xa + (xb - xa) * (k + 0.5) / n;
        c += s1 > s0 ? time_fraction(xx, s0, s1) : ((xx >= kStart + kTravel * s0 && xx <= kStart + kWidth + kTravel * s0) ? 1.0 : 0.0);
      }
      c /= n;
      double expect = 1 - 0.5 * c;
      double sigma = 0.5 * std::sqrt(c * (1 - c) / spp);
      double got = film.pixel(x, y).g;
      if (c > 0.01 && c < 0.99) ++r.partial;
      ++r.checked;
      // +1e-5: float rounding of the samples (values ≤ 1, a few u each), averaged in double
      if (!(std::abs(got - expect) <= kZ * sigma + 1e-5)) {
        ++r.failures;
        UNSCOPED_INFO("pixel " << x << "," << y << ": " << got << " expected " << expect << " sigma " << sigma);
      }
    }
  return r;
}

}  // namespace

TEST_CASE("a sliding square's mean coverage equals the analytic fraction", "[render][motion]") {
  for (SamplerKind kind : {SamplerKind::independent, SamplerKind::sobol}) {
    Result r = render_and_compare(Shutter{0, 1}, kind, 4096);
    CHECK(r.failures == 0);
    CHECK(r.partial >= 20);  // most of the swept pixels are partly covered
  }
  // Half the shutter: the square covers half the sweep.
  Result half = render_and_compare(Shutter{0.5f, 1}, SamplerKind::independent, 512);
  CHECK(half.failures == 0);
}

TEST_CASE("a closed shutter freezes the motion at its time", "[render][motion]") {
  for (Float t : {0.f, 0.3f, 1.f}) {
    Result r = render_and_compare(Shutter{t, t}, SamplerKind::independent, 64);
    CHECK(r.failures == 0);
    CHECK(r.partial <= 4);  // only the pixels straddling the square's two edges
  }
}

TEST_CASE("cameras reject a reversed or non-finite shutter and a negative aperture", "[cameras][motion][errors]") {
  PerspectiveCamera cam(Transform{}, 1.0f, 8, 8);
  CHECK_THROWS_WITH(cam.set_shutter(Shutter{1, 0}), Catch::Contains("shutter"));
  CHECK_THROWS_AS(cam.set_shutter(Shutter{0, std::numeric_limits<Float>::infinity()}), Error);
  CHECK_NOTHROW(cam.set_shutter(Shutter{0, 0}));
  CHECK_THROWS_WITH(PerspectiveCamera(Transform{}, 1.0f, 8, 8, -0.1f, 1), Catch::Contains("aperture"));
  CHECK_THROWS_WITH(PerspectiveCamera(Transform{}, 1.0f, 8, 8, 0.1f, 0), Catch::Contains("focus distance"));
  OrthographicCamera ortho(Transform{}, 1, 8, 8);
  CHECK_THROWS_AS(ortho.set_shutter(Shutter{2, 1}), Error);
}

}  // namespace motion_blur_test
