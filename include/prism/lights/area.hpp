// prism/lights/area.hpp — diffuse area lights on triangles and spheres, emitting
// a constant radiance Le from their front side (or both sides).
// Triangles are sampled uniformly by the solid angle they subtend (spherical
// triangles, Arvo 1995) when that is between kMinSphericalSolidAngle and
// kMaxSphericalSolidAngle, and uniformly by area otherwise; spheres by the
// cone of directions they subtend when the receiver is outside (pbrt-v4 book,
// section 6.2.4) and by area otherwise; sample_li converts area densities to
// solid angle. docs/lights.md gives the measurement behind the thresholds.
#pragma once
#include <algorithm>
#include <array>
#include <memory>
#include "prism/geometry/sphere.hpp"
#include "prism/lights/light.hpp"
#include "prism/sampling/warps.hpp"
#include "prism/textures/texture.hpp"

namespace prism {

namespace detail {
struct EmittedDirection {
  Normal3f n;  // the emitting side's normal
  Vector3f w;
  Float pdf;   // per solid angle, including the choice of side
};
// A direction leaving a diffuse emitter with normal n: cosine-distributed
// about n, or about either side with probability 1/2 if it emits from both.
inline std::optional<EmittedDirection> sample_emitted_direction(Normal3f n, bool two_sided, Point2f u_dir,
                                                                Float u_side) {
  Float side_pdf = 1;
  if (two_sided) {
    side_pdf = 0.5f;
    if (u_side < 0.5f) n = -n;
  }
  Vector3f wl = sample_cosine_hemisphere(u_dir);
  Float pdf = pdf_cosine_hemisphere(wl.z) * side_pdf;
  if (!(pdf > 0)) return std::nullopt;
  return EmittedDirection{n, Frame::from_z(Vector3f(n)).from_local(wl), pdf};
}
}  // namespace detail

// Which side of a triangle emits: the front (the side its winding's normal
// points to, glTF's and prism's convention), the back, or both.
enum class EmittingSide { front, back, both };

struct AreaEmission {
  AreaEmission(RGB radiance_ = RGB(1), Float scale_ = 1, bool two_sided_ = false,
               std::shared_ptr<const ImageTexture> texture_ = nullptr)
      : radiance(radiance_), scale(scale_), two_sided(two_sided_), texture(std::move(texture_)) {}
  // Emission from an explicit side, whatever the winding (Scene::build
  // rejects `back` on spheres: they emit outwards or both ways).
  AreaEmission(RGB radiance_, Float scale_, EmittingSide side, std::shared_ptr<const ImageTexture> texture_ = nullptr)
      : AreaEmission(radiance_, scale_, side == EmittingSide::both, std::move(texture_)) {
    back = side == EmittingSide::back;
  }
  RGB radiance{1};
  Float scale = 1;
  bool two_sided = false;
  bool back = false;  // one-sided emission from the back of the winding
  // Optional emissive texture (glTF emissiveTexture, sRGB): its rgb
  // multiplies radiance at the point's uv (the texture's texcoord set).
  std::shared_ptr<const ImageTexture> texture;
};

template <class S>
class TriangleAreaLight {
 public:
  // p0, p1, p2 in world space; the front side is that of (p1 - p0) x (p2 - p0).
  // uv: the vertices' texture coordinates in the emissive texture's set
  // (needed only with a texture).
  TriangleAreaLight(const Point3f& p0, const Point3f& p1, const Point3f& p2, const AreaEmission& e, uint32_t instance,
                    uint32_t primitive, const std::array<Point2f, 3>& uv = {},
                    std::optional<RGB> texture_mean = std::nullopt)
      : m_p{p0, p1, p2}, m_uv(uv), m_emission(e), m_instance(instance), m_primitive(primitive) {
    Vector3f c = cross(p1 - p0, p2 - p0);
    m_area = length(c) / 2;
    m_n = Normal3f(normalize(c));
    m_centre = Point3f((Vector3f(p0) + Vector3f(p1) + Vector3f(p2)) / 3);
    m_radius = std::max({distance(m_centre, p0), distance(m_centre, p1), distance(m_centre, p2)}) * (1 + 4 * gamma(3));
    m_rgb = e.radiance * e.scale;
    if (e.texture) {
      // The power estimate: the texture at the centroid and the vertices,
      // plus a small share of its mean so that no triangle that may emit
      // gets probability 0 (the caustic pass starts paths by power).
      RGB sum(0);
      Point2f centroid = uv[0] * (Float(1) / 3) + uv[1] * (Float(1) / 3) + uv[2] * (Float(1) / 3);
      sum = sum + e.texture->evaluate(centroid).rgb * 2;
      for (int i = 0; i < 3; ++i) sum = sum + e.texture->evaluate(uv[size_t(i)]).rgb;
      // texture_mean: the texture's average(), passed in when many lights share it.
      RGB mean = texture_mean ? *texture_mean : e.texture->average();
      m_power_rgb = m_rgb * (sum / 5 + mean * Float(1e-3));
    } else {
      m_power_rgb = m_rgb;
    }
  }

