// MIP pyramids (textures/mipmap.hpp) and the footprint lookups of
// ImageTexture (texture.hpp): level sizes and their means, sRGB-correct
// averaging, the polyphase box of odd sizes worked by hand, trilinear at a
// zero footprint equal to the plain lookup, EWA against a brute-force sum
// over every texel (Heckbert 1989's weights written out here) and exact on a
// linear ramp, both filters' limit on a fine checkerboard, and the texture
// transform's action on the footprint.
#include <catch2/catch.hpp>
#include <cmath>
#include <prism/textures/mipmap.hpp>
#include <prism/textures/texture.hpp>
#include "support/random.hpp"

namespace mipmap_test {

using namespace prism;

namespace {

double srgb_to_linear(double v) { return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4); }

ImageTexture texture(TextureImage img, ColorEncoding enc = ColorEncoding::linear, WrapMode wrap = WrapMode::repeat) {
  ImageTexture t;
  t.image = std::make_shared<const TextureImage>(std::move(img));
  t.encoding = enc;
  t.wrap_s = t.wrap_t = wrap;
  t.build_mipmaps();
  return t;
}

// Mean of channel 0 over an image, sRGB-decoded when asked (by the formula).
double mean0(const TextureImage& img, bool srgb) {
  double s = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) {
      double v = img.channel(x, y, 0);
      s += srgb ? srgb_to_linear(v) : v;
    }
  return s / (double(img.width()) * img.height());
}

// A w x h checkerboard of single texels, 0 and 1.
TextureImage checker(int w, int h) {
  std::vector<float> v(size_t(w) * size_t(h));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) v[size_t(y) * size_t(w) + size_t(x)] = float((x + y) % 2);
  return TextureImage::from_f32(w, h, 1, std::move(v));
}

}  // namespace

TEST_CASE("MIP levels halve down to 1x1 and keep the image's mean", "[textures][mipmap]") {
  PCG32 rng(9, 1);
  for (auto [w, h] : {std::pair{8, 8}, std::pair{7, 5}, std::pair{13, 1}, std::pair{1, 6}, std::pair{64, 3}}) {
    std::vector<float> v(size_t(w) * size_t(h) * 2);
    for (auto& x : v) x = rng.next_float();
    TextureImage img = TextureImage::from_f32(w, h, 2, v);
    auto levels = build_mip_levels(img, false);
    int lw = w, lh = h;
    INFO(w << "x" << h);
    for (const auto& l : levels) {
      lw = std::max(1, lw / 2);
      lh = std::max(1, lh / 2);
      CHECK(l.width() == lw);
      CHECK(l.height() == lh);
      CHECK(l.channels() == 2);
      // Every input texel carries the same weight: the mean is kept, up to
      // float rounding of a few averaging steps (values in [0, 1)).
      CHECK(std::abs(mean0(l, false) - mean0(img, false)) <= 1e-6);
    }
    REQUIRE_FALSE(levels.empty());
    CHECK(levels.back().width() == 1);
    CHECK(levels.back().height() == 1);
  }
  CHECK(build_mip_levels(TextureImage::from_f32(1, 1, 1, {0.5f}), false).empty());
  // The polyphase box by hand: 1 2 3 4 5 -> m = 2: (2 1 + 2 2 + 1 3) / 5 = 1.8
  // and (1 3 + 2 4 + 2 5) / 5 = 4.2; 3 texels -> their mean.
  auto five = build_mip_levels(TextureImage::from_f32(5, 1, 1, {1, 2, 3, 4, 5}), false);
  REQUIRE(five[0].width() == 2);
  CHECK(five[0].channel(0, 0, 0) == Approx(1.8).epsilon(1e-6));
  CHECK(five[0].channel(1, 0, 0) == Approx(4.2).epsilon(1e-6));
  CHECK(five[1].channel(0, 0, 0) == Approx(3).epsilon(1e-6));
  auto three = build_mip_levels(TextureImage::from_f32(1, 3, 1, {1, 5, 6}), false);
  CHECK(three[0].channel(0, 0, 0) == Approx(4).epsilon(1e-6));
}

