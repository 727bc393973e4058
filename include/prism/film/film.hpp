// prism/film/film.hpp — the film: per pixel, the weighted sum of sample values
// and of their squares, so that both the estimate and its variance are known.
// In RGB mode it accumulates linear sRGB; in spectral mode CIE XYZ, turned into
// linear sRGB when read. (The squares are kept in linear sRGB in both modes, so
// that variance() is per output channel.) Each pixel is written by one thread
// at a time (the tile that owns it), in a fixed sample order, so the result
// does not depend on the thread count.
#pragma once
#include <string>
#include <vector>
#include "prism/error.hpp"
#include "prism/spectra/spectrum.hpp"

namespace prism {

// What a film accumulates: linear sRGB (RGB rendering) or CIE XYZ (spectral).
enum class FilmEncoding { rgb, xyz };

class Film {
 public:
  Film() = default;
  Film(int width, int height, FilmEncoding enc = FilmEncoding::rgb)
      : m_width(width), m_height(height), m_encoding(enc), m_pixels(size_t(width) * size_t(height)) {}

  int width() const { return m_width; }
  int height() const { return m_height; }
  FilmEncoding encoding() const { return m_encoding; }

  // Called by the renderer before it adds samples: an empty film takes the
  // colour model's encoding; a film that already holds samples of the other
  // encoding cannot be continued.
  void prepare(FilmEncoding enc) {
    if (enc == m_encoding) return;
    for (const Pixel& p : m_pixels)
      if (p.count != 0)
        throw Error(std::string("film: holds ") + (m_encoding == FilmEncoding::rgb ? "RGB" : "XYZ") +
                    " samples; cannot add " + (enc == FilmEncoding::rgb ? "RGB" : "XYZ") + " samples to it");
    m_encoding = enc;
  }

  // Adds a sample in the film's encoding (linear sRGB, or XYZ as x, y, z).
  void add_sample(int x, int y, const RGB& v, Float weight) {
    Pixel& p = m_pixels[index(x, y)];
    RGB out = m_encoding == FilmEncoding::xyz ? xyz_to_linear_srgb({v.r, v.g, v.b}) : v;
    for (int c = 0; c < 3; ++c) {
      p.sum[c] += double(weight) * double(v[c]);
      p.sum_sq[c] += double(weight) * double(out[c]) * double(out[c]);
    }
    p.weight += double(weight);
    p.count += 1;
  }

  // Adds splatted values (light tracing), one triple per pixel in the film's
  // encoding, each multiplied by scale; they add to the pixels' estimates.
  void add_splats(const std::vector<double>& values, double scale) {
    if (values.size() != m_pixels.size() * 3) throw Error("film: splat buffer size does not match the film");
    if (m_splat.empty()) m_splat.assign(values.size(), 0.0);
    for (size_t i = 0; i < values.size(); ++i) m_splat[i] += values[i] * scale;
  }

  // The pixel's estimate in linear sRGB: sum(w L) / sum(w), plus splats.
  RGB pixel(int x, int y) const {
    const Pixel& p = m_pixels[index(x, y)];
    double v[3] = {0, 0, 0};
    if (p.weight > 0)
      for (int c = 0; c < 3; ++c) v[c] = p.sum[c] / p.weight;
    if (!m_splat.empty())
      for (int c = 0; c < 3; ++c) v[c] += m_splat[index(x, y) * 3 + size_t(c)];
    RGB out{Float(v[0]), Float(v[1]), Float(v[2])};
    return m_encoding == FilmEncoding::xyz ? xyz_to_linear_srgb({out.r, out.g, out.b}) : out;
  }
  // Estimated variance of the pixel's estimate (the sample variance of the
  // weighted values divided by the sample count). Splats are not included.
  RGB variance(int x, int y) const {
    const Pixel& p = m_pixels[index(x, y)];
    if (p.count < 2 || p.weight == 0) return {};
    RGB v;
    RGB m = camera_pixel(x, y);
    for (int c = 0; c < 3; ++c) {
      double mean = double(m[c]);
      double var = std::max(0.0, p.sum_sq[c] / p.weight - mean * mean) * double(p.count) / double(p.count - 1);
      v[c] = Float(var / double(p.count));
    }
    return v;
  }
  uint64_t sample_count(int x, int y) const { return m_pixels[index(x, y)].count; }
  // The camera samples' estimate alone (no splats), in linear sRGB.
  RGB sample_mean(int x, int y) const { return camera_pixel(x, y); }

