// prism/lights/light_bounds.hpp — spatial and directional bounds of a light's
// emission, and the importance of such a bound for a receiving point: the
// measure a light BVH descends by (Conty Estevez & Kulla 2018, "Importance
// Sampling of Many Lights with Adaptive Tree Splitting"; pbrt-v4 book,
// section 12.6.3). Our own formulation:
//
//  - `bounds`: a box holding every emitting point;
//  - `phi`: the peak radiant intensity (W/sr, as luminance) the light sends in
//    any direction: I for point and spot lights, L A for a flat emitter of
//    area A (its intensity along its normal), L pi r^2 for a sphere. With it,
//    phi cos / d^2 bounds the irradiance at distance d, so that lights of
//    different kinds compare fairly. Nodes sum the phi of their lights;
//  - an orientation cone: `w` and `cos_theta_o` bound the directions of the
//    emitters' normals (spots: the axis and inner angle), `cos_theta_e` the
//    angle beyond theta_o that emission reaches (pi/2 for Lambertian
//    surfaces, outer - inner for spots); `two_sided` mirrors the cone.
//
// importance(p, n) is conservative: it is zero only where no light in the
// bound can send anything to p (behind every normal of the cone by more than
// theta_e), and it never depends on occlusion.
#pragma once
#include <algorithm>
#include <cmath>
#include <optional>
#include <variant>
#include "prism/lights/area.hpp"
#include "prism/lights/power_sampler.hpp"
#include "prism/lights/punctual.hpp"
#include "prism/math/bounds.hpp"

namespace prism {

namespace detail {
// Angle between unit vectors, accurate near 0 and pi (unlike acos of the dot).
inline Float angle_between(const Vector3f& a, const Vector3f& b) {
  if (dot(a, b) < 0) return pi - 2 * std::asin(std::min(Float(1), length(a + b) / 2));
  return 2 * std::asin(std::min(Float(1), length(a - b) / 2));
}
// cos(max(0, theta_a - theta_b)) from the sines and cosines of the angles.
inline Float cos_minus_clamped(Float sin_a, Float cos_a, Float sin_b, Float cos_b) {
  if (cos_a > cos_b) return 1;  // theta_a < theta_b
  return cos_a * cos_b + sin_a * sin_b;
}
// sin(max(0, theta_a - theta_b)).
inline Float sin_minus_clamped(Float sin_a, Float cos_a, Float sin_b, Float cos_b) {
  if (cos_a > cos_b) return 0;
  return sin_a * cos_b - cos_a * sin_b;
}
}  // namespace detail

struct LightBounds {
  Bounds3f bounds;
  Float phi = 0;
  Vector3f w{0, 0, 1};
  Float cos_theta_o = 1;  // cos of the normal cone's half-angle (-1: every direction)
  Float cos_theta_e = 0;  // cos of the emission spread beyond it (0: a hemisphere)
  bool two_sided = false;

  Point3f centroid() const { return bounds.centroid(); }

