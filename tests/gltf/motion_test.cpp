// glTF animations as motion blur: the shared AnimatedCube turns about y
// (keyframes at 0, 1 and 2 s, LINEAR: slerp). Loaded with the shutter open
// over [0.2, 0.8] s, inside one keyframe interval, its moving instance must
// be where the cube is when loaded still at each time in between: a ray at
// time t meets it at the same distance. Skipped when ../shared is absent.
// A camera node that an animation moves gets its motion over the shutter
// (camera motion blur), keyed at the shutter's ends.
#include <catch2/catch.hpp>
#include "support/gltf_deform.hpp"
#include "support/random.hpp"
#include "support/skip.hpp"
#include <filesystem>
#include <prism/io/gltf.hpp>

namespace motion_test {

using namespace prism;

TEST_CASE("a glTF animation over the shutter moves the instance as the file does", "[gltf][motion][shared]") {
  const std::string path = std::string(PRISM_SHARED_DIR) + "/scenes/AnimatedCube/glTF/AnimatedCube.gltf";
  if (!std::filesystem::exists(path)) PRISM_TEST_SKIP("../shared/scenes/AnimatedCube is absent");
  GltfOptions blur;
  blur.time = 0.2;
  blur.shutter = 0.6;
  auto moving = load_gltf<RGB>(path, blur);
  CHECK(moving.moving_instances == 1);
  moving.scene.build();
  REQUIRE(moving.scene.accel().has_motion());
  // Without a shutter nothing moves.
  auto still0 = load_gltf<RGB>(path);
  CHECK(still0.moving_instances == 0);

  PCG32 rng(4, 2);
  int compared = 0;
  double worst = 0;
  for (double t : {0.2, 0.35, 0.5, 0.65, 0.8}) {
    GltfOptions at;
    at.time = t;
    auto still = load_gltf<RGB>(path, at);
    still.scene.build();
    for (int k = 0; k < 200; ++k) {
      Vector3f d = test::random_unit(rng);
      Ray ray{Point3f{0, 0, 0} - d * Float(5), d, Float(t)};
      auto a = moving.scene.intersect(ray);
      auto b = still.scene.intersect(ray);
      REQUIRE(a.has_value());
      REQUIRE(b.has_value());
      Float ta = length(a->p - ray.o), tb = length(b->p - ray.o);
      worst = std::max(worst, double(std::abs(ta - tb)));
      ++compared;
    }
  }
  INFO("largest distance difference " << worst << " over " << compared << " rays");
  // 1e-4: distances ≈ 5 (ulp 4.8e-7) through two float transforms and the hit point, ~20 roundings: ≲ 1e-5
  CHECK(worst < 1e-4);
  // Half way through the shutter the cube has turned, so a ray that would
  // meet an unturned cube's face straight on meets it elsewhere.
  Ray diag{{5, 0.3f, 0.2f}, {-1, 0, 0}, 0.5f};
  auto turned = moving.scene.intersect(diag);
  auto start = moving.scene.intersect(Ray{diag.o, diag.d, 0.2f});
  REQUIRE(turned.has_value());
  REQUIRE(start.has_value());
  // a control: the turn must move the hit by more than 1e-3, 10× the rounding bound above
  CHECK(std::abs(length(turned->p - diag.o) - length(start->p - diag.o)) > 1e-3f);
}

TEST_CASE("glTF options reject a negative or non-finite shutter and time", "[gltf][motion][errors]") {
  const std::string path = std::string(PRISM_TEST_TMP_DIR) + "/no_such_file.gltf";
  GltfOptions bad;
  bad.shutter = -1;
  CHECK_THROWS_WITH(load_gltf<RGB>(path, bad), Catch::Contains("shutter"));
  bad.shutter = std::numeric_limits<double>::quiet_NaN();
  CHECK_THROWS_WITH(load_gltf<RGB>(path, bad), Catch::Contains("shutter"));
  GltfOptions bad_time;
  bad_time.time = std::numeric_limits<double>::infinity();
  CHECK_THROWS_WITH(load_gltf<RGB>(path, bad_time), Catch::Contains("time"));
}

// A camera whose node slides from x = 0 to x = 2 over one second (LINEAR)
// and turns by 90 degrees about y: loaded with the shutter over [0.25, 0.75],
// GltfCamera::motion runs from the node at 0.25 (x = 0.5) to the node at
// 0.75 (x = 1.5), each with glTF's -z view turned to prism's +z; without a
// shutter, or over an interval the animation does not move, there is none.
TEST_CASE("a glTF camera node moving over the shutter gets its motion", "[gltf][motion][camera]") {
  using gltf_deform::json;
  gltf_deform::Builder b;
  const float s = std::sqrt(0.5f);
  int a_t = b.add(std::vector<float>{0, 1}, 5126, "SCALAR");
  int a_x = b.add(std::vector<float>{0, 0, 5, 2, 0, 5}, 5126, "VEC3");
  int a_r = b.add(std::vector<float>{0, 0, 0, 1, 0, s, 0, s}, 5126, "VEC4");
  b.g["scene"] = 0;
  b.g["scenes"] = json::array({{{"nodes", {0}}}});
  b.g["nodes"] = json::array({{{"camera", 0}, {"translation", {0, 0, 5}}}});
  b.g["cameras"] = json::array({{{"type", "perspective"}, {"perspective", {{"yfov", 0.7}, {"znear", 0.1}}}}});
  b.g["animations"] = json::array({{{"samplers", json::array({{{"input", a_t}, {"output", a_x}, {"interpolation", "LINEAR"}},
                                                             {{"input", a_t}, {"output", a_r}, {"interpolation", "LINEAR"}}})},
                                    {"channels", json::array({{{"sampler", 0}, {"target", {{"node", 0}, {"path", "translation"}}}},
                                                              {{"sampler", 1}, {"target", {{"node", 0}, {"path", "rotation"}}}}})}}});
  const std::string path = gltf_json::write_temp_gltf("gltf_motion", "camera.gltf", b.finish());
  GltfOptions blur;
  blur.time = 0.25;
  blur.shutter = 0.5;
  auto g = load_gltf<RGB>(path, blur);
  REQUIRE(g.cameras.size() == 1);
  REQUIRE(g.cameras[0].motion.has_value());
  const AnimatedTransform& m = *g.cameras[0].motion;
  CHECK(m.start_time() == 0.25f);
  CHECK(m.end_time() == 0.75f);
  // The eye and the view direction (glTF's -z of the node) at both ends and
  // half way: x = 2 t, the node turned by 90 t degrees about y.
  for (double t : {0.25, 0.5, 0.75}) {
    Transform xf = m.at(Float(t));
    Point3f eye = xf(Point3f(0, 0, 0));
    Vector3f view = normalize(xf(Vector3f(0, 0, 1)));
    const double a = 0.5 * 3.14159265358979 * t;  // the node's turn about y
    INFO("time " << t << ": eye " << eye.x << " " << eye.y << " " << eye.z << ", view " << view.x << " " << view.y
                 << " " << view.z);
    // 1e-5: float transforms of values of order 1 (a few roundings of 6e-8)
    CHECK(std::abs(eye.x - 2 * t) < 1e-5);
    CHECK(std::abs(eye.z - 5) < 1e-5);
    // The node's -z turned by a about y: (-sin a, 0, -cos a).
    CHECK(std::abs(view.x + std::sin(a)) < 1e-5);
    CHECK(std::abs(view.y) < 1e-5);
    CHECK(std::abs(view.z + std::cos(a)) < 1e-5);
  }
  // camera_to_world is the pose when the shutter opens.
  CHECK(std::abs(g.cameras[0].camera_to_world(Point3f(0, 0, 0)).x - 0.5f) < 1e-5f);
  GltfOptions still;
  still.time = 0.25;
  CHECK_FALSE(load_gltf<RGB>(path, still).cameras[0].motion.has_value());
  GltfOptions after;  // after the last key nothing moves
  after.time = 2;
  after.shutter = 0.5;
  CHECK_FALSE(load_gltf<RGB>(path, after).cameras[0].motion.has_value());
}

}  // namespace motion_test
