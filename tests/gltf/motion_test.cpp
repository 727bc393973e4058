// glTF animations as motion blur: the shared AnimatedCube turns about y
// (keyframes at 0, 1 and 2 s, LINEAR: slerp). Loaded with the shutter open
// over [0.2, 0.8] s, inside one keyframe interval, its moving instance must
// be where the cube is when loaded still at each time in between: a ray at
// time t meets it at the same distance. Skipped when ../shared is absent.
#include <catch2/catch.hpp>
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

}  // namespace motion_test
