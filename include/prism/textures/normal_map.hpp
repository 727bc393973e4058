// prism/textures/normal_map.hpp — tangent-space normal mapping (glTF 2.0
// material.normalTexture).
//
// glTF: the texel's rgb in [0, 1] maps to the tangent-space normal
// (2r - 1, 2g - 1, 2b - 1), whose x and y are multiplied by normalTexture.scale
// before normalising; x points along the tangent T, y along the bitangent
// B = cross(N, T) * tangent.w, z along the normal N. The texel is linear (normal
// maps are never sRGB-decoded).
//
// Robustness (the render loop must not produce NaN):
// - T, B and N come from interpolated vertex attributes and need not be
//   orthonormal: N is normalised, T is made orthogonal to N (Gram-Schmidt) and
//   normalised, and B = sign * cross(N, T), where sign is the sign of
//   dot(B_in, cross(N, T)) — the handedness the caller's bitangent carries
//   (+1 when B_in gives none: zero or NaN).
// - A degenerate T (zero, NaN, or parallel to N within the rounding error of
//   the Gram-Schmidt step) gets replaced by an arbitrary tangent around N
//   (Duff et al. 2017, math/frame.hpp).
// - A non-finite or zero tangent-space normal (NaN texel or scale) gives N; a
//   degenerate N gives (0, 0, 1).
// - The result is unit length and finite. A mapped normal on or below the
//   tangent plane (dot(n, N) <= 0, possible with large scales or odd texels) is
//   bent back to normal_map_min_cos above it, keeping its azimuth.
#pragma once
#include <algorithm>
#include <cmath>
#include "prism/math/frame.hpp"
#include "prism/math/vector.hpp"
#include "prism/spectra/rgb.hpp"

namespace prism {

// The cosine to N that a mapped normal below the tangent plane is bent back to
// (about 0.57 degrees above the plane): just above the plane, with a margin
// far larger than the rounding of the final normalisation.
inline constexpr Float normal_map_min_cos = Float(0.01);

namespace detail {
// v / |v|, scaled by its largest component first so that neither the squares
// overflow nor underflow; false (and v unchanged) when v is zero or not finite.
template <template <class> class C>
bool normalize_robust(C<Float>& v) noexcept {
  const Float m = std::max({std::abs(v.x), std::abs(v.y), std::abs(v.z)});
  if (!(m > 0) || !std::isfinite(m)) return false;
  C<Float> s = v / m;
  v = s / length(s);
  return true;
}
}  // namespace detail

inline Normal3f apply_normal_map(RGB texel, Float scale, const Vector3f& T, const Vector3f& B,
                                 const Normal3f& N) noexcept {
  // The geometric frame.
  Vector3f n(N);
  if (!detail::normalize_robust(n)) n = Vector3f(0, 0, 1);
  Vector3f t = T;
  bool t_ok = false;
  if (detail::normalize_robust(t)) {
    // Gram-Schmidt. The residual of a t parallel to n is rounding noise,
    // bounded by a few ulps of |t| = 1: below that bound t carries no direction.
    t -= n * dot(n, t);
    t_ok = std::max({std::abs(t.x), std::abs(t.y), std::abs(t.z)}) > gamma(8) && detail::normalize_robust(t);
  }
  if (!t_ok) {
    Vector3f b_any;
    coordinate_system(n, &t, &b_any);
  }
  Vector3f b = cross(n, t);
  if (dot(B, b) < 0) b = -b;  // NaN or zero B_in compares false: sign +1

  // The tangent-space normal.
  Vector3f ts(scale * (2 * texel.r - 1), scale * (2 * texel.g - 1), 2 * texel.b - 1);
  if (!detail::normalize_robust(ts)) return Normal3f(n);

  Vector3f w = t * ts.x + b * ts.y + n * ts.z;
  if (!detail::normalize_robust(w)) return Normal3f(n);
  if (dot(w, n) > 0) return Normal3f(w);

  // Below (or on) the tangent plane: keep the azimuth, lift to normal_map_min_cos.
  Vector3f tangential = w - n * dot(w, n);
  if (!detail::normalize_robust(tangential)) return Normal3f(n);  // w was -n
  const Float sin_min = std::sqrt(1 - normal_map_min_cos * normal_map_min_cos);
  Vector3f lifted = tangential * sin_min + n * normal_map_min_cos;
  if (!detail::normalize_robust(lifted)) return Normal3f(n);
  return Normal3f(lifted);
}

}  // namespace prism
