// tests/support/mesh_compare.hpp — whether two loaded scenes have the same
// surface: world-space triangles and the distance from one's corners and
// centroids to the other's surface (brute force, for models of a few
// thousand triangles), written in double from the textbook.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>
#include <prism/accel/scene_accel.hpp>

namespace mesh_compare {

using D3 = std::array<double, 3>;
using Tri = std::array<D3, 3>;

inline D3 sub(const D3& a, const D3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
inline double dot(const D3& a, const D3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline D3 cross(const D3& a, const D3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
inline D3 mad(const D3& a, double s, const D3& b) { return {a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]}; }
inline double dist(const D3& a, const D3& b) { return std::sqrt(dot(sub(a, b), sub(a, b))); }

// The distance from p to the triangle t: the closest point by its Voronoi
// regions (Ericson, Real-Time Collision Detection, 2005, section 5.1.5).
inline double point_triangle(const D3& p, const Tri& t) {
  D3 ab = sub(t[1], t[0]), ac = sub(t[2], t[0]), ap = sub(p, t[0]);
  double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return dist(p, t[0]);
  D3 bp = sub(p, t[1]);
  double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return dist(p, t[1]);
  double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return dist(p, mad(t[0], d1 / (d1 - d3), ab));
  D3 cp = sub(p, t[2]);
  double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return dist(p, t[2]);
  double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return dist(p, mad(t[0], d2 / (d2 - d6), ac));
  double va = d3 * d6 - d5 * d4;
  if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0)
    return dist(p, mad(t[1], (d4 - d3) / ((d4 - d3) + (d5 - d6)), sub(t[2], t[1])));
  double denom = 1 / (va + vb + vc);
  return dist(p, mad(mad(t[0], vb * denom, ab), vc * denom, ac));
}

inline double area(const Tri& t) {
  D3 c = cross(sub(t[1], t[0]), sub(t[2], t[0]));
  return 0.5 * std::sqrt(dot(c, c));
}

// World-space triangles of every mesh instance.
template <class G>
inline std::vector<Tri> world_triangles(const G& g) {
  std::vector<Tri> out;
  const auto& accel = g.scene.accel();
  for (const auto& inst : accel.instances()) {
    if (inst.kind != prism::Instance::Kind::mesh) continue;
    const prism::TriangleMesh& m = accel.meshes()[inst.geometry];
    for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
      Tri c{};
      for (size_t k = 0; k < 3; ++k) {
        prism::Point3f p = inst.object_to_world(m.positions[m.indices[t + k]]);
        c[k] = {p.x, p.y, p.z};
      }
      out.push_back(c);
    }
  }
  return out;
}

// The largest distance from a corner or the centroid of a triangle of `a` to
// the surface of `b` (brute force: small models only).
inline double worst_distance(const std::vector<Tri>& a, const std::vector<Tri>& b) {
  double worst = 0;
  for (const Tri& t : a) {
    D3 centroid{};
    for (const D3& v : t) centroid = mad(centroid, 1.0 / 3, v);
    for (const D3& p : {t[0], t[1], t[2], centroid}) {
      double best = std::numeric_limits<double>::infinity();
      for (const Tri& u : b) best = std::min(best, point_triangle(p, u));
      worst = std::max(worst, best);
    }
  }
  return worst;
}

}  // namespace mesh_compare
