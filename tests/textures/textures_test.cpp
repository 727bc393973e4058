// Textures: image storage, glTF sampling (nearest and bilinear, every wrap mode
// on both axes), sRGB decoding, channel expansion, KHR_texture_transform and
// normal mapping. Expectations are computed by hand in the comments.
#include <catch2/catch.hpp>
#include <climits>
#include <cmath>
#include <limits>
#include <prism/textures/image.hpp>
#include <prism/textures/normal_map.hpp>
#include <prism/textures/texture.hpp>

namespace textures_test {

using namespace prism;

namespace {

double srgb_formula(double v) { return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4); }

ImageTexture make_texture(TextureImage img, FilterMode filter, WrapMode s = WrapMode::repeat,
                          WrapMode t = WrapMode::repeat) {
  ImageTexture tex;
  tex.image = std::make_shared<const TextureImage>(std::move(img));
  tex.filter = filter;
  tex.wrap_s = s;
  tex.wrap_t = t;
  return tex;
}

// 3x2 grey f32 image:   row 0 (top):  0  1  2
//                       row 1:       10 20 40
TextureImage image_3x2() { return TextureImage::from_f32(3, 2, 1, {0, 1, 2, 10, 20, 40}); }

// Four texels with values 1 2 3 4 along one axis: a 4x1 image (along u) or a 1x4
// image (along v).
TextureImage ramp(bool along_v) {
  return along_v ? TextureImage::from_f32(1, 4, 1, {1, 2, 3, 4}) : TextureImage::from_f32(4, 1, 1, {1, 2, 3, 4});
}

// Looks the ramp up at coordinate c along its axis (the other coordinate at the
// centre of the single texel).
Float ramp_lookup(const ImageTexture& tex, bool along_v, Float c) {
  Point2f uv = along_v ? Point2f{0.5f, c} : Point2f{c, 0.5f};
  RGBA r = tex.evaluate(uv);
  // Grey images replicate to rgb with alpha 1.
  CHECK(r.rgb.r == r.rgb.g);
  CHECK(r.rgb.r == r.rgb.b);
  CHECK(r.a == 1);
  return r.rgb.r;
}

void check_normal(const Normal3f& n, const Vector3f& expected) {
  INFO("n = (" << n.x << ", " << n.y << ", " << n.z << "), expected (" << expected.x << ", " << expected.y << ", "
               << expected.z << ")");
  // 1e-6: a few float ulps of a unit vector's components (ulp ≤ 6e-8) after the frame product and normalisation
  CHECK(n.x == Approx(expected.x).margin(1e-6));
  CHECK(n.y == Approx(expected.y).margin(1e-6));
  CHECK(n.z == Approx(expected.z).margin(1e-6));
}

void check_unit_finite(const Normal3f& n) {
  INFO("n = (" << n.x << ", " << n.y << ", " << n.z << ")");
  REQUIRE(std::isfinite(n.x));
  REQUIRE(std::isfinite(n.y));
  REQUIRE(std::isfinite(n.z));
  // 1e-6: normalize() in float leaves |n| within a few ulps (2^-24 ≈ 6e-8 each) of 1
  CHECK(length(n) == Approx(1).margin(1e-6));
}

const Float inv_sqrt2 = Float(1 / std::sqrt(2.0));

}  // namespace

// --- TextureImage --------------------------------------------------------------

TEST_CASE("texture image stores and normalises u8 u16 and f32 values", "[textures][image]") {
  TextureImage a = TextureImage::from_u8(2, 1, 2, {0, 51, 255, 128});
  CHECK(a.width() == 2);
  CHECK(a.height() == 1);
  CHECK(a.channels() == 2);
  CHECK(a.format() == PixelFormat::u8);
  CHECK(a.bytes() == 4);
  CHECK(a.channel(0, 0, 0) == 0.f);
  // 1e-7: one float rounding of code / 255 (half an ulp at 0.2–0.5 is ≤ 3e-8)
  CHECK(a.channel(0, 0, 1) == Approx(0.2).margin(1e-7));
  CHECK(a.channel(1, 0, 0) == 1.f);
  CHECK(a.channel(1, 0, 1) == Approx(128.0 / 255.0).margin(1e-7));

  TextureImage b = TextureImage::from_u16(1, 2, 1, {65535, 13107});
  CHECK(b.format() == PixelFormat::u16);
  CHECK(b.bytes() == 4);
  CHECK(b.channel(0, 0, 0) == 1.f);
  // 1e-7: one float rounding of code / 65535
  CHECK(b.channel(0, 1, 0) == Approx(0.2).margin(1e-7));

  TextureImage c = TextureImage::from_f32(1, 1, 3, {-1.5f, 2.f, 0.25f});
  CHECK(c.format() == PixelFormat::f32);
  CHECK(c.bytes() == 12);
  CHECK(c.channel(0, 0, 0) == -1.5f);  // stored as is, no clamping
  CHECK(c.channel(0, 0, 1) == 2.f);

  // Row-major, row 0 at the top: (x, y) = (2, 1) of the 3x2 image is 40.
  TextureImage d = image_3x2();
  CHECK(d.channel(2, 1, 0) == 40.f);
  CHECK(d.channel(1, 0, 0) == 1.f);

  TextureImage z(3, 2, 4, PixelFormat::u16);
  CHECK(z.bytes() == 3 * 2 * 4 * 2);
  CHECK(z.channel(2, 1, 3) == 0.f);
  CHECK(TextureImage().empty());
  CHECK(TextureImage().bytes() == 0);
}

