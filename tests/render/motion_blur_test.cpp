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

// What moves. camera: the square stays at kStart and the camera slides by
// -kTravel over the motion instead: the same picture in the camera's frame,
// so the same expected coverage (the pixel extents below are the camera's
// at time 0, where both set-ups coincide). vertices: the square's vertices
// carry the slide as three keys (deformation blur), the same motion.
enum class Mover { instance, camera, vertices };
Result render_and_compare(Shutter shutter, SamplerKind kind, int spp, Mover mover = Mover::instance) {
  const bool camera_moves = mover == Mover::camera;
  Scene<RGB> scene;
  uint32_t grey = scene.add_material(DiffuseMaterial{RGB(0.5f)});
  if (mover == Mover::vertices) {
    VertexMotion keys;
    keys.time0 = 0;
    keys.time1 = 1;
    for (int k = 0; k < 3; ++k) {
      keys.positions.push_back(square().positions);
      for (auto& p : keys.positions.back()) p.x += kStart + kTravel * Float(k) / 2;
    }
    scene.add_instance(scene.add_deforming_mesh(square(), keys), grey);
  } else if (camera_moves) {
    scene.add_instance(scene.add_mesh(square()), grey, translate({kStart, 0, 0}));
  } else {
    scene.add_instance(scene.add_mesh(square()), grey,
                       AnimatedTransform(TransformKey::trs({kStart, 0, 0}), TransformKey::trs({kStart + kTravel, 0, 0}), 0, 1));
  }
  scene.add_light(UniformInfiniteLight<RGB>(RGB(1)));
  scene.build();
  const int w = kW, h = kH;
  const Transform view = look_at_camera_to_world({0, 0, -1}, {0, 0, 0}, {0, 1, 0});
  OrthographicCamera cam(view, 0.1f, w, h);
  if (camera_moves)
    cam.set_motion(AnimatedTransform(TransformKey::decompose(view), TransformKey::decompose(translate({-kTravel, 0, 0}) * view),
                                     0, 1));
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

// The blur over the whole shutter matches the analytic coverage, and a
// closed shutter freezes whatever moves where it is at that time.
static void check_blur_and_freeze(Mover mover) {
  Result r = render_and_compare(Shutter{0, 1}, SamplerKind::independent, 4096, mover);
  CHECK(r.failures == 0);
  CHECK(r.partial >= 20);
  for (Float t : {0.f, 0.3f, 1.f}) {
    Result frozen = render_and_compare(Shutter{t, t}, SamplerKind::independent, 64, mover);
    CHECK(frozen.failures == 0);
    CHECK(frozen.partial <= 4);
  }
}

// Camera motion blur: the camera sliding the other way over the still square
// gives the same coverage, exactly as predicted.
TEST_CASE("a moving camera over a still square blurs as the square moving the other way", "[render][motion][camera]") {
  check_blur_and_freeze(Mover::camera);
}

// Deformation blur: the slide given as vertex keys blurs as the sliding
// instance does.
TEST_CASE("a square whose vertices slide blurs as the sliding instance", "[render][motion][deform]") {
  check_blur_and_freeze(Mover::vertices);
}

TEST_CASE("a deforming mesh cannot emit", "[render][motion][deform]") {
  Scene<RGB> scene;
  VertexMotion keys;
  keys.positions = {square().positions, square().positions};
  uint32_t mesh = scene.add_deforming_mesh(square(), keys);
  scene.add_instance(mesh, scene.add_material(DiffuseMaterial{}), Transform{}, AreaEmission{RGB(1)});
  CHECK_THROWS_WITH(scene.build(), Catch::Contains("deforming mesh cannot emit"));
}

namespace {
// A perspective camera at the origin turning by kTurn about y over the
// shutter, or still while the scene (a grey square 3 units ahead, off
// centre) turns by -kTurn about the same axis: at every time the square
// sits in the same place relative to the camera (slerp of r q0 against q0
// is r^u q0; of identity against r^-1, r^-u).
constexpr Float kTurn = 0.25f;
Film render_turn(bool camera_turns, int spp) {
  Scene<RGB> scene;
  uint32_t grey = scene.add_material(DiffuseMaterial{RGB(0.5f)});
  uint32_t mesh = scene.add_mesh(square());
  const Transform place = translate({-0.2f, 0, 3}) * scale(1, 0.5f, 1);
  if (camera_turns) {
    scene.add_instance(mesh, grey, place);
  } else {
    TransformKey a = TransformKey::trs({0, 0, 0}), b = TransformKey::trs({0, 0, 0});
    b.rotation = Quaternion::from_axis_angle({0, 1, 0}, -kTurn);
    // The square's placement composed after the turn: place the mesh with
    // its own instance transform baked into the vertices.
    TriangleMesh m = square();
    for (auto& p : m.positions) p = place(p);
    uint32_t placed = scene.add_mesh(m);
    scene.add_instance(placed, grey, AnimatedTransform(a, b, 0, 1));
  }
  scene.add_light(UniformInfiniteLight<RGB>(RGB(1)));
  scene.build();
  const Transform view = look_at_camera_to_world({0, 0, 0}, {0, 0, 1}, {0, 1, 0});
  PerspectiveCamera cam(view, 0.8f, 24, 12);
  if (camera_turns)
    cam.set_motion(AnimatedTransform(TransformKey::decompose(view),
                                     TransformKey::decompose(rotate(kTurn, {0, 1, 0}) * view), 0, 1));
  cam.set_shutter(Shutter{0, 1});
  Film film(24, 12);
  RenderOptions opt;
  opt.spp = spp;
  opt.seed = 5;
  PathOptions popt;
  popt.rr_min_depth = 1000;  // every sample is exactly 0.5 or 1
  render(scene, cam, BSDFPathIntegrator(popt), film, opt);
  return film;
}
}  // namespace

// The two turning set-ups render the same image within noise: every sample
// is 0.5 (the square) or 1, so a pixel's mean is 1 - 0.5 c and its variance
// 0.25 c (1 - c) / spp, c estimated from both renders; the difference of the
// two independent means within z sqrt(2) sigma, z by Sidak over the 288
// pixels at 10^-3. Controls: the turn blurs (some pixels partly covered),
// and a still camera given equal keys renders bit for bit as one without.
TEST_CASE("a turning camera equals the scene turning the other way", "[render][motion][camera]") {
  const int spp = 2048;
  Film a = render_turn(true, spp), b = render_turn(false, spp);
  const double z = reference_physics::sidak_z(1e-3, 24 * 12);
  int partial = 0;
  for (int y = 0; y < 12; ++y)
    for (int x = 0; x < 24; ++x) {
      double va = a.pixel(x, y).g, vb = b.pixel(x, y).g;
      double c = std::clamp(2 * (1 - (va + vb) / 2), 0.0, 1.0);
      double sigma = 0.5 * std::sqrt(c * (1 - c) / spp);
      if (c > 0.05 && c < 0.95) ++partial;
      INFO("pixel " << x << "," << y << ": " << va << " vs " << vb << ", sigma " << sigma);
      // +1e-5: float rounding of the samples, averaged in double (as above)
      CHECK(std::abs(va - vb) <= z * std::sqrt(2.0) * sigma + 1e-5);
    }
  CHECK(partial >= 12);
  // Equal keys: still, bit for bit.
  Scene<RGB> scene;
  scene.add_instance(scene.add_mesh(square()), scene.add_material(DiffuseMaterial{RGB(0.5f)}), translate({0, 0, 3}));
  scene.add_light(UniformInfiniteLight<RGB>(RGB(1)));
  scene.build();
  const Transform view = look_at_camera_to_world({0, 0, 0}, {0, 0, 1}, {0, 1, 0});
  PerspectiveCamera still(view, 0.8f, 16, 8), keyed(view, 0.8f, 16, 8);
  keyed.set_motion(AnimatedTransform(TransformKey::decompose(view), TransformKey::decompose(view), 0, 1));
  CHECK_FALSE(keyed.placement().is_moving());
  for (auto* c : {&still, &keyed}) c->set_shutter(Shutter{0, 1});
  Film fs(16, 8), fk(16, 8);
  RenderOptions opt;
  opt.spp = 8;
  render(scene, still, PathIntegrator{}, fs, opt);
  render(scene, keyed, PathIntegrator{}, fk, opt);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 16; ++x) CHECK(fs.pixel(x, y) == fk.pixel(x, y));
}