  LightKind kind() const { return LightKind::area; }
  Float area() const { return m_area; }
  // Off: always sample by area (for comparisons; the default is on).
  void set_solid_angle_sampling(bool on) { m_solid_angle_sampling = on; }
  const Point3f& vertex(int i) const { return m_p[i]; }
  const Normal3f& normal() const { return m_n; }  // the front side's
  bool two_sided() const { return m_emission.two_sided; }

  // Radiance leaving the light at a point with geometric normal n towards w.
  // Without a texture; with one, the texture's value at the centroid.
  template <class W>
  S L(const Normal3f& /*n*/, const Vector3f& w, const W& lambda) const {
    if (!m_emission.two_sided && dot(m_n, w) < 0) return S{};
    return spectrum_traits<S>::illuminant(radiance_at({Float(1) / 3, Float(1) / 3, Float(1) / 3}), lambda);
  }
  // Radiance leaving the light at the hit si towards si.wo.
  template <class W>
  S L(const SurfaceInteraction& si, const W& lambda) const {
    if (!m_emission.two_sided && dot(m_n, si.wo) < 0) return S{};
    if (!m_emission.texture) return spectrum_traits<S>::illuminant(m_rgb, lambda);
    Point2f uv = m_emission.texture->texcoord == 1 ? si.uv1 : si.uv;
    return spectrum_traits<S>::illuminant(m_rgb * m_emission.texture->evaluate(uv).rgb, lambda);
  }

  // Below this solid angle (sr) the spherical triangle's angle sum loses too
  // many digits and area sampling is as good (its 1 / distance^2 factor is
  // nearly constant over a small light); above the maximum the receiver sits
  // almost on the light's plane.
  static constexpr double kMinSphericalSolidAngle = 1e-4;
  static constexpr double kMaxSphericalSolidAngle = 6.2;
  // And only where the light's distance varies by more than this factor
  // over it (see spherical_solid_angle).
  static constexpr Float kSphericalDistanceRatio = 2;

  // The solid angle the light subtends at p if sample_li samples it by solid
  // angle from there, else 0 (it samples by area).
  double spherical_solid_angle(const Point3f& p) const {
    if (m_area == 0 || !m_solid_angle_sampling) return 0;
    // Cheap test first: the solid angle is at most area / d^2 with d the
    // distance to the triangle's bounding sphere, which rules most distant
    // receivers out without the exact formula (the decision is the same).
    Float d = distance(p, m_centre) - m_radius;
    if (d > 0 && double(m_area) < kMinSphericalSolidAngle * double(d) * double(d)) return 0;
    // Area sampling's density per solid angle is d^3 / (A h) at distance d
    // (h the distance to the light's plane): when the farthest corner is
    // less than kSphericalDistanceRatio times as far as the nearest point
    // could be, that density varies by less than the ratio cubed over the
    // light, area sampling is nearly as good and costs a fraction.
    Float h = std::abs(dot(m_n, m_p[0] - p));
    Float d_near = std::max(h, d);
    Float d_far = std::max({distance(p, m_p[0]), distance(p, m_p[1]), distance(p, m_p[2])});
    if (!(d_far > kSphericalDistanceRatio * d_near)) return 0;
    double omega = spherical_triangle_area(m_p[0] - p, m_p[1] - p, m_p[2] - p);
    return omega >= kMinSphericalSolidAngle && omega <= kMaxSphericalSolidAngle ? omega : 0;
  }