TEST_CASE("texture image constructors reject bad sizes with prism Error", "[textures][image]") {
  CHECK_THROWS_AS(TextureImage(0, 4, 3, PixelFormat::u8), Error);
  CHECK_THROWS_AS(TextureImage(4, 0, 3, PixelFormat::u8), Error);
  CHECK_THROWS_AS(TextureImage(-2, 4, 3, PixelFormat::f32), Error);
  CHECK_THROWS_AS(TextureImage(4, -1, 3, PixelFormat::u16), Error);
  CHECK_THROWS_AS(TextureImage(4, 4, 0, PixelFormat::u8), Error);
  CHECK_THROWS_AS(TextureImage(4, 4, 5, PixelFormat::u8), Error);
  CHECK_THROWS_AS(TextureImage(4, 4, -1, PixelFormat::u8), Error);
  // INT_MAX^2 * 4 channels * 4 bytes does not fit in the address space.
  CHECK_THROWS_AS(TextureImage(INT_MAX, INT_MAX, 4, PixelFormat::f32), Error);
  CHECK_THROWS_AS(TextureImage::from_u8(INT_MAX, INT_MAX, 4, {}), Error);
  // Data of the wrong size.
  CHECK_THROWS_AS(TextureImage::from_u8(2, 2, 3, std::vector<uint8_t>(11)), Error);
  CHECK_THROWS_AS(TextureImage::from_u8(2, 2, 3, std::vector<uint8_t>(13)), Error);
  CHECK_THROWS_AS(TextureImage::from_u16(2, 2, 1, std::vector<uint16_t>(3)), Error);
  CHECK_THROWS_AS(TextureImage::from_f32(2, 2, 4, std::vector<float>(15)), Error);
  CHECK_THROWS_AS(TextureImage::from_f32(0, 2, 4, {}), Error);
  CHECK_NOTHROW(TextureImage::from_u8(2, 2, 3, std::vector<uint8_t>(12)));
  CHECK_THROWS_WITH(TextureImage(4, 4, 7, PixelFormat::u8), Catch::Contains("7 channels"));
}

TEST_CASE("u16 images shrink to u8 only when every value is a multiple of 257", "[textures][image]") {
  SECTION("convertible") {
    TextureImage img = TextureImage::from_u16(2, 2, 1, {0, 257, 257 * 128, 65535});
    const float before[4] = {img.channel(0, 0, 0), img.channel(1, 0, 0), img.channel(0, 1, 0), img.channel(1, 1, 0)};
    REQUIRE(img.bytes() == 8);
    CHECK(img.shrink_to_smallest());
    CHECK(img.format() == PixelFormat::u8);
    CHECK(img.bytes() == 4);
    CHECK(img.u16_data().empty());
    REQUIRE(img.u8_data().size() == 4);
    CHECK(img.u8_data()[2] == 128);
    CHECK(img.u8_data()[3] == 255);
    // Bit-identical normalised values.
    CHECK(img.channel(0, 0, 0) == before[0]);
    CHECK(img.channel(1, 0, 0) == before[1]);
    CHECK(img.channel(0, 1, 0) == before[2]);
    CHECK(img.channel(1, 1, 0) == before[3]);
    CHECK_FALSE(img.shrink_to_smallest());  // already u8
  }
  SECTION("not convertible") {
    TextureImage img = TextureImage::from_u16(2, 1, 2, {0, 257, 514, 1000});
    CHECK_FALSE(img.shrink_to_smallest());
    CHECK(img.format() == PixelFormat::u16);
    CHECK(img.bytes() == 8);
    // 1e-7: one float rounding of code / 65535
    CHECK(img.channel(1, 0, 1) == Approx(1000.0 / 65535.0).margin(1e-7));
    TextureImage one_off = TextureImage::from_u16(1, 1, 1, {65534});
    CHECK_FALSE(one_off.shrink_to_smallest());
  }
  SECTION("other formats stay") {
    TextureImage f = TextureImage::from_f32(1, 1, 1, {1.f});
    CHECK_FALSE(f.shrink_to_smallest());
    CHECK(f.format() == PixelFormat::f32);
    TextureImage empty;
    CHECK_FALSE(empty.shrink_to_smallest());
  }
}

// --- Sampling -------------------------------------------------------------------

TEST_CASE("nearest lookup returns the texel containing uv", "[textures][sampling]") {
  ImageTexture tex = make_texture(image_3x2(), FilterMode::nearest);
  const float expected[2][3] = {{0, 1, 2}, {10, 20, 40}};
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x) {
      INFO("texel " << x << ", " << y);
      // Centre and points inside the texel near its corners.
      CHECK(tex.evaluate({(x + 0.5f) / 3, (y + 0.5f) / 2}).rgb.r == expected[y][x]);
      CHECK(tex.evaluate({(x + 0.05f) / 3, (y + 0.05f) / 2}).rgb.r == expected[y][x]);
      CHECK(tex.evaluate({(x + 0.95f) / 3, (y + 0.95f) / 2}).rgb.r == expected[y][x]);
    }
  // v grows downwards: v = 0.1 is the top row, v = 0.9 the bottom row.
  CHECK(tex.evaluate({0.9f, 0.1f}).rgb.r == 2);
  CHECK(tex.evaluate({0.9f, 0.9f}).rgb.r == 40);
}

