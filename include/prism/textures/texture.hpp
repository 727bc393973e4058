// prism/textures/texture.hpp — image textures with glTF samplers: wrap modes
// (repeat, clamp to edge, mirrored repeat), nearest or bilinear magnification
// filtering, sRGB or linear colour encoding, and KHR_texture_transform.
//
// Conventions (glTF 2.0, section 3.8 "Texture Data"): uv (0,0) is the top-left
// corner of the image, u to the right, v down; texel (x, y) covers
// [x/W, (x+1)/W] x [y/H, (y+1)/H] and its centre is at ((x+0.5)/W, (y+0.5)/H).
// Texel lookup follows the OpenGL 4.6 specification, section 8.14.2 ("Coordinate
// Wrapping and Texel Selection"): nearest takes texel floor(u W); linear blends
// the texel centres around u W - 1/2, i0 = floor(u W - 1/2), i1 = i0 + 1, with
// weight frac(u W - 1/2), each index wrapped on its own through the wrap mode
// (table 8.20), so repeat wraps around the border, clamp_to_edge repeats the
// edge texel and mirrored_repeat mirrors.
//
// sRGB textures (glTF baseColorTexture, emissiveTexture) are decoded per texel
// before filtering, as GPUs do for SRGB8 formats: 8-bit values through an exact
// 256-entry table, 16-bit and float values through the formula. Alpha is never
// decoded. evaluate(uv) applies `filter`, the magnification filter, to the
// image; evaluate(uv, footprint, TextureFilter) filters over a pixel's
// footprint in uv with the MIP pyramid (textures/mipmap.hpp,
// build_mipmaps()): trilinear (two levels' bilinear lookups blended by the
// footprint's size) or EWA (Heckbert 1989: a Gaussian over the footprint's
// ellipse, as pbrt-v4 filters, eccentricity at most max_anisotropy).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <optional>
#include <string_view>
#include <vector>
#include "prism/attributes.hpp"
#include "prism/math/vector.hpp"
#include "prism/spectra/rgb.hpp"
#include "prism/spectra/spectrum.hpp"
#include "prism/textures/image.hpp"
#include "prism/textures/mipmap.hpp"

namespace prism {

// glTF sampler wrapS / wrapT: 10497 REPEAT, 33071 CLAMP_TO_EDGE, 33648 MIRRORED_REPEAT.
enum class WrapMode : uint8_t { repeat, clamp_to_edge, mirrored_repeat };
// glTF sampler magFilter: 9728 NEAREST, 9729 LINEAR.
enum class FilterMode : uint8_t { nearest, linear };
enum class ColorEncoding : uint8_t { linear, srgb };

// How a lookup over a pixel's footprint filters (prism-render
// --texture-filter): point, the nearest texel of the image; bilinear, the
// sampler's magnification filter on the image whatever the footprint (what
// evaluate(uv) does); trilinear and ewa, the MIP pyramid where the footprint
// covers more than a texel, else the magnification filter.
enum class TextureFilter : uint8_t { point, bilinear, trilinear, ewa };
constexpr const char* texture_filter_name(TextureFilter f) {
  switch (f) {
    case TextureFilter::point: return "point";
    case TextureFilter::bilinear: return "bilinear";
    case TextureFilter::trilinear: return "trilinear";
    case TextureFilter::ewa: return "ewa";
  }
  return "?";
}
constexpr std::optional<TextureFilter> parse_texture_filter(std::string_view s) {
  for (TextureFilter f : {TextureFilter::point, TextureFilter::bilinear, TextureFilter::trilinear, TextureFilter::ewa})
    if (s == texture_filter_name(f)) return f;
  return std::nullopt;
}

// A pixel's footprint in uv: how uv changes from one pixel to the next along
// x (dudx, dvdx) and y (dudy, dvdy). Zero: a point.
struct TextureFootprint {
  Float dudx = 0, dvdx = 0, dudy = 0, dvdy = 0;
};

// The glTF (OpenGL) enum values; nullopt for anything else. A glTF sampler
// without wrapS/wrapT means repeat; without magFilter, the implementation's
// choice (prism: linear). Minification filters (with mipmaps) map to their
// magnification part: 9984/9986 nearest, 9985/9987 linear.
constexpr std::optional<WrapMode> wrap_mode_from_gltf(int v) {
  switch (v) {
    case 10497: return WrapMode::repeat;
    case 33071: return WrapMode::clamp_to_edge;
    case 33648: return WrapMode::mirrored_repeat;
    default: return std::nullopt;
  }
}
constexpr std::optional<FilterMode> filter_mode_from_gltf(int v) {
  switch (v) {
    case 9728: case 9984: case 9986: return FilterMode::nearest;
    case 9729: case 9985: case 9987: return FilterMode::linear;
    default: return std::nullopt;
  }
}

// KHR_texture_transform: uv' = T(offset) R(rotation) S(scale) uv, with
//   R = [ cos  sin ]
//       [ -sin cos ]  acting on the column (u, v),
// i.e. u' = cos u + sin v, v' = -sin u + cos v: a counter-clockwise rotation of
// the uvs in glTF's u-right, v-down uv space (an image rotated clockwise). This
// is the matrix of the extension's worked example ("offset [0, 1], rotation
// pi/2, scale [0.5, 0.5] uses only the lower-left quadrant of the image,
// rotated clockwise 90 degrees") and of the glTF sample viewer, Babylon.js,
// three.js and Blender. The GLSL listing in the extension's README, read with
// GLSL's column-major constructors, gives the transpose (the y-up rotation);
// KhronosGroup/glTF issue #1563 records that the listing is the one in error.
struct TextureTransform {
  Point2f offset{0, 0};
  Float rotation = 0;
  Point2f scale{1, 1};