// An 8-bit sRGB image is averaged as linear light: black and white give a
// level of linear 0.5 (code 188), where averaging the codes would give 128
// (linear 0.216). Each level's texel is rounded to the nearest code, which
// moves its linear value by at most the sRGB curve's steepest slope (2.4 /
// 1.055 = 2.275, at 1) times half a code: 4.47e-3 for the mean too. Alpha is
// averaged as stored.
TEST_CASE("MIP levels of sRGB images average linear light", "[textures][mipmap][srgb]") {
  const double q = 2.4 / 1.055 * 0.5 / 255;
  auto bw = build_mip_levels(TextureImage::from_u8(2, 1, 2, {0, 0, 255, 255}), true);
  REQUIRE(bw.size() == 1);
  CHECK(bw[0].format() == PixelFormat::u8);
  CHECK(std::abs(srgb_to_linear(bw[0].channel(0, 0, 0)) - 0.5) <= q);
  CHECK(std::abs(bw[0].channel(0, 0, 1) - 128.0 / 255) <= 0.5 / 255 + 1e-7);  // alpha: (0 + 1) / 2, rounded
  PCG32 rng(3, 8);
  std::vector<uint8_t> v(37 * 23);
  for (auto& x : v) x = uint8_t(rng.next_u32() & 255);
  TextureImage img = TextureImage::from_u8(37, 23, 1, v);
  const double m = mean0(img, true);
  for (const auto& l : build_mip_levels(img, true)) CHECK(std::abs(mean0(l, true) - m) <= q);
}

// At a zero footprint, and one under a texel, trilinear and EWA are the
// sampler's own lookup, value for value (nearest and bilinear, sRGB, every
// wrap); point is the nearest texel; bilinear ignores the footprint.
TEST_CASE("footprint lookups at a point equal the sampler's lookup", "[textures][mipmap]") {
  PCG32 rng(5, 2);
  std::vector<uint8_t> v(16 * 8 * 3);
  for (auto& x : v) x = uint8_t(rng.next_u32() & 255);
  for (WrapMode wrap : {WrapMode::repeat, WrapMode::clamp_to_edge, WrapMode::mirrored_repeat})
    for (FilterMode mag : {FilterMode::nearest, FilterMode::linear}) {
      ImageTexture t = texture(TextureImage::from_u8(16, 8, 3, v), ColorEncoding::srgb, wrap);
      t.filter = mag;
      ImageTexture nearest = t;
      nearest.filter = FilterMode::nearest;
      for (int i = 0; i < 200; ++i) {
        Point2f uv{rng.next_float() * 3 - 1, rng.next_float() * 3 - 1};
        const RGBA want = t.evaluate(uv);
        const TextureFootprint small{0.3f / 16, 0.1f / 8, -0.2f / 16, 0.4f / 8};  // under a texel
        for (TextureFootprint fp : {TextureFootprint{}, small}) {
          const RGBA tri = t.evaluate(uv, fp, TextureFilter::trilinear);
          CHECK((tri.rgb == want.rgb && tri.a == want.a));
        }
        const RGBA ewa0 = t.evaluate(uv, TextureFootprint{}, TextureFilter::ewa);
        CHECK(ewa0.rgb == want.rgb);
        CHECK(t.evaluate(uv, small, TextureFilter::bilinear).rgb == want.rgb);
        CHECK(t.evaluate(uv, small, TextureFilter::point).rgb == nearest.evaluate(uv).rgb);
      }
    }
}