TEST_CASE("bilinear lookup at texel centres and between texels", "[textures][sampling]") {
  ImageTexture tex = make_texture(image_3x2(), FilterMode::linear, WrapMode::clamp_to_edge,
                                  WrapMode::clamp_to_edge);
  const float expected[2][3] = {{0, 1, 2}, {10, 20, 40}};
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x) {
      INFO("texel centre " << x << ", " << y);
      // 1e-5: bilinear blend of values ≤ 40 in float: ~4 roundings of ulp(40) = 3.8e-6
      CHECK(tex.evaluate({(x + 0.5f) / 3, (y + 0.5f) / 2}).rgb.r == Approx(expected[y][x]).margin(1e-5));
    }
  // u = 1/3 is the edge between texels 0 and 1 (s = 0.5); v = 0.25 the centre of row 0.
  // 1e-5: as above, values ≤ 20 and float weights from u·w − 1/2 (error ~2^-24·w·u)
  CHECK(tex.evaluate({1.f / 3, 0.25f}).rgb.r == Approx(0.5).margin(1e-5));
  // v = 0.5: halfway between the rows: (0.5 + (10 + 20) / 2) / 2 = 7.75.
  CHECK(tex.evaluate({1.f / 3, 0.5f}).rgb.r == Approx(7.75).margin(1e-5));
  // u = 0.4, v = 0.6: s = 1.2 - 0.5 = 0.7, t = 1.2 - 0.5 = 0.7 between texels
  // 1e-4: weights from float s, t (error ~1e-7) times texel steps ≤ 20, plus ~4 roundings of ulp(12) ≈ 9.5e-7: ≲ 1e-5
  // (0,0) (1,0) (0,1) (1,1): 0.09 * 0 + 0.21 * 1 + 0.21 * 10 + 0.49 * 20 = 12.11.
  CHECK(tex.evaluate({0.4f, 0.6f}).rgb.r == Approx(12.11).margin(1e-4));
  // u = 0.75, v = 0.25: s = 1.75, between texels 1 and 2 of row 0: 0.25 * 1 + 0.75 * 2.
  CHECK(tex.evaluate({0.75f, 0.25f}).rgb.r == Approx(1.75).margin(1e-5));
  // Nearest at the same point gives texel 2 of row 0.
  ImageTexture near = tex;
  near.filter = FilterMode::nearest;
  CHECK(near.evaluate({0.75f, 0.25f}).rgb.r == 2);
}

TEST_CASE("wrap modes on both axes with nearest and bilinear lookup", "[textures][sampling][wrap]") {
  // Four texels 1 2 3 4 with centres at 0.125 0.375 0.625 0.875.
  const Float coords[] = {-0.2f, 1.3f, 2.6f, 3.3f, -1.2f};
  struct Case {
    WrapMode mode;
    const char* name;
    float nearest[5];
    float linear[5];
    float linear_border[3];  // at 0, 0.05 and 1
  };
  // Hand computation, s = 4 c - 1/2 for bilinear:
  // repeat: c -> frac(c) = 0.8 0.3 0.6 0.3 0.8;
  //   nearest: texels 3 1 2 1 3 -> 4 2 3 2 4;
  //   linear: s = 2.7 -> 3 * 0.3 + 4 * 0.7 = 3.7; s = 0.7 -> 1.7; s = 1.9 -> 2.9.
  //   border: c = 0: s = -0.5 between texel 3 (wrapped -1) and 0 -> 2.5;
  //   c = 0.05: s = -0.3 -> 0.3 * 4 + 0.7 * 1 = 1.9; c = 1: s = 3.5, texels 3 and 0 -> 2.5.
  // clamp_to_edge: below 0 -> texel 0 (1), above 1 -> texel 3 (4);
  //   border: c = 0 and 0.05 -> 1, c = 1 -> 4.
  // mirrored_repeat (period 2, [1, 2] mirrored): c -> 0.2 0.7 0.6 0.7 0.8;
  //   nearest: texels 0 2 2 2 3 -> 1 3 3 3 4;
  //   linear: s = 0.3 -> 0.7 * 1 + 0.3 * 2 = 1.3; s = 2.3 -> 0.7 * 3 + 0.3 * 4 = 3.3;
  //   s = 1.9 -> 2.9; s = 2.7 -> 3.7. Border: the mirror repeats the edge texel: 1 1 4.
  const Case cases[] = {
      {WrapMode::repeat, "repeat", {4, 2, 3, 2, 4}, {3.7f, 1.7f, 2.9f, 1.7f, 3.7f}, {2.5f, 1.9f, 2.5f}},
      {WrapMode::clamp_to_edge, "clamp_to_edge", {1, 4, 4, 4, 1}, {1, 4, 4, 4, 1}, {1, 1, 4}},
      {WrapMode::mirrored_repeat, "mirrored_repeat", {1, 3, 3, 3, 4}, {1.3f, 3.3f, 2.9f, 3.3f, 3.7f}, {1, 1, 4}},
  };
  for (bool along_v : {false, true}) {
    for (const Case& c : cases) {
      INFO((along_v ? "wrap_t " : "wrap_s ") << c.name);
      // The other axis gets a different mode, which must not matter for the
      // single texel across.
      const WrapMode other = c.mode == WrapMode::repeat ? WrapMode::clamp_to_edge : WrapMode::repeat;
      ImageTexture tn = make_texture(ramp(along_v), FilterMode::nearest, along_v ? other : c.mode,
                                     along_v ? c.mode : other);
      ImageTexture tl = tn;
      tl.filter = FilterMode::linear;
      for (int i = 0; i < 5; ++i) {
        INFO("coordinate " << coords[i]);
        CHECK(ramp_lookup(tn, along_v, coords[i]) == c.nearest[i]);
        // 1e-5: bilinear blend of texels ≤ 4 in float; wrapped s carries ~ulp(4 c) ≈ 5e-7 times steps ≤ 3
        CHECK(ramp_lookup(tl, along_v, coords[i]) == Approx(c.linear[i]).margin(1e-5));
      }
      CHECK(ramp_lookup(tl, along_v, 0.f) == Approx(c.linear_border[0]).margin(1e-5));
      CHECK(ramp_lookup(tl, along_v, 0.05f) == Approx(c.linear_border[1]).margin(1e-5));
      CHECK(ramp_lookup(tl, along_v, 1.f) == Approx(c.linear_border[2]).margin(1e-5));
    }
  }
}