  // How much this bound may light a receiver at p with normal n (a zero
  // normal: a point in a medium or the camera, no cosine term).
  Float importance(const Point3f& p, const Normal3f& n) const {
    if (!(phi > 0)) return 0;
    Point3f pc = bounds.centroid();
    Float d2_true = distance_squared(p, pc);
    Float r2 = sqr(length(bounds.diagonal()) / 2);  // the bounding sphere's radius, squared
    // Inside the bounding sphere no direction bound holds and the distance is
    // not meaningful: clamp it at the radius and take every angle as 0.
    Float d2 = std::max({d2_true, r2, Float(1e-12)});
    if (d2_true <= r2) return phi / d2;
    Vector3f wo = (p - pc) / std::sqrt(d2_true);  // from the lights to the receiver
    // Angle theta_b of the cone of directions the bounding sphere subtends from p.
    Float sin2_b = r2 / d2_true;
    Float sin_b = std::sqrt(sin2_b), cos_b = safe_sqrt(1 - sin2_b);
    // theta' = max(0, theta_w - theta_o - theta_b): the smallest angle between
    // the direction to p and any emitter normal of the cone.
    Float cos_w = dot(w, wo);
    if (two_sided) cos_w = std::abs(cos_w);
    Float sin_w = safe_sqrt(1 - sqr(cos_w));
    Float sin_o = safe_sqrt(1 - sqr(cos_theta_o));
    Float cos_x = detail::cos_minus_clamped(sin_w, cos_w, sin_o, cos_theta_o);
    Float sin_x = detail::sin_minus_clamped(sin_w, cos_w, sin_o, cos_theta_o);
    Float cos_p = detail::cos_minus_clamped(sin_x, cos_x, sin_b, cos_b);
    if (cos_p < cos_theta_e) return 0;
    Float imp = phi * std::max(Float(0), cos_p) / d2;
    if (n != Normal3f{}) {
      // The receiver's cosine, at its most favourable over the bounding sphere.
      Float cos_i = abs_dot(wo, n) / length(Vector3f(n));
      Float sin_i = safe_sqrt(1 - sqr(cos_i));
      imp *= detail::cos_minus_clamped(sin_i, cos_i, sin_b, cos_b);
    }
    return std::max(Float(0), imp);
  }
};

// The smallest cone (w, cos) we construct that holds the cones a and b.
inline void union_cones(const Vector3f& wa, Float cos_a, const Vector3f& wb, Float cos_b, Vector3f* w, Float* cos_o) {
  Float theta_a = safe_acos(cos_a), theta_b = safe_acos(cos_b);
  Float theta_d = detail::angle_between(wa, wb);
  if (std::min(theta_d + theta_b, pi) <= theta_a) {
    *w = wa;
    *cos_o = cos_a;
    return;
  }
  if (std::min(theta_d + theta_a, pi) <= theta_b) {
    *w = wb;
    *cos_o = cos_b;
    return;
  }
  Float theta_o = (theta_a + theta_d + theta_b) / 2;
  Vector3f axis = cross(wa, wb);
  if (theta_o >= pi || !(length_squared(axis) > 0)) {
    *w = wa;
    *cos_o = -1;
    return;
  }
  // Turn wa towards wb by theta_o - theta_a: the new cone's edge then touches
  // both old cones' far edges.
  Float theta_r = theta_o - theta_a;
  Vector3f k = normalize(axis);
  *w = normalize(wa * std::cos(theta_r) + cross(k, wa) * std::sin(theta_r));
  *cos_o = std::cos(theta_o);
}

inline LightBounds union_light_bounds(const LightBounds& a, const LightBounds& b) {
  if (!(a.phi > 0)) return b;
  if (!(b.phi > 0)) return a;
  LightBounds r;
  r.bounds = union_bounds(a.bounds, b.bounds);
  r.phi = a.phi + b.phi;
  union_cones(a.w, a.cos_theta_o, b.w, b.cos_theta_o, &r.w, &r.cos_theta_o);
  r.cos_theta_e = std::min(a.cos_theta_e, b.cos_theta_e);
  r.two_sided = a.two_sided || b.two_sided;
  return r;
}

// Bounds of one light of colour type S, or nullopt for a light that has none
// (environments, sun and distant lights: they light every point alike and a
// BVH sampler handles them apart). A light of zero power has phi = 0.
template <class S>
struct LightBoundsOf {
  const Float power;  // light_power_luminance of the light

  std::optional<LightBounds> operator()(const TriangleAreaLight<S>& l) const {
    LightBounds b;
    b.bounds = union_bounds(Bounds3f(l.vertex(0), l.vertex(1)), l.vertex(2));
    Float sides = l.two_sided() ? 2 : 1;
    // power = pi sides A L: the intensity along the normal is L A.
    b.phi = valid(power) / (pi * sides);
    b.w = Vector3f(l.normal());
    if (!(b.phi > 0) || b.w.has_nan()) return zero(b.bounds);
    b.cos_theta_o = 1;
    b.cos_theta_e = 0;
    b.two_sided = l.two_sided();
    return b;
  }
  std::optional<LightBounds> operator()(const SphereAreaLight<S>& l) const {
    const Sphere& s = l.sphere();
    LightBounds b;
    Vector3f r(s.radius, s.radius, s.radius);
    b.bounds = Bounds3f(s.center - r, s.center + r);
    // power = pi sides 4 pi r^2 L: the intensity in any direction is L pi r^2.
    b.phi = valid(power) / (4 * pi * (l.two_sided() ? 2 : 1));
    b.cos_theta_o = -1;  // normals in every direction
    b.cos_theta_e = 0;
    return b;
  }
  std::optional<LightBounds> operator()(const PointLight<S>& l) const {
    LightBounds b;
    b.bounds = Bounds3f(l.position());
    b.phi = valid(power) / (4 * pi);
    b.cos_theta_o = -1;
    b.cos_theta_e = 0;
    return b;
  }
  std::optional<LightBounds> operator()(const SpotLight<S>& l) const {
    LightBounds b;
    b.bounds = Bounds3f(l.position());
    Float omega = l.falloff().solid_angle();
    b.phi = omega > 0 ? valid(power) / omega : 0;  // the intensity inside the inner cone
    b.w = l.direction();
    b.cos_theta_o = l.falloff().cos_inner;
    Float theta_e = std::max(Float(0), safe_acos(l.falloff().cos_outer) - safe_acos(l.falloff().cos_inner));
    b.cos_theta_e = std::cos(theta_e);
    return b;
  }
  template <class L>
  std::optional<LightBounds> operator()(const L&) const {
    return std::nullopt;
  }

 private:
  static Float valid(Float p) { return std::isfinite(p) && p > 0 ? p : 0; }
  static LightBounds zero(const Bounds3f& box) {
    LightBounds b;
    b.bounds = box;
    return b;
  }
};

template <class S, class L>
std::optional<LightBounds> light_bounds(const L& light) {
  return LightBoundsOf<S>{light_power_luminance<S>(light)}(light);
}
template <class S, class... Ls>
std::optional<LightBounds> light_bounds(const std::variant<Ls...>& light) {
  return std::visit([](const auto& l) { return light_bounds<S>(l); }, light);
}

}  // namespace prism
