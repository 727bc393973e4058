// prism/io/gltf/meshes.hpp — glTF mesh primitives as prism TriangleMeshes:
// POSITION, indices (strips and fans converted to triangles), NORMAL,
// TEXCOORD_0/1, TANGENT and COLOR_0, each read through accessors.hpp and
// checked, or decoded from KHR_draco_mesh_compression through Debian's
// libdraco when prism::gltf found it (PRISM_HAS_DRACO); and the triangle
// counts the loader reports.
#pragma once
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>
#include <tiny_gltf.h>
#if defined(PRISM_HAS_DRACO)
#include <draco/compression/decode.h>
#endif
#include "prism/geometry/triangle.hpp"
#include "prism/io/gltf/accessors.hpp"
#include "prism/io/gltf/container.hpp"
#include "prism/io/gltf/deform.hpp"

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

// A KHR_draco_mesh_compression primitive, decoded: its vertex count, its
// triangles, and the attributes the extension maps, by glTF name (values
// as doubles, integers normalised where the encoder marked them so).
struct DecodedPrimitive {
  size_t vertices = 0;
  std::vector<uint32_t> indices;
  std::map<std::string, std::pair<int, std::vector<double>>> attributes;  // components, values
};

#if defined(PRISM_HAS_DRACO)
inline std::optional<DecodedPrimitive> decode_draco(const Document& doc, const tinygltf::Primitive& prim,
                                                    const std::string& where) {
  const auto* e = ext(prim.extensions, "KHR_draco_mesh_compression");
  if (!e) return std::nullopt;
  const std::string ew = where + ".extensions.KHR_draco_mesh_compression";
  int bv = as_index(number(e, "bufferView", -1));
  doc.check_index(bv, doc.model.bufferViews.size(), ew + ".bufferView", "bufferView");
  const auto& view = doc.model.bufferViews[size_t(bv)];
  doc.check_index(view.buffer, doc.model.buffers.size(), idx("bufferViews", bv) + ".buffer", "buffer");
  const auto& bytes = doc.model.buffers[size_t(view.buffer)].data;
  if (view.byteOffset > bytes.size() || view.byteLength > bytes.size() - view.byteOffset)
    doc.fail(idx("bufferViews", bv), "byte range runs past the end of buffers[" + std::to_string(view.buffer) + "]");
  draco::DecoderBuffer in;
  in.Init(reinterpret_cast<const char*>(bytes.data() + view.byteOffset), view.byteLength);
  draco::Decoder decoder;
  auto decoded = decoder.DecodeMeshFromBuffer(&in);
  if (!decoded.ok() || !decoded.value())
    doc.fail(ew, "Draco cannot decode " + idx("bufferViews", bv) +
                     (decoded.ok() ? std::string() : ": " + decoded.status().error_msg_string()));
  std::unique_ptr<draco::Mesh> mesh = std::move(decoded).value();
  DecodedPrimitive out;
  out.vertices = mesh->num_points();
  out.indices.reserve(size_t(mesh->num_faces()) * 3);
  for (uint32_t f = 0; f < mesh->num_faces(); ++f) {
    const auto& face = mesh->face(draco::FaceIndex(f));
    for (int k = 0; k < 3; ++k) {
      uint32_t v = face[k].value();
      if (v >= out.vertices) doc.fail(ew, "Draco face " + std::to_string(f) + " indexes past its " +
                                              std::to_string(out.vertices) + " points");
      out.indices.push_back(v);
    }
  }
  if (!e->Has("attributes") || !e->Get("attributes").IsObject()) doc.fail(ew + ".attributes", "must be an object");
  const auto& attrs = e->Get("attributes");
  for (const auto& name : attrs.Keys()) {
    const auto& id_value = attrs.Get(name);
    int id = as_index(id_value.IsNumber() ? id_value.GetNumberAsDouble() : -1.0);
    const draco::PointAttribute* a = id >= 0 ? mesh->GetAttributeByUniqueId(uint32_t(id)) : nullptr;
    if (!a) doc.fail(ew + ".attributes." + name, "the Draco data has no attribute with this id");
    const int comps = a->num_components();
    std::vector<double> values(out.vertices * size_t(comps));
    for (uint32_t i = 0; i < out.vertices; ++i) {
      auto value = a->mapped_index(draco::PointIndex(i));
      if (value.value() >= a->size() || !a->ConvertValue<double>(value, int8_t(comps), &values[size_t(i) * size_t(comps)]))
        doc.fail(ew + ".attributes." + name, "the Draco value of point " + std::to_string(i) + " cannot be read");
    }
    out.attributes[name] = {comps, std::move(values)};
  }
  return out;
}
#endif

// The prism mesh of a triangle primitive (TRIANGLES, TRIANGLE_STRIP or
// TRIANGLE_FAN; strips and fans become triangles), its attributes checked;
// morphed and skinned by `deform` when given (deform.hpp).
inline TriangleMesh build_primitive(const Document& doc, const tinygltf::Primitive& prim, const std::string& where,
                                    const Deformation* deform = nullptr) {
  TriangleMesh tm;
  std::optional<DecodedPrimitive> draco;
#if defined(PRISM_HAS_DRACO)
  draco = decode_draco(doc, prim, where);
#endif
  // An attribute's values: from the Draco data where the extension maps it,
  // else from its accessor.
  auto read = [&](const std::string& name, int accessor, const std::string& aw, int comps) {
    if (draco) {
      auto found = draco->attributes.find(name);
      if (found != draco->attributes.end()) {
        if (found->second.first != comps)
          doc.fail(aw, "the Draco attribute has " + std::to_string(found->second.first) + " components, " +
                           std::to_string(comps) + " expected");
        return std::move(found->second.second);  // each attribute is read once
      }
    }
    return read_accessor(doc, accessor, aw, comps);
  };
  auto it = prim.attributes.find("POSITION");
  if (it == prim.attributes.end()) doc.fail(where + ".attributes", "has no POSITION");
  std::string pw = where + ".attributes.POSITION";
  auto pos = read("POSITION", it->second, pw, 3);
  size_t nv = pos.size() / 3;
  std::optional<PrimitiveDeformer> deformer;
  if (deform && deform->any()) {
    deformer.emplace(doc, prim, where, *deform, nv, read);
    deformer->positions(pos);
  }
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
  int mode = prim.mode;
  if (draco) {  // decoded as a triangle list (from TRIANGLES or TRIANGLE_STRIP)
    idxs = std::move(draco->indices);
    mode = TINYGLTF_MODE_TRIANGLES;
  } else if (prim.indices != -1) {
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
  if (mode == TINYGLTF_MODE_TRIANGLES) {
    idxs.resize(idxs.size() / 3 * 3);
    tm.indices = std::move(idxs);
  } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
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
    auto v = read(name, a->second, aw, comps);
    if (v.size() / size_t(comps) != nv)
      doc.fail(aw, "has " + std::to_string(v.size() / size_t(comps)) + " elements, POSITION has " + std::to_string(nv));
    for (double d : v)
      if (!std::isfinite(d)) doc.fail(aw, "holds a non-finite value");
    if (deformer && std::string(name) == "NORMAL") deformer->normals(v);
    if (deformer && std::string(name) == "TANGENT") deformer->tangents(v);
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
