// prism/cameras/perspective.hpp — a perspective camera with an optional thin
// lens. Camera space: +x right, +y up, +z forward. Raster space: x right, y
// down, in pixels. fov_y is the vertical field of view (as glTF's yfov).
// Also what every camera shares: CameraSample, Shutter, CameraMotion (camera
// motion blur) and the CameraLike concept.
#pragma once
#include <concepts>
#include <optional>
#include <string>
#include "prism/attributes.hpp"
#include "prism/error.hpp"
#include "prism/geometry/ray.hpp"
#include "prism/math/animated_transform.hpp"
#include "prism/math/transform.hpp"
#include "prism/sampling/warps.hpp"

namespace prism {

// Where a world point appears to the camera, for tracing paths from the lights
// (light tracing): the raster position, the (sampled) lens point it is joined
// to, and the camera's importance factor for that connection.
struct CameraConnection {
  Point2f p_raster;  // pixels
  Point3f p_lens;    // world space
  // Raster area per unit area of the surface at the point, over |cos| there:
  // for a perspective camera 1 / (r^2 cos^3(theta) s_x s_y), with r the distance
  // to the lens point, theta the angle to the optical axis and s_x, s_y the
  // size of a pixel on the plane at distance 1. A light path's contribution to
  // its pixel is beta * f * |cos at the point| * importance (docs/caustics.md).
  Float importance = 0;
};

struct CameraSample {
  Point2f p_film;  // raster position, pixels
  Point2f p_lens;  // [0,1)^2
  Float time = 0;
};

// The interval during which a camera's shutter is open. Rays get a time
// drawn uniformly in [open, close); an empty interval (the default) gives
// every ray the time `open` and costs no sample dimension.
struct Shutter {
  Float open = 0, close = 0;
  bool is_open_interval() const { return close > open; }
  Float time(Float u) const { return open + u * (close - open); }
  // Throws prism::Error unless both ends are finite and open <= close.
  static Shutter checked(Float open, Float close) {
    if (!std::isfinite(open) || !std::isfinite(close) || close < open)
      throw Error("camera: the shutter interval [" + std::to_string(open) + ", " + std::to_string(close) +
                  "] must be finite with open <= close");
    return {open, close};
  }
};

// What render() and the light-tracing pass ask of a camera: a ray for a
// camera sample (at the sample's time), the shutter interval, and where a
// world point appears on the film at a time (nullopt when it does not).
// PerspectiveCamera and OrthographicCamera model it.
template <class C>
concept CameraLike = requires(const C& c, const CameraSample& s, const Point3f& p, Point2f u, Float time) {
  { c.generate_ray(s) } -> std::same_as<Ray>;
  { c.shutter() } -> std::convertible_to<Shutter>;
  { c.connect(p, u, time) } -> std::same_as<std::optional<CameraConnection>>;
};

// Camera motion blur: where a camera is at each time. Still (the default) it
// is one Transform and a camera pays one branch per ray for the option;
// moving, an AnimatedTransform (translation and stretch linear, rotation by
// slerp, between two keys; before the first key's time and after the
// second's it stays at that key) evaluated at each ray's time. Rays get
// their times from the camera's Shutter, so the motion matters only while
// the shutter is open for an interval.
class CameraMotion {
 public:
  CameraMotion() = default;
  explicit CameraMotion(const Transform& camera_to_world) : m_still(camera_to_world) {}
  // A motion whose keys are equal is still: camera_to_world() is its first key.
  explicit CameraMotion(const AnimatedTransform& camera_to_world)
      : m_still(camera_to_world.at(camera_to_world.start_time())),
        m_motion(camera_to_world),
        m_moving(camera_to_world.is_moving()) {}
  bool is_moving() const { return m_moving; }
  // The transform when still, else at the first key.
  const Transform& camera_to_world() const { return m_still; }
  const AnimatedTransform& motion() const { return m_motion; }
  // Calls f with the camera-to-world transform at `time`.
  template <class F>
  decltype(auto) at(Float time, F&& f) const {
    if (!m_moving) [[likely]] return f(m_still);
    const Transform t = transform_at(time);
    return f(t);
  }
  // The transform at `time` (out of line: a still camera's rays stay lean).
  PRISM_NOINLINE Transform transform_at(Float time) const { return m_moving ? m_motion.at(time) : m_still; }

