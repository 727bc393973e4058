// prism/lights/punctual.hpp — lights without area: point and spot lights
// (delta in position), the distant light (delta in direction), and the sun, a
// distant light of finite angular size, sampled uniformly in its cone, so that
// unlike the others it can be hit by BSDF-sampled rays and weighed by MIS
// (pbrt-v4 book, sections 12.2-12.4). The spot's falloff follows glTF
// KHR_lights_punctual. Units and densities: docs/lights.md.
#pragma once
#include <string>
#include "prism/error.hpp"
#include "prism/lights/light.hpp"
#include "prism/spectra/traits.hpp"

namespace prism {

namespace detail {

inline void check_non_negative(const RGB& c, const char* light, const char* what) {
  if (!c.is_finite() || c.r < 0 || c.g < 0 || c.b < 0)
    throw Error(std::string(light) + ": " + what + " (" + std::to_string(c.r) + ", " + std::to_string(c.g) + ", " +
                std::to_string(c.b) + ") must be finite and non-negative");
}
inline void check_non_negative(Float v, const char* light, const char* what) {
  if (!std::isfinite(v) || v < 0)
    throw Error(std::string(light) + ": " + what + " " + std::to_string(v) + " must be finite and non-negative");
}
inline void check_finite(const Point3f& p, const char* light, const char* what) {
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
    throw Error(std::string(light) + ": " + what + " must be finite");
}
// A unit copy of d, which must be finite and non-zero.
inline Vector3f checked_direction(const Vector3f& d, const char* light, const char* what) {
  Float l2 = length_squared(d);
  if (!std::isfinite(d.x) || !std::isfinite(d.y) || !std::isfinite(d.z) || !(l2 > 0) || !std::isfinite(l2))
    throw Error(std::string(light) + ": " + what + " must be finite and non-zero");
  return d / std::sqrt(l2);
}

}  // namespace detail

// Emits intensity I (radiant intensity, W/sr, as RGB times scale) equally in
// every direction from a point; the radiance a sample carries is I / d^2.
template <class S>
class PointLight {
 public:
  PointLight(const Point3f& position, const RGB& intensity, Float scale = 1)
      : m_p(position), m_intensity(intensity * scale) {
    detail::check_finite(position, "point light", "position");
    detail::check_non_negative(intensity, "point light", "intensity");
    detail::check_non_negative(scale, "point light", "scale");
  }

  LightKind kind() const { return LightKind::delta_position; }
  const Point3f& position() const { return m_p; }

  // The one direction to the light; pdf 1 (a delta), L = I / d^2.
  template <class W>
  std::optional<LightLiSample<S>> sample_li(const LightSampleContext& ctx, Point2f /*u*/, const W& lambda) const {
    Vector3f to_light = m_p - ctx.p;
    Float d2 = length_squared(to_light);
    if (!(d2 > 0) || m_intensity.is_black()) return std::nullopt;
    Vector3f wi = to_light / std::sqrt(d2);
    S L = spectrum_traits<S>::illuminant(m_intensity, lambda) / d2;
    return LightLiSample<S>{L, wi, 1, m_p, false};
  }
  // No BSDF-sampled direction hits a point.
  Float pdf_li(const LightSampleContext&, const Vector3f&, const SurfaceInteraction&) const { return 0; }

  template <class W>
  S power(const W& lambda) const {
    return spectrum_traits<S>::illuminant(m_intensity, lambda) * (4 * pi);
  }

 private:
  Point3f m_p;
  RGB m_intensity;
};

// glTF KHR_lights_punctual spot falloff: with t = (cos theta - cos outer) /
// max(0.001, cos inner - cos outer) clamped to [0, 1], the intensity is scaled
// by t^2 (1 inside the inner cone, 0 outside the outer one).
struct SpotFalloff {
  Float cos_inner = 1, cos_outer = 0;
  Float inv_range = 1;  // 1 / max(0.001, cos_inner - cos_outer)

