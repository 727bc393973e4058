// Bad glTF input (issue "glTF, part 4: bad input"). A corpus generated here at
// run time, with fixed seeds, from the small shared models: (a) one targeted
// edit per kind of error (out-of-range indices, ranges past the end of a
// buffer, node cycles, NaN and Inf positions, missing files, unsupported
// images, empty meshes, a bad GLB header), each of which must throw a
// prism::Error naming the file, the element and what is wrong; (b) 100
// truncations each of Box.glb and of the data-URI Box.gltf, and random byte
// flips of Box.glb and BoxTextured.glb, which must load cleanly or throw a
// prism::Error (never crash, hang or throw anything else); (c) the inputs the
// libFuzzer target (fuzz/gltf_fuzz.cpp, scripts/fuzz.sh) found. Run under
// ASan + UBSan by scripts/sanitize.sh. Skipped when ../shared is absent.
#include <catch2/catch.hpp>
#include "support/skip.hpp"
#include "support/gltf_deform.hpp"
#include "support/gltf_json.hpp"
#include "support/meshopt_box.hpp"
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <fstream>
#include <limits>
#include <mutex>
#include <nlohmann/json.hpp>
#include <prism/io/gltf.hpp>
#include <random>
#include <thread>

namespace bad_input_test {

using namespace prism;
using Catch::Matchers::Contains;
using nlohmann::json;


namespace {

namespace fs = std::filesystem;
const std::string shared_scenes = std::string(PRISM_SHARED_DIR) + "/scenes/";
bool have_scenes() { return fs::exists(shared_scenes + "Box/glTF-Binary/Box.glb"); }

std::string read_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}
void write_bytes(const std::string& path, const std::string& bytes) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(bytes.data(), std::streamsize(bytes.size()));
  REQUIRE(f.good());
}
std::string case_dir(const std::string& name) {
  std::string d = std::string(PRISM_TEST_TMP_DIR) + "/gltf_bad/" + name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

// A hung load would stall ctest until its timeout: fail fast and say which.
class Watchdog {
 public:
  Watchdog(std::string what, int seconds) : m_what(std::move(what)) {
    m_thread = std::thread([this, seconds] {
      std::unique_lock<std::mutex> lock(m_mutex);
      if (!m_cv.wait_for(lock, std::chrono::seconds(seconds), [this] { return m_done; })) {
        std::fprintf(stderr, "HANG: %s took more than %d s\n", m_what.c_str(), seconds);
        std::fflush(stderr);
        std::_Exit(3);
      }
    });
  }
  ~Watchdog() {
    {
      std::lock_guard<std::mutex> lock(m_mutex);
      m_done = true;
    }
    m_cv.notify_one();
    m_thread.join();
  }

 private:
  std::string m_what;
  std::mutex m_mutex;
  std::condition_variable m_cv;
  bool m_done = false;
  std::thread m_thread;
};

// Each verdict is also appended, as "path<TAB>loaded|rejected", to
// gltf_bad/prism_verdicts.tsv in the test's temporary folder, so that
// scripts/validate_gltf.sh can compare the corpus left there with the
// Khronos glTF-Validator's opinion (the last line for a path counts).
void record_verdict(const std::string& path, bool loaded) {
  std::ofstream f(std::string(PRISM_TEST_TMP_DIR) + "/gltf_bad/prism_verdicts.tsv", std::ios::app);
  f << path << '\t' << (loaded ? "loaded" : "rejected") << '\n';
}

// Loads and builds `path`. Returns "" when it loads, else the prism::Error's
// message (which must name the file). Any other exception escapes to Catch,
// which fails the test with it.
std::string load_message(const std::string& path) {
  Watchdog dog(path, 60);
  try {
    auto loaded = load_gltf<RGB>(path);
    loaded.scene.build();
  } catch (const Error& e) {
    record_verdict(path, false);
    std::string msg = e.what();
    INFO(msg);
    CHECK_THAT(msg, Contains(path));
    return msg.empty() ? std::string("(empty message)") : msg;
  }
  record_verdict(path, true);
  return {};
}

// `path` must throw a prism::Error naming the file and each of `parts` (the
// element and what is wrong).
void require_error(const std::string& path, std::initializer_list<const char*> parts) {
  INFO("file " << path);
  std::string msg = load_message(path);
  INFO("message: " << msg);
  REQUIRE_FALSE(msg.empty());
  for (const char* p : parts) CHECK_THAT(msg, Contains(p));
}

// A copy of a shared model's folder (its .gltf, .bin and images) in its own
// temporary folder, with the JSON parsed for editing.
struct Edit {
  std::string dir, name;
  json gltf;
  // Writes the edited JSON beside the copied resources; returns its path.
  std::string write(const std::string& file_name = "edited.gltf") const {
    std::string path = dir + "/" + file_name;
    write_bytes(path, gltf.dump(1));
    return path;
  }
};
Edit edit(const std::string& case_name, const std::string& model_dir, const std::string& gltf_file) {
  Edit e;
  e.dir = case_dir(case_name);
  for (const auto& f : fs::directory_iterator(shared_scenes + model_dir))
    if (f.is_regular_file()) fs::copy_file(f.path(), e.dir + "/" + f.path().filename().string());
  e.gltf = json::parse(read_bytes(shared_scenes + model_dir + "/" + gltf_file));
  return e;
}
Edit box(const std::string& case_name) { return edit(case_name, "Box/glTF", "Box.gltf"); }
Edit box_textured(const std::string& case_name) { return edit(case_name, "BoxTextured/glTF", "BoxTextured.gltf"); }

// The unedited copies load: the errors below come from the edits.
TEST_CASE("bad input: the unedited copies of the small models load", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  CHECK(load_message(box("unedited_box").write()).empty());
  CHECK(load_message(box_textured("unedited_box_textured").write()).empty());
  CHECK(load_message(edit("unedited_cameras", "Cameras/glTF", "Cameras.gltf").write()).empty());
  CHECK(load_message(edit("unedited_instancing", "SimpleInstancing/glTF", "SimpleInstancing.gltf").write()).empty());
  CHECK(load_message(edit("unedited_animated", "AnimatedCube/glTF", "AnimatedCube.gltf").write()).empty());
}

TEST_CASE("bad input: out-of-range accessor indices", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto e = box("accessor_index");
  e.gltf["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 3;
  require_error(e.write("position.gltf"), {"meshes[0].primitives[0].attributes.POSITION", "accessor index 3 out of range"});
  e.gltf = json::parse(read_bytes(shared_scenes + "Box/glTF/Box.gltf"));
  e.gltf["meshes"][0]["primitives"][0]["indices"] = 99;
  require_error(e.write("indices.gltf"), {"meshes[0].primitives[0].indices", "accessor index 99 out of range"});
  // The instancing extension's accessors.
  auto s = edit("accessor_index_instancing", "SimpleInstancing/glTF", "SimpleInstancing.gltf");
  s.gltf["nodes"][0]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"]["ROTATION"] = 6;
  require_error(s.write(), {"nodes[0].extensions.EXT_mesh_gpu_instancing.attributes.ROTATION", "accessor index 6"});
  // An animation sampler's.
  auto a = edit("accessor_index_animation", "AnimatedCube/glTF", "AnimatedCube.gltf");
  a.gltf["animations"][0]["samplers"][0]["output"] = 40;
  require_error(a.write(), {"animations[0].samplers[0].output", "accessor index 40"});
}

TEST_CASE("bad input: out-of-range bufferView indices", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto e = box("bufferview_index");
  e.gltf["accessors"][2]["bufferView"] = 2;
  require_error(e.write(), {"accessors[2]", "bufferView index 2 out of range"});
  // An image's bufferView.
  auto t = box_textured("bufferview_index_image");
  t.gltf["images"][0] = {{"bufferView", 7}, {"mimeType", "image/png"}};
  require_error(t.write(), {"images[0]", "bufferView"});
}

TEST_CASE("bad input: out-of-range buffer indices", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto e = box("buffer_index");
  e.gltf["bufferViews"][0]["buffer"] = 1;
  require_error(e.write(), {"bufferViews[0]", "buffer"});
}

TEST_CASE("bad input: out-of-range image indices", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto e = box_textured("image_index");
  e.gltf["textures"][0]["source"] = 1;
  require_error(e.write(), {"textures[0].source", "image index 1 out of range"});
}

TEST_CASE("bad input: out-of-range texture indices", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto e = box_textured("texture_index");
  e.gltf["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["index"] = 5;
  require_error(e.write(), {"materials[0].pbrMetallicRoughness.baseColorTexture", "texture index 5 out of range"});
  e.gltf = json::parse(read_bytes(shared_scenes + "BoxTextured/glTF/BoxTextured.gltf"));
  e.gltf["materials"][0]["emissiveFactor"] = {1, 1, 1};
  e.gltf["materials"][0]["emissiveTexture"] = {{"index", -2}};
  require_error(e.write("emissive.gltf"), {"materials[0]", "texture"});
}

TEST_CASE("bad input: out-of-range material indices", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto e = box("material_index");
  e.gltf["meshes"][0]["primitives"][0]["material"] = 1;
  require_error(e.write(), {"meshes[0].primitives[0].material", "material index 1 out of range"});
}

TEST_CASE("bad input: out-of-range node indices", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto e = box("node_index");
  e.gltf["nodes"][0]["children"] = {1, 2};
  require_error(e.write("child.gltf"), {"nodes[0].children[1]", "node index 2 out of range"});
  e.gltf = json::parse(read_bytes(shared_scenes + "Box/glTF/Box.gltf"));
  e.gltf["scenes"][0]["nodes"] = {0, -1};
  require_error(e.write("scene.gltf"), {"scenes[0].nodes[1]", "node index -1 out of range"});
  e.gltf = json::parse(read_bytes(shared_scenes + "Box/glTF/Box.gltf"));
  e.gltf["nodes"][1]["mesh"] = 1;
  require_error(e.write("mesh.gltf"), {"nodes[1].mesh", "mesh index 1 out of range"});
  auto a = edit("node_index_animation", "AnimatedCube/glTF", "AnimatedCube.gltf");
  a.gltf["animations"][0]["channels"][0]["target"]["node"] = 1;
  require_error(a.write(), {"animations[0].channels[0].target.node", "node index 1 out of range"});
}

// Found by the glTF-Validator cross-check (scripts/validate_gltf.sh): a
// byte flip that renamed "scenes" left "scene": 0 pointing at nothing.
TEST_CASE("bad input: a default scene index with no scenes", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto e = box("default_scene_index");
  e.gltf.erase("scenes");
  e.gltf["scene"] = 0;
  require_error(e.write(), {"scene", "index 0 out of range"});
}

TEST_CASE("bad input: out-of-range camera indices", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto e = edit("camera_index", "Cameras/glTF", "Cameras.gltf");
  e.gltf["nodes"][2]["camera"] = 2;
  require_error(e.write(), {"nodes[2].camera", "camera index 2 out of range"});
}

TEST_CASE("bad input: accessor and bufferView ranges past the end of their buffer", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto e = box("ranges");
  e.gltf["accessors"][2]["count"] = 25;  // 24 positions fit
  require_error(e.write("count.gltf"), {"attributes.POSITION (accessors[2])", "runs past the end of bufferViews[1]"});
  e.gltf["accessors"][2]["count"] = 24;
  e.gltf["accessors"][2]["byteOffset"] = 300;
  require_error(e.write("offset.gltf"), {"accessors[2]", "runs past the end of bufferViews[1]"});
  e.gltf["accessors"][2]["byteOffset"] = 288;
  e.gltf["bufferViews"][0]["byteLength"] = 80;  // 576 + 80 > 648
  require_error(e.write("view.gltf"), {"bufferViews[0]", "runs past the end of buffers[0] (648 bytes)"});
  // A count too large for any buffer must not allocate first.
  e.gltf = json::parse(read_bytes(shared_scenes + "Box/glTF/Box.gltf"));
  e.gltf["accessors"][2]["count"] = 2000000000;
  require_error(e.write("huge.gltf"), {"accessors[2]", "runs past the end"});
  e.gltf["accessors"][2].erase("bufferView");
  e.gltf["accessors"][2].erase("byteOffset");
  require_error(e.write("huge_zeros.gltf"), {"accessors[2]", "implausibly large"});
  // An image's bufferView past the end of its buffer.
  auto t = box_textured("ranges_image");
  size_t bin = fs::file_size(t.dir + "/BoxTextured0.bin");
  t.gltf["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", bin - 8}, {"byteLength", 4096}});
  t.gltf["images"][0] = {{"bufferView", t.gltf["bufferViews"].size() - 1}, {"mimeType", "image/png"}};
  require_error(t.write(), {"images[0]", "runs past the end of buffers[0]"});
}

TEST_CASE("bad input: node cycles", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto e = box("node_cycle");
  e.gltf["nodes"][1]["children"] = {0};
  require_error(e.write("two.gltf"), {"nodes[0]", "cycle"});
  e.gltf["nodes"][1]["children"] = {1};
  require_error(e.write("self.gltf"), {"nodes[1]", "cycle"});
}

TEST_CASE("bad input: NaN and Inf positions", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  // POSITION is accessors[2]: bufferViews[1] (offset 0, stride 12) + 288.
  auto e = box("nonfinite_positions");
  std::string bin = read_bytes(e.dir + "/Box0.bin");
  float values[] = {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                    -std::numeric_limits<float>::infinity()};
  for (int k = 0; k < 3; ++k) {
    std::string bad = bin;
    std::memcpy(&bad[288 + 12 * size_t(5 + k) + 4 * size_t(k)], &values[k], 4);
    std::string bin_name = "bad" + std::to_string(k) + ".bin";
    write_bytes(e.dir + "/" + bin_name, bad);
    e.gltf["buffers"][0]["uri"] = bin_name;
    require_error(e.write("bad" + std::to_string(k) + ".gltf"),
                  {"meshes[0].primitives[0].attributes.POSITION", ("element " + std::to_string(5 + k)).c_str(), "not finite"});
  }
  // Also through a sparse accessor, whose values substitute finite ones.
  std::string bad = bin + std::string(16, '\0');
  uint16_t index = 3;
  float nan = std::numeric_limits<float>::quiet_NaN();
  std::memcpy(&bad[648], &index, 2);
  std::memcpy(&bad[652], &nan, 4);
  write_bytes(e.dir + "/sparse.bin", bad);
  e.gltf["buffers"][0] = {{"uri", "sparse.bin"}, {"byteLength", 664}};
  e.gltf["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", 648}, {"byteLength", 2}});
  e.gltf["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", 652}, {"byteLength", 12}});
  e.gltf["accessors"][2]["sparse"] = {{"count", 1},
                                      {"indices", {{"bufferView", 2}, {"componentType", 5123}}},
                                      {"values", {{"bufferView", 3}}}};
  require_error(e.write("sparse.gltf"), {"attributes.POSITION", "element 3", "not finite"});
  // And a node's transform.
  e.gltf = json::parse(read_bytes(shared_scenes + "Box/glTF/Box.gltf"));
  e.gltf["nodes"][0]["matrix"] = {1e200, 0, 0, 0, 0, 1e200, 0, 0, 0, 0, 1e200, 0, 0, 0, 0, 1};
  e.gltf["nodes"][1]["scale"] = {1e200, 1e200, 1e200};  // finite, but their product is not
  require_error(e.write("transform.gltf"), {"nodes[1]", "not finite"});
}