TEST_CASE("wrap_s and wrap_t apply independently", "[textures][sampling][wrap]") {
  // 4x4 image, value x + 10 y.
  std::vector<float> v(16);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) v[size_t(y * 4 + x)] = float(x + 10 * y);
  ImageTexture tex = make_texture(TextureImage::from_f32(4, 4, 1, v), FilterMode::nearest, WrapMode::repeat,
                                  WrapMode::clamp_to_edge);
  // u = -0.2 repeats to 0.8 (x = 3); v = 1.3 clamps to the bottom row (y = 3).
  CHECK(tex.evaluate({-0.2f, 1.3f}).rgb.r == 33);
  tex.wrap_s = WrapMode::mirrored_repeat;
  tex.wrap_t = WrapMode::repeat;
  // u = -0.2 mirrors to 0.2 (x = 0); v = 1.3 repeats to 0.3 (y = 1).
  CHECK(tex.evaluate({-0.2f, 1.3f}).rgb.r == 10);
}

TEST_CASE("non-finite and huge uv give defined texels", "[textures][sampling]") {
  const Float nan = std::numeric_limits<Float>::quiet_NaN();
  for (WrapMode m : {WrapMode::repeat, WrapMode::clamp_to_edge, WrapMode::mirrored_repeat}) {
    for (FilterMode f : {FilterMode::nearest, FilterMode::linear}) {
      ImageTexture tex = make_texture(ramp(false), f, m, m);
      INFO("wrap " << int(m) << " filter " << int(f));
      // A non-finite coordinate is looked up at 0.
      const Float at0 = tex.evaluate({0.f, 0.5f}).rgb.r;
      CHECK(tex.evaluate({nan, 0.5f}).rgb.r == at0);
      CHECK(tex.evaluate({infinity, 0.5f}).rgb.r == at0);
      CHECK(tex.evaluate({-infinity, nan}).rgb.r == tex.evaluate({0.f, 0.f}).rgb.r);
      for (Float u : {1e30f, -1e30f, 3e9f, -2.5e9f, 16777217.f, std::numeric_limits<Float>::max(),
                      -std::numeric_limits<Float>::max(), std::numeric_limits<Float>::denorm_min()}) {
        RGBA r = tex.evaluate({u, u});
        INFO("u " << u);
        CHECK(r.rgb.r >= 1);
        CHECK(r.rgb.r <= 4);
      }
    }
  }
  // Nearest repeat at 0 is texel 0; bilinear repeat at 0 blends texels 3 and 0.
  CHECK(make_texture(ramp(false), FilterMode::nearest).evaluate({nan, 0.5f}).rgb.r == 1);
  // bare Approx: Catch's 100·FLT_EPSILON ≈ 1.2e-5 relative, float rounding of a two-texel blend
  CHECK(make_texture(ramp(false), FilterMode::linear).evaluate({nan, 0.5f}).rgb.r == Approx(2.5));
  // A non-finite transform result is handled the same way.
  ImageTexture t = make_texture(ramp(false), FilterMode::nearest);
  t.transform.scale = {infinity, 1};
  CHECK(t.evaluate({0.f, 0.5f}).rgb.r == 1);  // inf * 0 = NaN -> 0
}

TEST_CASE("empty or missing image evaluates to white", "[textures][sampling]") {
  ImageTexture none;
  RGBA r = none.evaluate({0.3f, 0.7f});
  CHECK(r.rgb == RGB(1));
  CHECK(r.a == 1);
  CHECK(none.average() == RGB(1));
  ImageTexture empty;
  empty.image = std::make_shared<const TextureImage>();
  CHECK(empty.evaluate({0.3f, 0.7f}).rgb == RGB(1));
  CHECK(empty.average() == RGB(1));
}

