// prism/io/gltf/accessors.hpp — typed reads of glTF accessors: component
// types and sizes, normalized integers, strided bufferViews, accessors with no
// bufferView (zeros) and sparse substitution, every byte range checked
// against its bufferView and buffer before it is read. Values come out as
// doubles; callers convert and check them.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <initializer_list>
#include <string>
#include <vector>
#include <tiny_gltf.h>
#include "prism/io/gltf/container.hpp"

namespace prism::gltf_detail {

inline int component_size(int type) {
  switch (type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_INT:
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
    case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
  }
}
inline int type_components(int type) {
  switch (type) {
    case TINYGLTF_TYPE_SCALAR: return 1;
    case TINYGLTF_TYPE_VEC2: return 2;
    case TINYGLTF_TYPE_VEC3: return 3;
    case TINYGLTF_TYPE_VEC4: return 4;
    case TINYGLTF_TYPE_MAT2: return 4;
    case TINYGLTF_TYPE_MAT3: return 9;
    case TINYGLTF_TYPE_MAT4: return 16;
    default: return 0;
  }
}
inline double read_component(const unsigned char* p, int type, bool normalized) {
  switch (type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
      int8_t v;
      std::memcpy(&v, p, 1);
      return normalized ? std::max(double(v) / 127.0, -1.0) : double(v);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return normalized ? double(*p) / 255.0 : double(*p);
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
      int16_t v;
      std::memcpy(&v, p, 2);
      return normalized ? std::max(double(v) / 32767.0, -1.0) : double(v);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
      uint16_t v;
      std::memcpy(&v, p, 2);
      return normalized ? double(v) / 65535.0 : double(v);
    }
    case TINYGLTF_COMPONENT_TYPE_INT: {
      int32_t v;
      std::memcpy(&v, p, 4);
      return double(v);
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
      uint32_t v;
      std::memcpy(&v, p, 4);
      return double(v);
    }
    case TINYGLTF_COMPONENT_TYPE_FLOAT: {
      float v;
      std::memcpy(&v, p, 4);
      return double(v);
    }
    default: return 0;
  }
}

// The bytes of a bufferView, checked against its buffer.
struct ViewBytes {
  const unsigned char* data = nullptr;
  size_t size = 0, stride = 0;
};
inline ViewBytes view_bytes(const Document& doc, int view, const std::string& element) {
  doc.check_index(view, doc.model.bufferViews.size(), element + ".bufferView", "bufferView");
  const auto& bv = doc.model.bufferViews[size_t(view)];
  std::string where = idx("bufferViews", view);
  doc.check_index(bv.buffer, doc.model.buffers.size(), where + ".buffer", "buffer");
  const auto& buf = doc.model.buffers[size_t(bv.buffer)];
  if (bv.byteOffset > buf.data.size() || bv.byteLength > buf.data.size() - bv.byteOffset)
    doc.fail(where, "byte range [" + std::to_string(bv.byteOffset) + ", " + std::to_string(bv.byteOffset + bv.byteLength) +
                        ") runs past the end of " + idx("buffers", bv.buffer) + " (" + std::to_string(buf.data.size()) +
                        " bytes)");
  return {buf.data.data() + bv.byteOffset, bv.byteLength, bv.byteStride};
}