  // The linear part alone (scale, then rotation), for derivatives.
  Point2f apply_linear(Point2f d) const noexcept {
    const Float su = d.x * scale.x, sv = d.y * scale.y;
    if (rotation == 0) return {su, sv};
    const Float c = std::cos(rotation), s = std::sin(rotation);
    return {c * su + s * sv, -s * su + c * sv};
  }
  Point2f apply(Point2f uv) const noexcept {
    const Float su = uv.x * scale.x, sv = uv.y * scale.y;
    Float ru = su, rv = sv;
    if (rotation != 0) {
      const Float c = std::cos(rotation), s = std::sin(rotation);
      ru = c * su + s * sv;
      rv = -s * su + c * sv;
    }
    return {ru + offset.x, rv + offset.y};
  }
  bool is_identity() const noexcept {
    return offset.x == 0 && offset.y == 0 && rotation == 0 && scale.x == 1 && scale.y == 1;
  }
};

struct RGBA {
  RGB rgb{0};
  Float a = 1;
};

namespace detail {

// Texel index wrapping (OpenGL 4.6, table 8.20) of an integer coordinate i on
// an axis of n texels. The reduced coordinates of the lookups below keep i
// within one period of [0, n) (repeat) or [0, 2n) (mirrored), so a conditional
// add replaces the slow 64-bit remainder; the remainder stays as the fallback.
inline int64_t wrap_texel(int64_t i, int64_t n, WrapMode m) noexcept {
  switch (m) {
    case WrapMode::repeat:
      if (i < 0) i += n;
      else if (i >= n) i -= n;
      if (i < 0 || i >= n) [[unlikely]] {
        i %= n;
        if (i < 0) i += n;
      }
      return i;
    case WrapMode::clamp_to_edge: return i < 0 ? 0 : (i >= n ? n - 1 : i);
    case WrapMode::mirrored_repeat: {
      const int64_t n2 = 2 * n;
      if (i < 0) i += n2;
      else if (i >= n2) i -= n2;
      if (i < 0 || i >= n2) [[unlikely]] {
        i %= n2;
        if (i < 0) i += n2;
      }
      // (n - 1) - mirror(i - n), mirror(a) = a >= 0 ? a : -(1 + a)
      const int64_t a = i - n;
      return (n - 1) - (a >= 0 ? a : -(1 + a));
    }
  }
  return 0;
}

// Brings a finite coordinate into a small range with the same lookup result, so
// that u * n converts to an integer without overflow and keeps its precision:
// repeat: [0, 1] (period 1), mirrored_repeat: [0, 2] (period 2), clamp:
// [-1, 2] (everything beyond samples the edge texel anyway).
inline Float reduce_coordinate(Float u, WrapMode m) noexcept {
  switch (m) {
    case WrapMode::repeat: return u - std::floor(u);
    case WrapMode::mirrored_repeat: return u - 2 * std::floor(u * Float(0.5));
    case WrapMode::clamp_to_edge: return std::clamp(u, Float(-1), Float(2));
  }
  return 0;
}

// Normalised stored value of one channel (no colour decoding).
// Normalised as TextureImage::channel does, bit for bit.
inline float texel_value(const uint8_t* p, size_t i) noexcept { return unorm8_table[p[i]]; }
inline float texel_value(const uint16_t* p, size_t i) noexcept { return float(p[i]) / 65535.f; }
inline float texel_value(const float* p, size_t i) noexcept { return p[i]; }
// The same value decoded from sRGB to linear.
inline float texel_srgb(const uint8_t* p, size_t i, const float* table) noexcept { return table[p[i]]; }
inline float texel_srgb(const uint16_t* p, size_t i, const float*) noexcept {
  return srgb_decode(float(p[i]) / 65535.f);
}
inline float texel_srgb(const float* p, size_t i, const float*) noexcept { return srgb_decode(p[i]); }

// Loads the channels of the texel starting at value index i into out[0..nc),
// decoding the colour channels when `table` is non-null (sRGB): all but the
// alpha channel of 2- and 4-channel images.
template <class T>
inline void load_texel(const T* p, size_t i, int nc, const float* srgb_table, float* out) noexcept {
  if (srgb_table) {
    const int ncolour = (nc == 2 || nc == 4) ? nc - 1 : nc;
    for (int c = 0; c < ncolour; ++c) out[c] = texel_srgb(p, i + size_t(c), srgb_table);
    for (int c = ncolour; c < nc; ++c) out[c] = texel_value(p, i + size_t(c));
  } else {
    for (int c = 0; c < nc; ++c) out[c] = texel_value(p, i + size_t(c));
  }
}

// 1 channel: grey, a = 1; 2: grey + alpha; 3: rgb, a = 1; 4: rgba.
inline RGBA expand_channels(const float* v, int nc) noexcept {
  switch (nc) {
    case 1: return {RGB(v[0]), 1};
    case 2: return {RGB(v[0]), v[1]};
    case 3: return {RGB(v[0], v[1], v[2]), 1};
    default: return {RGB(v[0], v[1], v[2]), v[3]};
  }
}

}  // namespace detail

// An image with a glTF sampler (see the conventions at the top of this file).
class ImageTexture {
 public:
  std::shared_ptr<const TextureImage> image;
  WrapMode wrap_s = WrapMode::repeat, wrap_t = WrapMode::repeat;
  FilterMode filter = FilterMode::linear;          // magnification filter; no mipmaps
  ColorEncoding encoding = ColorEncoding::linear;  // srgb: colour channels decoded per texel before filtering
  TextureTransform transform;
  int texcoord = 0;  // which TEXCOORD_n set (0 or 1); the caller picks the uv
  // Levels 1, 2, ... of the MIP pyramid (build_mipmaps(); null: none, and
  // the footprint lookups use the image alone). Shared like the image.
  std::shared_ptr<const std::vector<TextureImage>> mips;
  // glTF minFilter: false for NEAREST or LINEAR (no mipmaps), which the
  // footprint lookups honour by filtering the image alone.
  bool use_mipmaps = true;
  Float max_anisotropy = 8;  // EWA: the footprint's ellipse at most this eccentric
  // The filter of evaluate(uv, footprint): bilinear (the default) is
  // evaluate(uv), whatever the footprint.
  TextureFilter filtering = TextureFilter::bilinear;

