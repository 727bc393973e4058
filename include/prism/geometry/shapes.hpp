// prism/geometry/shapes.hpp — meshes built in code: quads, axis-aligned
// boxes, right prisms over a triangle, and uv spheres. Every closed shape's
// triangles face outwards (counter-clockwise seen from outside, the glTF and
// prism convention for the front side). Quads carry uvs over [0, 1]^2; a uv
// sphere carries smooth normals and longitude/latitude uvs.
#pragma once
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>
#include "prism/error.hpp"
#include "prism/geometry/triangle.hpp"

namespace prism {

// Two triangles spanning the parallelogram p, p + a, p + a + b, p + b; the
// front side is that of a x b.
inline void append_quad(TriangleMesh& m, const Point3f& p, const Vector3f& a, const Vector3f& b) {
  uint32_t base = uint32_t(m.positions.size());
  m.positions.insert(m.positions.end(), {p, p + a, p + a + b, p + b});
  m.uvs.insert(m.uvs.end(), {{0, 0}, {1, 0}, {1, 1}, {0, 1}});
  m.indices.insert(m.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
}

// An axis-aligned box with outward-facing triangles.
inline TriangleMesh make_box(const Point3f& lo, const Point3f& hi) {
  TriangleMesh m;
  Vector3f d = hi - lo;
  Vector3f ex{d.x, 0, 0}, ey{0, d.y, 0}, ez{0, 0, d.z};
  append_quad(m, lo, ey, ex);                  // -z
  append_quad(m, lo + ez, ex, ey);             // +z
  append_quad(m, lo, ez, ey);                  // -x
  append_quad(m, lo + ex, ey, ez);             // +x
  append_quad(m, lo, ex, ez);                  // -y
  append_quad(m, lo + ey, ez, ex);             // +y
  return m;
}

// A right prism whose cross-section is the triangle a, b, c in the xz-plane,
// from y0 to y1, with outward-facing triangles.
inline TriangleMesh make_triangular_prism(Point2f a, Point2f b, Point2f c, Float y0, Float y1) {
  TriangleMesh m;
  Point3f lo[3] = {{a.x, y0, a.y}, {b.x, y0, b.y}, {c.x, y0, c.y}};
  Point3f hi[3] = {{a.x, y1, a.y}, {b.x, y1, b.y}, {c.x, y1, c.y}};
  // Orient the base so that a, b, c run clockwise seen from +y (normal -y below).
  Vector3f n = cross(lo[1] - lo[0], lo[2] - lo[0]);
  if (n.y > 0) {
    std::swap(lo[1], lo[2]);
    std::swap(hi[1], hi[2]);
  }
  m.positions = {lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]};
  m.indices = {0, 1, 2, 3, 5, 4};  // bottom (-y), top (+y)
  // Sides: two triangles each, wound so that the normal points away from the axis.
  Point3f centre = lo[0] + (Vector3f(lo[1]) + Vector3f(lo[2]) - 2 * Vector3f(lo[0])) / 3;
  for (uint32_t i = 0; i < 3; ++i) {
    uint32_t j = (i + 1) % 3;
    Vector3f side_n = cross(lo[j] - lo[i], hi[i] - lo[i]);
    if (dot(side_n, lo[i] - centre) > 0)
      m.indices.insert(m.indices.end(), {i, j, j + 3, i, j + 3, i + 3});
    else
      m.indices.insert(m.indices.end(), {i, j + 3, j, i, i + 3, j + 3});
  }
  return m;
}

// A sphere of `rings` latitude bands and `segments` longitude bands, +y up:
// smooth normals, u along longitude (0 at +x, increasing towards -z), v from
// 0 at the north pole to 1 at the south pole; the seam's vertices are
// duplicated so that uvs do not wrap. Throws prism::Error unless rings >= 2,
// segments >= 3 and the radius is positive and finite. (prism's analytic
// Sphere, geometry/sphere.hpp, is exact and cheaper to trace: this mesh is
// for when a tessellated sphere is wanted, e.g. to compare with a renderer
// that tessellates.)
inline TriangleMesh make_uv_sphere(const Point3f& centre, Float radius, int rings = 32, int segments = 64) {
  if (rings < 2 || segments < 3)
    throw Error("make_uv_sphere: needs at least 2 rings and 3 segments, got " + std::to_string(rings) + " and " +
                std::to_string(segments));
  if (!(radius > 0) || !std::isfinite(radius))
    throw Error("make_uv_sphere: the radius must be positive and finite, got " + std::to_string(radius));
  TriangleMesh m;
  const Float pi_f = Float(3.14159265358979323846);
  // The seam's second copy and each pole repeat the exact same position, so
  // that the mesh is watertight (no ray slips between copies an ulp apart).
  for (int r = 0; r <= rings; ++r) {
    const Float v = Float(r) / Float(rings), theta = v * pi_f;
    const size_t row_start = m.positions.size();
    for (int s = 0; s <= segments; ++s) {
      const Float u = Float(s) / Float(segments), phi = u * 2 * pi_f;
      Vector3f n{std::sin(theta) * std::cos(phi), std::cos(theta), -std::sin(theta) * std::sin(phi)};
      if (r == 0 || r == rings) n = Vector3f{0, r == 0 ? Float(1) : Float(-1), 0};
      Point3f p = centre + radius * n;
      if (s == segments) {
        p = m.positions[row_start];
        n = Vector3f(m.normals[row_start]);
      }
      m.positions.push_back(p);
      m.normals.push_back(Normal3f(n));
      m.uvs.push_back({u, v});
    }
  }
  const uint32_t row = uint32_t(segments) + 1;
  for (uint32_t r = 0; r < uint32_t(rings); ++r)
    for (uint32_t s = 0; s < uint32_t(segments); ++s) {
      const uint32_t a = r * row + s, b = a + 1, c = a + row, d = c + 1;
      // Counter-clockwise seen from outside; the poles' degenerate halves are left out.
      if (r != 0) m.indices.insert(m.indices.end(), {a, c, b});
      if (r + 1 != uint32_t(rings)) m.indices.insert(m.indices.end(), {b, c, d});
    }
  return m;
}

}  // namespace prism
