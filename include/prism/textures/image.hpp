// prism/textures/image.hpp — decoded image storage for textures: 1-4 channels
// of 8-bit, 16-bit or 32-bit float values, row-major, row 0 at the top of the
// image (as PNG and JPEG decode it, and as glTF's uv (0,0) = top-left expects).
//
// Values are stored as decoded, with no colour decoding: channel() returns the
// normalised stored value (u8 v/255, u16 v/65535, f32 as stored). The colour
// encoding (linear or sRGB) belongs to the texture that samples the image
// (textures/texture.hpp), because glTF lets one image be used both ways.
//
// "Kept in the smallest format that holds it": a 16-bit PNG whose values are
// all 8-bit values scaled by 257 (what converting an 8-bit image to 16 bits
// produces) is stored as 8-bit by shrink_to_smallest(), halving its memory
// with bit-identical normalised values: v / 65535 and (v / 257) / 255 are the
// same real number, and both are computed as one correctly rounded division.
#pragma once
#include <array>
#include <cassert>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <utility>
#include <vector>
#include "prism/error.hpp"

namespace prism {

namespace detail {
// i / 255 rounded once to float (what an 8-bit UNORM value means), for every
// 8-bit code: a lookup instead of a division in the texture's inner loop.
inline constexpr std::array<float, 256> unorm8_table = [] {
  std::array<float, 256> t{};
  for (int i = 0; i < 256; ++i) t[size_t(i)] = float(i) / 255.f;
  return t;
}();
}  // namespace detail

enum class PixelFormat : uint8_t { u8, u16, f32 };

// Bytes per stored channel value.
constexpr size_t pixel_format_size(PixelFormat f) {
  return f == PixelFormat::u8 ? 1 : (f == PixelFormat::u16 ? 2 : 4);
}
constexpr const char* pixel_format_name(PixelFormat f) {
  return f == PixelFormat::u8 ? "u8" : (f == PixelFormat::u16 ? "u16" : "f32");
}

class TextureImage {
 public:
  TextureImage() = default;

  // A zero-filled image. Throws prism::Error when width or height is not
  // positive, channels is outside 1..4, or the storage size overflows.
  TextureImage(int width, int height, int channels, PixelFormat format)
      : m_width(width), m_height(height), m_channels(channels), m_format(format) {
    const size_t n = checked_size(width, height, channels, format);
    switch (format) {
      case PixelFormat::u8: m_u8.assign(n, 0); break;
      case PixelFormat::u16: m_u16.assign(n, 0); break;
      case PixelFormat::f32: m_f32.assign(n, 0.f); break;
    }
  }

  // Images from decoded values (width * height * channels of them, row-major,
  // channels interleaved, row 0 at the top). Throw prism::Error on bad sizes or
  // when data.size() does not match.
  static TextureImage from_u8(int w, int h, int channels, std::vector<uint8_t> data) {
    TextureImage img(w, h, channels, PixelFormat::u8, no_storage{});
    check_data_size(img, data.size());
    img.m_u8 = std::move(data);
    return img;
  }
  static TextureImage from_u16(int w, int h, int channels, std::vector<uint16_t> data) {
    TextureImage img(w, h, channels, PixelFormat::u16, no_storage{});
    check_data_size(img, data.size());
    img.m_u16 = std::move(data);
    return img;
  }
  static TextureImage from_f32(int w, int h, int channels, std::vector<float> data) {
    TextureImage img(w, h, channels, PixelFormat::f32, no_storage{});
    check_data_size(img, data.size());
    img.m_f32 = std::move(data);
    return img;
  }

  int width() const noexcept { return m_width; }
  int height() const noexcept { return m_height; }
  int channels() const noexcept { return m_channels; }
  PixelFormat format() const noexcept { return m_format; }
  // True for a default-constructed image (no texels).
  bool empty() const noexcept { return m_width == 0; }
  // Number of stored values: width * height * channels.
  size_t size() const noexcept { return size_t(m_width) * size_t(m_height) * size_t(m_channels); }
  // Storage size in bytes.
  size_t bytes() const noexcept { return size() * pixel_format_size(m_format); }

