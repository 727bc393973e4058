// prism/sampling/warps.hpp — maps from [0,1)^2 to common domains, each paired
// with its density. Naming: sample_x(u) returns a point, pdf_x(...) its density
// in the measure named in the comment (area for disks and triangles, solid angle
// for directions). References: pbrt-v4 book, sections A.5 and 13.6;
// Shirley & Chiu 1997 (concentric disk).
#pragma once
#include <array>
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