  // Builds the pyramid for this texture's encoding (O(texels), once per
  // image and encoding: share `mips` between textures of the same image).
  void build_mipmaps() {
    if (image && !image->empty())
      mips = std::make_shared<const std::vector<TextureImage>>(build_mip_levels(*image, encoding == ColorEncoding::srgb));
  }
  // The number of levels the footprint lookups use (1: the image alone).
  int levels() const noexcept { return 1 + (use_mipmaps && mips ? int(mips->size()) : 0); }
  const TextureImage& level(int k) const noexcept { return k == 0 ? *image : (*mips)[size_t(k - 1)]; }

  // Filtered RGBA over a pixel's footprint (uv and footprint before the
  // transform, which is applied to both). Trilinear: the footprint's size
  // in texels w = max(|d/dx|, |d/dy|) (uv scaled by the image's size) picks
  // the level log2(w); levels 0 and below are evaluate(uv) exactly. EWA: a
  // Gaussian (exp(-2 r^2) - exp(-2)) over the ellipse the two derivative
  // vectors span (widened by a texel, the minor axis stretched to at least
  // 1 / max_anisotropy of the major), on the two levels around the minor
  // axis' size. Allocates nothing and throws nothing.
  RGBA evaluate(Point2f uv, TextureFootprint fp) const noexcept {
    if (filtering == TextureFilter::bilinear) [[likely]] return evaluate(uv);
    return evaluate(uv, fp, filtering);
  }
  // Out of line: the default bilinear lookup above stays as small as evaluate(uv).
  PRISM_NOINLINE RGBA evaluate(Point2f uv, TextureFootprint fp, TextureFilter f) const noexcept {
    const TextureImage* img = image.get();
    if (!img || img->empty()) return {RGB(1), 1};
    if (f == TextureFilter::bilinear) return evaluate(uv);
    if (!transform.is_identity()) {
      uv = transform.apply(uv);
      const Point2f dx = transform.apply_linear({fp.dudx, fp.dvdx}), dy = transform.apply_linear({fp.dudy, fp.dvdy});
      fp = {dx.x, dx.y, dy.x, dy.y};
    }
    const Float u = std::isfinite(uv.x) ? uv.x : Float(0);
    const Float v = std::isfinite(uv.y) ? uv.y : Float(0);
    if (f == TextureFilter::point) return lookup_level(0, u, v, FilterMode::nearest);
    const Float W = Float(img->width()), H = Float(img->height());
    const Float lx = std::sqrt(sqr(fp.dudx * W) + sqr(fp.dvdx * H)), ly = std::sqrt(sqr(fp.dudy * W) + sqr(fp.dvdy * H));
    const int n = levels();
    if (f == TextureFilter::trilinear || !(std::min(lx, ly) > 0)) {
      const Float width = std::max(lx, ly);
      if (!(width > 1) || n == 1 || !std::isfinite(width)) return lookup_level(0, u, v, filter);
      return blend_levels(std::min(std::log2(width), Float(n - 1)),
                          [&](int k) { return lookup_level(k, u, v, FilterMode::linear); });
    }
    // EWA: major axis a, minor axis b (uv units), b clamped to |a| / max_anisotropy.
    Float au = fp.dudx, av = fp.dvdx, bu = fp.dudy, bv = fp.dvdy;
    Float la = lx, lb = ly;
    if (lb > la) {
      std::swap(au, bu);
      std::swap(av, bv);
      std::swap(la, lb);
    }
    if (lb * max_anisotropy < la) {
      const Float k = la / (lb * max_anisotropy);
      bu *= k;
      bv *= k;
      lb *= k;
    }
    if (!std::isfinite(la)) return lookup_level(0, u, v, filter);
    // A minor axis wider than the image: the whole image, the top level
    // (its ellipse there could span millions of texels).
    if (!(lb < Float(int64_t(1) << (n - 1)))) return lookup_level(n - 1, u, v, FilterMode::linear);
    return blend_levels(std::clamp(std::log2(std::max(lb, Float(1e-8))), Float(0), Float(n - 1)),
                        [&](int k) { return ewa_level(k, u, v, au, av, bu, bv); });
  }

