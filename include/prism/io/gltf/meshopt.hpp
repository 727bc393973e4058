// prism/io/gltf/meshopt.hpp — EXT_meshopt_compression: bufferViews whose
// bytes are stored compressed by meshoptimizer's codecs (vertex attributes,
// triangle indices, index sequences, with the octahedral, quaternion and
// exponential filters), decoded by Debian's libmeshoptimizer
// (libmeshoptimizer-dev) when prism::gltf found it (PRISM_HAS_MESHOPT).
//
// A compressed bufferView names its compressed bytes in the extension
// (buffer, byteOffset, byteLength) and their decoded layout (count elements
// of byteStride bytes); its own buffer is usually a "fallback" buffer with
// no data (the buffer's own EXT_meshopt_compression.fallback). The loader
// decodes each such bufferView once, after tinygltf has read the file and
// before any accessor is read, into a buffer of its own, and points the
// bufferView at it: the rest of the loader sees plain bufferViews.
#pragma once
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>
#include <tiny_gltf.h>
#include "prism/io/gltf/container.hpp"
#if defined(PRISM_HAS_MESHOPT)
#include <meshoptimizer.h>
#endif

namespace prism::gltf_detail {

// Whether a buffer is a fallback buffer of EXT_meshopt_compression (its data
// may be absent: only compressed bufferViews refer to it).
inline bool meshopt_fallback(const tinygltf::Buffer& b) {
  const tinygltf::Value* e = ext(b.extensions, "EXT_meshopt_compression");
  return e && e->Has("fallback") && e->Get("fallback").IsBool() && e->Get("fallback").Get<bool>();
}

// Decodes every compressed bufferView of doc.model in place (see above).
// Errors name the bufferView and what is wrong with it.
inline void decode_meshopt(Document& doc) {
  auto& model = doc.model;
  size_t views = model.bufferViews.size();
  for (size_t v = 0; v < views; ++v) {
    tinygltf::BufferView& bv = model.bufferViews[v];
    std::string where = idx("bufferViews", int(v));
    const tinygltf::Value* e = ext(bv.extensions, "EXT_meshopt_compression");
    if (!e) {
      // A fallback buffer holds no data prism can read.
      if (bv.buffer >= 0 && size_t(bv.buffer) < model.buffers.size() && meshopt_fallback(model.buffers[size_t(bv.buffer)]))
        doc.fail(where, "refers to an EXT_meshopt_compression fallback buffer, which holds no data, without being "
                        "compressed itself");
      continue;
    }
    std::string ew = where + ".extensions.EXT_meshopt_compression";
#if !defined(PRISM_HAS_MESHOPT)
    doc.fail(ew, "prism::gltf was built without meshoptimizer (Debian's libmeshoptimizer-dev), which decodes it");
#else
    auto integer = [&](const char* key, bool required, double fallback) {
      if (!e->Has(key)) {
        if (required) doc.fail(ew + "." + key, "missing");
        return fallback;
      }
      const auto& x = e->Get(key);
      double d = x.IsNumber() ? x.GetNumberAsDouble() : -1;
      if (!(d >= 0 && d <= 4294967295.0 && d == double(int64_t(d)))) doc.fail(ew + "." + key, "is not a valid integer");
      return d;
    };
    auto text = [&](const char* key, const char* fallback) {
      if (!e->Has(key)) return std::string(fallback);
      const auto& x = e->Get(key);
      if (!x.IsString()) doc.fail(ew + "." + key, "is not a string");
      return x.Get<std::string>();
    };
    int buffer = as_index(integer("buffer", true, 0));
    size_t offset = size_t(integer("byteOffset", false, 0));
    size_t length = size_t(integer("byteLength", true, 0));
    size_t stride = size_t(integer("byteStride", true, 0));
    size_t count = size_t(integer("count", true, 0));
    if (!e->Has("mode")) doc.fail(ew + ".mode", "missing");
    std::string mode = text("mode", "");
    std::string filter = text("filter", "NONE");
    doc.check_index(buffer, model.buffers.size(), ew + ".buffer", "buffer");
    const auto& src = model.buffers[size_t(buffer)].data;
    if (offset > src.size() || length > src.size() - offset)
      doc.fail(ew, "bytes " + std::to_string(offset) + " + " + std::to_string(length) + " run past the end of " +
                       idx("buffers", buffer) + " (" + std::to_string(src.size()) + " bytes)");
    if (count == 0 || count > (size_t(1) << 28)) doc.fail(ew + ".count", std::to_string(count) + " is out of range");
    if (mode == "ATTRIBUTES") {
      if (stride == 0 || stride % 4 != 0 || stride > 256)
        doc.fail(ew + ".byteStride", std::to_string(stride) + " (attributes need a multiple of 4 up to 256)");
    } else if (mode == "TRIANGLES" || mode == "INDICES") {
      if (stride != 2 && stride != 4) doc.fail(ew + ".byteStride", std::to_string(stride) + " (indices need 2 or 4)");
      if (mode == "TRIANGLES" && count % 3 != 0)
        doc.fail(ew + ".count", std::to_string(count) + " is not a multiple of 3 (mode TRIANGLES)");
    } else {
      doc.fail(ew + ".mode", "'" + mode + "' is not ATTRIBUTES, TRIANGLES or INDICES");
    }
    if (filter != "NONE" && mode != "ATTRIBUTES")
      doc.fail(ew + ".filter", "'" + filter + "' applies only to mode ATTRIBUTES");
    if (filter == "OCTAHEDRAL" && stride != 4 && stride != 8)
      doc.fail(ew + ".filter", "OCTAHEDRAL needs byteStride 4 or 8, not " + std::to_string(stride));
    if (filter == "QUATERNION" && stride != 8)
      doc.fail(ew + ".filter", "QUATERNION needs byteStride 8, not " + std::to_string(stride));
    if (filter != "NONE" && filter != "OCTAHEDRAL" && filter != "QUATERNION" && filter != "EXPONENTIAL")
      doc.fail(ew + ".filter", "'" + filter + "' is not NONE, OCTAHEDRAL, QUATERNION or EXPONENTIAL");
    if (size_t(bv.byteLength) != count * stride)
      doc.fail(where + ".byteLength", std::to_string(bv.byteLength) + " is not count x byteStride = " +
                                         std::to_string(count * stride));
    std::vector<unsigned char> out(count * stride);
    const unsigned char* in = src.data() + offset;
    int rc = 0;
    if (mode == "ATTRIBUTES") rc = meshopt_decodeVertexBuffer(out.data(), count, stride, in, length);
    else if (mode == "TRIANGLES") rc = meshopt_decodeIndexBuffer(out.data(), count, stride, in, length);
    else rc = meshopt_decodeIndexSequence(out.data(), count, stride, in, length);
    if (rc != 0) doc.fail(ew, "the compressed data does not decode (meshoptimizer error " + std::to_string(rc) + ")");
    if (filter == "OCTAHEDRAL") meshopt_decodeFilterOct(out.data(), count, stride);
    else if (filter == "QUATERNION") meshopt_decodeFilterQuat(out.data(), count, stride);
    else if (filter == "EXPONENTIAL") meshopt_decodeFilterExp(out.data(), count, stride);
    tinygltf::Buffer decoded;
    decoded.data = std::move(out);
    model.buffers.push_back(std::move(decoded));
    bv.buffer = int(model.buffers.size() - 1);
    bv.byteOffset = 0;
#endif
  }
}

}  // namespace prism::gltf_detail
