// prism/sampling/warps.hpp — maps from [0,1)^2 to common domains, each paired
// with its density. Naming: sample_x(u) returns a point, pdf_x(...) its density
// in the measure named in the comment (area for disks and triangles, solid angle
// for directions). References: pbrt-v4 book, sections A.5 and 13.6;
// Shirley & Chiu 1997 (concentric disk).
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include "prism/math/vector.hpp"

namespace prism {

// Concentric map of the unit square to the unit disk; pdf 1/pi per unit area.
inline Point2f sample_uniform_disk_concentric(Point2f u) {
  Point2f o{2 * u.x - 1, 2 * u.y - 1};
  if (o.x == 0 && o.y == 0) return {0, 0};
  Float r, theta;
  if (std::abs(o.x) > std::abs(o.y)) {
    r = o.x;
    theta = pi_over_4 * (o.y / o.x);
  } else {
    r = o.y;
    theta = pi_over_2 - pi_over_4 * (o.x / o.y);
  }
  return {r * std::cos(theta), r * std::sin(theta)};
}
inline constexpr Float pdf_uniform_disk() { return inv_pi; }

// Cosine-weighted hemisphere about +z (Malley's method); pdf cos(theta)/pi per solid angle.
inline Vector3f sample_cosine_hemisphere(Point2f u) {
  Point2f d = sample_uniform_disk_concentric(u);
  Float z = safe_sqrt(1 - d.x * d.x - d.y * d.y);
  return {d.x, d.y, z};
}
inline Float pdf_cosine_hemisphere(Float cos_theta) { return cos_theta > 0 ? cos_theta * inv_pi : 0; }

// Uniform hemisphere about +z; pdf 1/(2 pi) per solid angle.
inline Vector3f sample_uniform_hemisphere(Point2f u) {
  Float z = u.x;
  Float r = safe_sqrt(1 - z * z);
  Float phi = 2 * pi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}
inline constexpr Float pdf_uniform_hemisphere() { return inv_2pi; }

// Uniform sphere; pdf 1/(4 pi) per solid angle.
inline Vector3f sample_uniform_sphere(Point2f u) {
  Float z = 1 - 2 * u.x;
  Float r = safe_sqrt(1 - z * z);
  Float phi = 2 * pi * u.y;
  return {r * std::cos(phi), r * std::sin(phi), z};
}
inline constexpr Float pdf_uniform_sphere() { return inv_4pi; }

// Uniform cone about +z with cos(theta) >= cos_max; pdf 1/(2 pi (1 - cos_max)) per solid angle.
inline Vector3f sample_uniform_cone(Point2f u, Float cos_max) {
  Float cos_theta = (1 - u.x) + u.x * cos_max;
  Float sin_theta = safe_sqrt(1 - cos_theta * cos_theta);
  Float phi = u.y * 2 * pi;
  return spherical_direction(sin_theta, cos_theta, phi);
}
inline Float pdf_uniform_cone(Float cos_max) { return 1 / (2 * pi * (1 - cos_max)); }

// Uniform barycentrics on a triangle, area-preserving (Heitz 2019, "A
// Low-Distortion Map Between Triangle and Square"); pdf 1/area per unit area.
inline std::array<Float, 3> sample_uniform_triangle(Point2f u) {
  Float b0, b1;
  if (u.x < u.y) {
    b0 = u.x / 2;
    b1 = u.y - b0;
  } else {
    b1 = u.y / 2;
    b0 = u.x - b1;
  }
  return {b0, b1, 1 - b0 - b1};
}

// Spherical triangles: the directions from a point towards a triangle whose
// corners are at a, b, c relative to it. Both functions work in double, which
// keeps Arvo's construction accurate down to the smallest solid angles the
// area lights use it for (lights/area.hpp).
namespace detail {
struct Vec3d {
  double x, y, z;
};
inline Vec3d to_d(const Vector3f& v) { return {v.x, v.y, v.z}; }
inline double dot_d(const Vec3d& a, const Vec3d& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline Vec3d cross_d(const Vec3d& a, const Vec3d& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline Vec3d add_d(const Vec3d& a, const Vec3d& b, double s) { return {a.x + b.x * s, a.y + b.y * s, a.z + b.z * s}; }
inline Vec3d scale_d(const Vec3d& a, double s) { return {a.x * s, a.y * s, a.z * s}; }
inline bool normalize_d(Vec3d* v) {
  double l = std::sqrt(dot_d(*v, *v));
  if (!(l > 0) || !std::isfinite(l)) return false;
  *v = scale_d(*v, 1 / l);
  return true;
}
}  // namespace detail

// Solid angle subtended at the origin by the triangle with corners a, b, c
// (any non-zero vectors; Van Oosterom and Strackee 1983): stable for small and
// large triangles.
inline double spherical_triangle_area(const Vector3f& a, const Vector3f& b, const Vector3f& c) {
  using namespace detail;
  Vec3d A = to_d(a), B = to_d(b), C = to_d(c);
  double la = std::sqrt(dot_d(A, A)), lb = std::sqrt(dot_d(B, B)), lc = std::sqrt(dot_d(C, C));
  double num = std::abs(dot_d(A, cross_d(B, C)));
  double den = la * lb * lc + dot_d(A, B) * lc + dot_d(A, C) * lb + dot_d(B, C) * la;
  double omega = 2 * std::atan2(num, den);
  return std::isfinite(omega) ? omega : 0;
}

// A direction uniformly distributed over the spherical triangle a, b, c (any
// non-zero vectors; Arvo 1995, "Stratified sampling of spherical triangles"):
// u.x picks the sub-triangle (a, b, c') of area u.x * A with c' on the arc
// from a to c, and u.y the point on the arc from b to c' so that the area
// grows linearly. The density is 1 / area per unit solid angle; nullopt for a
// degenerate triangle (collinear corners, area 0).
struct SphericalTriangleSample {
  Vector3f w;
  double area;  // the triangle's solid angle: the density is 1 / area
};
// `area`, when given, is spherical_triangle_area(a, b, c), computed by the
// caller already.
inline std::optional<SphericalTriangleSample> sample_spherical_triangle(const Vector3f& a_, const Vector3f& b_,
                                                                        const Vector3f& c_, Point2f u,
                                                                        double area = -1) {
  using namespace detail;
  if (area < 0) area = spherical_triangle_area(a_, b_, c_);
  if (!(area > 0)) return std::nullopt;
  Vec3d a = to_d(a_), b = to_d(b_), c = to_d(c_);
  if (!normalize_d(&a) || !normalize_d(&b) || !normalize_d(&c)) return std::nullopt;
  // The interior angle alpha at corner a lies between the planes of the
  // edges a-b and a-c: between their normals a x b and a x c.
  Vec3d n_ab = cross_d(a, b), n_ac = cross_d(a, c);
  if (!normalize_d(&n_ab) || !normalize_d(&n_ac)) return std::nullopt;
  Vec3d sn = cross_d(n_ab, n_ac);
  double cos_alpha = dot_d(n_ab, n_ac), sin_alpha = std::sqrt(dot_d(sn, sn));
  double alpha = std::atan2(sin_alpha, cos_alpha);
  // The sub-triangle (a, b, c') of area u.x * area fixes c' on the arc a..c
  // (the area is the Van Oosterom-Strackee value, equal to the angle excess
  // alpha + beta + gamma - pi but without its cancellation).
  double area_sub = double(u.x) * area;
  double s = std::sin(area_sub - alpha), t = std::cos(area_sub - alpha);
  double cos_ab = dot_d(a, b);
  double p = t - cos_alpha, q = s + sin_alpha * cos_ab;
  double den = (q * s + p * t) * sin_alpha;
  double cos_b = den != 0 ? std::clamp(((q * t - p * s) * cos_alpha - q) / den, -1.0, 1.0) : 1.0;
  Vec3d c_perp = add_d(c, a, -dot_d(c, a));
  if (!normalize_d(&c_perp)) return std::nullopt;
  Vec3d c2 = add_d(scale_d(a, cos_b), c_perp, std::sqrt(std::max(0.0, 1 - cos_b * cos_b)));
  // Along the arc b..c' the cosine to b falls linearly in u.y.
  double z = std::clamp(1 - double(u.y) * (1 - dot_d(c2, b)), -1.0, 1.0);
  Vec3d c2_perp = add_d(c2, b, -dot_d(c2, b));
  Vec3d w = b;
  if (normalize_d(&c2_perp)) w = add_d(scale_d(b, z), c2_perp, std::sqrt(std::max(0.0, 1 - z * z)));
  if (!normalize_d(&w)) return std::nullopt;
  return SphericalTriangleSample{Vector3f{Float(w.x), Float(w.y), Float(w.z)}, area};
}

// Power heuristic with beta = 2 (Veach 1997, section 9.2.4), for one sample from
// each of two techniques with densities f and g.
inline Float power_heuristic(Float f_pdf, Float g_pdf) {
  if (std::isinf(f_pdf)) return 1;
  Float f = f_pdf * f_pdf, g = g_pdf * g_pdf;
  return f + g > 0 ? f / (f + g) : 0;
}
inline Float balance_heuristic(Float f_pdf, Float g_pdf) {
  return f_pdf + g_pdf > 0 ? f_pdf / (f_pdf + g_pdf) : 0;
}

}  // namespace prism
