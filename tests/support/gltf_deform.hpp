// tests/support/gltf_deform.hpp — small glTF files with skins and morph
// targets, written by tests (tests/gltf/skin_test.cpp, the bad-input tests):
// a two-bone strip and a triangle with two morph targets, their arrays in a
// data-URI buffer.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>
#include "support/gltf_json.hpp"

namespace gltf_deform {

using gltf_json::json;

// A glTF under construction whose arrays go into one data-URI buffer, one
// bufferView and accessor each.
struct Builder {
  json g;
  std::vector<unsigned char> bytes;
  Builder() {
    g["asset"] = {{"version", "2.0"}};
    g["accessors"] = json::array();
    g["bufferViews"] = json::array();
  }
  template <class T>
  int add(const std::vector<T>& v, int component_type, const char* type, bool normalized = false) {
    while (bytes.size() % 4) bytes.push_back(0);
    size_t offset = bytes.size();
    bytes.resize(offset + v.size() * sizeof(T));
    std::memcpy(bytes.data() + offset, v.data(), v.size() * sizeof(T));
    size_t comps = std::string(type) == "SCALAR" ? 1 : std::string(type) == "MAT4" ? 16 : size_t(type[3] - '0');
    g["bufferViews"].push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", v.size() * sizeof(T)}});
    json a = {{"bufferView", g["bufferViews"].size() - 1},
              {"componentType", component_type},
              {"count", v.size() / comps},
              {"type", type}};
    if (normalized) a["normalized"] = true;
    if (std::string(type) == "VEC3" && component_type == 5126) {  // POSITION needs min and max
      std::array<float, 3> lo{1e30f, 1e30f, 1e30f}, hi{-1e30f, -1e30f, -1e30f};
      for (size_t i = 0; i < v.size(); ++i) {
        lo[i % 3] = std::min(lo[i % 3], float(v[i]));
        hi[i % 3] = std::max(hi[i % 3], float(v[i]));
      }
      a["min"] = lo;
      a["max"] = hi;
    }
    g["accessors"].push_back(a);
    return int(g["accessors"].size()) - 1;
  }
  json finish() {
    g["buffers"] = json::array({{{"byteLength", bytes.size()},
                                 {"uri", "data:application/octet-stream;base64," + gltf_json::base64(bytes)}}});
    return g;
  }
};

// The strip: five vertices in the plane z = 0 and three triangles.
//   v0 (0, 0, 0)   joint 0 only
//   v1 (1.5, 0, 0) joints 0 and 1, half each, normal (1, 0, 0)
//   v2 (2, 0, 0)   joint 1 only, normal (1, 0, 0)
//   v3 (2, 1, 0)   joint 1 only
//   v4 (0, 1, 0)   joint 0 only
// Bone 0 sits at the origin, bone 1 at (1, 0, 0) as bone 0's child; bone 1
// turns about z from 0 (t = 0) to 90 degrees (t = 1), LINEAR (slerp). The
// inverse bind matrices are the bind poses' inverses: identity and a
// translation by (-1, 0, 0). The mesh node's own translation (100, 0, 0)
// must be ignored (glTF 2.0, 3.7.3.3: only the joints place a skinned mesh).
// `weights_scale` multiplies every weight (1: a valid file).
inline json two_bone_strip(float weights_scale = 1, bool float_weights = true) {
  Builder b;
  std::vector<float> pos{0, 0, 0, 1.5f, 0, 0, 2, 0, 0, 2, 1, 0, 0, 1, 0};
  std::vector<float> nrm{0, 0, 1, 1, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1};
  std::vector<uint16_t> idx{0, 1, 4, 1, 3, 4, 1, 2, 3};
  std::vector<uint8_t> joints{0, 1, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0};
  std::vector<float> w{1, 0, 0, 0, 0.5f, 0.5f, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
  for (float& x : w) x *= weights_scale;
  std::vector<float> ibm{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1,    // identity
                         1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, -1, 0, 0, 1};  // translate -x (column-major)
  const float s45 = float(std::sqrt(0.5));
  std::vector<float> times{0, 1}, rot{0, 0, 0, 1, 0, 0, s45, s45};
  int a_pos = b.add(pos, 5126, "VEC3"), a_nrm = b.add(nrm, 5126, "VEC3"), a_idx = b.add(idx, 5123, "SCALAR");
  int a_j = b.add(joints, 5121, "VEC4");
  int a_w;
  if (float_weights) {
    a_w = b.add(w, 5126, "VEC4");
  } else {  // normalized unsigned bytes: 1 is 255, a half is 127.5, stored as 128 and 127
    std::vector<uint8_t> wb(w.size());
    for (size_t i = 0; i < w.size(); ++i) wb[i] = uint8_t(std::lround(w[i] * 255));
    wb[5] = 127;  // v1's two halves sum to 255
    a_w = b.add(wb, 5121, "VEC4", true);
  }
  int a_ibm = b.add(ibm, 5126, "MAT4"), a_t = b.add(times, 5126, "SCALAR"), a_r = b.add(rot, 5126, "VEC4");
  b.g["scene"] = 0;
  b.g["scenes"] = json::array({{{"nodes", {0, 1}}}});
  b.g["nodes"] = json::array({{{"mesh", 0}, {"skin", 0}, {"translation", {100, 0, 0}}},
                              {{"children", {2}}},
                              {{"translation", {1, 0, 0}}}});
  b.g["skins"] = json::array({{{"joints", {1, 2}}, {"inverseBindMatrices", a_ibm}}});
  b.g["meshes"] = json::array({{{"primitives", json::array({{{"attributes",
                                                               {{"POSITION", a_pos},
                                                                {"NORMAL", a_nrm},
                                                                {"JOINTS_0", a_j},
                                                                {"WEIGHTS_0", a_w}}},
                                                              {"indices", a_idx}}})}}});
  b.g["animations"] = json::array(
      {{{"samplers", json::array({{{"input", a_t}, {"output", a_r}, {"interpolation", "LINEAR"}}})},
        {"channels", json::array({{{"sampler", 0}, {"target", {{"node", 2}, {"path", "rotation"}}}}})}}});
  return b.finish();
}

// A triangle with two morph targets: target 0 lifts every vertex by
// (0, 0, 1) and turns v0's normal towards +x by (1, 0, 0); target 1 moves
// v0 alone by (1, 0, 0). Default weights [0.25, 0]; `animate` adds a LINEAR
// weights channel from [0, 0] at t = 0 to [1, 0.5] at t = 1 (`weights`:
// the channel's output, two per key).
inline json morph_triangle(bool animate, std::vector<double> mesh_weights = {0.25, 0},
                           std::vector<float> weights = {0, 0, 1, 0.5f}) {
  Builder b;
  std::vector<float> pos{0, 0, 0, 1, 0, 0, 0, 1, 0}, nrm{0, 0, 1, 0, 0, 1, 0, 0, 1};
  std::vector<float> d0{0, 0, 1, 0, 0, 1, 0, 0, 1}, n0{1, 0, 0, 0, 0, 0, 0, 0, 0}, d1{1, 0, 0, 0, 0, 0, 0, 0, 0};
  std::vector<float> times{0, 1};
  int a_pos = b.add(pos, 5126, "VEC3"), a_nrm = b.add(nrm, 5126, "VEC3");
  int a_d0 = b.add(d0, 5126, "VEC3"), a_n0 = b.add(n0, 5126, "VEC3"), a_d1 = b.add(d1, 5126, "VEC3");
  int a_t = b.add(times, 5126, "SCALAR"), a_w = b.add(weights, 5126, "SCALAR");
  b.g["scene"] = 0;
  b.g["scenes"] = json::array({{{"nodes", {0}}}});
  b.g["nodes"] = json::array({{{"mesh", 0}}});
  json mesh = {{"primitives", json::array({{{"attributes", {{"POSITION", a_pos}, {"NORMAL", a_nrm}}},
                                            {"targets", json::array({{{"POSITION", a_d0}, {"NORMAL", a_n0}},
                                                                     {{"POSITION", a_d1}}})}}})}};
  if (!mesh_weights.empty()) mesh["weights"] = mesh_weights;
  b.g["meshes"] = json::array({mesh});
  if (animate)
    b.g["animations"] = json::array(
        {{{"samplers", json::array({{{"input", a_t}, {"output", a_w}, {"interpolation", "LINEAR"}}})},
          {"channels", json::array({{{"sampler", 0}, {"target", {{"node", 0}, {"path", "weights"}}}}})}}});
  return b.finish();
}

}  // namespace gltf_deform