  SpotFalloff() = default;
  SpotFalloff(Float inner_angle, Float outer_angle)
      : cos_inner(std::cos(inner_angle)), cos_outer(std::cos(outer_angle)),
        inv_range(1 / std::max(Float(0.001), cos_inner - cos_outer)) {}
  Float operator()(Float cos_theta) const {
    return sqr(std::clamp((cos_theta - cos_outer) * inv_range, Float(0), Float(1)));
  }
  // Integral of the falloff over the sphere of directions.
  Float solid_angle() const {
    double range = 1 / double(inv_range), co = cos_outer;
    double top = std::min(1.0, co + range);  // where t reaches 1
    double ramp = (top - co) * (top - co) * (top - co) / (3 * range * range);
    return Float(2 * double(pi) * (ramp + (1 - top)));
  }
};

// A point light restricted to a cone about `direction` (the direction the
// light travels), with glTF's smooth falloff between the inner and outer cone
// angles (radians, 0 <= inner <= outer <= pi). Intensity as PointLight: the
// value inside the inner cone.
template <class S>
class SpotLight {
 public:
  SpotLight(const Point3f& position, const Vector3f& direction, const RGB& intensity, Float scale,
            Float inner_angle, Float outer_angle)
      : m_p(position), m_intensity(intensity * scale) {
    const char* name = "spot light";
    detail::check_finite(position, name, "position");
    m_axis = detail::checked_direction(direction, name, "direction");
    detail::check_non_negative(intensity, name, "intensity");
    detail::check_non_negative(scale, name, "scale");
    if (!std::isfinite(outer_angle) || !(outer_angle > 0) || outer_angle > pi)
      throw Error("spot light: outer cone angle " + std::to_string(outer_angle) + " must be in (0, pi]");
    if (!std::isfinite(inner_angle) || inner_angle < 0 || inner_angle > outer_angle)
      throw Error("spot light: inner cone angle " + std::to_string(inner_angle) +
                  " must be in [0, outer cone angle = " + std::to_string(outer_angle) + "]");
    m_falloff = SpotFalloff(inner_angle, outer_angle);
  }

  LightKind kind() const { return LightKind::delta_position; }
  const Point3f& position() const { return m_p; }
  const Vector3f& direction() const { return m_axis; }
  const SpotFalloff& falloff() const { return m_falloff; }

  // The one direction to the light; pdf 1 (a delta), L = I falloff / d^2.
  // Fails outside the outer cone.
  template <class W>
  std::optional<LightLiSample<S>> sample_li(const LightSampleContext& ctx, Point2f /*u*/, const W& lambda) const {
    Vector3f to_light = m_p - ctx.p;
    Float d2 = length_squared(to_light);
    if (!(d2 > 0) || m_intensity.is_black()) return std::nullopt;
    Vector3f wi = to_light / std::sqrt(d2);
    Float f = m_falloff(-dot(wi, m_axis));
    if (f == 0) return std::nullopt;
    S L = spectrum_traits<S>::illuminant(m_intensity, lambda) * (f / d2);
    return LightLiSample<S>{L, wi, 1, m_p, false};
  }
  Float pdf_li(const LightSampleContext&, const Vector3f&, const SurfaceInteraction&) const { return 0; }

  template <class W>
  S power(const W& lambda) const {
    return spectrum_traits<S>::illuminant(m_intensity, lambda) * m_falloff.solid_angle();
  }

 private:
  Point3f m_p;
  Vector3f m_axis;
  RGB m_intensity;
  SpotFalloff m_falloff;
};

// Parallel light travelling along `direction` from infinitely far away, with
// irradiance E (W/m^2 on a surface facing it, RGB times scale): a sample carries
// L = E with pdf 1. Power is E through a disk of the scene's bounding radius.
template <class S>
class DistantLight {
 public:
  DistantLight(const Vector3f& direction, const RGB& irradiance, Float scale = 1)
      : m_irradiance(irradiance * scale) {
    m_to_light = -detail::checked_direction(direction, "distant light", "direction");
    detail::check_non_negative(irradiance, "distant light", "irradiance");
    detail::check_non_negative(scale, "distant light", "scale");
  }

  LightKind kind() const { return LightKind::delta_direction; }
  // Unit direction from the scene towards the light.
  const Vector3f& to_light() const { return m_to_light; }

  template <class W>
  std::optional<LightLiSample<S>> sample_li(const LightSampleContext& ctx, Point2f /*u*/, const W& lambda) const {
    if (m_irradiance.is_black()) return std::nullopt;
    S L = spectrum_traits<S>::illuminant(m_irradiance, lambda);
    return LightLiSample<S>{L, m_to_light, 1, ctx.p + m_to_light * (2 * m_scene_radius), true};
  }
  Float pdf_li(const LightSampleContext&, const Vector3f&, const SurfaceInteraction&) const { return 0; }

  void set_scene_radius(Float r) { m_scene_radius = r; }
  Float scene_radius() const { return m_scene_radius; }
  template <class W>
  S power(const W& lambda) const {
    return spectrum_traits<S>::illuminant(m_irradiance, lambda) * (pi * sqr(m_scene_radius));
  }

