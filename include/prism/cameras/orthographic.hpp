// prism/cameras/orthographic.hpp — an orthographic camera: parallel rays along
// the camera's +z from the plane z = 0, over a screen window `window_height`
// world units tall (its width follows the image's aspect ratio). Camera space
// and raster space as for PerspectiveCamera.
#pragma once
#include <optional>
#include "prism/cameras/perspective.hpp"
#include "prism/error.hpp"

namespace prism {

class OrthographicCamera {
 public:
  OrthographicCamera() = default;
  OrthographicCamera(const Transform& camera_to_world, Float window_height, int width, int height)
      : m_place(camera_to_world), m_width(width), m_height(height) {
    if (!(window_height > 0) || !std::isfinite(window_height))
      throw Error("orthographic camera: the window height must be positive and finite");
    m_half_h = window_height / 2;
    m_half_w = m_half_h * Float(width) / Float(height);
  }

  int width() const { return m_width; }
  int height() const { return m_height; }
  // Half the screen window's size in world units.
  Float window_half_width() const { return m_half_w; }
  Float window_half_height() const { return m_half_h; }
  // The camera's transform (when it moves: at its first key).
  const Transform& camera_to_world() const { return m_place.camera_to_world(); }
  const Shutter& shutter() const { return m_shutter; }
  void set_shutter(const Shutter& s) { m_shutter = Shutter::checked(s.open, s.close); }
  // Camera motion blur, as PerspectiveCamera::set_motion.
  void set_motion(const AnimatedTransform& camera_to_world) { m_place = CameraMotion(camera_to_world); }
  const CameraMotion& placement() const { return m_place; }

  Ray generate_ray(const CameraSample& s) const {
    Float x = (2 * s.p_film.x / Float(m_width) - 1) * m_half_w;
    Float y = (1 - 2 * s.p_film.y / Float(m_height)) * m_half_h;
    return m_place.at(s.time, [&](const Transform& to_world) {
      return Ray{to_world(Point3f{x, y, 0}), normalize(to_world(Vector3f{0, 0, 1})), s.time};
    });
  }

  // The pixel that sees p (if p is in front of the image plane and inside the
  // window), the point of the image plane it is seen from, and the importance:
  // raster area per unit of projected area, 1 / (s_x s_y) with s_x, s_y a
  // pixel's size in world units (docs/caustics.md). At `time` for a moving camera.
  std::optional<CameraConnection> connect(const Point3f& p, Point2f, Float time = 0) const {
    return m_place.at(time, [&](const Transform& to_world) { return connect_at(to_world, p); });
  }

 private:
  std::optional<CameraConnection> connect_at(const Transform& to_world, const Point3f& p) const {
    Point3f pc = inverse(to_world)(p);
    if (!(pc.z > 0)) return std::nullopt;
    Point2f raster{(pc.x / m_half_w + 1) * Float(m_width) / 2, (1 - pc.y / m_half_h) * Float(m_height) / 2};
    if (!(raster.x >= 0 && raster.x < Float(m_width) && raster.y >= 0 && raster.y < Float(m_height))) return std::nullopt;
    Float sx = 2 * m_half_w / Float(m_width), sy = 2 * m_half_h / Float(m_height);
    return CameraConnection{raster, to_world(Point3f{pc.x, pc.y, 0}), 1 / (sx * sy)};
  }

  CameraMotion m_place;
  int m_width = 1, m_height = 1;
  Float m_half_w = 1, m_half_h = 1;
  Shutter m_shutter;
};

}  // namespace prism
