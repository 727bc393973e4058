// prism/geometry/sphere.hpp — a sphere given by centre and radius in world space.
// The quadratic is solved in interval arithmetic with the numerically stable
// discriminant of pbrt-v4 (book, section 6.8.3 and 6.2.2), so a hit is accepted
// only when its t is provably in (0, t_max); the hit point is reprojected onto
// the sphere, leaving an error of at most gamma(5) |p| (section 6.8.5).
//
// Origins inside the sphere take a separate path. A ray spawned inside (after
// a refraction or an internal reflection) starts only ~gamma(5) r inside the
// surface; at grazing angles the single-precision intervals of c = |o-c|^2 - r^2
// and of the discriminant then straddle zero, and the ray would escape through
// the sphere (tests/geometry/self_intersection_test.cpp: 35-42% of rays
// spawned inwards at 1e-1 to 1e-7 rad below the tangent plane leaked, and
// ~13% of rays from random inside origins missed). In double, o - centre is exact (or off by one rounding), so the
// sign of c is certain unless the origin lies within ~1e-15 r of the surface;
// when c < 0 is certain the exit root needs no subtraction of like terms and
// its relative error is bounded by gamma-style terms (see exit_from_inside).
#pragma once
#include <cmath>
#include <optional>
#include <utility>
#include "prism/geometry/interaction.hpp"
#include "prism/math/interval.hpp"

namespace prism {

struct Sphere {
  Point3f center;
  Float radius = 1;

