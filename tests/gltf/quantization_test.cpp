// KHR_mesh_quantization: vertex attributes stored as 8- and 16-bit integers,
// normalized or not, with the node's transform (usually a scale and an
// offset) mapping them back into the model's space.
//
// The expected values are decoded here from the extension's README (its
// table of normalized integer types, after the glTF 2.0 specification's),
// not from prism's reader: a normalized signed integer c of b bits
// is max(c / (2^(b-1) - 1), -1), a normalized unsigned one c / (2^b - 1), and
// one that is not normalized is its value. Every component type the
// extension allows for POSITION (byte, unsigned byte, short, unsigned short,
// each normalized or not, and float) is written with its extreme codes, and
// so is every type allowed for TEXCOORD_0; NORMAL and TANGENT take the
// normalized signed types (and float) in turn. The shared quantized twin of
// AnimatedMorphCube must give its plain file's triangles within one
// quantization step.
#include <catch2/catch.hpp>
#include "support/gltf_json.hpp"
#include "support/mesh_compare.hpp"
#include "support/skip.hpp"
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <prism/io/gltf.hpp>
#include <prism/prism.hpp>

namespace quantization_test {

using namespace prism;
using nlohmann::json;

namespace {

const std::string scenes_dir = std::string(PRISM_SHARED_DIR) + "/scenes/";
bool have_scenes() { return std::filesystem::exists(scenes_dir + "README.md"); }

enum : int { i8 = 5120, u8 = 5121, i16 = 5122, u16 = 5123, f32 = 5126 };

struct Format {
  int type;
  bool normalized;
};

int bytes_of(int type) { return type == i8 || type == u8 ? 1 : type == f32 ? 4 : 2; }
bool is_signed(int type) { return type == i8 || type == i16; }
double lowest(int type) { return type == i8 ? -128 : type == i16 ? -32768 : 0; }
double highest(int type) { return type == i8 ? 127 : type == u8 ? 255 : type == i16 ? 32767 : 65535; }

// The specification's decoding of normalized integers (KHR_mesh_quantization README).
double decode(double c, Format f) {
  if (f.type == f32 || !f.normalized) return c;
  int bits = 8 * bytes_of(f.type);
  if (is_signed(f.type)) return std::max(c / (std::ldexp(1.0, bits - 1) - 1), -1.0);
  return c / (std::ldexp(1.0, bits) - 1);
}

// Appends the codes as `f.type`, each element padded to a multiple of four
// bytes (the stride glTF requires of vertex attributes); returns the stride.
size_t append(std::vector<unsigned char>& buf, const std::vector<std::vector<double>>& elems, Format f) {
  size_t elem = elems[0].size() * size_t(bytes_of(f.type));
  size_t stride = (elem + 3) / 4 * 4;
  for (const auto& e : elems) {
    size_t at = buf.size();
    buf.resize(at + stride, 0);
    for (size_t c = 0; c < e.size(); ++c) {
      unsigned char* p = buf.data() + at + c * size_t(bytes_of(f.type));
      switch (f.type) {
        case i8: { int8_t v = int8_t(e[c]); std::memcpy(p, &v, 1); break; }
        case u8: { uint8_t v = uint8_t(e[c]); std::memcpy(p, &v, 1); break; }
        case i16: { int16_t v = int16_t(e[c]); std::memcpy(p, &v, 2); break; }
        case u16: { uint16_t v = uint16_t(e[c]); std::memcpy(p, &v, 2); break; }
        default: { float v = float(e[c]); std::memcpy(p, &v, 4); break; }
      }
    }
  }
  return stride;
}

// Three vertices' codes for a 3- or 2-component attribute in format f: each
// component takes its type's lowest and highest code somewhere, and the
// decoded triangle is not degenerate.
std::vector<std::vector<double>> extreme_codes(Format f, int comps) {
  double lo = lowest(f.type), hi = highest(f.type);
  if (f.type == f32) lo = -1.5, hi = 2.25;
  double mid = is_signed(f.type) || f.type == f32 ? 0 : 7;
  if (comps == 2) return {{lo, hi}, {hi, mid}, {mid, lo}};
  return {{lo, mid, hi}, {hi, lo + 1, mid}, {mid, hi, lo}};
}

struct Case {
  Format position, texcoord, normal, tangent;
};

std::string name(Format f) {
  const char* t = f.type == i8 ? "byte" : f.type == u8 ? "unsigned byte" : f.type == i16 ? "short" :
                  f.type == u16 ? "unsigned short" : "float";
  return std::string(t) + (f.normalized && f.type != f32 ? " normalized" : "");
}

}  // namespace

TEST_CASE("KHR_mesh_quantization: every allowed component type decodes as the specification says", "[gltf][quantization]") {
  const std::vector<Format> integer_formats = {{i8, false}, {i8, true}, {u8, false}, {u8, true},  {i16, false},
                                               {i16, true}, {u16, false}, {u16, true}, {f32, false}};
  const std::vector<Format> direction_formats = {{i8, true}, {i16, true}, {f32, false}};
  const Vector3f scale{2, 3, 0.5f}, offset{1, -2, 0.25f};
  int checked = 0;
  for (size_t k = 0; k < integer_formats.size(); ++k) {
    Case c{integer_formats[k], integer_formats[(k + 4) % integer_formats.size()], direction_formats[k % 3],
           direction_formats[(k + 1) % 3]};
    INFO("POSITION " << name(c.position) << ", TEXCOORD_0 " << name(c.texcoord) << ", NORMAL " << name(c.normal)
                     << ", TANGENT " << name(c.tangent));
    auto pos = extreme_codes(c.position, 3);
    auto uv = extreme_codes(c.texcoord, 2);
    // Unit normals and tangents at right angles to them, as codes of the
    // normalized type (the highest code stands for 1, the lowest for -1).
    double one = c.normal.type == f32 ? 1 : highest(c.normal.type), neg = c.normal.type == f32 ? -1 : lowest(c.normal.type);
    double half = c.normal.type == f32 ? 0.5 : std::floor(one / 2);
    std::vector<std::vector<double>> nrm = {{0, 0, one}, {neg, 0, 0}, {half, -half, half}};
    double tone = c.tangent.type == f32 ? 1 : highest(c.tangent.type),
           tneg = c.tangent.type == f32 ? -1 : lowest(c.tangent.type);
    std::vector<std::vector<double>> tan = {{tone, 0, 0, tone}, {0, tone, 0, tneg}, {tone, tone, 0, tone}};

    std::vector<unsigned char> buf;
    json views = json::array(), accessors = json::array();
    auto add = [&](const std::vector<std::vector<double>>& elems, Format f, const char* type) {
      size_t at = buf.size();
      size_t stride = append(buf, elems, f);
      json view = {{"buffer", 0}, {"byteOffset", at}, {"byteLength", buf.size() - at}, {"byteStride", stride},
                   {"target", 34962}};
      views.push_back(view);
      json acc = {{"bufferView", views.size() - 1}, {"componentType", f.type}, {"count", elems.size()}, {"type", type}};
      if (f.normalized) acc["normalized"] = true;
      if (std::string(type) == "VEC3" && &elems == &pos) {
        std::vector<double> mn(3, 1e300), mx(3, -1e300);
        for (const auto& e : elems)
          for (size_t a = 0; a < 3; ++a) mn[a] = std::min(mn[a], e[a]), mx[a] = std::max(mx[a], e[a]);
        acc["min"] = mn;
        acc["max"] = mx;
      }
      accessors.push_back(acc);
      return int(accessors.size() - 1);
    };
    int a_pos = add(pos, c.position, "VEC3");
    int a_nrm = add(nrm, c.normal, "VEC3");
    int a_tan = add(tan, c.tangent, "VEC4");
    int a_uv = add(uv, c.texcoord, "VEC2");
    json g;
    g["asset"] = {{"version", "2.0"}};
    g["extensionsUsed"] = {"KHR_mesh_quantization"};
    g["extensionsRequired"] = {"KHR_mesh_quantization"};
    g["scene"] = 0;
    g["scenes"] = json::array({{{"nodes", {0}}}});
    g["nodes"] = json::array({{{"mesh", 0}, {"scale", {scale.x, scale.y, scale.z}},
                               {"translation", {offset.x, offset.y, offset.z}}}});
    g["meshes"] = json::array({{{"primitives", json::array({{{"attributes", {{"POSITION", a_pos}, {"NORMAL", a_nrm},
                                                                             {"TANGENT", a_tan}, {"TEXCOORD_0", a_uv}}}}})}}});
    g["buffers"] = json::array({{{"byteLength", buf.size()},
                                 {"uri", "data:application/octet-stream;base64," + gltf_json::base64(buf)}}});
    g["bufferViews"] = views;
    g["accessors"] = accessors;
    auto loaded = load_gltf<RGB>(gltf_json::write_temp_gltf("gltf_quantization", "case" + std::to_string(k) + ".gltf", g));
    for (const auto& w : loaded.warnings) CHECK(w.find("quantization") == std::string::npos);
    const auto& meshes = loaded.scene.accel().meshes();
    REQUIRE(meshes.size() == 1);
    const TriangleMesh& m = meshes[0];
    REQUIRE(m.positions.size() == 3);
    REQUIRE(m.normals.size() == 3);
    REQUIRE(m.tangents.size() == 3);
    REQUIRE(m.uvs.size() == 3);
    Bounds3f expected_bounds;
    for (size_t v = 0; v < 3; ++v) {
      INFO("vertex " << v);
      // Float rounding of the decoded value: a few ulps of the largest code.
      for (size_t a = 0; a < 3; ++a) {
        double want = decode(pos[v][a], c.position);
        CHECK(std::abs(m.positions[v][int(a)] - want) <= 1e-6 * std::max(1.0, std::abs(want)));
      }
      Point3f p{float(decode(pos[v][0], c.position)), float(decode(pos[v][1], c.position)),
                float(decode(pos[v][2], c.position))};
      expected_bounds = union_bounds(expected_bounds, Point3f{offset.x + scale.x * p.x, offset.y + scale.y * p.y,
                                                              offset.z + scale.z * p.z});
      for (size_t a = 0; a < 2; ++a) {
        double want = decode(uv[v][a], c.texcoord);
        CHECK(std::abs(m.uvs[v][int(a)] - want) <= 1e-6 * std::max(1.0, std::abs(want)));
      }
      // Directions: the decoded vector normalized (a normalized code of
      // 1/2 is 63/127, not 0.5, so the expected direction is computed from
      // the codes).
      double n[3], len = 0;
      for (size_t a = 0; a < 3; ++a) n[a] = decode(nrm[v][a], c.normal), len += n[a] * n[a];
      len = std::sqrt(len);
      double got_len = std::sqrt(double(m.normals[v].x) * m.normals[v].x + double(m.normals[v].y) * m.normals[v].y +
                                 double(m.normals[v].z) * m.normals[v].z);
      REQUIRE(got_len > 0);
      // 1e-6: float normalisation of the decoded code, a few ulps of unit components (2^-24 each)
      for (size_t a = 0; a < 3; ++a) CHECK(std::abs(m.normals[v][int(a)] / got_len - n[a] / len) <= 1e-6);
      for (size_t a = 0; a < 3; ++a) {
        // 1e-6: one float rounding of a decoded code in [-1, 1]
        double want = decode(tan[v][a], c.tangent);
        CHECK(std::abs(m.tangents[v][a] - want) <= 1e-6);
      }
      CHECK(m.tangents[v][3] == (decode(tan[v][3], c.tangent) < 0 ? -1.0f : 1.0f));
    }
    // The node's scale and offset place the decoded triangle.
    // 1e-5 relative: the node's float scale and offset and the bounds' transform, a few roundings each
    for (int a = 0; a < 3; ++a) {
      CHECK(std::abs(loaded.bounds.min[a] - expected_bounds.min[a]) <= 1e-5f * std::max(1.0f, std::abs(expected_bounds.min[a])));
      CHECK(std::abs(loaded.bounds.max[a] - expected_bounds.max[a]) <= 1e-5f * std::max(1.0f, std::abs(expected_bounds.max[a])));
    }
    ++checked;
  }
  CHECK(checked == 9);
}

using mesh_compare::Tri;
using mesh_compare::world_triangles;
using mesh_compare::worst_distance;
using mesh_compare::area;

// The quantized twin stores positions as unsigned shorts with a node scale
// of 3.649e-6 under a parent scale of 100 (and normals as normalized bytes):
// rounding to the nearest code moves a vertex by at most half a step,
// 0.5 x 3.649e-6 x 100 = 1.8e-4 world units per axis, so 3.2e-4 in
// distance. Tolerance: one step per axis, 3.65e-4 x sqrt(3) = 6.3e-4. The
// twin may split a face's quad along the other diagonal, so the check is
// on surfaces: every corner and centroid of each file lies on the other's
// surface, both ways, and the areas agree.
TEST_CASE("KHR_mesh_quantization: the quantized AnimatedMorphCube gives the plain file's triangles", "[gltf][quantization]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto twin = load_gltf<RGB>(scenes_dir + "AnimatedMorphCube/glTF-Quantized/AnimatedMorphCube.gltf");
  auto plain = load_gltf<RGB>(scenes_dir + "AnimatedMorphCube/glTF-Binary/AnimatedMorphCube.glb");
  for (const auto& w : twin.warnings) CHECK(w.find("quantization") == std::string::npos);
  REQUIRE(twin.scene_triangles == plain.scene_triangles);
  REQUIRE(twin.scene_triangles == 12);
  auto a = world_triangles(twin), b = world_triangles(plain);
  const double tol = 3.65e-4 * std::sqrt(3.0);
  double ab = worst_distance(a, b), ba = worst_distance(b, a);
  INFO("worst distance twin to plain " << ab << ", plain to twin " << ba << ", tolerance " << tol);
  CHECK(ab <= tol);
  CHECK(ba <= tol);
  double area_a = 0, area_b = 0;
  for (const Tri& t : a) area_a += area(t);
  for (const Tri& t : b) area_b += area(t);
  // A 2 x 2 x 2 cube (a control that both scales were applied): area 24,
  // and the twin's within a step of it on every edge (relative 2 x 3.65e-4 / 2).
  // 1e-4: the float areas of 12 triangles summed to 24 (ulp(24) = 1.9e-6, ~20 roundings)
  CHECK(std::abs(area_b - 24) <= 1e-4);
  CHECK(std::abs(area_a - area_b) <= 24 * 2 * 3.65e-4);
}

}  // namespace quantization_test