  template <class W>
  std::optional<LightLiSample<S>> sample_li(const LightSampleContext& ctx, Point2f u, const W& lambda) const {
    std::array<Float, 3> b;
    Float pdf_sa = 0;  // solid-angle density when sampled by solid angle
    if (double omega = spherical_solid_angle(ctx.p); omega > 0) {
      auto st = sample_spherical_triangle(m_p[0] - ctx.p, m_p[1] - ctx.p, m_p[2] - ctx.p, u, omega);
      if (!st) return std::nullopt;
      auto hit = barycentrics_along(ctx.p, st->w);
      if (!hit) return std::nullopt;
      b = *hit;
      pdf_sa = Float(1 / omega);
    } else {
      b = sample_uniform_triangle(u);
    }
    Vector3f v0(m_p[0]), v1(m_p[1]), v2(m_p[2]);
    Point3f p(v0 * b[0] + v1 * b[1] + v2 * b[2]);
    Vector3f p_err = (abs(v0 * b[0]) + abs(v1 * b[1]) + abs(v2 * b[2])) * gamma(6);
    Vector3f to_light = p - ctx.p;
    Float d2 = length_squared(to_light);
    if (!(d2 > 0)) return std::nullopt;
    Vector3f wi = to_light / std::sqrt(d2);
    Float cos_l = std::abs(dot(m_n, wi));
    if (cos_l == 0) return std::nullopt;
    if (!m_emission.two_sided && dot(m_n, -wi) < 0) return std::nullopt;
    S Le = spectrum_traits<S>::illuminant(radiance_at(b), lambda);
    if (Le.is_black()) return std::nullopt;
    Float pdf = pdf_sa > 0 ? pdf_sa : d2 / (cos_l * m_area);
    if (!std::isfinite(pdf)) return std::nullopt;
    Point3f p_off = offset_ray_origin(p, p_err, m_n, -wi);
    return LightLiSample<S>{Le, wi, pdf, p_off, false, m_instance, m_primitive};
  }

  // Solid-angle density of sample_li producing direction wi hitting this light at si.
  Float pdf_li(const LightSampleContext& ctx, const Vector3f& wi, const SurfaceInteraction& si) const {
    if (double omega = spherical_solid_angle(ctx.p); omega > 0) return Float(1 / omega);
    Float cos_l = std::abs(dot(m_n, wi));
    if (cos_l == 0) return 0;
    return distance_squared(ctx.p, si.p) / (cos_l * m_area);
  }

  // An emitted ray: origin uniform by area, direction cosine-distributed about
  // the emitting side's normal (either side with probability 1/2 if two-sided).
  template <class W>
  std::optional<LightLeSample<S>> sample_le(Point2f u_pos, Point2f u_dir, Float u_side, const W& lambda) const {
    auto b = sample_uniform_triangle(u_pos);
    Vector3f v0(m_p[0]), v1(m_p[1]), v2(m_p[2]);
    Point3f p(v0 * b[0] + v1 * b[1] + v2 * b[2]);
    Vector3f p_err = (abs(v0 * b[0]) + abs(v1 * b[1]) + abs(v2 * b[2])) * gamma(6);
    auto d = detail::sample_emitted_direction(m_n, m_emission.two_sided, u_dir, u_side);
    if (!d) return std::nullopt;
    S Le = spectrum_traits<S>::illuminant(radiance_at(b), lambda);
    Ray ray{offset_ray_origin(p, p_err, d->n, d->w), d->w};
    return LightLeSample<S>{Le, ray, d->n, 1 / m_area, d->pdf, m_instance, m_primitive};
  }

  // With an emissive texture, an estimate (see the constructor).
  template <class W>
  S power(const W& lambda) const {
    Float sides = m_emission.two_sided ? 2 : 1;
    return spectrum_traits<S>::illuminant(m_power_rgb, lambda) * (pi * sides * m_area);
  }

 private:
  // Radiance (RGB) at barycentrics b.
  RGB radiance_at(const std::array<Float, 3>& b) const {
    if (!m_emission.texture) return m_rgb;
    Point2f uv = m_uv[0] * b[0] + m_uv[1] * b[1] + m_uv[2] * b[2];
    return m_rgb * m_emission.texture->evaluate(uv).rgb;
  }