  // The normalised stored value of channel c of texel (x, y): u8 v/255,
  // u16 v/65535, f32 as stored. No colour decoding. Precondition: in range.
  float channel(int x, int y, int c) const noexcept {
    assert(x >= 0 && x < m_width && y >= 0 && y < m_height && c >= 0 && c < m_channels);
    const size_t i = (size_t(y) * size_t(m_width) + size_t(x)) * size_t(m_channels) + size_t(c);
    switch (m_format) {
      case PixelFormat::u8: return detail::unorm8_table[m_u8[i]];
      case PixelFormat::u16: return float(m_u16[i]) / 65535.f;
      case PixelFormat::f32: return m_f32[i];
    }
    return 0.f;
  }

  // Raw storage of the format the image holds (empty spans for the others).
  std::span<const uint8_t> u8_data() const noexcept { return m_u8; }
  std::span<const uint16_t> u16_data() const noexcept { return m_u16; }
  std::span<const float> f32_data() const noexcept { return m_f32; }
  std::span<uint8_t> u8_data() noexcept { return m_u8; }
  std::span<uint16_t> u16_data() noexcept { return m_u16; }
  std::span<float> f32_data() noexcept { return m_f32; }

  // Converts a u16 image to u8 when every value is an exact 8-bit value scaled
  // by 257 (v % 257 == 0), so that no information is lost. Returns true if
  // converted; u8 and f32 images, and u16 images with other values, are left as
  // they are.
  bool shrink_to_smallest() {
    if (m_format != PixelFormat::u16 || m_u16.empty()) return false;
    for (uint16_t v : m_u16)
      if (v % 257 != 0) return false;
    std::vector<uint8_t> out(m_u16.size());
    for (size_t i = 0; i < m_u16.size(); ++i) out[i] = uint8_t(m_u16[i] / 257);
    m_u8 = std::move(out);
    std::vector<uint16_t>().swap(m_u16);
    m_format = PixelFormat::u8;
    return true;
  }

 private:
  struct no_storage {};
  // Validates the sizes without allocating (the from_* factories move the data in).
  TextureImage(int width, int height, int channels, PixelFormat format, no_storage)
      : m_width(width), m_height(height), m_channels(channels), m_format(format) {
    (void)checked_size(width, height, channels, format);
  }

  // width * height * channels, after checking each argument and that the byte
  // size fits in a ptrdiff_t (what std::vector and pointer arithmetic need).
  static size_t checked_size(int w, int h, int channels, PixelFormat format) {
    if (w <= 0 || h <= 0)
      throw Error("TextureImage: size " + std::to_string(w) + "x" + std::to_string(h) +
                  " is invalid (width and height must be positive)");
    if (channels < 1 || channels > 4)
      throw Error("TextureImage: " + std::to_string(channels) +
                  " channels is invalid (must be 1 to 4)");
    const size_t limit = size_t(std::numeric_limits<std::ptrdiff_t>::max()) / pixel_format_size(format);
    const size_t wh_limit = limit / size_t(channels);
    if (size_t(w) > wh_limit / size_t(h))
      throw Error("TextureImage: size " + std::to_string(w) + "x" + std::to_string(h) + "x" +
                  std::to_string(channels) + " " + pixel_format_name(format) +
                  " overflows the addressable storage");
    return size_t(w) * size_t(h) * size_t(channels);
  }
  static void check_data_size(const TextureImage& img, size_t got) {
    if (got != img.size())
      throw Error("TextureImage: " + std::to_string(img.m_width) + "x" + std::to_string(img.m_height) +
                  "x" + std::to_string(img.m_channels) + " " + pixel_format_name(img.m_format) +
                  " image needs " + std::to_string(img.size()) + " values, got " + std::to_string(got));
  }

  int m_width = 0, m_height = 0, m_channels = 0;
  PixelFormat m_format = PixelFormat::u8;
  std::vector<uint8_t> m_u8;
  std::vector<uint16_t> m_u16;
  std::vector<float> m_f32;
};

// The sRGB EOTF (IEC 61966-2-1) of every 8-bit code, evaluated in double and
// rounded once to float: decoding an 8-bit sRGB texel is a table lookup.
// Computed on first use (a function-local static: thread-safe initialisation).
inline const std::array<float, 256>& srgb_u8_decode_table() {
  static const std::array<float, 256> table = [] {
    std::array<float, 256> t{};
    for (int i = 0; i < 256; ++i) {
      const double v = double(i) / 255.0;
      t[size_t(i)] = float(v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4));
    }
    return t;
  }();
  return table;
}

}  // namespace prism
