// prism/geometry/ray.hpp — rays, and spawning rays off surfaces without
// self-intersection. offset_ray_origin moves a point just outside the box that
// bounds its rounding error, along the normal and away from the surface on the
// side the ray leaves (pbrt-v4 book, section 6.8.6): no tuned epsilon.
#pragma once
#include "prism/math/transform.hpp"

namespace prism {

struct Ray {
  Point3f o;
  Vector3f d;
  Float time = 0;
  Point3f at(Float t) const { return o + d * t; }
};

// p lies within +-p_error of the exact surface point; n is the geometric
// normal there; w is the direction the new ray leaves in.
inline Point3f offset_ray_origin(const Point3f& p, const Vector3f& p_error, const Normal3f& n, const Vector3f& w) {
  Float d = dot(abs(n), p_error);
  Vector3f offset = Vector3f(n) * d;
  if (dot(w, n) < 0) offset = -offset;
  Point3f po = p + offset;
  // Round away from p so that the offset survives the addition's rounding.
  for (int i = 0; i < 3; ++i) {
    if (offset[i] > 0)
      po[i] = next_float_up(po[i]);
    else if (offset[i] < 0)
      po[i] = next_float_down(po[i]);
  }
  return po;
}

// Transform a ray into another space (e.g. world to an instance's object space).
// The origin's rounding error is absorbed by moving it forward along d to the
// edge of its error box by the parameter distance *dt; the direction is
// transformed unnormalised, so t' + *dt in the new space is t in the old one.
inline Ray transform_ray(const Transform& t, const Ray& r, Float* dt_out) {
  Vector3f o_err;
  Point3f o = t.apply(r.o, &o_err);
  Vector3f d = t(r.d);
  Float len2 = length_squared(d);
  Float dt = 0;
  if (len2 > 0) {
    dt = dot(abs(d), o_err) / len2;
    o += d * dt;
  }
  *dt_out = dt;
  return {o, d, r.time};
}

}  // namespace prism