// Errors found only when building (here a light whose power overflows float:
// a finite node scale of 1e20 makes each emitting triangle's area about 1e40)
// still name the file: load_gltf gives the scene its path (Scene::set_source).
// The fuzzer found this one (a light of power inf, the message without a path).
TEST_CASE("bad input: an emitting mesh whose power overflows", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto e = box("power_overflow");
  e.gltf["nodes"][1]["scale"] = {1e20, 1e20, 1e20};
  e.gltf["materials"][0]["emissiveFactor"] = {1, 1, 1};
  require_error(e.write(), {"light", "power inf"});
}

TEST_CASE("bad input: missing external files", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto e = box_textured("missing_files");
  e.gltf["buffers"][0]["uri"] = "no_such_buffer.bin";
  require_error(e.write("buffer.gltf"), {"buffers[0]", "no_such_buffer.bin"});
  e.gltf = json::parse(read_bytes(shared_scenes + "BoxTextured/glTF/BoxTextured.gltf"));
  e.gltf["images"][0]["uri"] = "no_such_image.png";
  require_error(e.write("image.gltf"), {"images[0]", "no_such_image.png"});
  // The glTF file itself.
  require_error(e.dir + "/no_such_file.gltf", {"no such file"});
}

TEST_CASE("bad input: unsupported image formats", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto e = box_textured("image_formats");
  struct Format {
    const char* file;
    std::string bytes;
  };
  // A 2x2 24-bit BMP, which stb_image would decode but glTF does not allow;
  // a GIF header; a WebP (RIFF) header; bytes that are no image at all; a
  // PNG signature on garbage.
  std::string bmp = std::string("BM") + std::string("\x46\0\0\0\0\0\0\0\x36\0\0\0\x28\0\0\0\2\0\0\0\2\0\0\0\1\0\x18\0", 28) +
                    std::string(40 - 16 + 16, '\0');
  Format formats[] = {{"image.bmp", bmp},
                      {"image.gif", std::string("GIF89a\2\0\2\0\0\0\0;", 14)},
                      {"image.webp", std::string("RIFF\x1a\0\0\0WEBPVP8L\x0d\0\0\0\x2f\0\0\0\0\0\0\0\0\0\0\0\0\0", 34)},
                      {"image.txt", "this is not an image"},
                      {"image.png", std::string("\x89PNG\r\n\x1a\n", 8) + "garbage garbage garbage"}};
  for (const auto& f : formats) {
    write_bytes(e.dir + "/" + f.file, f.bytes);
    e.gltf["images"][0]["uri"] = f.file;
    require_error(e.write(std::string(f.file) + ".gltf"), {"images[0]", f.file});
  }
}

