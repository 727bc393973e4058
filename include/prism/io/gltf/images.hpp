// prism/io/gltf/images.hpp — a glTF file's images: the encoded bytes kept
// while tinygltf parses (its image loader callback, defer_image), checked to
// be whole PNG or JPEG files and decoded once each, in parallel, through
// io/image_io.hpp's decode_image; WebP files (EXT_texture_webp) through
// Debian's libwebp when prism::gltf found it (PRISM_HAS_WEBP). A failed image
// is an error only when a texture uses it (materials.hpp).
#pragma once
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstring>
#include <exception>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>
#include <tiny_gltf.h>
#include "prism/io/image_io.hpp"
#include "prism/textures/image.hpp"
#if defined(PRISM_HAS_WEBP)
#include <webp/decode.h>
#endif

namespace prism::gltf_detail {

// Encoded image bytes kept by the image loader callback, decoded later in
// parallel.
struct PendingImages {
  std::vector<std::vector<unsigned char>> encoded;  // by image index
  const tinygltf::Model* model = nullptr;           // being parsed: its buffers and bufferViews are in
};

inline bool defer_image(tinygltf::Image* image, const int image_idx, std::string* err, std::string* /*warn*/,
                        int /*req_width*/, int /*req_height*/, const unsigned char* bytes, int size, void* user) {
  auto* pending = static_cast<PendingImages*>(user);
  if (image_idx < 0) return false;
  // tinygltf 2.7 hands over an image's bufferView without checking its byte
  // range against the buffer (it checked both indices).
  if (image->bufferView >= 0 && pending->model) {
    const auto& bv = pending->model->bufferViews[size_t(image->bufferView)];
    const auto& buf = pending->model->buffers[size_t(bv.buffer)];
    if (bv.byteOffset > buf.data.size() || bv.byteLength > buf.data.size() - bv.byteOffset) {
      if (err)
        *err += "images[" + std::to_string(image_idx) + "]: bufferViews[" + std::to_string(image->bufferView) +
                "] byte range [" + std::to_string(bv.byteOffset) + ", " + std::to_string(bv.byteOffset + bv.byteLength) +
                ") runs past the end of buffers[" + std::to_string(bv.buffer) + "] (" + std::to_string(buf.data.size()) +
                " bytes)\n";
      return false;
    }
  }
  if (pending->encoded.size() <= size_t(image_idx)) pending->encoded.resize(size_t(image_idx) + 1);
  pending->encoded[size_t(image_idx)].assign(bytes, bytes + std::max(size, 0));
  image->width = image->height = image->component = 0;
  return true;
}

// The decoded images, by image index.
struct Images {
  std::vector<std::shared_ptr<const TextureImage>> decoded;  // null where decoding failed
  std::map<size_t, std::string> errors;                      // why, for those
  size_t count = 0, bytes = 0;                               // decoded images and their bytes
};

// A RIFF container holding a WebP image.
inline bool is_webp(const std::vector<unsigned char>& b) {
  return b.size() >= 12 && std::memcmp(b.data(), "RIFF", 4) == 0 && std::memcmp(b.data() + 8, "WEBP", 4) == 0;
}

// glTF images are PNG or JPEG (or WebP, EXT_texture_webp); stb_image would
// also guess at BMP, GIF, TGA, PSD, HDR, PIC and PNM. Checks the signature,
// and that a PNG's chunks and a JPEG's end-of-image marker are all there, so
// stb_image never decodes a truncated file (it reads past the end as zeros);
// a WebP file's RIFF size must fit in the bytes.
inline std::string image_format_problem(const std::vector<unsigned char>& b) {
  static const unsigned char png[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  if (b.size() >= 8 && std::memcmp(b.data(), png, 8) == 0) {
    for (size_t at = 8;;) {
      if (b.size() - at < 12) return "truncated PNG (no IEND chunk)";
      size_t len = size_t(b[at]) << 24 | size_t(b[at + 1]) << 16 | size_t(b[at + 2]) << 8 | size_t(b[at + 3]);
      if (len > b.size() - at - 12)
        return "truncated PNG (the chunk at byte " + std::to_string(at) + " runs past the end)";
      const unsigned char* type = b.data() + at + 4;
      if (at == 8 && std::memcmp(type, "IHDR", 4) != 0) return "corrupt PNG (the first chunk is not IHDR)";
      if (std::memcmp(type, "IEND", 4) == 0) return {};
      at += 12 + len;
    }
  }
  if (b.size() >= 4 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF) {
    for (size_t k = b.size() - 1; k >= 3; --k)  // EOI, possibly followed by padding
      if (b[k - 1] == 0xFF && b[k] == 0xD9) return {};
    return "truncated JPEG (no end-of-image marker)";
  }
  if (is_webp(b)) {
    size_t riff = size_t(b[4]) | size_t(b[5]) << 8 | size_t(b[6]) << 16 | size_t(b[7]) << 24;
    if (riff + 8 > b.size()) return "truncated WebP (the RIFF header promises " + std::to_string(riff + 8) + " bytes)";
#if defined(PRISM_HAS_WEBP)
    return {};
#else
    return "a WebP image, but prism::gltf was built without libwebp (EXT_texture_webp; Debian: libwebp-dev)";
#endif
  }
  return "unsupported image format (glTF images are PNG or JPEG, or WebP with EXT_texture_webp)";
}

#if defined(PRISM_HAS_WEBP)
// A WebP file as 8-bit RGB, or RGBA when it has alpha, through libwebp.
inline DecodedImage decode_webp(const std::vector<unsigned char>& b, int max_pixels_log2) {
  DecodedImage out;
  WebPBitstreamFeatures f;
  if (WebPGetFeatures(b.data(), b.size(), &f) != VP8_STATUS_OK || f.width <= 0 || f.height <= 0) {
    out.error = "not a valid WebP image";
    return out;
  }
  if (double(f.width) * double(f.height) > std::ldexp(1.0, max_pixels_log2)) {
    out.error = std::to_string(f.width) + " x " + std::to_string(f.height) + " pixels is too large (at most 2^" +
                std::to_string(max_pixels_log2) + " pixels)";
    out.over_limit = true;
    return out;
  }
  out.channels = f.has_alpha ? 4 : 3;
  const size_t stride = size_t(f.width) * size_t(out.channels);
  out.u8.resize(stride * size_t(f.height));
  const uint8_t* ok = f.has_alpha ? WebPDecodeRGBAInto(b.data(), b.size(), out.u8.data(), out.u8.size(), int(stride))
                                  : WebPDecodeRGBInto(b.data(), b.size(), out.u8.data(), out.u8.size(), int(stride));
  if (!ok) {
    out.u8.clear();
    out.error = "libwebp cannot decode the WebP image";
    return out;
  }
  out.width = f.width;
  out.height = f.height;
  return out;
}
#endif

// Decodes every referenced image once, on all cores; 16-bit PNGs stay 16-bit
// unless every value fits 8 bits.
inline Images decode_images(const tinygltf::Model& model, PendingImages& pending) {
  size_t n = model.images.size();
  Images out;
  out.decoded.assign(n, nullptr);
  std::vector<std::string> errors(n);
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t i; (i = next.fetch_add(1)) < n;) {
      if (i >= pending.encoded.size() || pending.encoded[i].empty()) {
        const auto& im = model.images[i];
        bool external = !im.uri.empty() && im.uri.rfind("data:", 0) != 0;
        errors[i] = im.uri.empty() && im.bufferView < 0 ? "has neither a uri nor a bufferView"
                    : external                          ? "file not found, unreadable or empty"
                                                        : "no image data";
        continue;
      }
      const auto& bytes = pending.encoded[i];
      if (bytes.size() > size_t(std::numeric_limits<int>::max())) {
        errors[i] = "image too large";
        continue;
      }
      errors[i] = image_format_problem(bytes);
      if (!errors[i].empty()) continue;
      try {
#if defined(PRISM_HAS_WEBP)
        DecodedImage px = is_webp(bytes) ? decode_webp(bytes, 28)
                                         : decode_image(bytes.data(), bytes.size(), {.max_pixels_log2 = 28});
#else
        DecodedImage px = decode_image(bytes.data(), bytes.size(), {.max_pixels_log2 = 28});
#endif
        if (!px.error.empty()) {
          errors[i] = px.over_limit ? px.error : "cannot decode: " + px.error;
          continue;
        }
        if (!px.u16.empty()) {
          auto img = std::make_shared<TextureImage>(
              TextureImage::from_u16(px.width, px.height, px.channels, std::move(px.u16)));
          img->shrink_to_smallest();
          out.decoded[i] = img;
        } else {
          out.decoded[i] =
              std::make_shared<TextureImage>(TextureImage::from_u8(px.width, px.height, px.channels, std::move(px.u8)));
        }
      } catch (const std::exception& e) {
        errors[i] = e.what();
      }
    }
  };
  unsigned threads = std::max(1u, std::min(std::thread::hardware_concurrency(), unsigned(n)));
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto& t : pool) t.join();
  pending.encoded.clear();
  for (size_t i = 0; i < n; ++i) {
    // An image no texture uses is not an error worth failing the scene for.
    if (!errors[i].empty()) out.errors[i] = errors[i];
    if (out.decoded[i]) {
      ++out.count;
      out.bytes += out.decoded[i]->bytes();
    }
  }
  return out;
}

}  // namespace prism::gltf_detail