TEST_CASE("channel counts 1 to 4 expand to rgba", "[textures][sampling]") {
  auto eval = [](std::vector<uint8_t> px, int nc) {
    return make_texture(TextureImage::from_u8(1, 1, nc, std::move(px)), FilterMode::linear).evaluate({0.5f, 0.5f});
  };
  // bare Approx: Catch's 100·FLT_EPSILON relative; code · (1/255) differs from code/255 by ≤ 2 float roundings
  const float k = 1.f / 255.f;
  RGBA g = eval({51}, 1);
  CHECK(g.rgb.r == Approx(51 * k));
  CHECK(g.rgb.g == Approx(51 * k));
  CHECK(g.rgb.b == Approx(51 * k));
  CHECK(g.a == 1);
  RGBA ga = eval({51, 102}, 2);
  CHECK(ga.rgb.r == Approx(51 * k));
  CHECK(ga.rgb.g == Approx(51 * k));
  CHECK(ga.rgb.b == Approx(51 * k));
  CHECK(ga.a == Approx(102 * k));
  RGBA rgb = eval({51, 102, 153}, 3);
  CHECK(rgb.rgb.r == Approx(51 * k));
  CHECK(rgb.rgb.g == Approx(102 * k));
  CHECK(rgb.rgb.b == Approx(153 * k));
  CHECK(rgb.a == 1);
  RGBA rgba = eval({51, 102, 153, 204}, 4);
  CHECK(rgba.rgb.r == Approx(51 * k));
  CHECK(rgba.rgb.g == Approx(102 * k));
  CHECK(rgba.rgb.b == Approx(153 * k));
  CHECK(rgba.a == Approx(204 * k));
}

TEST_CASE("sRGB decoding matches the formula and spares alpha", "[textures][srgb]") {
  SECTION("every 8-bit code through the table") {
    std::vector<uint8_t> px(256);
    for (int i = 0; i < 256; ++i) px[size_t(i)] = uint8_t(i);
    ImageTexture tex = make_texture(TextureImage::from_u8(256, 1, 1, px), FilterMode::nearest);
    tex.encoding = ColorEncoding::srgb;
    for (int i = 0; i < 256; ++i) {
      const double expected = srgb_formula(i / 255.0);
      const Float got = tex.evaluate({(i + 0.5f) / 256, 0.5f}).rgb.g;
      INFO("code " << i << " got " << got << " expected " << expected);
      CHECK(got == float(expected));  // exact: the table is the formula rounded once
    }
    // 1e-7: the table is the formula rounded once to float (half an ulp at 0.2 is 7.5e-9); 1e-9 for 10/255/12.92 ≈ 3e-3 (ulp 2.3e-10)
    // Spot values: 128 -> 0.2158605, 255 -> 1, 10 -> 10 / 255 / 12.92 (linear segment).
    CHECK(tex.evaluate({128.5f / 256, 0.5f}).rgb.r == Approx(0.2158605).margin(1e-7));
    CHECK(tex.evaluate({255.5f / 256, 0.5f}).rgb.r == 1);
    CHECK(tex.evaluate({10.5f / 256, 0.5f}).rgb.r == Approx(10.0 / 255 / 12.92).margin(1e-9));
    // The same image with linear encoding returns the stored values.
    // 1e-7: one float rounding of 128/255
    tex.encoding = ColorEncoding::linear;
    CHECK(tex.evaluate({128.5f / 256, 0.5f}).rgb.r == Approx(128.0 / 255).margin(1e-7));
  }
  SECTION("u16 and f32 through the formula") {
    ImageTexture t16 = make_texture(TextureImage::from_u16(1, 1, 3, {32768, 65535, 1000}), FilterMode::linear);
    t16.encoding = ColorEncoding::srgb;
    // 1e-6: float pow in the formula: ~ten roundings, 10·2^-24 ≈ 6e-7 relative; 1e-8 on the linear segment's 1.2e-3 (ulp 1.2e-10)
    RGBA r = t16.evaluate({0.5f, 0.5f});
    CHECK(r.rgb.r == Approx(srgb_formula(32768.0 / 65535)).margin(1e-6));
    CHECK(r.rgb.g == Approx(1).margin(1e-6));
    CHECK(r.rgb.b == Approx(1000.0 / 65535 / 12.92).margin(1e-8));
    ImageTexture t32 = make_texture(TextureImage::from_f32(1, 1, 3, {0.5f, 0.01f, 0.9f}), FilterMode::linear);
    t32.encoding = ColorEncoding::srgb;
    r = t32.evaluate({0.5f, 0.5f});
    CHECK(r.rgb.r == Approx(srgb_formula(0.5)).margin(1e-6));
    CHECK(r.rgb.g == Approx(0.01 / 12.92).margin(1e-8));
    CHECK(r.rgb.b == Approx(srgb_formula(0.9)).margin(1e-6));
  }
  SECTION("alpha is not decoded") {
    ImageTexture ga = make_texture(TextureImage::from_u8(1, 1, 2, {128, 128}), FilterMode::nearest);
    ga.encoding = ColorEncoding::srgb;
    // 1e-7: the 8-bit table rounds the formula once to float (half an ulp at 0.5 is 3e-8)
    RGBA r = ga.evaluate({0.5f, 0.5f});
    CHECK(r.rgb.r == Approx(srgb_formula(128.0 / 255)).margin(1e-7));
    CHECK(r.rgb.b == Approx(srgb_formula(128.0 / 255)).margin(1e-7));
    CHECK(r.a == Approx(128.0 / 255).margin(1e-7));
    ImageTexture rgba = make_texture(TextureImage::from_u8(1, 1, 4, {128, 128, 128, 128}), FilterMode::nearest);
    rgba.encoding = ColorEncoding::srgb;
    r = rgba.evaluate({0.5f, 0.5f});
    CHECK(r.rgb.g == Approx(srgb_formula(128.0 / 255)).margin(1e-7));
    CHECK(r.a == Approx(128.0 / 255).margin(1e-7));
  }
  SECTION("decoded per texel before filtering") {
    // Black and white texels; halfway between their centres the mean of the
    // decoded values is 0.5, not decode(0.5) = 0.214.
    ImageTexture tex = make_texture(TextureImage::from_u8(2, 1, 1, {0, 255}), FilterMode::linear,
                                    WrapMode::clamp_to_edge, WrapMode::clamp_to_edge);
    tex.encoding = ColorEncoding::srgb;
    // 1e-6: float blend of the decoded values 0 and 1 (a few roundings of ulp(1) = 1.2e-7)
    CHECK(tex.evaluate({0.5f, 0.5f}).rgb.r == Approx(0.5).margin(1e-6));
    // u = 0.375: s = 0.75 - 0.5 = 0.25 -> 0.75 * 0 + 0.25 * 1.
    CHECK(tex.evaluate({0.375f, 0.5f}).rgb.r == Approx(0.25).margin(1e-6));
  }
}

