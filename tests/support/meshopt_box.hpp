// tests/support/meshopt_box.hpp — the box of gltf_json::box_gltf with its
// bufferViews compressed by EXT_meshopt_compression, encoded here with
// meshoptimizer's encoders (the library prism::gltf decodes with, when it
// was found: PRISM_HAS_MESHOPT).
#pragma once
#if defined(PRISM_HAS_MESHOPT)
#include <cstdint>
#include <vector>
#include <meshoptimizer.h>
#include "support/gltf_json.hpp"

namespace gltf_json {

// Positions as ATTRIBUTES (stride 12; with `exp`, through the EXPONENTIAL
// filter at 24 bits, exact for the box's coordinates), normals as normalized
// bytes through the OCTAHEDRAL filter (stride 4), indices as TRIANGLES or,
// with `sequence`, INDICES (stride 2). Buffer 0 holds the compressed bytes
// (a data URI); buffer 1 is the fallback buffer, with no data.
inline json meshopt_box_gltf(bool sequence, bool exp) {
  BoxArrays box = box_arrays(1);
  size_t n = box.pos.size() / 3;
  json g = box_gltf(1, json{{"pbrMetallicRoughness", {{"baseColorFactor", {0.5, 0.5, 0.5, 1.0}}}}},
                    {"EXT_meshopt_compression"});
  g["extensionsRequired"] = {"EXT_meshopt_compression"};
  std::vector<unsigned char> data;
  // Appends encoded bytes (4-byte aligned) and returns their offset.
  auto put = [&](const std::vector<unsigned char>& bytes, size_t size) {
    size_t at = data.size();
    data.insert(data.end(), bytes.begin(), bytes.begin() + std::ptrdiff_t(size));
    while (data.size() % 4) data.push_back(0);
    return at;
  };
  auto view = [&](size_t at, size_t length, size_t stride, size_t count, const char* mode, const char* filter) {
    json e = {{"buffer", 0}, {"byteOffset", at}, {"byteLength", length}, {"byteStride", stride},
              {"count", count}, {"mode", mode}};
    if (filter) e["filter"] = filter;
    json v = {{"buffer", 1}, {"byteOffset", 0}, {"byteLength", count * stride},
              {"extensions", {{"EXT_meshopt_compression", e}}}};
    if (std::string(mode) == "ATTRIBUTES") v["byteStride"] = stride;
    return v;
  };
  json views = json::array();
  {  // positions
    std::vector<unsigned char> raw(n * 12);
    if (exp) meshopt_encodeFilterExp(raw.data(), n, 12, 24, box.pos.data());
    else std::memcpy(raw.data(), box.pos.data(), raw.size());
    std::vector<unsigned char> enc(meshopt_encodeVertexBufferBound(n, 12));
    size_t size = meshopt_encodeVertexBuffer(enc.data(), enc.size(), raw.data(), n, 12);
    views.push_back(view(put(enc, size), size, 12, n, "ATTRIBUTES", exp ? "EXPONENTIAL" : nullptr));
  }
  {  // normals: octahedral, 8 bits, as normalized signed bytes (w = 0)
    std::vector<float> xyzw;
    for (size_t i = 0; i < n; ++i) xyzw.insert(xyzw.end(), {box.nrm[3 * i], box.nrm[3 * i + 1], box.nrm[3 * i + 2], 0.0f});
    std::vector<unsigned char> raw(n * 4);
    meshopt_encodeFilterOct(raw.data(), n, 4, 8, xyzw.data());
    std::vector<unsigned char> enc(meshopt_encodeVertexBufferBound(n, 4));
    size_t size = meshopt_encodeVertexBuffer(enc.data(), enc.size(), raw.data(), n, 4);
    views.push_back(view(put(enc, size), size, 4, n, "ATTRIBUTES", "OCTAHEDRAL"));
  }
  {  // indices
    std::vector<unsigned> idx(box.idx.begin(), box.idx.end());
    std::vector<unsigned char> enc(sequence ? meshopt_encodeIndexSequenceBound(idx.size(), n)
                                            : meshopt_encodeIndexBufferBound(idx.size(), n));
    size_t size = sequence ? meshopt_encodeIndexSequence(enc.data(), enc.size(), idx.data(), idx.size())
                           : meshopt_encodeIndexBuffer(enc.data(), enc.size(), idx.data(), idx.size());
    views.push_back(view(put(enc, size), size, 2, idx.size(), sequence ? "INDICES" : "TRIANGLES", nullptr));
  }
  size_t decoded = 0;
  for (const auto& v : views) decoded += v["byteLength"].get<size_t>();
  g["buffers"] = json::array(
      {{{"byteLength", data.size()}, {"uri", "data:application/octet-stream;base64," + base64(data)}},
       {{"byteLength", decoded}, {"extensions", {{"EXT_meshopt_compression", {{"fallback", true}}}}}}});
  g["bufferViews"] = views;
  // The normals are normalized signed bytes now.
  g["accessors"][1]["componentType"] = 5120;
  g["accessors"][1]["normalized"] = true;
  return g;
}

}  // namespace gltf_json
#endif
