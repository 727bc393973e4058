// prism/io/gltf/meshes.hpp — glTF mesh primitives as prism TriangleMeshes:
// POSITION, indices (strips and fans converted to triangles), NORMAL,
// TEXCOORD_0/1, TANGENT and COLOR_0, each read through accessors.hpp and
// checked; and the triangle counts the loader reports.
#pragma once
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>
#include <tiny_gltf.h>
#include "prism/geometry/triangle.hpp"
#include "prism/io/gltf/accessors.hpp"
#include "prism/io/gltf/container.hpp"

namespace prism::gltf_detail {

// The triangles of a primitive, from its counts (unchecked: 0 where an index
// is out of range; points and lines have none).
inline size_t primitive_triangles(const tinygltf::Model& model, int m, int p) {
  const auto& prim = model.meshes[size_t(m)].primitives[size_t(p)];
  size_t n = 0;
  if (prim.indices >= 0) {
    if (size_t(prim.indices) < model.accessors.size()) n = model.accessors[size_t(prim.indices)].count;
  } else {
    auto it = prim.attributes.find("POSITION");
    if (it != prim.attributes.end() && it->second >= 0 && size_t(it->second) < model.accessors.size())
      n = model.accessors[size_t(it->second)].count;
  }
  switch (prim.mode) {
    case TINYGLTF_MODE_TRIANGLES: return n / 3;
    case TINYGLTF_MODE_TRIANGLE_STRIP:
    case TINYGLTF_MODE_TRIANGLE_FAN: return n >= 3 ? n - 2 : 0;
    default: return 0;
  }
}

// The triangles of each mesh of the file, summed over its primitives.
inline std::vector<size_t> mesh_triangle_counts(const tinygltf::Model& model) {
  std::vector<size_t> out;
  for (size_t m = 0; m < model.meshes.size(); ++m) {
    size_t tris = 0;
    for (size_t p = 0; p < model.meshes[m].primitives.size(); ++p) tris += primitive_triangles(model, int(m), int(p));
    out.push_back(tris);
  }
  return out;
}

// The prism mesh of a triangle primitive (TRIANGLES, TRIANGLE_STRIP or
// TRIANGLE_FAN; strips and fans become triangles), its attributes checked.
inline TriangleMesh build_primitive(const Document& doc, const tinygltf::Primitive& prim, const std::string& where) {
  TriangleMesh tm;
  auto it = prim.attributes.find("POSITION");
  if (it == prim.attributes.end()) doc.fail(where + ".attributes", "has no POSITION");
  std::string pw = where + ".attributes.POSITION";
  auto pos = read_accessor(doc, it->second, pw, 3);
  size_t nv = pos.size() / 3;
  tm.positions.resize(nv);
  for (size_t i = 0; i < nv; ++i) {
    double x = pos[3 * i], y = pos[3 * i + 1], z = pos[3 * i + 2];
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z) || std::abs(x) > 1e30 || std::abs(y) > 1e30 ||
        std::abs(z) > 1e30)
      doc.fail(pw, "element " + std::to_string(i) + " is not finite");
    tm.positions[i] = Point3f(Float(x), Float(y), Float(z));
  }
  // Indices (or the implicit 0..n-1), then strips and fans to triangles.
  std::vector<uint32_t> idxs;
  if (prim.indices != -1) {
    auto raw = read_accessor(doc, prim.indices, where + ".indices", 1,
                             {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                              TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT});
    idxs.resize(raw.size());
    for (size_t i = 0; i < raw.size(); ++i) {
      if (raw[i] >= double(nv))
        doc.fail(where + ".indices", "element " + std::to_string(i) + " = " + std::to_string(size_t(raw[i])) +
                                         " is past the vertex count " + std::to_string(nv));
      idxs[i] = uint32_t(raw[i]);
    }
  } else {
    idxs.resize(nv);
    for (size_t i = 0; i < nv; ++i) idxs[i] = uint32_t(i);
  }
  if (prim.mode == TINYGLTF_MODE_TRIANGLES) {
    idxs.resize(idxs.size() / 3 * 3);
    tm.indices = std::move(idxs);
  } else if (prim.mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
    for (size_t i = 2; i < idxs.size(); ++i) {
      // Every other triangle swaps two vertices to keep the winding.
      if (i % 2 == 0) tm.indices.insert(tm.indices.end(), {idxs[i - 2], idxs[i - 1], idxs[i]});
      else tm.indices.insert(tm.indices.end(), {idxs[i - 1], idxs[i - 2], idxs[i]});
    }
  } else {
    for (size_t i = 2; i < idxs.size(); ++i) tm.indices.insert(tm.indices.end(), {idxs[i - 1], idxs[i], idxs[0]});
  }
  // Degenerate triangles (repeated indices) would only cost time.
  auto optional_attr = [&](const char* name, int comps, auto&& store) {
    auto a = prim.attributes.find(name);
    if (a == prim.attributes.end()) return;
    std::string aw = where + ".attributes." + name;
    auto v = read_accessor(doc, a->second, aw, comps);
    if (v.size() / size_t(comps) != nv)
      doc.fail(aw, "has " + std::to_string(v.size() / size_t(comps)) + " elements, POSITION has " + std::to_string(nv));
    for (double d : v)
      if (!std::isfinite(d)) doc.fail(aw, "holds a non-finite value");
    store(v);
  };
  optional_attr("NORMAL", 3, [&](const std::vector<double>& v) {
    tm.normals.resize(nv);
    for (size_t i = 0; i < nv; ++i) tm.normals[i] = Normal3f(Float(v[3 * i]), Float(v[3 * i + 1]), Float(v[3 * i + 2]));
  });
  optional_attr("TEXCOORD_0", 2, [&](const std::vector<double>& v) {
    tm.uvs.resize(nv);
    for (size_t i = 0; i < nv; ++i) tm.uvs[i] = Point2f{Float(v[2 * i]), Float(v[2 * i + 1])};
  });
  optional_attr("TEXCOORD_1", 2, [&](const std::vector<double>& v) {
    tm.uvs1.resize(nv);
    for (size_t i = 0; i < nv; ++i) tm.uvs1[i] = Point2f{Float(v[2 * i]), Float(v[2 * i + 1])};
  });
  optional_attr("TANGENT", 4, [&](const std::vector<double>& v) {
    tm.tangents.resize(nv);
    for (size_t i = 0; i < nv; ++i)
      tm.tangents[i] = {Float(v[4 * i]), Float(v[4 * i + 1]), Float(v[4 * i + 2]), v[4 * i + 3] < 0 ? Float(-1) : Float(1)};
  });
  auto color = prim.attributes.find("COLOR_0");
  if (color != prim.attributes.end()) {
    int a = color->second;
    doc.check_index(a, doc.model.accessors.size(), where + ".attributes.COLOR_0", "accessor");
    int comps = doc.model.accessors[size_t(a)].type == TINYGLTF_TYPE_VEC4 ? 4 : 3;
    optional_attr("COLOR_0", comps, [&](const std::vector<double>& v) {
      tm.colors.resize(nv);
      for (size_t i = 0; i < nv; ++i)
        tm.colors[i] = {Float(v[size_t(comps) * i]), Float(v[size_t(comps) * i + 1]), Float(v[size_t(comps) * i + 2]),
                        comps == 4 ? Float(v[size_t(comps) * i + 3]) : Float(1)};
    });
  }
  return tm;
}

}  // namespace prism::gltf_detail