  // Filtered RGBA (linear values) at uv, the transform applied first. A
  // non-finite coordinate (after the transform) is replaced by 0, so it gives
  // the lookup at 0 through the wrap mode; an empty image gives RGBA{RGB(1), 1}.
  // Allocates nothing and throws nothing.
  PRISM_FLATTEN RGBA evaluate(Point2f uv) const noexcept {
    const TextureImage* img = image.get();
    if (!img || img->empty()) return {RGB(1), 1};
    if (!transform.is_identity()) uv = transform.apply(uv);
    const Float u = std::isfinite(uv.x) ? uv.x : Float(0);
    const Float v = std::isfinite(uv.y) ? uv.y : Float(0);
    return lookup_level(0, u, v, filter);
  }

  // The mean of evaluate over the unit uv square, approximated by the mean
  // texel (decoded like evaluate; the transform and alpha are ignored). Used for
  // light power estimates. O(texels): call it once, not per sample.
  RGB average() const {
    const TextureImage* img = image.get();
    if (!img || img->empty()) return RGB(1);
    const float* table = encoding == ColorEncoding::srgb ? srgb_u8_decode_table().data() : nullptr;
    switch (img->format()) {
      case PixelFormat::u8: return mean(img->u8_data().data(), *img, table);
      case PixelFormat::u16: return mean(img->u16_data().data(), *img, table);
      case PixelFormat::f32: return mean(img->f32_data().data(), *img, table);
    }
    return RGB(1);
  }

