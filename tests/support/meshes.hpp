// Code-built meshes shared by the tests and the benches (bench/ adds tests/
// to its include path for this header).
#pragma once
#include <cmath>
#include <cstdint>

#include "prism/geometry/triangle.hpp"

namespace prism::test {

// A closed tube of n sides, radius r, from c0 to c1: each side a quad cut
// into two long slivers, each end a fan of n thin triangles around its
// centre; 4n triangles, counter-clockwise from outside. Along a diagonal axis
// its triangles' boxes are far larger than they are, so MeshAccel pre-splits
// them.
inline TriangleMesh sliver_tube(int n, Float r, const Point3f& c0, const Point3f& c1) {
  Vector3f w = normalize(c1 - c0);
  Vector3f u = normalize(cross(w, std::abs(w.x) < 0.9f ? Vector3f{1, 0, 0} : Vector3f{0, 1, 0}));
  Vector3f v = cross(w, u);
  TriangleMesh m;
  for (int i = 0; i < n; ++i) {  // vertex 2i on the c0 ring, 2i + 1 on the c1 ring
    Float a = 2 * pi * Float(i) / Float(n);
    Vector3f off = (u * std::cos(a) + v * std::sin(a)) * r;
    m.positions.push_back(c0 + off);
    m.positions.push_back(c1 + off);
  }
  const uint32_t centre0 = uint32_t(2 * n), centre1 = centre0 + 1, un = uint32_t(n);
  m.positions.push_back(c0);
  m.positions.push_back(c1);
  for (uint32_t i = 0; i < un; ++i) {
    uint32_t j = (i + 1) % un;
    uint32_t b0 = 2 * i, b1 = 2 * j, t0 = 2 * i + 1, t1 = 2 * j + 1;
    m.indices.insert(m.indices.end(), {b0, b1, t1, b0, t1, t0, centre0, b1, b0, centre1, t0, t1});
  }
  return m;
}

}  // namespace prism::test