TEST_CASE("bad input: empty meshes", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto e = box("empty_meshes");
  e.gltf["meshes"][0]["primitives"] = json::array();
  require_error(e.write("no_primitives.gltf"), {"meshes[0]", "primitives"});
  e.gltf = json::parse(read_bytes(shared_scenes + "Box/glTF/Box.gltf"));
  e.gltf["accessors"][0]["count"] = 0;
  require_error(e.write("no_indices.gltf"), {"meshes[0].primitives[0]", "count"});
  e.gltf["accessors"][0]["count"] = 2;  // not one triangle
  require_error(e.write("two_indices.gltf"), {"meshes[0].primitives[0]", "triangle"});
  e.gltf = json::parse(read_bytes(shared_scenes + "Box/glTF/Box.gltf"));
  e.gltf["meshes"][0]["primitives"][0].erase("attributes");
  require_error(e.write("no_attributes.gltf"), {"meshes[0].primitives[0].attributes", "missing"});
  e.gltf = json::parse(read_bytes(shared_scenes + "Box/glTF/Box.gltf"));
  e.gltf["meshes"][0]["primitives"][0]["attributes"].erase("POSITION");
  require_error(e.write("no_position.gltf"), {"meshes[0].primitives[0].attributes", "no POSITION"});
}

// Edits of Box.glb's 12-byte header and first chunk header.
TEST_CASE("bad input: wrong GLB magic, version and chunk lengths", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  const std::string glb = read_bytes(shared_scenes + "Box/glTF-Binary/Box.glb");
  REQUIRE(glb.size() == 1664);
  std::string dir = case_dir("glb_header");
  auto put32 = [](std::string s, size_t at, uint32_t v) {
    std::memcpy(&s[at], &v, 4);
    return s;
  };
  uint32_t json_len;
  std::memcpy(&json_len, &glb[12], 4);
  struct Case {
    const char* name;
    std::string bytes;
    std::initializer_list<const char*> parts;
  };
  const Case cases[] = {
      {"magic.glb", "glTX" + glb.substr(4), {"GLB header", "magic"}},
      {"version1.glb", put32(glb, 4, 1), {"GLB header", "version 1"}},
      {"version3.glb", put32(glb, 4, 3), {"GLB header", "version 3"}},
      {"length_long.glb", put32(glb, 8, 1668), {"GLB header", "length 1668", "1664"}},
      {"length_short.glb", put32(glb, 8, 1000), {"GLB header", "length 1000", "1664"}},
      {"json_chunk_long.glb", put32(glb, 12, 4000), {"GLB chunk 0", "length 4000"}},
      {"json_chunk_huge.glb", put32(glb, 12, 0xfffffff0u), {"GLB chunk 0", "length 4294967280"}},
      {"json_chunk_short.glb", put32(glb, 12, json_len - 8), {"GLB"}},
      {"json_chunk_zero.glb", put32(glb, 12, 0), {"GLB chunk 0", "length 0"}},
      {"json_chunk_type.glb", put32(glb, 16, 0x004E4942), {"GLB chunk 0", "type"}},
      {"bin_chunk_long.glb", put32(glb, 20 + json_len, 2000), {"GLB chunk 1", "length 2000"}},
      {"bin_chunk_type.glb", put32(glb, 24 + json_len, 0x4E4F534A), {"GLB chunk 1", "type"}},
      {"header_only.glb", glb.substr(0, 12), {"GLB"}},
      {"magic_only.glb", glb.substr(0, 4), {"GLB"}},
      {"empty.glb", "", {"GLB"}},
  };
  for (const auto& c : cases) {
    write_bytes(dir + "/" + c.name, c.bytes);
    require_error(dir + "/" + c.name, c.parts);
  }
  // The .gltf extension does not hide a bad GLB header.
  write_bytes(dir + "/version3.gltf", put32(glb, 4, 3));
  require_error(dir + "/version3.gltf", {"GLB header", "version 3"});
}

