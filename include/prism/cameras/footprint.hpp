// prism/cameras/footprint.hpp — how large a pixel is where a ray hits a
// surface, for texture filtering: pbrt-v4's approximation (Pharr, Jakob and
// Humphreys, 4th ed., 5.2.6 and 10.1.1, "Approximate_dp_dxy"), which needs
// no differentials carried along the path. For a point p with normal n, the
// camera's ray to p is shifted by one pixel along x (and y) on the image
// plane: for a perspective camera a direction one pixel apart from the eye,
// for an orthographic one the parallel ray one pixel over; each shifted ray
// meets the plane through p with normal n, and dp/dx, dp/dy are those points
// less p. Scaled by max(1/8, 1/sqrt(spp)) (pbrt-v4's choice): with many
// samples a pixel is integrated by the samples themselves, and a narrower
// filter blurs less.
//
// The same approximation serves every vertex of a path (pbrt-v4 does so for
// rays without differentials): after a bounce, a point seen in a mirror or
// lit indirectly is filtered as if the camera saw it directly, a footprint
// that is too small after curved mirrors and too large after nothing (it
// never grows with roughness). A thin lens is treated as its pinhole; a
// moving camera as where it is at its first key.
//
// uv_footprint() turns dp/dx, dp/dy into du/dx, dv/dx, du/dy, dv/dy by least
// squares against the surface's dp/du, dp/dv (pbrt-v4 10.1.1).
#pragma once
#include <algorithm>
#include <cmath>
#include "prism/cameras/orthographic.hpp"
#include "prism/cameras/perspective.hpp"
#include "prism/math/transform.hpp"
#include "prism/textures/texture.hpp"

namespace prism {

class PixelFootprint {
 public:
  PixelFootprint() = default;  // inactive: every footprint is 0
  PixelFootprint(const PerspectiveCamera& c, int spp) {
    const Float tan_half = c.fov_tan_half(), aspect = Float(c.width()) / Float(c.height());
    init(c.camera_to_world(), false, 2 * tan_half * aspect / Float(c.width()), 2 * tan_half / Float(c.height()), spp);
  }
  PixelFootprint(const OrthographicCamera& c, int spp) {
    init(c.camera_to_world(), true, 2 * c.window_half_width() / Float(c.width()),
         2 * c.window_half_height() / Float(c.height()), spp);
  }
  bool active() const { return m_active; }
  Float scale() const { return m_scale; }

  // dp/dx and dp/dy at p (world) on the plane of normal n; zero where a
  // shifted ray misses the plane (parallel to it) or p is behind the eye.
  void dp(const Point3f& p, const Normal3f& n, Vector3f* dpdx, Vector3f* dpdy) const {
    *dpdx = *dpdy = Vector3f(0, 0, 0);
    if (!m_active) return;
    const Point3f pc = m_to_camera(p);
    const Vector3f nc = m_to_camera(Vector3f(n));
    const Vector3f pv(pc.x, pc.y, pc.z);
    auto shifted = [&](const Vector3f& shift) -> Vector3f {
      if (m_ortho) {
        // The ray o = p + shift, direction +z, meets the plane at t.
        const Float denom = nc.z;
        const Float t = -dot(nc, shift) / denom;
        const Vector3f d = shift + Vector3f(0, 0, t);
        return std::isfinite(t) ? d : Vector3f(0, 0, 0);
      }
      if (!(pc.z > 0)) return Vector3f(0, 0, 0);
      const Vector3f dir = pv / pc.z + shift;  // through the image plane z = 1, one pixel over
      const Float denom = dot(nc, dir);
      const Float t = dot(nc, pv) / denom;
      const Vector3f d = dir * t - pv;
      return std::isfinite(t) && t > 0 ? d : Vector3f(0, 0, 0);
    };
    *dpdx = m_to_world(shifted(Vector3f(m_sx, 0, 0)));
    *dpdy = m_to_world(shifted(Vector3f(0, -m_sy, 0)));
  }

 private:
  void init(const Transform& camera_to_world, bool ortho, Float sx, Float sy, int spp) {
    m_to_world = camera_to_world;
    m_to_camera = inverse(camera_to_world);
    m_ortho = ortho;
    m_scale = std::max(Float(0.125), 1 / std::sqrt(Float(std::max(spp, 1))));
    m_sx = sx * m_scale;
    m_sy = sy * m_scale;
    m_active = true;
  }
  Transform m_to_world, m_to_camera;
  Float m_sx = 0, m_sy = 0, m_scale = 1;
  bool m_ortho = false, m_active = false;
};

// du/dx, dv/dx, du/dy, dv/dy from dp/dx, dp/dy and the surface's dp/du,
// dp/dv: the least-squares solution of dp = dp/du du + dp/dv dv (the 2 x 2
// normal equations); zero where dp/du and dp/dv are degenerate, each value
// clamped to +-1e8.
inline TextureFootprint uv_footprint(const Vector3f& dpdx, const Vector3f& dpdy, const Vector3f& dpdu,
                                const Vector3f& dpdv) {
  const double a = dot(dpdu, dpdu), b = dot(dpdu, dpdv), c = dot(dpdv, dpdv);
  const double det = a * c - b * b;
  if (!(std::abs(det) > 1e-30) || !std::isfinite(det)) return {};
  auto solve = [&](const Vector3f& d, Float* du, Float* dv) {
    const double ru = dot(dpdu, d), rv = dot(dpdv, d);
    const double u = (c * ru - b * rv) / det, v = (a * rv - b * ru) / det;
    *du = std::isfinite(u) ? Float(std::clamp(u, -1e8, 1e8)) : Float(0);
    *dv = std::isfinite(v) ? Float(std::clamp(v, -1e8, 1e8)) : Float(0);
  };
  TextureFootprint f;
  solve(dpdx, &f.dudx, &f.dvdx);
  solve(dpdy, &f.dudy, &f.dvdy);
  return f;
}

}  // namespace prism