TEST_CASE("average is the mean decoded texel", "[textures][sampling]") {
  ImageTexture tex = make_texture(TextureImage::from_u8(2, 1, 3, {0, 51, 255, 255, 51, 0}), FilterMode::linear);
  RGB a = tex.average();
  // bare Approx: 100·FLT_EPSILON relative covers the float sum of 2 texels; margin 1e-7 is one rounding of the table
  CHECK(a.r == Approx(0.5));
  CHECK(a.g == Approx(0.2));
  CHECK(a.b == Approx(0.5));
  tex.encoding = ColorEncoding::srgb;
  a = tex.average();
  CHECK(a.r == Approx(0.5));
  CHECK(a.g == Approx(srgb_formula(0.2)).margin(1e-7));
  ImageTexture grey = make_texture(TextureImage::from_f32(2, 2, 2, {1, 0, 2, 0, 3, 0, 6, 0}), FilterMode::linear);
  CHECK(grey.average() == RGB(3));
}

// --- KHR_texture_transform -------------------------------------------------------

TEST_CASE("KHR_texture_transform follows the worked example of the extension", "[textures][transform]") {
  // README: offset [0, 1], rotation pi/2, scale [0.5, 0.5] "utilizes only the
  // lower left quadrant of the source image, rotated clockwise 90 degrees".
  // uv' = T R S uv with R = [cos sin; -sin cos]: at pi/2, R (u, v) = (v, -u),
  // so uv' = (0.5 v, 1 - 0.5 u):
  //   (0, 0) -> (0, 1)   (1, 0) -> (0, 0.5)   (0, 1) -> (0.5, 1)   (1, 1) -> (0.5, 0.5)
  // i.e. the unit square maps onto [0, 0.5] x [0.5, 1], the lower-left quadrant
  // (v points down). The quadrant's top edge (v' = 0.5) is sampled along u = 1,
  // the right edge of the surface's uv square: the image appears rotated clockwise.
  TextureTransform t{{0, 1}, 1.57079632679f, {0.5f, 0.5f}};
  CHECK_FALSE(t.is_identity());
  auto check = [&](Point2f in, Point2f out) {
    Point2f r = t.apply(in);
    INFO("(" << in.x << ", " << in.y << ") -> (" << r.x << ", " << r.y << ")");
    // 1e-6: S, R, T in float: ~6 roundings of coordinates ≤ 1 plus float sin/cos of π/2 (cos error ≈ 4e-8)
    CHECK(r.x == Approx(out.x).margin(1e-6));
    CHECK(r.y == Approx(out.y).margin(1e-6));
  };
  check({0, 0}, {0, 1});
  check({1, 0}, {0, 0.5f});
  check({0, 1}, {0.5f, 1});
  check({1, 1}, {0.5f, 0.5f});
  check({0.5f, 0.5f}, {0.25f, 0.75f});
}

TEST_CASE("KHR_texture_transform rotation is counter-clockwise in uv space", "[textures][transform]") {
  // "Rotate the UVs by this many radians counter-clockwise around the origin":
  // with u right and v down, counter-clockwise turns +u towards -v (up).
  TextureTransform r90{{0, 0}, pi_over_2, {1, 1}};
  Point2f a = r90.apply({1, 0});
  // 1e-6: float cos(π/2) ≈ -4.4e-8 and a few roundings of unit coordinates
  CHECK(a.x == Approx(0).margin(1e-6));
  CHECK(a.y == Approx(-1).margin(1e-6));
  Point2f b = r90.apply({0, 1});
  CHECK(b.x == Approx(1).margin(1e-6));
  CHECK(b.y == Approx(0).margin(1e-6));
}