 private:
  // The lookups at the levels around the fractional level l, blended.
  template <class Lookup>
  RGBA blend_levels(Float l, Lookup&& at) const noexcept {
    const int n = levels();
    const int l0 = std::min(int(l), n - 1), l1 = std::min(l0 + 1, n - 1);
    const Float t = l - Float(l0);
    RGBA a = at(l0);
    if (t == 0 || l1 == l0) return a;
    RGBA b = at(l1);
    return {a.rgb * (1 - t) + b.rgb * t, a.a * (1 - t) + b.a * t};
  }
  // The sampler's lookup (nearest or bilinear) on level k.
  RGBA lookup_level(int k, Float u, Float v, FilterMode mode) const noexcept {
    const TextureImage& img = level(k);
    const float* table = encoding == ColorEncoding::srgb ? srgb_u8_decode_table().data() : nullptr;
    switch (img.format()) {
      case PixelFormat::u8: return lookup(img.u8_data().data(), img, u, v, table, mode);
      case PixelFormat::u16: return lookup(img.u16_data().data(), img, u, v, table, mode);
      case PixelFormat::f32: return lookup(img.f32_data().data(), img, u, v, table, mode);
    }
    return {RGB(1), 1};
  }
  // Texel (x, y) of level k, wrapped, decoded, into c.
  void texel(const TextureImage& img, int64_t x, int64_t y, float* c) const noexcept {
    const int64_t w = img.width(), h = img.height();
    x = detail::wrap_texel(x, w, wrap_s);
    y = detail::wrap_texel(y, h, wrap_t);
    const int nc = img.channels();
    const size_t i = (size_t(y) * size_t(w) + size_t(x)) * size_t(nc);
    const float* table = encoding == ColorEncoding::srgb ? srgb_u8_decode_table().data() : nullptr;
    switch (img.format()) {
      case PixelFormat::u8: detail::load_texel(img.u8_data().data(), i, nc, table, c); break;
      case PixelFormat::u16: detail::load_texel(img.u16_data().data(), i, nc, table, c); break;
      case PixelFormat::f32: detail::load_texel(img.f32_data().data(), i, nc, table, c); break;
    }
  }
  // EWA on level k: texel space s = u W - 1/2, t = v H - 1/2; the ellipse
  // A ds^2 + B ds dt + C dt^2 < 1 of the axes (du0, dv0), (du1, dv1) in
  // texels, each of A and C raised by 1 (at least a texel wide), normalised
  // by F = A C - B^2 / 4 (Heckbert 1989, section 3.5.8).
  RGBA ewa_level(int k, Float u, Float v, Float au, Float av, Float bu, Float bv) const noexcept {
    const TextureImage& img = level(k);
    const Float W = Float(img.width()), H = Float(img.height());
    u = detail::reduce_coordinate(u, wrap_s);
    v = detail::reduce_coordinate(v, wrap_t);
    const Float s = u * W - Float(0.5), t = v * H - Float(0.5);
    const Float du0 = au * W, dv0 = av * H, du1 = bu * W, dv1 = bv * H;
    Float A = dv0 * dv0 + dv1 * dv1 + 1, B = -2 * (du0 * dv0 + du1 * dv1), C = du0 * du0 + du1 * du1 + 1;
    const Float inv_f = 1 / (A * C - B * B / 4);
    A *= inv_f;
    B *= inv_f;
    C *= inv_f;
    const Float det = -B * B + 4 * A * C, inv_det = 1 / det;
    const Float us = std::sqrt(det * C), vs = std::sqrt(A * det);
    const int64_t s0 = int64_t(std::ceil(s - 2 * inv_det * us)), s1 = int64_t(std::floor(s + 2 * inv_det * us));
    const int64_t t0 = int64_t(std::ceil(t - 2 * inv_det * vs)), t1 = int64_t(std::floor(t + 2 * inv_det * vs));
    const int nc = img.channels();
    double sum[4] = {0, 0, 0, 0}, wsum = 0;
    const Float e = std::exp(Float(-2));
    float c[4] = {0, 0, 0, 0};
    for (int64_t y = t0; y <= t1; ++y) {
      const Float dt = Float(y) - t;
      for (int64_t x = s0; x <= s1; ++x) {
        const Float ds = Float(x) - s;
        const Float r2 = A * ds * ds + B * ds * dt + C * dt * dt;
        if (!(r2 < 1)) continue;
        const double wgt = double(std::exp(-2 * r2) - e);
        texel(img, x, y, c);
        for (int q = 0; q < nc; ++q) sum[q] += wgt * c[q];
        wsum += wgt;
      }
    }
    if (!(wsum > 0)) return lookup_level(k, u, v, FilterMode::linear);
    float m[4];
    for (int q = 0; q < 4; ++q) m[q] = float(sum[q] / wsum);
    return detail::expand_channels(m, nc);
  }