 private:
  Vector3f m_to_light;
  RGB m_irradiance;
  Float m_scene_radius = 1;
};

// A distant light of finite angular diameter: constant radiance from a cone of
// half-angle theta_max about the direction towards the light. It is given, like
// DistantLight, by the irradiance E it delivers to a surface facing it; the
// radiance is then L = E / (pi sin^2 theta_max) (the cosine-weighted solid
// angle of the cone). Directions are sampled uniformly in the cone, pdf
// 1 / (2 pi (1 - cos theta_max)) per solid angle, and rays escaping into the
// cone see Le: an infinite light, weighed by MIS like an environment map.
template <class S>
class SunLight {
 public:
  // angular_diameter in radians, in (0, pi] (the Sun: about 0.0093).
  SunLight(const Vector3f& direction, const RGB& irradiance, Float scale, Float angular_diameter) {
    const char* name = "sun light";
    m_to_light = -detail::checked_direction(direction, name, "direction");
    detail::check_non_negative(irradiance, name, "irradiance");
    detail::check_non_negative(scale, name, "scale");
    if (!std::isfinite(angular_diameter) || !(angular_diameter > 0) || angular_diameter > pi)
      throw Error("sun light: angular diameter " + std::to_string(angular_diameter) + " must be in (0, pi]");
    double half = double(angular_diameter) / 2;
    m_sin2_max = Float(sqr(std::sin(half)));
    // 1 - cos theta_max = 2 sin^2(theta_max / 2), without the cancellation of
    // 1 - cos for a small cone.
    m_one_minus_cos_max = Float(2 * sqr(std::sin(half / 2)));
    m_frame = Frame::from_z(m_to_light);
    m_irradiance = irradiance * scale;
    m_radiance = m_irradiance / (pi * m_sin2_max);
  }

  LightKind kind() const { return LightKind::infinite; }
  const Vector3f& to_light() const { return m_to_light; }
  const RGB& radiance() const { return m_radiance; }
  Float cone_pdf() const { return 1 / (2 * pi * m_one_minus_cos_max); }

  // Radiance along a ray escaping the scene: L inside the cone, 0 outside.
  template <class W>
  S Le(const Ray& ray, const W& lambda) const {
    if (!in_cone(ray.d)) return S{};
    return spectrum_traits<S>::illuminant(m_radiance, lambda);
  }

  // Uniform in the cone: 1 - cos theta uniform in [0, 1 - cos theta_max], so
  // that small cones keep their precision.
  template <class W>
  std::optional<LightLiSample<S>> sample_li(const LightSampleContext& /*ctx*/, Point2f u, const W& lambda) const {
    if (m_radiance.is_black()) return std::nullopt;
    Float omc = u.x * m_one_minus_cos_max;
    Float sin_theta = safe_sqrt(omc * (2 - omc));
    Vector3f wl = spherical_direction(sin_theta, 1 - omc, 2 * pi * u.y);
    Vector3f wi = normalize(m_frame.from_local(wl));
    S L = spectrum_traits<S>::illuminant(m_radiance, lambda);
    return LightLiSample<S>{L, wi, cone_pdf(), {}, true};
  }
  Float pdf_li(const LightSampleContext&, const Vector3f& w, const SurfaceInteraction&) const {
    return in_cone(w) ? cone_pdf() : 0;
  }

  void set_scene_radius(Float r) { m_scene_radius = r; }
  Float scene_radius() const { return m_scene_radius; }
  // All of E through a disk of the scene's bounding radius, as DistantLight.
  template <class W>
  S power(const W& lambda) const {
    return spectrum_traits<S>::illuminant(m_irradiance, lambda) * (pi * sqr(m_scene_radius));
  }

 private:
  // Within theta_max of the axis, tested by sin^2 of the angle (|w x axis|^2),
  // which keeps its precision for small cones, where cos is close to 1.
  bool in_cone(const Vector3f& w) const {
    Float l2 = length_squared(w);
    if (!(l2 > 0)) return false;
    Float c = dot(w, m_to_light);
    if (!(c > 0)) return false;
    return length_squared(cross(w, m_to_light)) <= m_sin2_max * l2;
  }

  Vector3f m_to_light;
  Frame m_frame;
  RGB m_irradiance, m_radiance;
  Float m_sin2_max = 0, m_one_minus_cos_max = 0;
  Float m_scene_radius = 1;
};

}  // namespace prism
