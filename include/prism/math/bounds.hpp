// prism/math/bounds.hpp — axis-aligned bounding boxes.
#pragma once
#include "prism/math/vector.hpp"

namespace prism {

struct Bounds3f {
  Point3f min{infinity, infinity, infinity};
  Point3f max{-infinity, -infinity, -infinity};

  constexpr Bounds3f() = default;
  constexpr explicit Bounds3f(const Point3f& p) : min(p), max(p) {}
  Bounds3f(const Point3f& a, const Point3f& b) : min(prism::min(a, b)), max(prism::max(a, b)) {}

  bool empty() const { return min.x > max.x || min.y > max.y || min.z > max.z; }
  Vector3f diagonal() const { return max - min; }
  Point3f centroid() const { return {(min.x + max.x) * 0.5f, (min.y + max.y) * 0.5f, (min.z + max.z) * 0.5f}; }
  Float surface_area() const {
    if (empty()) return 0;
    Vector3f d = diagonal();
    return 2 * (d.x * d.y + d.x * d.z + d.y * d.z);
  }
  int max_extent() const { return max_dimension(diagonal()); }
  // Position of p relative to the box: 0 at min, 1 at max, per axis.
  Vector3f offset(const Point3f& p) const {
    Vector3f o = p - min;
    for (int i = 0; i < 3; ++i)
      if (max[i] > min[i]) o[i] /= max[i] - min[i];
    return o;
  }
  bool inside(const Point3f& p) const {
    return p.x >= min.x && p.x <= max.x && p.y >= min.y && p.y <= max.y && p.z >= min.z && p.z <= max.z;
  }
  const Point3f& operator[](int i) const { return i == 0 ? min : max; }
  void bounding_sphere(Point3f* c, Float* r) const {
    *c = centroid();
    *r = inside(*c) ? distance(*c, max) : 0;
  }
};

inline Bounds3f union_bounds(const Bounds3f& b, const Point3f& p) {
  Bounds3f r;
  r.min = min(b.min, p);
  r.max = max(b.max, p);
  return r;
}
inline Bounds3f union_bounds(const Bounds3f& a, const Bounds3f& b) {
  Bounds3f r;
  r.min = min(a.min, b.min);
  r.max = max(a.max, b.max);
  return r;
}

}  // namespace prism
