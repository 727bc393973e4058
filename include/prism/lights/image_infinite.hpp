// prism/lights/image_infinite.hpp — an environment map: radiance arriving from
// every direction, read from an equirectangular (latitude-longitude) image and
// importance sampled by a piecewise-constant density over the image
// proportional to luminance x sin(theta) (pbrt-v4 book, section 12.5.2). For
// next-event estimation the density is MIS-compensated (Karlik et al. 2019,
// "MIS Compensation"): the average luminance is subtracted first, so that a
// bright sun does not take all the samples away from the rest of the sky.
// Conventions, units and densities: docs/lights.md.
#pragma once
#include <cstddef>
#include <memory>
#include <string>
#include <vector>
#include "prism/error.hpp"
#include "prism/lights/light.hpp"
#include "prism/math/transform.hpp"
#include "prism/sampling/distribution.hpp"
#include "prism/spectra/traits.hpp"

namespace prism {

// An image in memory: width x height texels, row-major from the top row (the
// +y pole), three linear RGB floats per texel. Any aspect ratio is accepted.
struct EnvironmentImage {
  int width = 0, height = 0;
  std::vector<float> rgb;

  RGB texel(int x, int y) const {
    size_t i = 3 * (size_t(y) * size_t(width) + size_t(x));
    return {rgb[i], rgb[i + 1], rgb[i + 2]};
  }
};

// The equirectangular parameterisation, in the light's own space (+y up):
// v = theta / pi with theta measured from +y (v = 0 is the image's top row),
// u = 1/2 + phi / (2 pi) with phi = atan2(x, -z), so the image's centre looks
// down -z (where a glTF camera looks) and u grows towards +x (to the right, seen
// from inside). The Jacobian is d(omega) = 2 pi^2 sin(theta) du dv.
inline Point2f equirect_from_direction(const Vector3f& w) {
  // atan2 for theta too: acos loses precision near the poles.
  Float theta = std::atan2(std::sqrt(w.x * w.x + w.z * w.z), w.y);
  Float phi = std::atan2(w.x, -w.z);
  Float u = Float(0.5) + phi * inv_2pi;
  return {std::clamp(u, Float(0), Float(1)), std::clamp(theta * inv_pi, Float(0), Float(1))};
}
inline Vector3f equirect_to_direction(Point2f uv) {
  Float theta = uv.y * pi, phi = (uv.x - Float(0.5)) * (2 * pi);
  Float st = std::sin(theta);
  return {st * std::sin(phi), std::cos(theta), -st * std::cos(phi)};
}

template <class S>
class ImageInfiniteLight {
 public:
  // image: linear RGB radiance (times scale); light_to_world: a rotation (an
  // orthonormal 3x3 part; translation is ignored) from the map's space to the
  // world. Throws prism::Error naming what is wrong with the image, the scale
  // or the transform.
  explicit ImageInfiniteLight(EnvironmentImage image, Float scale = 1, const Transform& light_to_world = {})
      : m_to_world(light_to_world), m_to_light(inverse(light_to_world)), m_scale(scale) {
    validate(image, scale, light_to_world);
    m_data = std::make_shared<const Data>(build(std::move(image)));
  }

  LightKind kind() const { return LightKind::infinite; }

  // Radiance arriving along a ray that escapes the scene (ray.d need not be unit).
  template <class W>
  S Le(const Ray& ray, const W& lambda) const {
    Vector3f wl = m_to_light(ray.d);
    if (!(length_squared(wl) > 0)) return S{};
    return lookup(equirect_from_direction(normalize(wl)), lambda);
  }

  // A direction towards the map, drawn from the compensated density when
  // allow_incomplete_pdf (the default, for MIS with BSDF sampling, which covers
  // the directions it leaves out), else from the full one; pdf per solid angle.
  // Fails (nullopt) for a black map or a sample on a pole.
  template <class W>
  std::optional<LightLiSample<S>> sample_li(const LightSampleContext& /*ctx*/, Point2f u, const W& lambda,
                                            bool allow_incomplete_pdf = true) const {
    const PiecewiseConstant2D& dist = allow_incomplete_pdf ? m_data->compensated : m_data->distribution;
    Float map_pdf = 0;
    Point2f uv = dist.sample(u, &map_pdf);
    Float sin_theta = std::sin(uv.y * pi);
    if (!(map_pdf > 0) || !(sin_theta > 0)) return std::nullopt;
    Float pdf = map_pdf / (2 * pi * pi * sin_theta);
    if (!std::isfinite(pdf)) return std::nullopt;
    S L = lookup(uv, lambda);
    if (L.is_black()) return std::nullopt;
    Vector3f wi = normalize(m_to_world(equirect_to_direction(uv)));
    return LightLiSample<S>{L, wi, pdf, {}, true};
  }

  // Solid-angle density of sample_li (with the same allow_incomplete_pdf) for
  // the world direction w.
  Float pdf_li(const LightSampleContext& /*ctx*/, const Vector3f& w, const SurfaceInteraction& /*si*/,
               bool allow_incomplete_pdf = true) const {
    Vector3f wl = m_to_light(w);
    Float l2 = length_squared(wl);
    if (!(l2 > 0)) return 0;
    wl = wl / std::sqrt(l2);
    Float sin_theta = std::sqrt(wl.x * wl.x + wl.z * wl.z);
    if (!(sin_theta > 0)) return 0;
    const PiecewiseConstant2D& dist = allow_incomplete_pdf ? m_data->compensated : m_data->distribution;
    return dist.pdf(equirect_from_direction(wl)) / (2 * pi * pi * sin_theta);
  }

