// EXT_meshopt_compression: bufferViews compressed by meshoptimizer's codecs.
// A box encoded here with meshoptimizer's encoders (tests/support/
// meshopt_box.hpp: attributes plain and through the exponential and
// octahedral filters, indices as triangles and as a sequence) must load as
// the box it encodes, and CesiumMan packed by gltfpack (tests/gltf/data:
// every filter, quantized attributes) must give the shared plain file's
// surface within the quantization step. Bad compressed data is tested in
// tests/gltf_input (under ASan + UBSan in CI).
#include <catch2/catch.hpp>
#include "support/gltf_json.hpp"
#include "support/mesh_compare.hpp"
#include "support/meshopt_box.hpp"
#include "support/skip.hpp"
#include <cmath>
#include <filesystem>
#include <string>
#include <prism/io/gltf.hpp>
#include <prism/prism.hpp>

namespace meshopt_test {

using namespace prism;
using nlohmann::json;

namespace {

const std::string scenes_dir = std::string(PRISM_SHARED_DIR) + "/scenes/";
const std::string packed_cesium_man = std::string(PRISM_TEST_SOURCE_DIR) + "/gltf/data/CesiumMan.meshopt.glb";
bool have_scenes() { return std::filesystem::exists(scenes_dir + "README.md"); }

}  // namespace

TEST_CASE("EXT_meshopt_compression: a box encoded by meshoptimizer loads as the box", "[gltf][meshopt]") {
#if defined(PRISM_HAS_MESHOPT)
  gltf_json::BoxArrays box = gltf_json::box_arrays(1);
  for (bool sequence : {false, true})
    for (bool exp : {false, true}) {
      INFO((sequence ? "INDICES" : "TRIANGLES") << ", positions " << (exp ? "EXPONENTIAL" : "unfiltered"));
      auto g = load_gltf<RGB>(gltf_json::write_temp_gltf("gltf_meshopt", "box.gltf", gltf_json::meshopt_box_gltf(sequence, exp)));
      for (const auto& w : g.warnings) CHECK(w.find("meshopt") == std::string::npos);
      const auto& meshes = g.scene.accel().meshes();
      REQUIRE(meshes.size() == 1);
      const TriangleMesh& m = meshes[0];
      REQUIRE(m.positions.size() == box.pos.size() / 3);
      REQUIRE(m.indices.size() == box.idx.size());
      for (size_t i = 0; i < box.idx.size(); ++i) CHECK(m.indices[i] == box.idx[i]);
      // The box's coordinates (0, +-0.5, 1) are exact in every encoding.
      for (size_t v = 0; v < m.positions.size(); ++v)
        for (int a = 0; a < 3; ++a) CHECK(m.positions[v][a] == box.pos[3 * v + size_t(a)]);
      // Axis-aligned unit normals through 8-bit octahedral codes: exact
      // directions (a normalized byte 127 or -127 on one axis, 0 elsewhere).
      REQUIRE(m.normals.size() == m.positions.size());
      for (size_t v = 0; v < m.normals.size(); ++v) {
        Vector3f n(m.normals[v].x, m.normals[v].y, m.normals[v].z);
        n = normalize(n);
        // 1e-6: the normals decode to float; a few ulps of unit components
        for (int a = 0; a < 3; ++a) CHECK(std::abs(n[a] - box.nrm[3 * v + size_t(a)]) <= 1e-6f);
      }
    }
#else
  std::string e;
  try {
    json g = gltf_json::box_gltf(1, json::object(), {"EXT_meshopt_compression"});
    g["extensionsRequired"] = {"EXT_meshopt_compression"};
    load_gltf<RGB>(gltf_json::write_temp_gltf("gltf_meshopt", "box.gltf", g));
  } catch (const Error& err) {
    e = err.what();
  }
  CHECK(e.find("'EXT_meshopt_compression' is required") != std::string::npos);
#endif
}

// gltfpack quantizes CesiumMan's positions to 14 bits over the mesh's
// extent (1.51 m tall): a vertex moves by at most half a step, 1.51 / 2^15 =
// 4.6e-5 m per axis, so 8.0e-5 m in distance. Tolerance: one step per axis,
// 1.51 / 2^14 x sqrt(3) = 1.6e-4 m. The comparison is of the meshes: both
// files lose their skin (gltfpack also quantizes the skin weights and the
// animation, whose pose skin_test checks), so each is drawn in its bind pose.
TEST_CASE("EXT_meshopt_compression: CesiumMan packed by gltfpack gives the plain file's surface", "[gltf][meshopt]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
#if defined(PRISM_HAS_MESHOPT)
  auto unskinned = [](const std::string& in, const std::string& name) {
    std::string dir = std::string(PRISM_TEST_TMP_DIR) + "/meshopt";
    std::filesystem::create_directories(dir);
    gltf_json::edit_glb(in, dir + "/" + name, [](json& g) {
      for (auto& n : g["nodes"]) n.erase("skin");
    });
    return dir + "/" + name;
  };
  auto packed = load_gltf<RGB>(unskinned(packed_cesium_man, "packed_unskinned.glb"));
  auto plain = load_gltf<RGB>(unskinned(scenes_dir + "CesiumMan/glTF-Binary/CesiumMan.glb", "plain_unskinned.glb"));
  CHECK(plain.deformed_instances == 0);
  for (const auto& w : packed.warnings) CHECK(w.find("meshopt") == std::string::npos);
  CHECK(packed.scene_triangles == plain.scene_triangles);
  auto a = mesh_compare::world_triangles(packed), b = mesh_compare::world_triangles(plain);
  const double tol = 1.51 / 16384 * std::sqrt(3.0);
  double ab = mesh_compare::worst_distance(a, b), ba = mesh_compare::worst_distance(b, a);
  INFO("worst distance packed to plain " << ab << ", plain to packed " << ba << ", tolerance " << tol);
  CHECK(ab <= tol);
  CHECK(ba <= tol);
#else
  std::string e;
  try {
    load_gltf<RGB>(packed_cesium_man);
  } catch (const Error& err) {
    e = err.what();
  }
  CHECK(e.find("'EXT_meshopt_compression' is required") != std::string::npos);
#endif
}

}  // namespace meshopt_test
