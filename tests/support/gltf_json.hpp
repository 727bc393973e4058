// tests/support/gltf_json.hpp — small glTF files written by tests: a box
// mesh with one material in a data URI, and a place to write them.
#pragma once
#include <array>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>
#include <vector>
#include <nlohmann/json.hpp>

namespace gltf_json {

using nlohmann::json;

inline std::string base64(const std::vector<unsigned char>& in) {
  static const char* t = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    unsigned v = unsigned(in[i]) << 16 | unsigned(in[i + 1]) << 8 | in[i + 2];
    for (int k = 3; k >= 0; --k) out += t[(v >> (6 * k)) & 63];
  }
  if (i + 1 == in.size()) {
    unsigned v = unsigned(in[i]) << 16;
    out += t[(v >> 18) & 63];
    out += t[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == in.size()) {
    unsigned v = unsigned(in[i]) << 16 | unsigned(in[i + 1]) << 8;
    out += t[(v >> 18) & 63];
    out += t[(v >> 12) & 63];
    out += t[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

// The box [-0.5, 0.5]^2 x [0, d]: 24 vertices with outward normals, 36
// indices, counter-clockwise seen from outside.
struct BoxArrays {
  std::vector<float> pos, nrm;
  std::vector<uint16_t> idx;
};
inline BoxArrays box_arrays(float d) {
  BoxArrays b;
  auto face = [&](std::array<float, 3> n, std::array<std::array<float, 3>, 4> v) {
    auto base = uint16_t(b.pos.size() / 3);
    for (auto& p : v) {
      b.pos.insert(b.pos.end(), p.begin(), p.end());
      b.nrm.insert(b.nrm.end(), n.begin(), n.end());
    }
    for (int k : {0, 1, 2, 0, 2, 3}) b.idx.push_back(uint16_t(base + k));
  };
  const float a = 0.5f;
  face({0, 0, 1}, {{{-a, -a, d}, {a, -a, d}, {a, a, d}, {-a, a, d}}});
  face({0, 0, -1}, {{{-a, -a, 0}, {-a, a, 0}, {a, a, 0}, {a, -a, 0}}});
  face({1, 0, 0}, {{{a, -a, 0}, {a, a, 0}, {a, a, d}, {a, -a, d}}});
  face({-1, 0, 0}, {{{-a, -a, 0}, {-a, -a, d}, {-a, a, d}, {-a, a, 0}}});
  face({0, 1, 0}, {{{-a, a, 0}, {-a, a, d}, {a, a, d}, {a, a, 0}}});
  face({0, -1, 0}, {{{-a, -a, 0}, {a, -a, 0}, {a, -a, d}, {-a, -a, d}}});
  return b;
}

// A glTF with one box [-0.5, 0.5]^2 x [0, d] (box_arrays: positions, normals
// and uint16 indices, in a data URI) and one material given as JSON.
inline json box_gltf(float d, const json& material, const std::vector<std::string>& extensions) {
  BoxArrays box = box_arrays(d);
  const auto& pos = box.pos;
  const auto& nrm = box.nrm;
  const auto& idx = box.idx;
  const float a = 0.5f;
  std::vector<unsigned char> bytes(pos.size() * 4 + nrm.size() * 4 + idx.size() * 2);
  std::memcpy(bytes.data(), pos.data(), pos.size() * 4);
  std::memcpy(bytes.data() + pos.size() * 4, nrm.data(), nrm.size() * 4);
  std::memcpy(bytes.data() + pos.size() * 8, idx.data(), idx.size() * 2);
  size_t n = pos.size() / 3;
  json g;
  g["asset"] = {{"version", "2.0"}};
  g["extensionsUsed"] = extensions;
  g["scene"] = 0;
  g["scenes"] = json::array({{{"nodes", {0}}}});
  g["nodes"] = json::array({{{"mesh", 0}}});
  g["meshes"] = json::array(
      {{{"primitives", json::array({{{"attributes", {{"POSITION", 0}, {"NORMAL", 1}}}, {"indices", 2}, {"material", 0}}})}}});
  g["materials"] = json::array({material});
  g["buffers"] = json::array(
      {{{"byteLength", bytes.size()}, {"uri", "data:application/octet-stream;base64," + base64(bytes)}}});
  g["bufferViews"] = json::array({{{"buffer", 0}, {"byteOffset", 0}, {"byteLength", n * 12}},
                                  {{"buffer", 0}, {"byteOffset", n * 12}, {"byteLength", n * 12}},
                                  {{"buffer", 0}, {"byteOffset", n * 24}, {"byteLength", idx.size() * 2}}});
  g["accessors"] = json::array({{{"bufferView", 0},
                                 {"componentType", 5126},
                                 {"count", n},
                                 {"type", "VEC3"},
                                 {"min", {-a, -a, 0}},
                                 {"max", {a, a, d}}},
                                {{"bufferView", 1}, {"componentType", 5126}, {"count", n}, {"type", "VEC3"}},
                                {{"bufferView", 2}, {"componentType", 5123}, {"count", idx.size()}, {"type", "SCALAR"}}});
  return g;
}

// A copy of the GLB file `in` at `out` with its JSON chunk edited by `edit`
// (the binary chunk kept; the JSON padded with spaces to 4 bytes, as the
// GLB layout asks). Throws std::runtime_error on a file that is not GLB.
template <class Edit>
void edit_glb(const std::string& in, const std::string& out, Edit&& edit) {
  std::ifstream f(in, std::ios::binary);
  std::string bytes{std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
  auto u32 = [&](size_t at) {
    uint32_t v = 0;
    if (at + 4 > bytes.size()) throw std::runtime_error(in + ": truncated GLB");
    std::memcpy(&v, bytes.data() + at, 4);
    return v;
  };
  if (bytes.size() < 20 || u32(0) != 0x46546C67u || u32(16) != 0x4E4F534Au) throw std::runtime_error(in + ": not GLB");
  size_t json_len = u32(12);
  json g = json::parse(bytes.substr(20, json_len));
  edit(g);
  std::string text = g.dump();
  while (text.size() % 4) text += ' ';
  std::string rest = bytes.substr(20 + json_len);
  std::string head(20, '\0');
  auto put = [&](size_t at, uint32_t v) { std::memcpy(head.data() + at, &v, 4); };
  put(0, 0x46546C67u);
  put(4, 2);
  put(8, uint32_t(20 + text.size() + rest.size()));
  put(12, uint32_t(text.size()));
  put(16, 0x4E4F534Au);
  std::ofstream(out, std::ios::binary) << head << text << rest;
}

// Writes g as PRISM_TEST_TMP_DIR/<dir>/<name> and returns the path.
inline std::string write_temp_gltf(const std::string& dir_name, const std::string& name, const json& g) {
  std::string dir = std::string(PRISM_TEST_TMP_DIR) + "/" + dir_name;
  std::filesystem::create_directories(dir);
  std::string path = dir + "/" + name;
  std::ofstream(path) << g.dump();
  return path;
}

}  // namespace gltf_json