  template <class T>
  RGBA lookup(const T* p, const TextureImage& img, Float u, Float v, const float* table,
              FilterMode mode) const noexcept {
    const int64_t w = img.width(), h = img.height();
    const int nc = img.channels();
    const size_t stride = size_t(nc);
    u = detail::reduce_coordinate(u, wrap_s);
    v = detail::reduce_coordinate(v, wrap_t);
    float c[4] = {0, 0, 0, 0};  // zeroed: GCC 12 -O3 -march=native sees a false maybe-uninitialized
    if (mode == FilterMode::nearest) {
      const int64_t x = detail::wrap_texel(int64_t(std::floor(u * Float(w))), w, wrap_s);
      const int64_t y = detail::wrap_texel(int64_t(std::floor(v * Float(h))), h, wrap_t);
      detail::load_texel(p, (size_t(y) * size_t(w) + size_t(x)) * stride, nc, table, c);
      return detail::expand_channels(c, nc);
    }
    const Float s = u * Float(w) - Float(0.5), t = v * Float(h) - Float(0.5);
    const Float fs = std::floor(s), ft = std::floor(t);
    const Float ds = s - fs, dt = t - ft;
    const int64_t x0 = detail::wrap_texel(int64_t(fs), w, wrap_s);
    const int64_t x1 = detail::wrap_texel(int64_t(fs) + 1, w, wrap_s);
    const int64_t y0 = detail::wrap_texel(int64_t(ft), h, wrap_t);
    const int64_t y1 = detail::wrap_texel(int64_t(ft) + 1, h, wrap_t);
    const size_t r0 = size_t(y0) * size_t(w), r1 = size_t(y1) * size_t(w);
    float c00[4], c10[4], c01[4], c11[4];
    detail::load_texel(p, (r0 + size_t(x0)) * stride, nc, table, c00);
    detail::load_texel(p, (r0 + size_t(x1)) * stride, nc, table, c10);
    detail::load_texel(p, (r1 + size_t(x0)) * stride, nc, table, c01);
    detail::load_texel(p, (r1 + size_t(x1)) * stride, nc, table, c11);
    const Float w00 = (1 - ds) * (1 - dt), w10 = ds * (1 - dt), w01 = (1 - ds) * dt, w11 = ds * dt;
    for (int k = 0; k < nc; ++k) c[k] = w00 * c00[k] + w10 * c10[k] + w01 * c01[k] + w11 * c11[k];
    return detail::expand_channels(c, nc);
  }

  template <class T>
  static RGB mean(const T* p, const TextureImage& img, const float* table) {
    const int nc = img.channels();
    const size_t n = size_t(img.width()) * size_t(img.height());
    double sum[4] = {0, 0, 0, 0};
    float c[4];
    for (size_t i = 0; i < n; ++i) {
      detail::load_texel(p, i * size_t(nc), nc, table, c);
      for (int k = 0; k < nc; ++k) sum[k] += c[k];
    }
    float m[4];
    for (int k = 0; k < 4; ++k) m[k] = float(sum[k] / double(n));
    return detail::expand_channels(m, nc).rgb;
  }
};

}  // namespace prism
