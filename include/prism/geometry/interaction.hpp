// prism/geometry/interaction.hpp — what a ray hit: the point with its
// conservative error bound, the geometric normal, the shading frame, uv, and the
// ids of what was hit. Rays spawned from it start outside the error bound.
#pragma once
#include <algorithm>
#include <cstdint>
#include "prism/geometry/ray.hpp"
#include "prism/spectra/rgb.hpp"

namespace prism {

struct SurfaceInteraction {
  Point3f p;
  Vector3f p_error;   // |p - exact point| <= p_error, per component
  Normal3f n;         // unit geometric normal (oriented by winding or outwards)
  Normal3f ns;        // unit shading normal, in the hemisphere of n
  Vector3f dpdu;      // surface tangent, used to orient the shading frame
  Vector3f dpdv;      // the other uv derivative (normal mapping without tangents)
  Point2f uv;
  Point2f uv1;        // second texture coordinate set (glTF TEXCOORD_1), (0, 0) if absent
  // The pixel's footprint in uv (TEXCOORD_0): how uv changes from one pixel
  // to the next along x and y, for texture filtering. 0 unless the scene has
  // a PixelFootprint (cameras/footprint.hpp, Scene::set_pixel_footprint).
  Float dudx = 0, dvdx = 0, dudy = 0, dvdy = 0;
  Vector3f tangent;   // a mesh's own tangent (glTF TANGENT), zero if absent
  Float tangent_w = 1;  // its bitangent handedness
  RGB color{1};       // vertex colour (glTF COLOR_0), white if absent
  Float alpha = 1;    // vertex alpha
  Vector3f wo;        // unit direction back along the incoming ray
  // How far back along wo space is known to be empty (half the incoming
  // segment's length), 0 when unknown; see spawn_origin.
  Float wo_free = 0;
  Float time = 0;
  int32_t material = -1;    // index into the scene's materials
  int32_t area_light = -1;  // index into the scene's lights, -1 if not emissive
  uint32_t instance = 0, primitive = 0;

  // A ray leaving on wo's side first steps back along the incoming ray,
  // through space that ray found empty, by twice the error box's size (at
  // most wo_free): a hit point near a concave edge or corner whose error box
  // reaches the neighbouring face (rounded onto or past its plane) then starts
  // on that face's inner side too, not only off its own surface.
  // tests/geometry/self_intersection_test.cpp has the near-edge box test.
  Point3f spawn_origin(const Vector3f& w) const {
    if (wo_free > 0 && dot(w, n) * dot(wo, n) > 0) {
      Float e = std::min(wo_free, 2 * (p_error.x + p_error.y + p_error.z));
      Vector3f step = wo * e;
      Point3f q = p + step;
      // q's error: p's, the rounding of wo * e and of the sum.
      Vector3f q_error = p_error + abs(step) * gamma(1) + abs(q - Point3f{}) * gamma(1);
      return offset_ray_origin(q, q_error, n, w);
    }
    return offset_ray_origin(p, p_error, n, w);
  }
  Ray spawn_ray(const Vector3f& d) const { return {spawn_origin(d), d, time}; }
  // A ray towards p_to (itself already offset off its own surface); it reaches
  // p_to at t = 1.
  Ray spawn_ray_to(const Point3f& p_to) const {
    Point3f o = spawn_origin(p_to - p);
    return {o, p_to - o, time};
  }
  // Shading frame: z = shading normal, x along the tangent (Gram-Schmidt).
  Frame shading_frame() const {
    Vector3f z(ns);
    Vector3f x = dpdu - z * dot(dpdu, z);
    Float l2 = length_squared(x);
    if (!(l2 > 0) || !std::isfinite(l2)) return Frame::from_z(z);
    x = x / std::sqrt(l2);
    return Frame::from_xz(x, z);
  }
};

}  // namespace prism