  // Barycentrics of where the ray o + t w meets the triangle's plane
  // (Moller-Trumbore in double), clamped onto the triangle: a direction from
  // the spherical sampler always points into it, up to rounding.
  std::optional<std::array<Float, 3>> barycentrics_along(const Point3f& o, const Vector3f& w) const {
    using namespace detail;
    Vec3d p0 = to_d(Vector3f(m_p[0])), e1 = to_d(m_p[1] - m_p[0]), e2 = to_d(m_p[2] - m_p[0]);
    Vec3d d = to_d(w), tv = add_d(to_d(Vector3f(o)), p0, -1);
    Vec3d pv = cross_d(d, e2);
    double det = dot_d(e1, pv);
    if (det == 0 || !std::isfinite(det)) return std::nullopt;
    double b1 = dot_d(tv, pv) / det;
    double b2 = dot_d(d, cross_d(tv, e1)) / det;
    double b0 = 1 - b1 - b2;
    b0 = std::max(b0, 0.0);
    b1 = std::max(b1, 0.0);
    b2 = std::max(b2, 0.0);
    double sum = b0 + b1 + b2;
    if (!(sum > 0)) return std::nullopt;
    return std::array<Float, 3>{Float(b0 / sum), Float(b1 / sum), Float(b2 / sum)};
  }

  Point3f m_p[3];
  std::array<Point2f, 3> m_uv;
  RGB m_rgb, m_power_rgb;
  Normal3f m_n;
  Float m_area = 0;
  Point3f m_centre;
  Float m_radius = 0;  // of a sphere about m_centre holding the triangle
  bool m_solid_angle_sampling = true;
  AreaEmission m_emission;
  uint32_t m_instance, m_primitive;
};

template <class S>
class SphereAreaLight {
 public:
  // The front side of a sphere is its outside.
  SphereAreaLight(const Sphere& s, const AreaEmission& e, uint32_t instance)
      : m_sphere(s), m_emission(e), m_instance(instance) {}

  LightKind kind() const { return LightKind::area; }
  const Sphere& sphere() const { return m_sphere; }
  bool two_sided() const { return m_emission.two_sided; }

  template <class W>
  S L(const Normal3f& n, const Vector3f& w, const W& lambda) const {
    if (!m_emission.two_sided && dot(n, w) < 0) return S{};
    return spectrum_traits<S>::illuminant(m_emission.radiance * m_emission.scale, lambda);
  }
  // Radiance leaving the light at the hit si towards si.wo.
  template <class W>
  S L(const SurfaceInteraction& si, const W& lambda) const {
    return L(si.n, si.wo, lambda);
  }