// ---- (c) inputs found by the fuzz target (fuzz/gltf_fuzz.cpp) ----

// A one-byte edit of TextureCoordinateTest.glb: the buffer's byteLength 7932
// -> 7931 leaves the PNG's bufferView [648, 7932) one byte past the end of the
// BIN buffer. tinygltf 2.7 does not check an image's bufferView range and hands
// the loader's image callback 7284 bytes from 7283 (heap-buffer-overflow under
// ASan in the fuzz target).
TEST_CASE("bad input: fuzzer-found image bufferView past the end of its buffer", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  std::string glb = read_bytes(shared_scenes + "TextureCoordinateTest/glTF-Binary/TextureCoordinateTest.glb");
  const std::string from = "\"buffers\":[{\"byteLength\":7932}]", to = "\"buffers\":[{\"byteLength\":7931}]";
  size_t at = glb.find(from);
  REQUIRE(at != std::string::npos);
  glb.replace(at, from.size(), to);
  std::string path = case_dir("fuzz_found") + "/image_view_past_buffer.glb";
  write_bytes(path, glb);
  require_error(path, {"images[0]", "bufferViews[19]", "runs past the end of buffers[0] (7931 bytes)"});
}

// ---- (b) truncations and byte flips: a clean load or a prism::Error ----

