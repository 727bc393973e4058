// PNG display mapping: exposure and the Khronos PBR Neutral tone mapper.
#include <catch2/catch.hpp>
#include <cmath>
#include <string>
#include <prism/io/image_io.hpp>

namespace tonemap_test {

using namespace prism;

TEST_CASE("PBR Neutral keeps mid-tones, compresses highlights below 1 and is monotonic", "[io][tonemap]") {
  // Above the toe (min channel >= 0.08) and below the knee (peak < 0.76 after
  // the offset) a colour only loses the 0.04 offset.
  RGB mid = tone_map_pbr_neutral(RGB(0.5f, 0.3f, 0.2f));
  // bare Approx: Catch's 100·FLT_EPSILON ≈ 1.2e-5 relative, one float subtraction of the offset
  CHECK(mid.r == Approx(0.46f));
  CHECK(mid.g == Approx(0.26f));
  CHECK(mid.b == Approx(0.16f));
  CHECK(tone_map_pbr_neutral(RGB(0.f)).max_component() == 0);
  // Grey ramp: monotonic, below 1, approaching 1.
  float prev = -1;
  for (float v = 0; v < 100; v = v * 1.1f + 0.001f) {
    float t = tone_map_pbr_neutral(RGB(v)).g;
    CHECK(t >= prev);
    CHECK(t < 1.0f);
    prev = t;
  }
  CHECK(prev > 0.99f);
  // Bright saturated colours desaturate towards white.
  RGB hot = tone_map_pbr_neutral(RGB(20.f, 2.f, 0.5f));
  CHECK(hot.r < 1);
  CHECK(hot.b / hot.r > 0.5f / 20.f);
}

TEST_CASE("write_png applies exposure and rejects a negative one", "[io][tonemap]") {
  Image img{2, 1, {4.f, 4.f, 4.f, 0.1f, 0.2f, 0.3f}};
  const std::string dir = PRISM_TEST_TMP_DIR;
  CHECK_NOTHROW(write_png(dir + "/tonemap_neutral.png", img, PngOptions{0.5f, ToneMap::neutral}));
  CHECK_NOTHROW(write_image(dir + "/tonemap_clamp.png", img, PngOptions{2.f, ToneMap::clamp}));
  CHECK_THROWS_AS(write_png(dir + "/bad.png", img, PngOptions{-1.f, ToneMap::clamp}), Error);
}

}  // namespace tonemap_test