  template <class W>
  std::optional<LightLiSample<S>> sample_li(const LightSampleContext& ctx, Point2f u, const W& lambda) const {
    const Point3f& c = m_sphere.center;
    Float r = m_sphere.radius;
    Float dc2 = distance_squared(receiver_origin(ctx), c);
    Point3f p;
    Normal3f n;
    Float pdf;
    if (dc2 <= r * r) {
      // Inside: uniform by area, converted to solid angle.
      Vector3f nv = sample_uniform_sphere(u);
      p = c + nv * r;
      n = Normal3f(nv);
      Vector3f wi = p - ctx.p;
      Float d2 = length_squared(wi);
      if (!(d2 > 0)) return std::nullopt;
      wi = wi / std::sqrt(d2);
      Float cos_l = std::abs(dot(n, wi));
      if (cos_l == 0) return std::nullopt;
      pdf = d2 / (cos_l * m_sphere.area());
    } else {
      // Outside: uniform in the cone subtended by the sphere; find the point
      // on the sphere from the angle alpha at its centre.
      Float dc = std::sqrt(dc2);
      Vector3f wc = (c - ctx.p) / dc;
      Float sin2_max = r * r / dc2;
      Float sin_max = std::sqrt(sin2_max);
      Float cos_max = safe_sqrt(1 - sin2_max);
      Float one_minus_cos_max = 1 - cos_max;
      Float cos_theta = (cos_max - 1) * u.x + 1;
      Float sin2_theta = 1 - sqr(cos_theta);
      // For tiny cones 1 - cos_max cancels catastrophically: use its Taylor
      // expansion, exact to float precision below sin^2 = 0.00068523
      // (1.5 degrees), as pbrt-v4 does.
      if (sin2_max < 0.00068523f) {
        sin2_theta = sin2_max * u.x;
        cos_theta = std::sqrt(1 - sin2_theta);
        one_minus_cos_max = sin2_max / 2;
      }
      Float cos_alpha = sin2_theta / sin_max + cos_theta * safe_sqrt(1 - sin2_theta / sin2_max);
      Float sin_alpha = safe_sqrt(1 - sqr(cos_alpha));
      Float phi = u.y * 2 * pi;
      Vector3f w = spherical_direction(sin_alpha, cos_alpha, phi);
      Frame f = Frame::from_z(-wc);
      Vector3f nv = f.from_local(w);
      n = Normal3f(nv);
      p = c + nv * r;
      pdf = 1 / (2 * pi * one_minus_cos_max);
    }
    Vector3f p_err = abs(p - Point3f{}) * gamma(5);
    Vector3f to_light = p - ctx.p;
    if (!(length_squared(to_light) > 0)) return std::nullopt;
    Vector3f wi = normalize(to_light);
    S Le = L(n, -wi, lambda);
    if (Le.is_black() || !std::isfinite(pdf)) return std::nullopt;
    Point3f p_off = offset_ray_origin(p, p_err, n, -wi);
    return LightLiSample<S>{Le, wi, pdf, p_off, false, m_instance, 0};
  }

  // An emitted ray: origin uniform on the sphere, direction cosine-distributed
  // about the outward normal (or, if two-sided, either normal with probability 1/2).
  template <class W>
  std::optional<LightLeSample<S>> sample_le(Point2f u_pos, Point2f u_dir, Float u_side, const W& lambda) const {
    Vector3f nv = sample_uniform_sphere(u_pos);
    Point3f p = m_sphere.center + nv * m_sphere.radius;
    Vector3f p_err = abs(p - Point3f{}) * gamma(5);
    auto d = detail::sample_emitted_direction(Normal3f(nv), m_emission.two_sided, u_dir, u_side);
    if (!d) return std::nullopt;
    S Le = spectrum_traits<S>::illuminant(m_emission.radiance * m_emission.scale, lambda);
    Ray ray{offset_ray_origin(p, p_err, d->n, d->w), d->w};
    return LightLeSample<S>{Le, ray, d->n, 1 / m_sphere.area(), d->pdf, m_instance, 0};
  }

  Float pdf_li(const LightSampleContext& ctx, const Vector3f& wi, const SurfaceInteraction& si) const {
    const Point3f& c = m_sphere.center;
    Float r = m_sphere.radius;
    Float dc2 = distance_squared(receiver_origin(ctx), c);
    if (dc2 <= r * r) {
      Float cos_l = std::abs(dot(si.n, wi));
      if (cos_l == 0) return 0;
      return distance_squared(ctx.p, si.p) / (cos_l * m_sphere.area());
    }
    Float sin2_max = r * r / dc2;
    Float one_minus_cos_max = sin2_max < 0.00068523f ? sin2_max / 2 : 1 - safe_sqrt(1 - sin2_max);
    return 1 / (2 * pi * one_minus_cos_max);
  }

  template <class W>
  S power(const W& lambda) const {
    Float sides = m_emission.two_sided ? 2 : 1;
    return spectrum_traits<S>::illuminant(m_emission.radiance * m_emission.scale, lambda) *
           (pi * sides * m_sphere.area());
  }

 private:
  // Where the receiver's shadow rays start: its point moved off its own surface
  // towards the centre. A receiver on this very sphere then counts as inside,
  // so the cone construction (meant for outside points) is never used there.
  Point3f receiver_origin(const LightSampleContext& ctx) const {
    if (ctx.n == Normal3f{}) return ctx.p;
    return offset_ray_origin(ctx.p, ctx.p_error, ctx.n, m_sphere.center - ctx.p);
  }

  Sphere m_sphere;
  AreaEmission m_emission;
  uint32_t m_instance;
};

}  // namespace prism
