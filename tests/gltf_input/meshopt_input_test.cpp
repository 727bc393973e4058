// Bad EXT_meshopt_compression input: each malformed case of the box that
// tests/support/meshopt_box.hpp encodes must be a prism::Error naming the
// file, the bufferView and what is wrong (never a crash: scripts/sanitize.sh
// runs this under ASan + UBSan).
#include <catch2/catch.hpp>
#include "support/gltf_json.hpp"
#include "support/meshopt_box.hpp"
#include <functional>
#include <string>
#include <nlohmann/json.hpp>
#include <prism/io/gltf.hpp>

namespace meshopt_input_test {

using namespace prism;
using nlohmann::json;

TEST_CASE("EXT_meshopt_compression: bad compressed bufferViews are errors naming the bufferView", "[gltf][meshopt]") {
#if defined(PRISM_HAS_MESHOPT)
  struct Case {
    const char* what;
    std::function<void(json&)> edit;
    const char* expect;
  };
  auto ext = [](json& g, int v) -> json& { return g["bufferViews"][size_t(v)]["extensions"]["EXT_meshopt_compression"]; };
  const std::vector<Case> cases = {
      {"truncated vertex data", [&](json& g) { ext(g, 0)["byteLength"] = 8; },
       "bufferViews[0].extensions.EXT_meshopt_compression: the compressed data does not decode"},
      {"truncated index data", [&](json& g) { ext(g, 2)["byteLength"] = 4; },
       "bufferViews[2].extensions.EXT_meshopt_compression: the compressed data does not decode"},
      {"unknown mode", [&](json& g) { ext(g, 0)["mode"] = "STRIPS"; },
       "bufferViews[0].extensions.EXT_meshopt_compression.mode: 'STRIPS' is not"},
      {"attribute stride not a multiple of 4", [&](json& g) { ext(g, 0)["byteStride"] = 6; },
       "bufferViews[0].extensions.EXT_meshopt_compression.byteStride: 6"},
      {"index stride 3", [&](json& g) { ext(g, 2)["byteStride"] = 3; },
       "bufferViews[2].extensions.EXT_meshopt_compression.byteStride: 3"},
      {"triangles not a multiple of 3", [&](json& g) { ext(g, 2)["count"] = 35; },
       "bufferViews[2].extensions.EXT_meshopt_compression.count: 35 is not a multiple of 3"},
      {"buffer out of range", [&](json& g) { ext(g, 1)["buffer"] = 7; },
       "bufferViews[1].extensions.EXT_meshopt_compression.buffer: buffer index 7 out of range"},
      {"compressed bytes past the buffer", [&](json& g) { ext(g, 1)["byteOffset"] = 1 << 20; },
       "bufferViews[1].extensions.EXT_meshopt_compression: bytes 1048576"},
      {"zero count", [&](json& g) { ext(g, 0)["count"] = 0; },
       "bufferViews[0].extensions.EXT_meshopt_compression.count: 0 is out of range"},
      {"negative count", [&](json& g) { ext(g, 0)["count"] = -3; },
       "bufferViews[0].extensions.EXT_meshopt_compression.count: is not a valid integer"},
      {"a quaternion filter on 12-byte elements", [&](json& g) { ext(g, 0)["filter"] = "QUATERNION"; },
       "bufferViews[0].extensions.EXT_meshopt_compression.filter: QUATERNION needs byteStride 8"},
      {"a filter on indices", [&](json& g) { ext(g, 2)["filter"] = "OCTAHEDRAL"; },
       "bufferViews[2].extensions.EXT_meshopt_compression.filter: 'OCTAHEDRAL' applies only to mode ATTRIBUTES"},
      {"the view's length not count x stride", [&](json& g) { g["bufferViews"][0]["byteLength"] = 100; },
       "bufferViews[0].byteLength: 100 is not count x byteStride = 288"},
      {"a plain view into the fallback buffer", [&](json& g) { g["bufferViews"][0].erase("extensions"); },
       "bufferViews[0]: refers to an EXT_meshopt_compression fallback buffer"},
      {"a missing mode", [&](json& g) { ext(g, 0).erase("mode"); },
       "bufferViews[0].extensions.EXT_meshopt_compression.mode: missing"},
  };
  for (const Case& c : cases) {
    INFO(c.what);
    json g = gltf_json::meshopt_box_gltf(false, false);
    c.edit(g);
    std::string path = gltf_json::write_temp_gltf("gltf_meshopt_input", "bad.gltf", g);
    std::string e = "(no error)";
    try {
      load_gltf<RGB>(path);
    } catch (const Error& err) {
      e = err.what();
    }
    INFO(e);
    CHECK(e.find(path + ": ") == 0);
    CHECK(e.find(c.expect) != std::string::npos);
  }
#else
  SUCCEED("prism::gltf was built without meshoptimizer: EXT_meshopt_compression is refused by name");
#endif
}

}  // namespace meshopt_input_test
