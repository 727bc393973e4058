// prism/cameras/perspective.hpp — a perspective camera with an optional thin
// lens. Camera space: +x right, +y up, +z forward. Raster space: x right, y
// down, in pixels. fov_y is the vertical field of view (as glTF's yfov).
#pragma once
#include "prism/geometry/ray.hpp"
#include "prism/sampling/warps.hpp"

namespace prism {

struct CameraSample {
  Point2f p_film;  // raster position, pixels
  Point2f p_lens;  // [0,1)^2
  Float time = 0;
};

class PerspectiveCamera {
 public:
  PerspectiveCamera() = default;
  PerspectiveCamera(const Transform& camera_to_world, Float fov_y_radians, int width, int height,
                    Float lens_radius = 0, Float focal_distance = 1)
      : m_to_world(camera_to_world), m_width(width), m_height(height), m_lens_radius(lens_radius),
        m_focal_distance(focal_distance) {
    m_tan_half = std::tan(fov_y_radians / 2);
    m_aspect = Float(width) / Float(height);
  }

  int width() const { return m_width; }
  int height() const { return m_height; }
  const Transform& camera_to_world() const { return m_to_world; }

  // A ray through the film position with a unit direction.
  Ray generate_ray(const CameraSample& s) const {
    Float sx = (2 * s.p_film.x / Float(m_width) - 1) * m_tan_half * m_aspect;
    Float sy = (1 - 2 * s.p_film.y / Float(m_height)) * m_tan_half;
    Vector3f d = normalize(Vector3f{sx, sy, 1});
    Point3f o{0, 0, 0};
    if (m_lens_radius > 0) {
      Point2f lens = sample_uniform_disk_concentric(s.p_lens) * m_lens_radius;
      Float ft = m_focal_distance / d.z;
      Point3f focus = o + d * ft;
      o = Point3f{lens.x, lens.y, 0};
      d = normalize(focus - o);
    }
    return Ray{m_to_world(o), normalize(m_to_world(d)), s.time};
  }

 private:
  Transform m_to_world;
  int m_width = 1, m_height = 1;
  Float m_tan_half = 1, m_aspect = 1;
  Float m_lens_radius = 0, m_focal_distance = 1;
};

}  // namespace prism
