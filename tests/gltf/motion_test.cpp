// glTF animations as motion blur: the shared AnimatedCube turns about y
// (keyframes at 0, 1 and 2 s, LINEAR: slerp). Loaded with the shutter open
// over [0.2, 0.8] s, inside one keyframe interval, its moving instance must
// be where the cube is when loaded still at each time in between: a ray at
// time t meets it at the same distance. Skipped when ../shared is absent.
// A camera node that an animation moves gets its motion over the shutter
// (camera motion blur), keyed at the shutter's ends. Skinned and morphing
// meshes deform over the shutter (deformation blur): their vertex keys are
// the still loads at the keys' times, and a morph that is linear in time
// over the shutter is met where the still file has it at any time.
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

// CesiumMan walks (skinning): with the shutter open, its mesh deforms,
// keyed at five evenly spaced times, each key being the still load's
// vertices at that time; no warning is left about deformation.
TEST_CASE("a skinned glTF mesh deforms over the shutter, keyed by the still loads", "[gltf][motion][deform][shared]") {
  const std::string path = std::string(PRISM_SHARED_DIR) + "/scenes/CesiumMan/glTF-Binary/CesiumMan.glb";
  if (!std::filesystem::exists(path)) PRISM_TEST_SKIP("../shared/scenes/CesiumMan is absent");
  GltfOptions blur;
  blur.time = 0.5;
  blur.shutter = 0.2;
  auto g = load_gltf<RGB>(path, blur);
  CHECK(g.deforming_meshes == 1);
  for (const auto& w : g.warnings) CHECK(w.find("deform") == std::string::npos);
  const SceneAccel& accel = g.scene.accel();
  uint32_t mesh = UINT32_MAX;
  for (uint32_t m = 0; m < accel.meshes().size(); ++m)
    if (accel.is_deforming(m)) mesh = m;
  REQUIRE(mesh != UINT32_MAX);
  const VertexMotion& vm = accel.vertex_motion(mesh);
  REQUIRE(vm.keys() == 5);
  CHECK(vm.time0 == 0.5f);
  CHECK(vm.time1 == 0.7f);
  double moved = 0;
  for (size_t k = 0; k < 5; ++k) {
    GltfOptions at;
    at.time = 0.5 + 0.2 * double(k) / 4;  // the loader's key times
    auto still = load_gltf<RGB>(path, at);
    const auto& sm = still.scene.accel().meshes();
    REQUIRE(sm.size() == accel.meshes().size());
    REQUIRE(sm[mesh].positions.size() == vm.positions[k].size());
    double worst = 0;
    for (size_t v = 0; v < vm.positions[k].size(); ++v) {
      worst = std::max(worst, double(length(vm.positions[k][v] - sm[mesh].positions[v])));
      moved = std::max(moved, double(length(vm.positions[k][v] - vm.positions[0][v])));
    }
    INFO("key " << k);
    CHECK(worst == 0);  // the same skinning at the same time
  }
  CHECK(moved > 0.01);  // a control: the man moves during the shutter
  // Without a shutter, or with a zero one, nothing deforms.
  CHECK(load_gltf<RGB>(path).deforming_meshes == 0);
  GltfOptions two;
  two.time = 0.5;
  two.shutter = 0.2;
  two.deformation_keys = 2;
  auto g2 = load_gltf<RGB>(path, two);
  REQUIRE(g2.deforming_meshes == 1);
  for (uint32_t m = 0; m < g2.scene.accel().meshes().size(); ++m)
    if (g2.scene.accel().is_deforming(m)) CHECK(g2.scene.accel().vertex_motion(m).keys() == 2);
  GltfOptions bad = two;
  bad.deformation_keys = 1;
  CHECK_THROWS_WITH(load_gltf<RGB>(path, bad), Catch::Contains("deformation_keys"));
}

// AnimatedMorphCube's weights are keyed every 1/30 s, LINEAR: over
// [0.505, 0.530], inside one keyframe interval, every vertex moves in a
// straight line, so two keys model the motion exactly and a ray at any
// time in between meets the cube where the still load at that time has it.
TEST_CASE("a morphing glTF mesh is met where the still file has it at every time", "[gltf][motion][deform][shared]") {
  const std::string path = std::string(PRISM_SHARED_DIR) + "/scenes/AnimatedMorphCube/glTF-Binary/AnimatedMorphCube.glb";
  if (!std::filesystem::exists(path)) PRISM_TEST_SKIP("../shared/scenes/AnimatedMorphCube is absent");
  GltfOptions blur;
  blur.time = 0.505;
  blur.shutter = 0.025;
  blur.deformation_keys = 2;
  auto moving = load_gltf<RGB>(path, blur);
  REQUIRE(moving.deforming_meshes == 1);
  moving.scene.build();
  REQUIRE(moving.scene.accel().has_motion());
  const Point3f c = moving.bounds.centroid();
  const Float r = length(moving.bounds.diagonal());
  PCG32 rng(7, 3);
  int compared = 0;
  double worst = 0, change = 0;
  for (double t : {0.505, 0.51, 0.5175, 0.525, 0.53}) {
    GltfOptions at;
    at.time = t;
    auto still = load_gltf<RGB>(path, at);
    still.scene.build();
    for (int k = 0; k < 200; ++k) {
      Vector3f d = test::random_unit(rng);
      Ray ray{c - d * r, d, Float(t)};
      auto a = moving.scene.intersect(ray);
      auto b = still.scene.intersect(ray);
      REQUIRE(a.has_value());
      REQUIRE(b.has_value());
      Float ta = length(a->p - ray.o), tb = length(b->p - ray.o);
      worst = std::max(worst, double(std::abs(ta - tb)));
      auto first = moving.scene.intersect(Ray{ray.o, ray.d, Float(0.505)});
      REQUIRE(first.has_value());
      change = std::max(change, double(std::abs(length(first->p - ray.o) - ta)));
      ++compared;
    }
  }
  // Weights that are all 0 when the shutter opens (at time 0) but move
  // during it still deform the mesh.
  GltfOptions from_rest;
  from_rest.time = 0;
  from_rest.shutter = 0.1;
  CHECK(load_gltf<RGB>(path, from_rest).deforming_meshes == 1);
  INFO("largest distance difference " << worst << " over " << compared << " rays; largest motion " << change);
  // 1e-4: distances of about 2-4 (ulp 2.4e-7-4.8e-7) through the blend, the
  // float morph and the hit point, a few tens of roundings: ≲ 2e-5
  CHECK(worst < 1e-4);
  CHECK(change > 1e-3);  // a control: the cube deforms during the shutter
}

TEST_CASE("glTF options reject fewer than two deformation keys", "[gltf][motion][errors]") {
  const std::string path = std::string(PRISM_TEST_TMP_DIR) + "/no_such_file.gltf";
  GltfOptions bad;
  bad.deformation_keys = 1;
  CHECK_THROWS_WITH(load_gltf<RGB>(path, bad), Catch::Contains("deformation_keys"));
}

}  // namespace motion_test
