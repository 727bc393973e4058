// prism/io/image_io.hpp — writing and reading images (opt-in: link prism::io).
// PNG: tone-mapped 8-bit sRGB through stb_image_write (exposure, clamp to
// [0, 1], the sRGB transfer function). EXR: linear half or float RGB through
// tinyexr. PFM: linear float RGB, bottom-to-top as the format defines.
// Non-finite values are written as 0: an image prism writes never holds NaN/Inf.
// Environment maps (read_environment): Radiance RGBE .hdr through stb_image,
// .exr through tinyexr, .pfm. decode_image is the one stb_image decoding path,
// shared with the glTF loader's textures (io/gltf/images.hpp).
#pragma once
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>
#include <stb/stb_image.h>
#include <stb/stb_image_write.h>
#include <tinyexr.h>
#include "prism/error.hpp"
#include "prism/film/aov.hpp"
#include "prism/film/film.hpp"
#include "prism/lights/image_infinite.hpp"

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

// An image decoded from memory by decode_image: interleaved samples, rows from
// the top (unless the caller set stb_image's global vertical flip).
struct DecodedImage {
  int width = 0, height = 0, channels = 0;
  std::vector<uint8_t> u8;    // an 8-bit file
  std::vector<uint16_t> u16;  // a 16-bit file (PNG, PNM)
  std::vector<float> f32;     // DecodeOptions::as_float (Radiance HDR: linear radiance)
  // Empty when decoded. Else what is wrong: the image is over the pixel limit
  // (over_limit: "W x H pixels is too large (at most 2^N pixels)"), or
  // stb_image's reason for refusing it.
  std::string error;
  bool over_limit = false;
};
struct DecodeOptions {
  bool as_float = false;    // float samples instead of the file's 8 or 16 bits
  int channels = 0;         // the channels wanted; 0: the file's
  int max_pixels_log2 = 0;  // refuse an image of more than 2^this pixels before decoding it; 0: no limit
};

// The one stb_image decoder of prism's image readers (Radiance HDR
// environment maps, glTF textures): whatever stb_image reads, from memory.
inline DecodedImage decode_image(const unsigned char* bytes, size_t size, const DecodeOptions& opt = {}) {
  DecodedImage out;
  auto failed = [&] {
    const char* why = stbi_failure_reason();
    out.error = why ? why : "unknown error";
    return out;
  };
  if (size > size_t(std::numeric_limits<int>::max())) {
    out.error = "larger than 2 GB";
    return out;
  }
  const int len = int(size);
  int w = 0, h = 0, c = 0;
  if (opt.max_pixels_log2 > 0) {
    if (!stbi_info_from_memory(bytes, len, &w, &h, &c)) return failed();
    if (double(w) * double(h) > std::ldexp(1.0, opt.max_pixels_log2)) {
      out.error = std::to_string(w) + " x " + std::to_string(h) + " pixels is too large (at most 2^" +
                  std::to_string(opt.max_pixels_log2) + " pixels)";
      out.over_limit = true;
      return out;
    }
  }
  // Copies stb's samples and frees them (also if the copy throws).
  auto take = [&](auto* px, auto& dst) {
    std::unique_ptr<void, void (*)(void*)> owned(px, stbi_image_free);
    out.width = w;
    out.height = h;
    out.channels = opt.channels ? opt.channels : c;
    dst.assign(px, px + size_t(w) * size_t(h) * size_t(out.channels));
  };
  if (opt.as_float) {
    float* px = stbi_loadf_from_memory(bytes, len, &w, &h, &c, opt.channels);
    if (!px) return failed();
    take(px, out.f32);
  } else if (stbi_is_16_bit_from_memory(bytes, len)) {
    stbi_us* px = stbi_load_16_from_memory(bytes, len, &w, &h, &c, opt.channels);
    if (!px) return failed();
    take(px, out.u16);
  } else {
    stbi_uc* px = stbi_load_from_memory(bytes, len, &w, &h, &c, opt.channels);
    if (!px) return failed();
    take(px, out.u8);
  }
  return out;
}

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