 private:
  Transform m_still;
  AnimatedTransform m_motion;
  bool m_moving = false;
};

// Which extent of the image a field of view spans: the vertical one (glTF's
// yfov, prism's default), the horizontal one, or the shorter of the two
// (pbrt-v4's "fov").
enum class FovAxis { vertical, horizontal, shorter };

class PerspectiveCamera {
 public:
  PerspectiveCamera() = default;
  // The vertical field of view that equals `fov` (radians) along `axis` for
  // an image of width x height pixels.
  static Float vertical_fov(Float fov, FovAxis axis, int width, int height) {
    const bool horizontal = axis == FovAxis::horizontal || (axis == FovAxis::shorter && width < height);
    if (!horizontal) return fov;
    return 2 * std::atan(std::tan(fov / 2) * Float(height) / Float(width));
  }
  // A camera whose field of view `fov` spans `axis` (see FovAxis).
  PerspectiveCamera(const Transform& camera_to_world, Float fov, FovAxis axis, int width, int height,
                    Float lens_radius = 0, Float focal_distance = 1)
      : PerspectiveCamera(camera_to_world, vertical_fov(fov, axis, width, height), width, height, lens_radius,
                          focal_distance) {}
  PerspectiveCamera(const Transform& camera_to_world, Float fov_y_radians, int width, int height,
                    Float lens_radius = 0, Float focal_distance = 1)
      : m_place(camera_to_world), m_width(width), m_height(height), m_lens_radius(lens_radius),
        m_focal_distance(focal_distance) {
    if (!(lens_radius >= 0) || !std::isfinite(lens_radius))
      throw Error("camera: the aperture radius must be zero or positive and finite, got " + std::to_string(lens_radius));
    if (lens_radius > 0 && (!(focal_distance > 0) || !std::isfinite(focal_distance)))
      throw Error("camera: the focus distance must be positive and finite, got " + std::to_string(focal_distance));
    if (!(fov_y_radians > 0 && fov_y_radians < Float(3.14159265)))
      throw Error("camera: the vertical field of view must be in (0, pi) radians, got " + std::to_string(fov_y_radians));
    m_tan_half = std::tan(fov_y_radians / 2);
    m_aspect = Float(width) / Float(height);
  }

  int width() const { return m_width; }
  int height() const { return m_height; }
  // The camera's transform (when it moves: at its first key).
  const Transform& camera_to_world() const { return m_place.camera_to_world(); }
  Float lens_radius() const { return m_lens_radius; }
  // tan(fov_y / 2): half the image plane's height at distance 1.
  Float fov_tan_half() const { return m_tan_half; }
  Float focal_distance() const { return m_focal_distance; }
  const Shutter& shutter() const { return m_shutter; }
  void set_shutter(const Shutter& s) { m_shutter = Shutter::checked(s.open, s.close); }
  // Camera motion blur: the camera-to-world transform over time, in place of
  // the constructor's (CameraMotion). Rays and connect() use it at their time.
  void set_motion(const AnimatedTransform& camera_to_world) { m_place = CameraMotion(camera_to_world); }
  const CameraMotion& placement() const { return m_place; }

  // A ray through the film position with a unit direction, at the sample's time.
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
    return m_place.at(s.time, [&](const Transform& to_world) { return Ray{to_world(o), normalize(to_world(d)), s.time}; });
  }

  // Joins the world point p to a lens point (u_lens picks it when the lens has
  // an aperture) and finds the pixel whose camera ray, at `time`, would see p
  // that way. nullopt when p is behind the camera or outside the film.
  std::optional<CameraConnection> connect(const Point3f& p, Point2f u_lens, Float time = 0) const {
    return m_place.at(time, [&](const Transform& to_world) { return connect_at(to_world, p, u_lens); });
  }

 private:
  std::optional<CameraConnection> connect_at(const Transform& to_world, const Point3f& p, Point2f u_lens) const {
    Point3f pc = inverse(to_world)(p);
    Point3f lens{0, 0, 0};
    if (m_lens_radius > 0) {
      Point2f l = sample_uniform_disk_concentric(u_lens) * m_lens_radius;
      lens = Point3f{l.x, l.y, 0};
    }
    Vector3f v = pc - lens;
    if (!(v.z > 0)) return std::nullopt;
    // The point on the plane z = 1 of the pinhole ray that sees the same
    // point of the plane of focus (for a pinhole: simply v / v.z).
    Float fx, fy;
    if (m_lens_radius > 0) {
      Float t = m_focal_distance / v.z;
      fx = (lens.x + v.x * t) / m_focal_distance;
      fy = (lens.y + v.y * t) / m_focal_distance;
    } else {
      fx = v.x / v.z;
      fy = v.y / v.z;
    }
    Point2f raster{(fx / (m_tan_half * m_aspect) + 1) * Float(m_width) / 2, (1 - fy / m_tan_half) * Float(m_height) / 2};
    if (!(raster.x >= 0 && raster.x < Float(m_width) && raster.y >= 0 && raster.y < Float(m_height))) return std::nullopt;
    Point3f lens_world = to_world(lens);
    Float r2 = distance_squared(p, lens_world);
    Float cos_theta = v.z / length(v);
    Float sx = 2 * m_tan_half * m_aspect / Float(m_width), sy = 2 * m_tan_half / Float(m_height);
    return CameraConnection{raster, lens_world, 1 / (r2 * cos_theta * cos_theta * cos_theta * sx * sy)};
  }

  CameraMotion m_place;
  int m_width = 1, m_height = 1;
  Float m_tan_half = 1, m_aspect = 1;
  Float m_lens_radius = 0, m_focal_distance = 1;
  Shutter m_shutter;
};

}  // namespace prism