TEST_CASE("KHR_texture_transform composes scale then rotation then offset", "[textures][transform]") {
  // offset (0.1, 0.2), rotation 0.3, scale (2, 3), uv (0.4, 0.5):
  // S uv = (0.8, 1.5); c = cos 0.3 = 0.9553365, s = sin 0.3 = 0.2955202;
  // R S uv = (c 0.8 + s 1.5, -s 0.8 + c 1.5) = (1.2075495, 1.1965886); + offset.
  TextureTransform t{{0.1f, 0.2f}, 0.3f, {2, 3}};
  Point2f r = t.apply({0.4f, 0.5f});
  // 1e-6: ~6 float roundings at magnitude 1.4 (ulp 1.2e-7) plus the printed reference's 1e-7 rounding
  CHECK(r.x == Approx(1.3075495).margin(1e-6));
  CHECK(r.y == Approx(1.3965886).margin(1e-6));
  CHECK(TextureTransform{}.is_identity());
  CHECK(TextureTransform{}.apply({0.3f, -2.f}) == Point2f{0.3f, -2.f});
  TextureTransform off;
  off.offset = {0, 1};
  CHECK_FALSE(off.is_identity());
  // Texture lookups apply the transform first: with offset (0.5, 0) the left
  // half of a 2x1 image reads the right texel.
  ImageTexture tex = make_texture(TextureImage::from_f32(2, 1, 1, {7, 9}), FilterMode::nearest);
  CHECK(tex.evaluate({0.1f, 0.5f}).rgb.r == 7);
  tex.transform.offset = {0.5f, 0};
  CHECK(tex.evaluate({0.1f, 0.5f}).rgb.r == 9);
}

TEST_CASE("glTF sampler enums map to the wrap and filter modes", "[textures][transform]") {
  CHECK(wrap_mode_from_gltf(10497) == WrapMode::repeat);
  CHECK(wrap_mode_from_gltf(33071) == WrapMode::clamp_to_edge);
  CHECK(wrap_mode_from_gltf(33648) == WrapMode::mirrored_repeat);
  CHECK_FALSE(wrap_mode_from_gltf(0).has_value());
  CHECK(filter_mode_from_gltf(9728) == FilterMode::nearest);
  CHECK(filter_mode_from_gltf(9729) == FilterMode::linear);
  CHECK(filter_mode_from_gltf(9987) == FilterMode::linear);
  CHECK_FALSE(filter_mode_from_gltf(10497).has_value());
}

// --- Normal mapping --------------------------------------------------------------

TEST_CASE("flat normal map texel returns the surface normal", "[textures][normal_map]") {
  const RGB flat(0.5f, 0.5f, 1);
  check_normal(apply_normal_map(flat, 1, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}), {0, 0, 1});
  // Non-unit, non-orthogonal inputs.
  check_normal(apply_normal_map(flat, 1, {1, 0, 1}, {0, 3, 0}, {0, 0, 2}), {0, 0, 1});
  Vector3f n = normalize(Vector3f(1, 2, 3));
  Normal3f r = apply_normal_map(flat, 1, {1, 0, 0}, {0, 1, 0}, Normal3f(n));
  check_normal(r, n);
}

TEST_CASE("tilted normal map texels lean towards the tangent and bitangent", "[textures][normal_map]") {
  const Vector3f T(1, 0, 0), B(0, 1, 0);
  const Normal3f N(0, 0, 1);
  // (1, 0.5, 1) -> (1, 0, 1) / sqrt 2: 45 degrees towards T.
  check_normal(apply_normal_map(RGB(1, 0.5f, 1), 1, T, B, N), {inv_sqrt2, 0, inv_sqrt2});
  // (0.5, 1, 1) -> (0, 1, 1) / sqrt 2: towards B.
  check_normal(apply_normal_map(RGB(0.5f, 1, 1), 1, T, B, N), {0, inv_sqrt2, inv_sqrt2});
  // (0, 0.5, 1): away from T.
  check_normal(apply_normal_map(RGB(0, 0.5f, 1), 1, T, B, N), {-inv_sqrt2, 0, inv_sqrt2});
  // scale multiplies x and y: (1, 0, 1) * (2, 2, 1) = (2, 0, 1) / sqrt 5.
  const Float s5 = Float(1 / std::sqrt(5.0));
  check_normal(apply_normal_map(RGB(1, 0.5f, 1), 2, T, B, N), {2 * s5, 0, s5});
  // A general texel (0.75, 0.25, 0.875) -> (0.5, -0.5, 0.75) / |.| .
  const Float l = std::sqrt(0.5f * 0.5f * 2 + 0.75f * 0.75f);
  check_normal(apply_normal_map(RGB(0.75f, 0.25f, 0.875f), 1, T, B, N), {0.5f / l, -0.5f / l, 0.75f / l});
  // Another frame: N = +y, T = +x, B = cross(N, T) = -z.
  check_normal(apply_normal_map(RGB(0.5f, 1, 1), 1, {1, 0, 0}, {0, 0, -1}, {0, 1, 0}), {0, inv_sqrt2, -inv_sqrt2});
  // A T that is not orthogonal to N is Gram-Schmidted: (1, 0, 1) against +z is +x.
  check_normal(apply_normal_map(RGB(1, 0.5f, 1), 1, {1, 0, 1}, {0, 3, 0}, {0, 0, 5}), {inv_sqrt2, 0, inv_sqrt2});
}