// connect() at a time inverts generate_ray() at that time, for a moving
// camera with a lens: the point a ray meets 4 units out maps back to the
// ray's film position (within float rounding of a few transforms, 1e-3
// pixels), and at another time elsewhere.
TEST_CASE("a moving camera's connect() at a time finds the pixel of its ray at that time", "[cameras][motion][camera]") {
  const Transform view = look_at_camera_to_world({0, 0, 0}, {0, 0, 1}, {0, 1, 0});
  PerspectiveCamera cam(view, 0.9f, 64, 48, 0.05f, 4);
  cam.set_motion(AnimatedTransform(TransformKey::decompose(view),
                                   TransformKey::decompose(translate({0.5f, 0, 0}) * rotate(0.3f, {0, 1, 0}) * view), 0, 1));
  for (Float t : {0.f, 0.4f, 1.f}) {
    CameraSample s;
    s.p_film = {20.5f, 30.25f};
    s.p_lens = {0.3f, 0.7f};
    s.time = t;
    Ray r = cam.generate_ray(s);
    Point3f p = r.o + r.d * Float(4 / r.d.z);  // approximately on the plane of focus
    auto c = cam.connect(p, s.p_lens, t);
    REQUIRE(c.has_value());
    INFO("time " << t << ": " << c->p_raster.x << ", " << c->p_raster.y);
    CHECK(std::abs(c->p_raster.x - 20.5f) < 1e-3f);
    CHECK(std::abs(c->p_raster.y - 30.25f) < 1e-3f);
    auto other = cam.connect(p, s.p_lens, t < 0.5f ? 1.f : 0.f);
    CHECK((!other || std::abs(other->p_raster.x - 20.5f) > 1));
  }
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