// A fine checkerboard (texels 0 and 1, 64 x 64) is 0.5 at every level from
// 1 on: footprints of 2 texels and more give 0.5 with either filter (up to
// float rounding of the blend), while bilinear keeps the texels' 0 or 1. A
// footprint of the whole image (64 texels) is the top level: the mean.
TEST_CASE("trilinear and EWA average a fine checkerboard away", "[textures][mipmap]") {
  ImageTexture t = texture(checker(64, 64));
  REQUIRE(t.levels() == 7);
  PCG32 rng(7, 7);
  for (int i = 0; i < 100; ++i) {
    Point2f uv{rng.next_float(), rng.next_float()};
    const Float k = 2 + 30 * rng.next_float();  // texels
    const Float a = 6.2831853f * rng.next_float();
    TextureFootprint fp{k / 64 * std::cos(a), k / 64 * std::sin(a), -k / 64 * std::sin(a), k / 64 * std::cos(a)};
    CHECK(std::abs(t.evaluate(uv, fp, TextureFilter::trilinear).rgb.g - 0.5f) <= 1e-6f);
    CHECK(std::abs(t.evaluate(uv, fp, TextureFilter::ewa).rgb.g - 0.5f) <= 1e-6f);
  }
  // A footprint far wider than the image (as near a horizon): the top level,
  // the mean, without visiting the millions of texels its ellipse spans.
  CHECK(std::abs(t.evaluate({0.3f, 0.6f}, TextureFootprint{1e8f, 0, 0, 1e7f}, TextureFilter::ewa).rgb.g - 0.5f) <= 1e-6f);
  CHECK(std::abs(t.evaluate({0.3f, 0.6f}, TextureFootprint{1e8f, 0, 0, 1e7f}, TextureFilter::trilinear).rgb.g - 0.5f) <=
        1e-6f);
  // Texel centres: bilinear and a point footprint give the texel itself.
  const Point2f centre{(3 + 0.5f) / 64, (0 + 0.5f) / 64};
  CHECK(t.evaluate(centre, TextureFootprint{4.f / 64, 0, 0, 4.f / 64}, TextureFilter::bilinear).rgb.g == 1);
  CHECK(t.evaluate(centre, TextureFootprint{1, 0, 0, 1}, TextureFilter::trilinear).rgb.g == Approx(0.5f));
}