struct Tally {
  int loaded = 0, errors = 0;
};

// Writes `bytes` to dir/name and loads it.
Tally& count(Tally& t, const std::string& path, const std::string& bytes, bool must_fail) {
  write_bytes(path, bytes);
  INFO("input " << path << " (" << bytes.size() << " bytes)");
  std::string msg = load_message(path);
  if (msg.empty()) {
    ++t.loaded;
    CHECK_FALSE(must_fail);
  } else {
    ++t.errors;
  }
  return t;
}

// Cut points spread over the file (including 0) plus a few random ones.
std::vector<size_t> cut_points(size_t size, int n, uint32_t seed) {
  std::vector<size_t> cuts;
  std::mt19937 rng(seed);
  for (int i = 0; i < n - 10; ++i) cuts.push_back(size * size_t(i) / size_t(n - 10));
  std::uniform_int_distribution<size_t> any(1, size - 1);
  while (cuts.size() < size_t(n)) cuts.push_back(any(rng));
  return cuts;
}

TEST_CASE("bad input: Box.glb truncated at 100 cut points", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  const std::string glb = read_bytes(shared_scenes + "Box/glTF-Binary/Box.glb");
  std::string dir = case_dir("truncated_glb");
  Tally t;
  // A truncated GLB is always an error: its header's length no longer matches.
  for (size_t cut : cut_points(glb.size(), 100, 2024))
    count(t, dir + "/cut" + std::to_string(cut) + ".glb", glb.substr(0, cut), true);
  CHECK(t.errors == 100);
}

