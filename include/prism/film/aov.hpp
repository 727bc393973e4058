// prism/film/aov.hpp — arbitrary output variables (AOVs) for denoisers and
// compositing: per pixel, the filtered mean over the camera samples of
//   albedo  the directional albedo of the first surface that is not a perfect
//           mirror or glass (one BSDF sample per camera sample: f |cos| / pdf,
//           whose mean is the albedo, for any BxDF, a user's too); through
//           perfectly specular surfaces the throughput multiplies it, and a
//           path that escapes after them gets the throughput. Linear sRGB.
//   normal  the world-space shading normal of that surface, turned towards
//           the viewer (a unit vector per sample; the mean may be shorter at
//           silhouettes).
//   depth   the distance along the camera ray to the first surface.
// A camera ray that misses everything gives albedo 0, normal 0 and depth 0 (a
// zero normal is what Open Image Denoise reads as "no surface").
// render() fills an AovFilm when RenderOptions::aovs points to one; it costs
// one more ray per camera sample (two or more through mirrors and glass) and
// its random numbers come from their own stream, so the image is the same
// with or without AOVs.
#pragma once
#include <algorithm>
#include <vector>
#include "prism/error.hpp"
#include "prism/math/vector.hpp"
#include "prism/spectra/spectrum.hpp"

namespace prism {

struct AovSample {
  RGB albedo;  // in the film's encoding (linear sRGB, or XYZ in spectral mode)
  Normal3f normal{0, 0, 0};
  Float depth = 0;
};

class AovFilm {
 public:
  AovFilm() = default;
  AovFilm(int width, int height) : m_width(width), m_height(height), m_pixels(size_t(width) * size_t(height)) {
    if (width <= 0 || height <= 0) throw Error("AOV film: the size must be positive");
  }
  int width() const { return m_width; }
  int height() const { return m_height; }
  // Spectral rendering accumulates albedo as CIE XYZ; the renderer says so.
  void set_xyz(bool xyz) { m_xyz = xyz; }

  void add_sample(int x, int y, const AovSample& s, Float weight) {
    Pixel& p = m_pixels[index(x, y)];
    double w = weight;
    for (int c = 0; c < 3; ++c) p.albedo[c] += w * double(s.albedo[c]);
    p.normal[0] += w * double(s.normal.x);
    p.normal[1] += w * double(s.normal.y);
    p.normal[2] += w * double(s.normal.z);
    p.depth += w * double(s.depth);
    p.weight += w;
  }

  // Linear sRGB in [0, 1] (the per-sample values are unbiased and unclamped;
  // the mean is clamped). In spectral mode the XYZ mean is converted and
  // divided by what a white surface gives (the equal-energy white point), so
  // a grey surface of reflectance r reads (r, r, r) in both colour models.
  RGB albedo(int x, int y) const {
    const Pixel& p = m_pixels[index(x, y)];
    if (p.weight == 0) return {};
    RGB v{Float(p.albedo[0] / p.weight), Float(p.albedo[1] / p.weight), Float(p.albedo[2] / p.weight)};
    if (m_xyz) {
      RGB rgb = xyz_to_linear_srgb({v.r, v.g, v.b});
      RGB white = xyz_to_linear_srgb({1, 1, 1});
      v = {rgb.r / white.r, rgb.g / white.g, rgb.b / white.b};
    }
    for (int c = 0; c < 3; ++c) v[c] = v[c] > 0 ? std::min(v[c], Float(1)) : Float(0);
    return v;
  }
  Vector3f normal(int x, int y) const {
    const Pixel& p = m_pixels[index(x, y)];
    if (p.weight == 0) return {0, 0, 0};
    return {Float(p.normal[0] / p.weight), Float(p.normal[1] / p.weight), Float(p.normal[2] / p.weight)};
  }
  Float depth(int x, int y) const {
    const Pixel& p = m_pixels[index(x, y)];
    return p.weight == 0 ? 0 : Float(p.depth / p.weight);
  }

  // Raw accumulators (row-major), for moving the AOVs between processes
  // (render/mpi.hpp), and merging those of disjoint shares of a render.
  struct Pixel {
    double albedo[3] = {0, 0, 0}, normal[3] = {0, 0, 0};
    double depth = 0, weight = 0;
  };
  std::vector<Pixel>& pixels() { return m_pixels; }
  const std::vector<Pixel>& pixels() const { return m_pixels; }
  bool xyz() const { return m_xyz; }
  void merge_pixels(const Pixel* src, size_t first, size_t n) {
    if (first > m_pixels.size() || n > m_pixels.size() - first) throw Error("AOV film: merged pixels out of range");
    for (size_t i = 0; i < n; ++i) {
      Pixel& d = m_pixels[first + i];
      const Pixel& o = src[i];
      for (int c = 0; c < 3; ++c) {
        d.albedo[c] += o.albedo[c];
        d.normal[c] += o.normal[c];
      }
      d.depth += o.depth;
      d.weight += o.weight;
    }
  }
  void merge(const AovFilm& other) {
    if (other.m_width != m_width || other.m_height != m_height)
      throw Error("AOV film: cannot merge films of different sizes");
    m_xyz = other.m_xyz;
    merge_pixels(other.m_pixels.data(), 0, other.m_pixels.size());
  }

 private:
  size_t index(int x, int y) const { return size_t(y) * size_t(m_width) + size_t(x); }
  int m_width = 0, m_height = 0;
  bool m_xyz = false;
  std::vector<Pixel> m_pixels;
};

}  // namespace prism