// EWA on level 0 (minor axis under a texel) against the weighted sum over
// every texel of the image with Heckbert's Gaussian exp(-2 r^2) - exp(-2)
// inside the ellipse r^2 < 1, r^2 = A ds^2 + B ds dt + C dt^2 with A = dv0^2
// + dv1^2 + 1, B = -2 (du0 dv0 + du1 dv1), C = du0^2 + du1^2 + 1 over A C -
// B^2 / 4 (texel units, clamped wrap so no texel repeats; the minor axis
// stretched to an eighth of the major where shorter): 1e-5 for float
// weights summed in double. On a linear ramp (value x + 2 y) at texel
// centres the ellipse is symmetric about the centre, so EWA returns the
// ramp's value there exactly (up to rounding).
TEST_CASE("EWA on the finest level equals the brute-force weighted sum and is exact on a ramp", "[textures][mipmap][ewa]") {
  const int W = 32, H = 24;
  PCG32 rng(11, 4);
  std::vector<float> noise(size_t(W) * H), ramp(size_t(W) * H);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      noise[size_t(y) * W + size_t(x)] = rng.next_float();
      ramp[size_t(y) * W + size_t(x)] = float(x + 2 * y);
    }
  ImageTexture tn = texture(TextureImage::from_f32(W, H, 1, noise), ColorEncoding::linear, WrapMode::clamp_to_edge);
  ImageTexture tr = texture(TextureImage::from_f32(W, H, 1, ramp), ColorEncoding::linear, WrapMode::clamp_to_edge);
  int compared = 0;
  for (int i = 0; i < 300; ++i) {
    // Major axis up to 6 texels, minor under 1 (so level 0 alone), any angle.
    const double a = 6.283185307 * rng.next_float(), major = 1 + 5 * rng.next_float(), minor = 0.2 + 0.7 * rng.next_float();
    TextureFootprint fp{Float(major * std::cos(a) / W), Float(major * std::sin(a) / H), Float(-minor * std::sin(a) / W),
                        Float(minor * std::cos(a) / H)};
    // The minor axis stretched to at least major / max_anisotropy (8).
    const double m2 = std::max(minor, major / 8);
    const double du0 = major * std::cos(a), dv0 = major * std::sin(a), du1 = -m2 * std::sin(a), dv1 = m2 * std::cos(a);
    // Away from the borders so that clamping plays no part.
    const double s = 8 + (W - 16) * rng.next_float(), t = 8 + (H - 16) * rng.next_float();
    Point2f uv{Float((s + 0.5) / W), Float((t + 0.5) / H)};
    double A = dv0 * dv0 + dv1 * dv1 + 1, B = -2 * (du0 * dv0 + du1 * dv1), C = du0 * du0 + du1 * du1 + 1;
    const double F = A * C - B * B / 4;
    A /= F;
    B /= F;
    C /= F;
    double sum = 0, wsum = 0;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        const double ds = x - s, dt = y - t, r2 = A * ds * ds + B * ds * dt + C * dt * dt;
        if (r2 >= 1) continue;
        const double w = std::exp(-2 * r2) - std::exp(-2.0);
        sum += w * noise[size_t(y) * W + size_t(x)];
        wsum += w;
      }
    REQUIRE(wsum > 0);
    INFO("footprint " << major << " x " << minor << " at " << s << ", " << t);
    CHECK(std::abs(tn.evaluate(uv, fp, TextureFilter::ewa).rgb.g - sum / wsum) <= 1e-5);
    // The ramp at a texel centre.
    const int xi = int(s), yi = int(t);
    const Point2f c{Float((xi + 0.5) / W), Float((yi + 0.5) / H)};
    CHECK(std::abs(tr.evaluate(c, fp, TextureFilter::ewa).rgb.g - (xi + 2 * yi)) <= 1e-4);
    ++compared;
  }
  CHECK(compared == 300);
}

// KHR_texture_transform scales the footprint with the coordinates: a
// texture scaled by 4 looked up over a footprint equals the untransformed
// texture at the scaled uv over the footprint scaled by 4.
TEST_CASE("the texture transform acts on the footprint", "[textures][mipmap][transform]") {
  PCG32 rng(2, 13);
  std::vector<float> v(32 * 32);
  for (auto& x : v) x = rng.next_float();
  ImageTexture plain = texture(TextureImage::from_f32(32, 32, 1, v));
  ImageTexture scaled = plain;
  scaled.transform.scale = {4, 4};
  for (int i = 0; i < 100; ++i) {
    Point2f uv{rng.next_float(), rng.next_float()};
    TextureFootprint fp{0.01f * rng.next_float(), 0.01f * rng.next_float(), 0.01f * rng.next_float(), 0.02f};
    for (TextureFilter f : {TextureFilter::trilinear, TextureFilter::ewa}) {
      const RGBA a = scaled.evaluate(uv, fp, f);
      const RGBA b = plain.evaluate({uv.x * 4, uv.y * 4}, TextureFootprint{fp.dudx * 4, fp.dvdx * 4, fp.dudy * 4, fp.dvdy * 4}, f);
      CHECK(a.rgb.g == Approx(b.rgb.g).epsilon(1e-5));
    }
  }
}

TEST_CASE("texture filters have names that parse back", "[textures][mipmap]") {
  for (TextureFilter f : {TextureFilter::point, TextureFilter::bilinear, TextureFilter::trilinear, TextureFilter::ewa})
    CHECK(parse_texture_filter(texture_filter_name(f)) == f);
  CHECK_FALSE(parse_texture_filter("anisotropic").has_value());
}

}  // namespace mipmap_test