namespace detail {
// The R, G and B channels at the root of a scanline EXR with other layers
// beside them (tinyexr's LoadEXR looks at the first four channels only, which
// in a file with "N.X" or "albedo.R" are not the image's). Empty if the file
// is tiled or has no root R, G and B: LoadEXR then reads it.
inline std::optional<Image> read_exr_root_rgb(const std::string& path) {
  EXRVersion version;
  if (ParseEXRVersionFromFile(&version, path.c_str()) != TINYEXR_SUCCESS || version.multipart || version.non_image ||
      version.tiled)
    return std::nullopt;
  EXRHeader header;
  InitEXRHeader(&header);
  const char* err = nullptr;
  if (ParseEXRHeaderFromFile(&header, &version, path.c_str(), &err) != TINYEXR_SUCCESS) {
    if (err) FreeEXRErrorMessage(err);
    return std::nullopt;
  }
  int idx[3] = {-1, -1, -1};
  for (int c = 0; c < header.num_channels; ++c) {
    std::string n = header.channels[c].name;
    if (n == "R") idx[0] = c;
    if (n == "G") idx[1] = c;
    if (n == "B") idx[2] = c;
    header.requested_pixel_types[c] = TINYEXR_PIXELTYPE_FLOAT;
  }
  if (idx[0] < 0 || idx[1] < 0 || idx[2] < 0 || header.num_channels <= 4 || header.tiled) {
    FreeEXRHeader(&header);
    return std::nullopt;
  }
  EXRImage image;
  InitEXRImage(&image);
  if (LoadEXRImageFromFile(&image, &header, path.c_str(), &err) != TINYEXR_SUCCESS) {
    std::string msg = err ? err : "unknown error";
    if (err) FreeEXRErrorMessage(err);
    FreeEXRHeader(&header);
    throw Error(path + ": cannot read EXR: " + msg);
  }
  Image img{image.width, image.height, std::vector<float>(size_t(image.width) * size_t(image.height) * 3)};
  for (size_t i = 0; i < size_t(image.width) * size_t(image.height); ++i)
    for (int c = 0; c < 3; ++c)
      img.rgb[3 * i + size_t(c)] = reinterpret_cast<const float*>(image.images[idx[c]])[i];
  FreeEXRImage(&image);
  FreeEXRHeader(&header);
  return img;
}
}  // namespace detail