TEST_CASE("bad input: data-URI Box.gltf truncated at 100 cut points", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  const std::string text = read_bytes(shared_scenes + "Box/glTF-Embedded/Box.gltf");
  std::string dir = case_dir("truncated_embedded");
  size_t end = text.find_last_of('}');
  Tally t;
  // Cut before the final '}', the JSON is incomplete: always an error.
  for (size_t cut : cut_points(text.size(), 100, 2025))
    count(t, dir + "/cut" + std::to_string(cut) + ".gltf", text.substr(0, cut), cut <= end);
  CHECK(t.errors + t.loaded == 100);
  CHECK(t.errors >= 99);
}

// Flips 1 to 4 random bytes of `bytes` per mutant (a fixed seed per file).
void flip_bytes(const std::string& model, const char* name, int mutants, uint32_t seed) {
  const std::string bytes = read_bytes(shared_scenes + model);
  REQUIRE(bytes.size() > 0);
  std::string dir = case_dir(std::string("flipped_") + name);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<size_t> where(0, bytes.size() - 1);
  std::uniform_int_distribution<int> how_many(1, 4), bit(1, 255);
  Tally t;
  for (int m = 0; m < mutants; ++m) {
    std::string b = bytes;
    for (int k = how_many(rng); k > 0; --k) b[where(rng)] ^= char(bit(rng));
    count(t, dir + "/flip" + std::to_string(m) + ".glb", b, false);
  }
  CHECK(t.loaded + t.errors == mutants);
  WARN(name << ": " << mutants << " mutants, " << t.loaded << " loaded, " << t.errors << " rejected with prism::Error");
}