  // Linear RGB, row-major from the top-left, 3 floats per pixel.
  std::vector<float> rgb_buffer() const {
    std::vector<float> out(m_pixels.size() * 3);
    for (int y = 0; y < m_height; ++y)
      for (int x = 0; x < m_width; ++x) {
        RGB c = pixel(x, y);
        size_t i = index(x, y) * 3;
        out[i] = c.r; out[i + 1] = c.g; out[i + 2] = c.b;
      }
    return out;
  }
  void clear() {
    std::fill(m_pixels.begin(), m_pixels.end(), Pixel{});
    m_splat.clear();
  }

  // Raw accumulators, for moving a film between processes (render/mpi.hpp):
  // one Pixel per pixel, row-major, and the splats (3 per pixel in the film's
  // encoding, or none when nothing was splatted).
  struct Pixel {
    double sum[3] = {0, 0, 0}, sum_sq[3] = {0, 0, 0};
    double weight = 0;
    uint64_t count = 0;
  };
  std::vector<Pixel>& pixels() { return m_pixels; }
  const std::vector<Pixel>& pixels() const { return m_pixels; }
  std::vector<double>& splats() { return m_splat; }
  const std::vector<double>& splats() const { return m_splat; }

  // Adds another film's samples to this one: the films of disjoint shares of
  // a render (RenderOptions::first_sample, tile_stride) merge into the whole
  // render's, up to the order of summation. Adding films in a fixed order gives
  // a bitwise reproducible result.
  void merge(const Film& other) {
    if (other.m_width != m_width || other.m_height != m_height)
      throw Error("film: cannot merge a " + std::to_string(other.m_width) + "x" + std::to_string(other.m_height) +
                  " film into a " + std::to_string(m_width) + "x" + std::to_string(m_height) + " one");
    bool other_empty = true;
    for (const Pixel& p : other.m_pixels)
      if (p.count != 0) {
        other_empty = false;
        break;
      }
    if (other_empty && other.m_splat.empty()) return;
    prepare(other.m_encoding);
    merge_pixels(other.m_pixels.data(), 0, other.m_pixels.size());
    if (!other.m_splat.empty()) add_splats(other.m_splat, 1.0);
  }
  // Adds n raw accumulators to pixels [first, first + n) (in the film's
  // encoding; the caller checks that the sender's matches).
  void merge_pixels(const Pixel* src, size_t first, size_t n) {
    if (first > m_pixels.size() || n > m_pixels.size() - first) throw Error("film: merged pixels out of range");
    for (size_t i = 0; i < n; ++i) {
      Pixel& d = m_pixels[first + i];
      const Pixel& o = src[i];
      for (int c = 0; c < 3; ++c) {
        d.sum[c] += o.sum[c];
        d.sum_sq[c] += o.sum_sq[c];
      }
      d.weight += o.weight;
      d.count += o.count;
    }
  }

 private:
  // The camera samples' estimate alone, in linear sRGB.
  RGB camera_pixel(int x, int y) const {
    const Pixel& p = m_pixels[index(x, y)];
    if (p.weight == 0) return {};
    RGB v{Float(p.sum[0] / p.weight), Float(p.sum[1] / p.weight), Float(p.sum[2] / p.weight)};
    return m_encoding == FilmEncoding::xyz ? xyz_to_linear_srgb({v.r, v.g, v.b}) : v;
  }

  size_t index(int x, int y) const { return size_t(y) * size_t(m_width) + size_t(x); }

  int m_width = 0, m_height = 0;
  FilmEncoding m_encoding = FilmEncoding::rgb;
  std::vector<Pixel> m_pixels;
  std::vector<double> m_splat;  // empty unless something was splatted
};

}  // namespace prism