inline Image read_exr(const std::string& path) {
  if (auto img = detail::read_exr_root_rgb(path)) return *std::move(img);
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

// One channel of a multi-channel EXR: a name ("R", "albedo.G", "Z"...) and
// width * height floats, row-major from the top-left.
struct ExrChannel {
  std::string name;
  std::vector<float> data;
};

// String attributes for an EXR header (name, non-empty value): how an image was made,
// e.g. a reference's sample count and seeds. Written with OpenEXR's "string"
// type, so any OpenEXR reader shows them.
using ExrAttributes = std::vector<std::pair<std::string, std::string>>;

// Writes channels as one 32-bit float EXR (zip compressed), in the name order
// OpenEXR readers expect, with the given string attributes in its header.
// Non-finite values are written as 0.
inline void write_exr_channels(const std::string& path, int width, int height, std::vector<ExrChannel> channels,
                               const ExrAttributes& attributes = {}) {
  if (width <= 0 || height <= 0 || channels.empty()) throw Error(path + ": an EXR needs a size and channels");
  for (const auto& c : channels)
    if (c.data.size() != size_t(width) * size_t(height))
      throw Error(path + ": EXR channel '" + c.name + "' does not match the image size");
  std::sort(channels.begin(), channels.end(), [](const ExrChannel& a, const ExrChannel& b) { return a.name < b.name; });
  for (auto& c : channels)
    for (float& v : c.data) v = detail::finite_or_zero(v);
  EXRHeader header;
  InitEXRHeader(&header);
  EXRImage image;
  InitEXRImage(&image);
  std::vector<float*> ptrs;
  for (auto& c : channels) ptrs.push_back(c.data.data());
  image.images = reinterpret_cast<unsigned char**>(ptrs.data());
  image.num_channels = int(channels.size());
  image.width = width;
  image.height = height;
  std::vector<EXRChannelInfo> info(channels.size());
  std::vector<int> types(channels.size(), TINYEXR_PIXELTYPE_FLOAT);
  for (size_t i = 0; i < channels.size(); ++i) {
    std::memset(&info[i], 0, sizeof(EXRChannelInfo));
    std::strncpy(info[i].name, channels[i].name.c_str(), 255);
  }
  header.num_channels = int(channels.size());
  header.channels = info.data();
  header.pixel_types = types.data();
  header.requested_pixel_types = types.data();
  header.compression_type = TINYEXR_COMPRESSIONTYPE_ZIP;
  std::vector<EXRAttribute> attrs(attributes.size());
  for (size_t i = 0; i < attributes.size(); ++i) {
    const auto& [name, value] = attributes[i];
    if (name.empty() || name.size() > 255 || name.find('\0') != std::string::npos)
      throw Error(path + ": EXR attribute name '" + name + "' must have 1 to 255 characters and no NUL");
    // (tinyexr does not read an empty attribute value back.)
    if (value.empty() || value.size() > size_t(std::numeric_limits<int>::max()))
      throw Error(path + ": EXR attribute '" + name + "' must have a value of 1 to 2^31 - 1 bytes");
    std::memset(&attrs[i], 0, sizeof(EXRAttribute));
    std::strncpy(attrs[i].name, name.c_str(), 255);
    std::strncpy(attrs[i].type, "string", 255);
    attrs[i].value = reinterpret_cast<unsigned char*>(const_cast<char*>(value.data()));
    attrs[i].size = int(value.size());
  }
  header.num_custom_attributes = int(attrs.size());
  header.custom_attributes = attrs.empty() ? nullptr : attrs.data();
  const char* err = nullptr;
  int rc = SaveEXRImageToFile(&image, &header, path.c_str(), &err);
  if (rc != TINYEXR_SUCCESS) {
    std::string msg = err ? err : "unknown error";
    if (err) FreeEXRErrorMessage(err);
    throw Error(path + ": cannot write EXR: " + msg);
  }
}

// An RGB image as an EXR (R, G, B, 32-bit float) with string attributes in
// its header; read_exr reads the image back, read_exr_attributes the rest.
inline void write_exr(const std::string& path, const Image& img, const ExrAttributes& attributes) {
  detail::check_image(img, path);
  const size_t n = size_t(img.width) * size_t(img.height);
  std::vector<ExrChannel> ch{{"R", {}}, {"G", {}}, {"B", {}}};
  for (size_t k = 0; k < 3; ++k) {
    ch[k].data.resize(n);
    for (size_t i = 0; i < n; ++i) ch[k].data[i] = img.rgb[3 * i + k];
  }
  write_exr_channels(path, img.width, img.height, std::move(ch), attributes);
}

// The string attributes of an EXR's header (see write_exr_channels); other
// attribute types are left out. Throws prism::Error naming the file if it
// cannot be read as an EXR.
inline std::map<std::string, std::string> read_exr_attributes(const std::string& path) {
  EXRVersion version;
  if (ParseEXRVersionFromFile(&version, path.c_str()) != TINYEXR_SUCCESS)
    throw Error(path + ": not a readable EXR file");
  if (version.multipart) throw Error(path + ": multi-part EXR files are not supported");
  EXRHeader header;
  InitEXRHeader(&header);
  const char* err = nullptr;
  if (ParseEXRHeaderFromFile(&header, &version, path.c_str(), &err) != TINYEXR_SUCCESS) {
    std::string msg = err ? err : "unknown error";
    if (err) FreeEXRErrorMessage(err);
    throw Error(path + ": cannot read the EXR header: " + msg);
  }
  std::map<std::string, std::string> out;
  for (int i = 0; i < header.num_custom_attributes; ++i) {
    const EXRAttribute& a = header.custom_attributes[i];
    if (std::string(a.type) == "string" && a.size >= 0)
      out[a.name] = std::string(reinterpret_cast<const char*>(a.value), size_t(a.size));
  }
  FreeEXRHeader(&header);
  return out;
}

// The film as an EXR with the layers a denoiser or compositor wants: R, G, B
// (the image), albedo.R/G/B, N.X/Y/Z (world-space shading normal), Z (depth
// along the camera ray) from the AOV film, and variance.R/G/B (the variance
// of each pixel's estimate, Film::variance).
inline void write_exr_with_aovs(const std::string& path, const Film& film, const AovFilm& aovs) {
  const int w = film.width(), h = film.height();
  if (aovs.width() != w || aovs.height() != h) throw Error(path + ": the AOV film's size differs from the film's");
  const size_t n = size_t(w) * size_t(h);
  const char* names[] = {"R", "G", "B", "albedo.R", "albedo.G", "albedo.B", "N.X", "N.Y", "N.Z", "Z",
                         "variance.R", "variance.G", "variance.B"};
  std::vector<ExrChannel> ch;
  for (const char* name : names) ch.push_back({name, std::vector<float>(n)});
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      size_t i = size_t(y) * size_t(w) + size_t(x);
      RGB c = film.pixel(x, y), a = aovs.albedo(x, y), v = film.variance(x, y);
      Vector3f nn = aovs.normal(x, y);
      float vals[] = {c.r, c.g, c.b, a.r, a.g, a.b, nn.x, nn.y, nn.z, aovs.depth(x, y), v.r, v.g, v.b};
      for (size_t k = 0; k < ch.size(); ++k) ch[k].data[i] = vals[k];
    }
  write_exr_channels(path, w, h, std::move(ch));
}

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