  // Power through a disk of the scene's bounding radius: pi r^2 times the
  // integral of Le over the sphere (exact per texel solid angle). In spectral
  // mode this uplifts the map's solid-angle-weighted mean colour, which is
  // what light selection needs (the uplift is not linear in RGB, so this is not
  // exactly the mean of the texels' spectra).
  void set_scene_radius(Float r) { m_scene_radius = r; }
  Float scene_radius() const { return m_scene_radius; }
  template <class W>
  S power(const W& lambda) const {
    return spectrum_traits<S>::illuminant(m_data->integral_rgb * m_scale, lambda) * (pi * sqr(m_scene_radius));
  }

  const EnvironmentImage& image() const { return m_data->image; }
  Float scale() const { return m_scale; }
  const Transform& light_to_world() const { return m_to_world; }

 private:
  // Shared between copies: the scene copies lights into its variant list.
  struct Data {
    EnvironmentImage image;
    PiecewiseConstant2D distribution;  // luminance x sin(theta)
    PiecewiseConstant2D compensated;   // max(luminance - mean, 0) x sin(theta), or the above if all 0
    RGB integral_rgb;                  // sum over texels of RGB x the texel's solid angle (unscaled)
  };

  static void validate(const EnvironmentImage& img, Float scale, const Transform& t) {
    const std::string where = "image infinite light: ";
    if (img.width <= 0 || img.height <= 0)
      throw Error(where + "image size " + std::to_string(img.width) + " x " + std::to_string(img.height) +
                  " must be positive");
    size_t expected = size_t(img.width) * size_t(img.height) * 3;
    if (img.rgb.size() != expected)
      throw Error(where + "image holds " + std::to_string(img.rgb.size()) + " floats, expected " +
                  std::to_string(expected) + " (width x height x 3)");
    for (size_t i = 0; i < img.rgb.size(); ++i) {
      float v = img.rgb[i];
      if (!std::isfinite(v) || v < 0) {
        size_t t_index = i / 3;
        throw Error(where + "texel (" + std::to_string(t_index % size_t(img.width)) + ", " +
                    std::to_string(t_index / size_t(img.width)) + ") channel " + "rgb"[i % 3] + " is " +
                    std::to_string(v) + ": radiance must be finite and non-negative");
      }
    }
    if (!std::isfinite(scale) || scale < 0)
      throw Error(where + "scale " + std::to_string(scale) + " must be finite and non-negative");
    // The Jacobian of the map assumes a rotation (or a reflection).
    const auto& m = t.matrix().m;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        double d = 0;
        for (int k = 0; k < 3; ++k) d += double(m[i][k]) * double(m[j][k]);
        if (!(std::abs(d - (i == j ? 1.0 : 0.0)) <= 1e-4))
          throw Error(where + "the transform must be a rotation (orthonormal, without scale or shear)");
      }
  }

  static Data build(EnvironmentImage img) {
    const int w = img.width, h = img.height;
    const size_t n = size_t(w) * size_t(h);
    std::vector<Float> lum(n), d(n);
    std::vector<double> sin_row(static_cast<size_t>(h));
    double lum_sin_sum = 0, sin_sum = 0;
    Data data;
    for (int y = 0; y < h; ++y) {
      // sin(theta) at the row's centre weights the row by its solid angle.
      sin_row[size_t(y)] = std::sin(pi * (double(y) + 0.5) / double(h));
      // Exact solid angle of a texel in this row: (2 pi / w) (cos theta0 - cos theta1).
      double omega = 2 * double(pi) / double(w) *
                     (std::cos(double(pi) * y / double(h)) - std::cos(double(pi) * (y + 1) / double(h)));
      double r = 0, g = 0, b = 0;
      for (int x = 0; x < w; ++x) {
        size_t i = size_t(y) * size_t(w) + size_t(x);
        RGB c = img.texel(x, y);
        r += c.r;
        g += c.g;
        b += c.b;
        lum[i] = c.luminance();
        d[i] = Float(double(lum[i]) * sin_row[size_t(y)]);
        lum_sin_sum += double(lum[i]) * sin_row[size_t(y)];
      }
      sin_sum += sin_row[size_t(y)] * w;
      data.integral_rgb += RGB(Float(r * omega), Float(g * omega), Float(b * omega));
    }
    data.distribution = PiecewiseConstant2D(d, w, h);
    // MIS compensation: subtract the solid-angle-weighted mean luminance, so
    // that light sampling concentrates on what is brighter than average and
    // BSDF sampling handles the rest. A map with nothing above its mean (a
    // constant one) keeps the full density.
    const double mean = lum_sin_sum / sin_sum;
    std::vector<Float> c(n);
    bool any = false;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        size_t i = size_t(y) * size_t(w) + size_t(x);
        double v = std::max(0.0, double(lum[i]) - mean) * sin_row[size_t(y)];
        c[i] = Float(v);
        any = any || c[i] > 0;
      }
    data.compensated = any ? PiecewiseConstant2D(c, w, h) : data.distribution;
    data.image = std::move(img);
    return data;
  }

  // The texel holding uv (nearest: the same piecewise-constant function the
  // sampling density follows), times the scale.
  template <class W>
  S lookup(Point2f uv, const W& lambda) const {
    const EnvironmentImage& img = m_data->image;
    int x = std::clamp(int(uv.x * Float(img.width)), 0, img.width - 1);
    int y = std::clamp(int(uv.y * Float(img.height)), 0, img.height - 1);
    RGB c = img.texel(x, y);
    if (c.is_black()) return S{};
    return spectrum_traits<S>::illuminant(c * m_scale, lambda);
  }

  std::shared_ptr<const Data> m_data;
  Transform m_to_world, m_to_light;
  Float m_scale = 1;
  Float m_scene_radius = 1;
};

}  // namespace prism
