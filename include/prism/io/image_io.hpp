// prism/io/image_io.hpp — writing and reading images (opt-in: link prism::io).
// PNG: tone-mapped 8-bit sRGB through stb_image_write (exposure, clamp to
// [0, 1], the sRGB transfer function). EXR: linear half or float RGB through
// tinyexr. PFM: linear float RGB, bottom-to-top as the format defines.
// Non-finite values are written as 0: an image prism writes never holds NaN/Inf.
#pragma once
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>
#include <stb/stb_image_write.h>
#include <tinyexr.h>
#include "prism/error.hpp"
#include "prism/film/film.hpp"

namespace prism {

struct Image {
  int width = 0, height = 0;
  std::vector<float> rgb;  // row-major from the top-left, 3 floats per pixel
};

namespace detail {
inline float finite_or_zero(float v) { return std::isfinite(v) ? v : 0.f; }
inline void check_image(const Image& img, const std::string& path) {
  if (img.width <= 0 || img.height <= 0 || img.rgb.size() != size_t(img.width) * size_t(img.height) * 3)
    throw Error(path + ": image size " + std::to_string(img.width) + "x" + std::to_string(img.height) +
                " does not match its data");
}
}  // namespace detail

// How a linear image becomes display values for PNG: scaled by `exposure`
// (a multiplier; 2^EV for EV stops), then tone mapped, then sRGB encoded.
enum class ToneMap {
  clamp,    // clip each channel to [0, 1]
  neutral,  // Khronos PBR Neutral: colours below ~0.76 unchanged, highlights compressed towards white
};
struct PngOptions {
  float exposure = 1;
  ToneMap tone_map = ToneMap::clamp;
};

// The Khronos PBR Neutral tone mapper (Khronos 3D Commerce, 2024): a small
// offset darkens near-black values by at most 0.04 (the Fresnel reflectance
// of a typical dielectric, which it removes), values whose largest channel
// stays below 0.76 are otherwise kept, and brighter colours are compressed so
// that their peak approaches 1, desaturating towards white as they do.
inline RGB tone_map_pbr_neutral(RGB c) {
  constexpr float start = 0.8f - 0.04f, desaturation = 0.15f;
  float x = std::min(c.r, std::min(c.g, c.b));
  float offset = x < 0.08f ? x - 6.25f * x * x : 0.04f;
  c = c - RGB(offset);
  float peak = c.max_component();
  if (peak < start) return c;
  const float d = 1 - start;
  float new_peak = 1 - d * d / (peak + d - start);
  c = c * (new_peak / peak);
  float g = 1 - 1 / (desaturation * (peak - new_peak) + 1);
  return c * (1 - g) + RGB(new_peak) * g;
}

inline void write_png(const std::string& path, const Image& img, const PngOptions& opt = {}) {
  detail::check_image(img, path);
  if (!(opt.exposure >= 0) || !std::isfinite(opt.exposure))
    throw Error(path + ": exposure must be finite and non-negative");
  std::vector<unsigned char> px(img.rgb.size());
  for (size_t i = 0; i < px.size(); i += 3) {
    RGB c{detail::finite_or_zero(img.rgb[i] * opt.exposure), detail::finite_or_zero(img.rgb[i + 1] * opt.exposure),
          detail::finite_or_zero(img.rgb[i + 2] * opt.exposure)};
    c = clamp_zero(c);
    if (opt.tone_map == ToneMap::neutral) c = tone_map_pbr_neutral(c);
    for (int k = 0; k < 3; ++k)
      px[i + size_t(k)] = (unsigned char)std::lround(srgb_encode(std::clamp(c[k], 0.f, 1.f)) * 255.f);
  }
  if (!stbi_write_png(path.c_str(), img.width, img.height, 3, px.data(), img.width * 3))
    throw Error(path + ": cannot write PNG (is the directory writable?)");
}

inline void write_exr(const std::string& path, const Image& img) {
  detail::check_image(img, path);
  std::vector<float> clean(img.rgb.size());
  for (size_t i = 0; i < clean.size(); ++i) clean[i] = detail::finite_or_zero(img.rgb[i]);
  const char* err = nullptr;
  // save_as_fp16 = 0: full float precision.
  int rc = SaveEXR(clean.data(), img.width, img.height, 3, 0, path.c_str(), &err);
  if (rc != TINYEXR_SUCCESS) {
    std::string msg = err ? err : "unknown error";
    if (err) FreeEXRErrorMessage(err);
    throw Error(path + ": cannot write EXR: " + msg);
  }
}

inline Image read_exr(const std::string& path) {
  float* data = nullptr;
  int w = 0, h = 0;
  const char* err = nullptr;
  int rc = LoadEXR(&data, &w, &h, path.c_str(), &err);
  if (rc != TINYEXR_SUCCESS) {
    std::string msg = err ? err : "unknown error";
    if (err) FreeEXRErrorMessage(err);
    throw Error(path + ": cannot read EXR: " + msg);
  }
  Image img{w, h, std::vector<float>(size_t(w) * size_t(h) * 3)};
  for (size_t i = 0; i < size_t(w) * size_t(h); ++i)
    for (int c = 0; c < 3; ++c) img.rgb[3 * i + size_t(c)] = data[4 * i + size_t(c)];  // LoadEXR gives RGBA
  std::free(data);
  return img;
}

inline void write_pfm(const std::string& path, const Image& img) {
  detail::check_image(img, path);
  std::ofstream f(path, std::ios::binary);
  if (!f) throw Error(path + ": cannot open for writing");
  // A negative scale marks little-endian data.
  f << "PF\n" << img.width << " " << img.height << "\n-1\n";
  std::vector<float> row(size_t(img.width) * 3);
  for (int y = img.height - 1; y >= 0; --y) {
    for (size_t i = 0; i < row.size(); ++i) row[i] = detail::finite_or_zero(img.rgb[size_t(y) * row.size() + i]);
    f.write(reinterpret_cast<const char*>(row.data()), std::streamsize(row.size() * sizeof(float)));
  }
  if (!f) throw Error(path + ": write failed");
}

inline Image read_pfm(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(path + ": cannot open");
  std::string magic;
  int w = 0, h = 0;
  double scale = 0;
  f >> magic >> w >> h >> scale;
  f.get();
  if (magic != "PF" || w <= 0 || h <= 0 || scale == 0)
    throw Error(path + ": not an RGB PFM file (header '" + magic + "')");
  if (scale > 0) throw Error(path + ": big-endian PFM is not supported");
  Image img{w, h, std::vector<float>(size_t(w) * size_t(h) * 3)};
  for (int y = h - 1; y >= 0; --y)
    f.read(reinterpret_cast<char*>(img.rgb.data() + size_t(y) * size_t(w) * 3), std::streamsize(size_t(w) * 3 * sizeof(float)));
  if (!f) throw Error(path + ": truncated PFM data");
  return img;
}

inline Image to_image(const Film& film) { return {film.width(), film.height(), film.rgb_buffer()}; }

// Writes by extension: .png (with png's exposure and tone map), .exr or .pfm.
inline void write_image(const std::string& path, const Image& img, const PngOptions& png = {}) {
  auto ends_with = [&](const char* ext) {
    std::string e(ext);
    if (path.size() < e.size()) return false;
    std::string tail = path.substr(path.size() - e.size());
    for (auto& c : tail) c = char(std::tolower(static_cast<unsigned char>(c)));
    return tail == e;
  };
  if (ends_with(".png")) return write_png(path, img, png);
  if (ends_with(".exr")) return write_exr(path, img);
  if (ends_with(".pfm")) return write_pfm(path, img);
  throw Error(path + ": unknown image format (use .png, .exr or .pfm)");
}

}  // namespace prism