namespace detail {
// The lower-case extension of path, with its dot ("" if none).
inline std::string env_file_extension(const std::string& path) {
  size_t dot = path.find_last_of('.'), slash = path.find_last_of("/\\");
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string e = path.substr(dot);
  for (auto& c : e) c = char(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

// A Radiance RGBE file in memory, checked and given a canonical header:
// "#?RADIANCE", "FORMAT=32-bit_rle_rgbe", a blank line, "-Y h +X w", then the
// file's pixel data unchanged. The pixel data is checked against the grammar
// stb_image 2.27 decodes (flat 4-byte RGBE texels for widths outside [8,
// 32767], else one run-length-encoded scanline after another) before stb sees
// it: stb loops forever on a truncated run-length-encoded scanline (a count
// of 0 read past the end makes no progress) and fills truncated flat data
// with garbage. Header lines other than FORMAT (GAMMA, PRIMARIES, EXPOSURE,
// a repeated "#?RADIANCE", comments) are ignored, as stb and most renderers
// do.
inline std::vector<unsigned char> canonical_rgbe(const std::vector<unsigned char>& file, const std::string& path) {
  const std::string where = path + ": Radiance HDR: ";
  size_t pos = 0;
  auto next_line = [&](std::string& line) {
    line.clear();
    while (pos < file.size() && file[pos] != '\n') line.push_back(char(file[pos++]));
    if (pos >= file.size()) return false;
    ++pos;  // the newline
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  };
  std::string line;
  if (!next_line(line) || (line != "#?RADIANCE" && line != "#?RGBE"))
    throw Error(where + "not a Radiance RGBE file (the first line must be #?RADIANCE or #?RGBE)");
  for (;;) {
    if (!next_line(line)) throw Error(where + "the header does not end (no blank line before the resolution)");
    if (line.empty()) break;
    if (line.rfind("FORMAT=", 0) == 0 && line != "FORMAT=32-bit_rle_rgbe")
      throw Error(where + "unsupported " + line + " (only 32-bit_rle_rgbe)");
  }
  if (!next_line(line)) throw Error(where + "no resolution line after the header");
  // "-Y h +X w" with 0 < w, h <= 2^24 (stb's limit).
  int w = 0, h = 0;
  {
    const char* c = line.c_str();
    char* end = nullptr;
    auto dimension = [&](const char* label) {
      if (std::strncmp(c, label, 3) != 0) return 0L;
      errno = 0;
      long v = std::strtol(c + 3, &end, 10);
      if (errno != 0 || end == c + 3 || v <= 0 || v > (1L << 24)) return 0L;
      c = end;
      while (*c == ' ') ++c;
      return v;
    };
    h = int(dimension("-Y "));
    w = h > 0 ? int(dimension("+X ")) : 0;
    if (w <= 0 || *c != 0)
      throw Error(where + "resolution line '" + line +
                  "' is not supported (only '-Y height +X width', sizes 1 to 2^24: rows from the top, left to right)");
  }
  const size_t data = pos, n = file.size();
  auto truncated = [&](int row) {
    return Error(where + "truncated pixel data (scanline " + std::to_string(row) + " of " + std::to_string(h) + ")");
  };
  auto check_flat = [&]() {
    size_t need = 4 * size_t(w) * size_t(h);
    if (n - data < need) throw truncated(int((n - data) / (4 * size_t(w))));
  };
  if (w < 8 || w >= 32768) {
    check_flat();
  } else {
    size_t p = data;
    for (int row = 0; row < h; ++row) {
      if (n - p < 4) throw truncated(row);
      if (file[p] != 2 || file[p + 1] != 2 || (file[p + 2] & 0x80)) {
        // Not run-length encoded: flat texels, which stb accepts only from the start.
        if (row == 0) {
          check_flat();
          break;
        }
        throw Error(where + "scanline " + std::to_string(row) +
                    " is not run-length encoded but the ones before it are");
      }
      int len = (int(file[p + 2]) << 8) | int(file[p + 3]);
      if (len != w)
        throw Error(where + "scanline " + std::to_string(row) + " has length " + std::to_string(len) +
                    ", expected the width " + std::to_string(w));
      p += 4;
      for (int channel = 0; channel < 4; ++channel)
        for (int i = 0; i < w;) {
          if (p >= n) throw truncated(row);
          int count = file[p++];
          bool run = count > 128;
          if (run) count -= 128;
          if (count == 0 || count > w - i)
            throw Error(where + "bad run-length data in scanline " + std::to_string(row));
          size_t bytes = run ? 1 : size_t(count);
          if (n - p < bytes) throw truncated(row);
          p += bytes;
          i += count;
        }
    }
  }
  std::string header = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y " + std::to_string(h) + " +X " + std::to_string(w) + "\n";
  std::vector<unsigned char> out(header.begin(), header.end());
  out.insert(out.end(), file.begin() + std::ptrdiff_t(data), file.end());
  return out;
}

inline EnvironmentImage read_rgbe(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Error(path + ": cannot open");
  std::vector<unsigned char> file((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (f.bad()) throw Error(path + ": read failed");
  std::vector<unsigned char> mem = canonical_rgbe(file, path);
  if (mem.size() > size_t(std::numeric_limits<int>::max())) throw Error(path + ": Radiance HDR: file too large");
  DecodedImage px = decode_image(mem.data(), mem.size(), {.as_float = true, .channels = 3});
  if (!px.error.empty()) throw Error(path + ": cannot decode Radiance HDR: " + px.error);
  return EnvironmentImage{px.width, px.height, std::move(px.f32)};
}
}  // namespace detail

// An equirectangular environment map from a file, by extension (any case):
// .hdr (Radiance RGBE), .exr (the R, G, B channels; alpha is dropped) or .pfm
// (RGB). Row 0 of the result is the file's top row, which ImageInfiniteLight
// takes as the +y pole. Any aspect ratio. Throws prism::Error naming the file
// and what is wrong: it does not exist or cannot be read, an unknown
// extension, a malformed or truncated file, or a texel that is not finite and
// non-negative (with its x, y from the top left).
inline EnvironmentImage read_environment(const std::string& path) {
  const std::string ext = detail::env_file_extension(path);
  if (ext != ".hdr" && ext != ".exr" && ext != ".pfm")
    throw Error(path + ": unknown environment map format '" + ext + "' (use .hdr, .exr or .pfm)");
  if (!std::ifstream(path, std::ios::binary)) throw Error(path + ": cannot open (missing or unreadable)");
  EnvironmentImage img;
  if (ext == ".hdr") {
    img = detail::read_rgbe(path);
  } else {
    Image rgb = ext == ".exr" ? read_exr(path) : read_pfm(path);
    img = EnvironmentImage{rgb.width, rgb.height, std::move(rgb.rgb)};
  }
  for (size_t i = 0; i < img.rgb.size(); ++i) {
    float v = img.rgb[i];
    if (!std::isfinite(v) || v < 0) {
      size_t t = i / 3;
      throw Error(path + ": texel (" + std::to_string(t % size_t(img.width)) + ", " +
                  std::to_string(t / size_t(img.width)) + ") channel " + "rgb"[i % 3] + " is " + std::to_string(v) +
                  ": an environment map's radiance must be finite and non-negative");
    }
  }
  return img;
}

}  // namespace prism