  Bounds3f bounds() const {
    Vector3f r{radius, radius, radius};
    Bounds3f b(center - r, center + r);
    // Cover the rounding of centre +- radius.
    Vector3f e = max(abs(b.min - Point3f{}), abs(b.max - Point3f{})) * gamma(1);
    return {b.min - e, b.max + e};
  }
  Float area() const { return 4 * pi * radius * radius; }
};

struct SphereHit {
  Float t;
};

namespace detail {

// The exit of a ray whose origin is certainly inside the sphere (c < 0), from
// o - centre, d, a = |d|^2, half_b = (o - centre).d and c, all in double, with
// c's absolute error at most c_err. The roots of a t^2 + 2 half_b t + c have
// opposite signs; the positive one is written without cancellation:
//   half_b <= 0: t = (-half_b + sqrt(half_b^2 - a c)) / a,
//   half_b >  0: t = -c / (half_b + sqrt(half_b^2 - a c)),
// sums of non-negative terms only (-a c > 0). Each has relative error at most
// c_err / |c| (from c, entering at most linearly) plus gamma_double(12) (the
// operations and half_b's rounding); the result is that bound's upper end, so
// a hit is accepted only when it is provably inside (0, t_max).
inline std::optional<SphereHit> exit_from_inside(double a, double half_b, double c, double c_err, Float t_max) {
  double disc = half_b * half_b - a * c;
  double root = std::sqrt(disc);
  double t = half_b <= 0 ? (root - half_b) / a : -c / (half_b + root);
  double rel = c_err / -c + gamma_double(12);
  if (!(t > 0) || !std::isfinite(t) || rel >= 0.5) return std::nullopt;
  if (t * (1 + rel) > double(t_max)) return std::nullopt;
  Float tf = Float(t);
  if (!(tf > 0)) return std::nullopt;
  return SphereHit{tf};
}

}  // namespace detail

inline std::optional<SphereHit> intersect_sphere(const Sphere& s, const Ray& ray, Float t_max) {
  // Early out for clear misses, in double: the ray's line passes farther than
  // r from the centre, or starts outside and moves away. The few double
  // operations err by ~1e-15 relative; the 1e-9 slack dwarfs that, so no ray
  // that could hit is rejected here. Origins certainly inside are finished
  // here too (see the file comment); everything else takes the interval path.
  {
    double ox = double(ray.o.x) - double(s.center.x), oy = double(ray.o.y) - double(s.center.y),
           oz = double(ray.o.z) - double(s.center.z);
    double dx = ray.d.x, dy = ray.d.y, dz = ray.d.z;
    double a = dx * dx + dy * dy + dz * dz, half_b = ox * dx + oy * dy + oz * dz;
    double c2 = ox * ox + oy * oy + oz * oz, r2 = double(s.radius) * double(s.radius);
    // Each of ox, oy, oz carries at most one rounding (none when the two
    // floats are within 2^29 of each other in magnitude); squaring and summing
    // add four more; r2 is exact (a float squared fits in a double); the
    // subtraction one more, relative to |c|.
    double c = c2 - r2;
    double c_err = gamma_double(6) * c2 + gamma_double(1) * std::abs(c);
    if (c < 0 && -c > c_err && a > 0) return detail::exit_from_inside(a, half_b, c, c_err, t_max);
    double f = half_b / a;
    double vx = ox - f * dx, vy = oy - f * dy, vz = oz - f * dz;
    double slack = 1e-9 * (r2 + c2);
    if (vx * vx + vy * vy + vz * vz > r2 + slack) return std::nullopt;
    if (c2 > r2 + slack && half_b > 0) return std::nullopt;
  }
  Vector3f oc = ray.o - s.center;  // one rounding per component
  Vector3f oc_err = abs(oc) * gamma(1);
  Interval ox = Interval::from_value_and_error(oc.x, oc_err.x);
  Interval oy = Interval::from_value_and_error(oc.y, oc_err.y);
  Interval oz = Interval::from_value_and_error(oc.z, oc_err.z);
  Interval dx(ray.d.x), dy(ray.d.y), dz(ray.d.z);

  Interval a = sqr(dx) + sqr(dy) + sqr(dz);
  Interval b = 2 * (dx * ox + dy * oy + dz * oz);
  Interval c = sqr(ox) + sqr(oy) + sqr(oz) - sqr(Interval(s.radius));
  // Discriminant as 4a (r + |v|)(r - |v|), v the closest-approach offset: free
  // of the catastrophic cancellation of b^2 - 4ac.
  Interval f = b / (2 * a);
  Interval vx = ox - f * dx, vy = oy - f * dy, vz = oz - f * dz;
  Interval len = sqrt(sqr(vx) + sqr(vy) + sqr(vz));
  Interval r(s.radius);
  Interval discrim = 4 * a * (r + len) * (r - len);
  if (discrim.lower() < 0) return std::nullopt;
  Interval root = sqrt(discrim);
  Interval q = b.midpoint() < 0 ? -0.5f * (b - root) : -0.5f * (b + root);
  Interval t0 = q / a, t1 = c / q;
  if (t0.lower() > t1.lower()) std::swap(t0, t1);
  if (t0.upper() > t_max || t1.lower() <= 0) return std::nullopt;
  Interval t = t0;
  if (t.lower() <= 0) {
    t = t1;
    if (t.upper() > t_max) return std::nullopt;
  }
  return SphereHit{t.midpoint()};
}

inline void sphere_interaction(const Sphere& s, const Ray& ray, const SphereHit& h, SurfaceInteraction* si) {
  Vector3f local = (ray.o - s.center) + ray.d * h.t;
  local = local * (s.radius / length(local));
  Vector3f local_err = abs(local) * gamma(5);
  si->p = s.center + local;
  si->p_error = local_err * (1 + gamma(2)) + abs(si->p - Point3f{}) * gamma(2);
  Normal3f n(local / s.radius);
  si->n = si->ns = normalize(n);
  Float phi = std::atan2(local.y, local.x);
  if (phi < 0) phi += 2 * pi;
  Float cos_theta = std::clamp(local.z / s.radius, Float(-1), Float(1));
  si->uv = {phi * inv_2pi, std::acos(cos_theta) * inv_pi};
  si->dpdu = Vector3f{-local.y, local.x, 0} * (2 * pi);
  // dp/dv for v = theta / pi: pi * (cos(theta) cos(phi), cos(theta) sin(phi), -sin(theta)) * r.
  Float sin_theta = safe_sqrt(1 - cos_theta * cos_theta);
  si->dpdv = Vector3f{cos_theta * std::cos(phi), cos_theta * std::sin(phi), -sin_theta} * (pi * s.radius);
}

}  // namespace prism