TEST_CASE("bad input: random byte flips of Box.glb", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  flip_bytes("Box/glTF-Binary/Box.glb", "box", 400, 7);
}

TEST_CASE("bad input: random byte flips of BoxTextured.glb", "[gltf][bad_input]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  flip_bytes("BoxTextured/glTF-Binary/BoxTextured.glb", "box_textured", 400, 11);
}

}  // namespace

}  // namespace bad_input_test

// Bad EXT_meshopt_compression input: each malformed case of the box that
// tests/support/meshopt_box.hpp encodes must be a prism::Error naming the
// file, the bufferView and what is wrong (never a crash: scripts/sanitize.sh
// runs this under ASan + UBSan).
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

// Bad skins and morph targets (io/gltf/deform.hpp): each malformed case of
// the files tests/support/gltf_deform.hpp writes must be a prism::Error
// naming the file, the element and what is wrong, under ASan + UBSan too.
namespace deform_input_test {

using namespace prism;
using nlohmann::json;

TEST_CASE("bad input: skins and morph targets are errors naming the element", "[gltf][bad_input][skin]") {
  struct Case {
    const char* what;
    json g;
    const char* expect;
  };
  auto strip = [](auto&& edit, float scale = 1) {
    json g = gltf_deform::two_bone_strip(scale);
    edit(g);
    return g;
  };
  auto morph = [](auto&& edit, std::vector<float> weights = {0, 0, 1, 0.5f}) {
    json g = gltf_deform::morph_triangle(true, {0.25, 0}, std::move(weights));
    edit(g);
    return g;
  };
  auto none = [](json&) {};
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<Case> cases = {
      {"a skin index out of range", strip([](json& g) { g["nodes"][0]["skin"] = 3; }),
       "nodes[0].skin: skin index 3 out of range"},
      {"a joint node out of range", strip([](json& g) { g["skins"][0]["joints"] = {1, 40}; }),
       "skins[0].joints[1]: node index 40 out of range"},
      {"a skin without joints", strip([](json& g) { g["skins"][0]["joints"] = json::array(); }),
       "skins[0].joints: is empty"},
      {"JOINTS_0 past the skin's joints", strip([](json& g) { g["skins"][0]["joints"] = {1}; }),
       "attributes.JOINTS_0: element 0 names joint 1, the skin has 1 joints"},
      {"weights that sum to 0.9", strip(none, 0.9f), "attributes.WEIGHTS_0: element 0: the weights sum to 0.9"},
      {"weights that sum to 0", strip(none, 0.0f), "the weights sum to 0"},
      {"a negative weight", strip(none, -1.0f), "attributes.WEIGHTS_0: element 0 has a negative or non-finite weight"},
      {"a NaN weight", strip(none, nan), "attributes.WEIGHTS_0: element 0 has a negative or non-finite weight"},
      {"a skinned primitive without JOINTS_0",
       strip([](json& g) { g["meshes"][0]["primitives"][0]["attributes"].erase("JOINTS_0"); }),
       "attributes: has WEIGHTS_0 without JOINTS_0"},
      {"a skinned primitive without joints or weights", strip([](json& g) {
         g["meshes"][0]["primitives"][0]["attributes"].erase("JOINTS_0");
         g["meshes"][0]["primitives"][0]["attributes"].erase("WEIGHTS_0");
       }),
       "has no JOINTS_0 and WEIGHTS_0, but its node has a skin"},
      {"fewer inverse bind matrices than joints",
       strip([](json& g) { g["accessors"][g["skins"][0]["inverseBindMatrices"].get<int>()]["count"] = 1; }),
       "skins[0].inverseBindMatrices: has 1 matrices for 2 joints"},
      {"WEIGHTS_0 of the wrong type", strip([](json& g) {
         g["meshes"][0]["primitives"][0]["attributes"]["WEIGHTS_0"] = g["meshes"][0]["primitives"][0]["attributes"]["POSITION"];
       }),
       "attributes.WEIGHTS_0 (accessors[0]): has 3 components per element, expected 4"},
      {"NaN animated morph weights", morph(none, {0, 0, nan, 0.5f}), "nodes[0].weights (animated): is not finite"},
      {"node weights of the wrong count", morph([](json& g) { g["nodes"][0]["weights"] = {1.0, 0.0, 0.0}; }),
       "nodes[0].weights: has 3 weights, the mesh's morph targets are 2"},
      {"mesh weights of the wrong count", morph([](json& g) { g["meshes"][0]["weights"] = {1.0}; }),
       "meshes[0].weights: has 1 weights, the mesh's morph targets are 2"},
      {"a target of the wrong length", morph([](json& g) { g["accessors"][2]["count"] = 2; }),
       "meshes[0].primitives[0].targets[0].POSITION: has 2 elements, POSITION has 3"},
      {"a target accessor out of range",
       morph([](json& g) { g["meshes"][0]["primitives"][0]["targets"][0]["POSITION"] = 50; }),
       "targets[0].POSITION: accessor index 50 out of range"},
      {"a weights channel whose output is too short", morph([](json& g) { g["accessors"][6]["count"] = 3; }),
       "animations[0].samplers[0]: input and output counts do not match"},
  };
  for (const Case& c : cases) {
    INFO(c.what);
    std::string path = gltf_json::write_temp_gltf("gltf_deform_input", "bad.gltf", c.g);
    std::string e = "(no error)";
    try {
      GltfOptions opt;
      opt.time = 0.5;
      load_gltf<RGB>(path, opt);
    } catch (const Error& err) {
      e = err.what();
    }
    INFO(e);
    CHECK(e.find(path + ": ") == 0);
    CHECK(e.find(c.expect) != std::string::npos);
  }
}

}  // namespace deform_input_test
