// prism/textures/mipmap.hpp — MIP pyramids of texture images, for the
// filtered lookups of ImageTexture (texture.hpp: trilinear and EWA).
//
// Level 0 is the image itself; level k + 1 halves each side of level k
// (rounded down, at least 1). Each level is the exact box filter of the one
// above: along an axis of even length n, output texel j averages inputs 2j
// and 2j + 1; of odd length n = 2m + 1 (m >= 1), output j covers n / m
// inputs, weighting 2j, 2j + 1 and 2j + 2 by (m - j), m and j + 1 over n
// (the polyphase box of Nvidia's "Non-Power-of-Two Mipmapping", 2002). Every
// input texel then carries the same total weight, so each level's mean
// equals the image's (in the linear values the averaging uses).
//
// The averaging happens on linear values: an sRGB texture's colour channels
// are decoded first and the result encoded back (alpha is never decoded), so
// a level is what the image looks like from farther away, not darker, as
// averaging sRGB codes would make it. Levels keep the image's pixel format
// (an 8-bit image's levels are 8-bit: the code nearest in linear light), so
// a pyramid costs a third of the image's memory.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>
#include "prism/spectra/spectrum.hpp"
#include "prism/textures/image.hpp"

namespace prism {

namespace detail {
// Linear float values of every channel of an image (sRGB colour channels
// decoded when `srgb`; alpha, the last channel of 2- and 4-channel images,
// never).
inline std::vector<float> linear_values(const TextureImage& img, bool srgb) {
  const int nc = img.channels(), ncolour = (nc == 2 || nc == 4) ? nc - 1 : nc;
  std::vector<float> out(img.size());
  if (img.format() == PixelFormat::u8) {  // 8-bit codes through tables: no pow per texel
    const auto& dec = srgb_u8_decode_table();
    const auto codes = img.u8_data();
    for (size_t i = 0; i < codes.size(); ++i)
      out[i] = srgb && int(i % size_t(nc)) < ncolour ? dec[codes[i]] : detail::unorm8_table[codes[i]];
    return out;
  }
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x)
      for (int c = 0; c < nc; ++c) {
        float v = img.channel(x, y, c);
        out[(size_t(y) * size_t(img.width()) + size_t(x)) * size_t(nc) + size_t(c)] =
            srgb && c < ncolour ? float(srgb_decode(v)) : v;
      }
  return out;
}
// One axis of the box downsampling: `in` holds `n` rows of `len` texels of
// `nc` channels along the axis (stride between texels `step`, between rows
// `row`); returns the half-length axis in the same layout.
inline int half_length(int n) { return std::max(1, n / 2); }
// Downsamples along x (axis 0) or y (axis 1) an image of w x h texels.
inline std::vector<float> box_halve(const std::vector<float>& in, int w, int h, int nc, int axis) {
  const int n = axis == 0 ? w : h, m = half_length(n);
  const int ow = axis == 0 ? m : w, oh = axis == 0 ? h : m;
  std::vector<float> out(size_t(ow) * size_t(oh) * size_t(nc), 0.f);
  auto at = [&](int x, int y, int c) { return double(in[(size_t(y) * size_t(w) + size_t(x)) * size_t(nc) + size_t(c)]); };
  for (int y = 0; y < oh; ++y)
    for (int x = 0; x < ow; ++x) {
      const int j = axis == 0 ? x : y;
      for (int c = 0; c < nc; ++c) {
        auto in_at = [&](int i) { return axis == 0 ? at(i, y, c) : at(x, i, c); };
        double v;
        if (n == 1) v = in_at(0);
        else if (n % 2 == 0) v = (in_at(2 * j) + in_at(2 * j + 1)) / 2;
        else v = (double(m - j) * in_at(2 * j) + double(m) * in_at(2 * j + 1) + double(j + 1) * in_at(2 * j + 2)) / n;
        out[(size_t(y) * size_t(ow) + size_t(x)) * size_t(nc) + size_t(c)] = float(v);
      }
    }
  return out;
}
// Linear values back into an image of `format` (sRGB colour channels
// encoded when `srgb`), rounded to the nearest code for u8 and u16.
inline TextureImage encode_level(const std::vector<float>& v, int w, int h, int nc, PixelFormat format, bool srgb) {
  const int ncolour = (nc == 2 || nc == 4) ? nc - 1 : nc;
  auto value = [&](size_t i) {
    float x = v[i];
    const int c = int(i % size_t(nc));
    return srgb && c < ncolour ? float(srgb_encode(std::max(x, 0.f))) : x;
  };
  switch (format) {
    case PixelFormat::u8: {
      std::vector<uint8_t> d(v.size());
      const auto& dec = srgb_u8_decode_table();
      for (size_t i = 0; i < v.size(); ++i) {
        if (srgb && int(i % size_t(nc)) < ncolour) {
          // The code whose decoded value is nearest (the table is increasing): no pow per texel.
          const float x = v[i];
          const auto it = std::lower_bound(dec.begin(), dec.end(), x);
          size_t c = size_t(it - dec.begin());
          if (c == dec.size()) c = 255;
          else if (c > 0 && x - dec[c - 1] < dec[c] - x) --c;
          d[i] = uint8_t(c);
        } else {
          d[i] = uint8_t(std::clamp(std::lround(v[i] * 255.f), 0L, 255L));
        }
      }
      return TextureImage::from_u8(w, h, nc, std::move(d));
    }
    case PixelFormat::u16: {
      std::vector<uint16_t> d(v.size());
      for (size_t i = 0; i < v.size(); ++i) d[i] = uint16_t(std::clamp(std::lround(value(i) * 65535.f), 0L, 65535L));
      return TextureImage::from_u16(w, h, nc, std::move(d));
    }
    case PixelFormat::f32: {
      std::vector<float> d(v.size());
      for (size_t i = 0; i < v.size(); ++i) d[i] = value(i);
      return TextureImage::from_f32(w, h, nc, std::move(d));
    }
  }
  return {};
}
}  // namespace detail

// The levels 1, 2, ... of an image's pyramid (level 0 is the image), down to
// 1 x 1; `srgb`: average the colour channels as linear values (the texture's
// ColorEncoding::srgb). Empty for an empty or 1 x 1 image. O(texels).
inline std::vector<TextureImage> build_mip_levels(const TextureImage& img, bool srgb) {
  std::vector<TextureImage> levels;
  if (img.empty()) return levels;
  int w = img.width(), h = img.height();
  const int nc = img.channels();
  std::vector<float> v = detail::linear_values(img, srgb);
  while (w > 1 || h > 1) {
    if (w > 1) {
      v = detail::box_halve(v, w, h, nc, 0);
      w = detail::half_length(w);
    }
    if (h > 1) {
      v = detail::box_halve(v, w, h, nc, 1);
      h = detail::half_length(h);
    }
    levels.push_back(detail::encode_level(v, w, h, nc, img.format(), srgb));
  }
  return levels;
}

}  // namespace prism