// Reads an accessor as doubles, `comps` per element (checked against its
// type). Handles strides, normalized integers, missing bufferViews (zeros)
// and sparse substitution; every byte range is checked.
inline std::vector<double> read_accessor(const Document& doc, int a, const std::string& element, int comps_wanted,
                                         std::initializer_list<int> allowed_types = {}) {
  doc.check_index(a, doc.model.accessors.size(), element, "accessor");
  const auto& acc = doc.model.accessors[size_t(a)];
  std::string where = element + " (" + idx("accessors", a) + ")";
  int csize = component_size(acc.componentType);
  if (csize == 0) doc.fail(where, "invalid componentType " + std::to_string(acc.componentType));
  int comps = type_components(acc.type);
  if (comps == 0) doc.fail(where, "invalid type");
  if (comps != comps_wanted)
    doc.fail(where, "has " + std::to_string(comps) + " components per element, expected " + std::to_string(comps_wanted));
  if (allowed_types.size() &&
      std::find(allowed_types.begin(), allowed_types.end(), acc.componentType) == allowed_types.end())
    doc.fail(where, "componentType " + std::to_string(acc.componentType) + " is not allowed here");
  size_t count = acc.count;
  if (count == 0) doc.fail(where, "count 0 (an accessor holds at least one element)");
  if (count > (size_t(1) << 31)) doc.fail(where, "count " + std::to_string(count) + " is implausibly large");
  size_t elem = size_t(csize) * size_t(comps);
  ViewBytes view;
  size_t stride = elem;
  if (acc.bufferView != -1) {  // checked before allocating `out`
    view = view_bytes(doc, acc.bufferView, where);
    stride = view.stride ? view.stride : elem;
    if (view.stride && view.stride < elem)
      doc.fail(where, "byteStride " + std::to_string(view.stride) + " is smaller than an element");
    // byteOffset + stride * (count - 1) + elem <= size, without overflow.
    if (count > 0 && (acc.byteOffset > view.size || elem > view.size - acc.byteOffset ||
                      (count - 1) > (view.size - acc.byteOffset - elem) / stride))
      doc.fail(where, "byteOffset " + std::to_string(acc.byteOffset) + " + " + std::to_string(count) +
                          " elements runs past the end of " + idx("bufferViews", acc.bufferView) + " (" +
                          std::to_string(view.size) + " bytes)");
  } else if (count > (size_t(1) << 24)) {
    // Without a bufferView the elements are zeros (plus sparse ones): no
    // buffer bounds the count, so cap it before allocating.
    doc.fail(where, "count " + std::to_string(count) + " is implausibly large for an accessor without a bufferView");
  }
  std::vector<double> out(count * size_t(comps), 0.0);
  if (acc.bufferView != -1) {
    for (size_t i = 0; i < count; ++i) {
      const unsigned char* p = view.data + acc.byteOffset + stride * i;
      for (int c = 0; c < comps; ++c)
        out[i * size_t(comps) + size_t(c)] =
            read_component(p + size_t(c) * size_t(csize), acc.componentType, acc.normalized);
    }
  }
  if (acc.sparse.isSparse) {
    const auto& sp = acc.sparse;
    std::string sw = where + ".sparse";
    if (sp.count < 0 || size_t(sp.count) > count)
      doc.fail(sw, "count " + std::to_string(sp.count) + " exceeds the accessor's count");
    int isize = component_size(sp.indices.componentType);
    if (isize == 0 || sp.indices.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT ||
        sp.indices.componentType == TINYGLTF_COMPONENT_TYPE_BYTE ||
        sp.indices.componentType == TINYGLTF_COMPONENT_TYPE_SHORT ||
        sp.indices.componentType == TINYGLTF_COMPONENT_TYPE_INT)
      doc.fail(sw + ".indices", "invalid componentType");
    ViewBytes ib = view_bytes(doc, sp.indices.bufferView, sw + ".indices");
    ViewBytes vb = view_bytes(doc, sp.values.bufferView, sw + ".values");
    size_t n = size_t(sp.count);
    if (sp.indices.byteOffset < 0 || size_t(sp.indices.byteOffset) + n * size_t(isize) > ib.size)
      doc.fail(sw + ".indices", "runs past the end of its bufferView");
    if (sp.values.byteOffset < 0 || size_t(sp.values.byteOffset) + n * elem > vb.size)
      doc.fail(sw + ".values", "runs past the end of its bufferView");
    for (size_t k = 0; k < n; ++k) {
      double di =
          read_component(ib.data + size_t(sp.indices.byteOffset) + k * size_t(isize), sp.indices.componentType, false);
      if (!(di >= 0) || di >= double(count))
        doc.fail(sw + ".indices", "index " + std::to_string(size_t(di)) + " out of range");
      size_t i = size_t(di);
      const unsigned char* p = vb.data + size_t(sp.values.byteOffset) + k * elem;
      for (int c = 0; c < comps; ++c)
        out[i * size_t(comps) + size_t(c)] =
            read_component(p + size_t(c) * size_t(csize), acc.componentType, acc.normalized);
    }
  }
  return out;
}

}  // namespace prism::gltf_detail
