// prism/math/frame.hpp — an orthonormal frame (x, y, z) for local shading space.
// from_z builds a branchless basis after Duff et al. 2017, "Building an
// Orthonormal Basis, Revisited" (JCGT 6(1)).
#pragma once
#include "prism/math/vector.hpp"

namespace prism {

inline void coordinate_system(const Vector3f& v1, Vector3f* v2, Vector3f* v3) {
  Float sign = std::copysign(Float(1), v1.z);
  Float a = -1 / (sign + v1.z);
  Float b = v1.x * v1.y * a;
  *v2 = {1 + sign * sqr(v1.x) * a, sign * b, -sign * v1.x};
  *v3 = {b, sign + sqr(v1.y) * a, -v1.y};
}

struct Frame {
  Vector3f x{1, 0, 0}, y{0, 1, 0}, z{0, 0, 1};

  static Frame from_z(const Vector3f& z) {
    Frame f;
    f.z = z;
    coordinate_system(z, &f.x, &f.y);
    return f;
  }
  static Frame from_xz(const Vector3f& x, const Vector3f& z) { return {x, cross(z, x), z}; }

  Vector3f to_local(const Vector3f& v) const { return {dot(v, x), dot(v, y), dot(v, z)}; }
  Vector3f from_local(const Vector3f& v) const { return x * v.x + y * v.y + z * v.z; }
};

}  // namespace prism