TEST_CASE("bitangent handedness flip mirrors the mapped normal", "[textures][normal_map]") {
  const Vector3f T(1, 0, 0);
  const Normal3f N(0, 0, 1);
  // cross(N, T) = +y. A bitangent along -y (glTF tangent.w = -1) flips the sign.
  check_normal(apply_normal_map(RGB(0.5f, 1, 1), 1, T, {0, -1, 0}, N), {0, -inv_sqrt2, inv_sqrt2});
  const RGB texel(0.8f, 0.7f, 0.9f);
  Normal3f right = apply_normal_map(texel, 1, T, {0, 1, 0}, N);
  Normal3f left = apply_normal_map(texel, 1, T, {0.1f, -2, 0.3f}, N);  // only the sign of dot(B, cross(N, T)) counts
  check_normal(left, {right.x, -right.y, right.z});
  CHECK(right.y > 0);
  // No usable handedness (zero or NaN bitangent): right-handed.
  check_normal(apply_normal_map(texel, 1, T, {0, 0, 0}, N), Vector3f(right));
  const Float nan = std::numeric_limits<Float>::quiet_NaN();
  check_normal(apply_normal_map(texel, 1, T, {nan, nan, nan}, N), Vector3f(right));
}

TEST_CASE("normal map scale 0 returns the surface normal", "[textures][normal_map]") {
  const Normal3f N(0, 0, 1);
  check_normal(apply_normal_map(RGB(0.9f, 0.1f, 0.8f), 0, {1, 0, 0}, {0, 1, 0}, N), {0, 0, 1});
  check_normal(apply_normal_map(RGB(0.0f, 1.0f, 0.6f), 0, {0.3f, 0.4f, 0.1f}, {0, 1, 0}, {0, 0, 2}), {0, 0, 1});
}

TEST_CASE("degenerate tangents still give a unit finite normal", "[textures][normal_map]") {
  const Float nan = std::numeric_limits<Float>::quiet_NaN();
  const Normal3f N = Normal3f(normalize(Vector3f(0.2f, -0.3f, 0.9f)));
  const Vector3f tangents[] = {{0, 0, 0}, Vector3f(N) * 3.f, Vector3f(N) * -0.5f, {nan, 0, 1}, {infinity, 0, 0},
                               Vector3f(N) + Vector3f(1e-9f, 0, 0)};
  for (const Vector3f& T : tangents) {
    INFO("T = (" << T.x << ", " << T.y << ", " << T.z << ")");
    // Flat texel: exactly N.
    check_normal(apply_normal_map(RGB(0.5f, 0.5f, 1), 1, T, {0, 1, 0}, N), Vector3f(N));
    // A tilted texel: unit, finite, 45 degrees from N in some direction.
    Normal3f r = apply_normal_map(RGB(1, 0.5f, 1), 1, T, {0, 1, 0}, N);
    check_unit_finite(r);
    // 1e-5: the tilted normal is built, orthonormalised and normalised in float (~30 roundings ≈ 2e-6) around degenerate frames
    CHECK(dot(r, N) == Approx(inv_sqrt2).margin(1e-5));
  }
}

TEST_CASE("mapped normals below the surface are bent back above it", "[textures][normal_map]") {
  const Vector3f T(1, 0, 0), B(0, 1, 0);
  const Normal3f N(0, 0, 1);
  // (1, 0.5, 0) -> (1, 0, -1): below the tangent plane, bent back above it
  // towards +x, at cos = normal_map_min_cos.
  Normal3f r = apply_normal_map(RGB(1, 0.5f, 0), 1, T, B, N);
  check_unit_finite(r);
  CHECK(r.z > 0);
  // 1e-6: a few float ulps of a unit vector's components
  CHECK(r.z == Approx(normal_map_min_cos).margin(1e-6));
  CHECK(r.x > 0.99f);
  CHECK(r.y == Approx(0).margin(1e-6));
  // Huge scale makes the normal nearly tangent but above: kept as is.
  Normal3f g = apply_normal_map(RGB(1, 0.5f, 1), 1e6f, T, B, N);
  check_unit_finite(g);
  CHECK(g.z > 0);
  // Straight down (0.5, 0.5, 0) has no azimuth: N.
  check_normal(apply_normal_map(RGB(0.5f, 0.5f, 0), 1, T, B, N), {0, 0, 1});
  // In the plane exactly (dot = 0) counts as below.
  Normal3f p = apply_normal_map(RGB(0.5f, 1, 0.5f), 1, T, B, N);
  // 1e-6: a few float ulps of a unit vector's components
  CHECK(p.z == Approx(normal_map_min_cos).margin(1e-6));
  CHECK(p.y > 0.99f);
  // Non-finite texels or scales give N.
  const Float nan = std::numeric_limits<Float>::quiet_NaN();
  check_normal(apply_normal_map(RGB(nan, 0.5f, 1), 1, T, B, N), {0, 0, 1});
  check_normal(apply_normal_map(RGB(0.5f, 0.5f, 1), infinity, T, B, N), {0, 0, 1});
  check_normal(apply_normal_map(RGB(0.7f, 0.2f, 1), nan, T, B, N), {0, 0, 1});
  // Huge but finite: unit and above.
  Normal3f h = apply_normal_map(RGB(1, 1, 1), std::numeric_limits<Float>::max(), T, B, N);
  check_unit_finite(h);
  CHECK(h.z > 0);
  // Degenerate N: a unit finite result.
  check_unit_finite(apply_normal_map(RGB(1, 0.5f, 1), 1, T, B, {0, 0, 0}));
  check_unit_finite(apply_normal_map(RGB(1, 0.5f, 1), 1, T, B, {nan, 0, 1}));
}

}  // namespace textures_test
