// Image infinite light: the equirectangular convention, chi-squared of
// sample_li against pdf_li (full and MIS-compensated densities) on a synthetic
// sky with a small bright sun, pdf_li and Le consistent with sample_li, the
// integral of Le, an MIS estimate with the compensated density, power, and bad
// input.
#include <catch2/catch.hpp>
#include "support/light_checks.hpp"
#include <prism/prism.hpp>
#include <prism/lights/image_infinite.hpp>
#include "support/chi2.hpp"
#include "support/reference_physics.hpp"

namespace image_infinite_test {

using namespace prism;

namespace {
constexpr double kPi = 3.14159265358979323846;
// Four chi-squared tests in this file.
const double alpha = prism_test::sidak_alpha(1e-3, 4);

// A gradient sky (bluish, brighter towards the zenith), a dim ground, and a
// sun of sun_w x sun_h texels of radiance sun_value.
EnvironmentImage sky_map(int w, int h, float sun_value, int sun_x, int sun_y, int sun_w = 2, int sun_h = 1) {
  EnvironmentImage img{w, h, std::vector<float>(size_t(w) * size_t(h) * 3)};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      float t = (float(y) + 0.5f) / float(h);  // 0 at the zenith
      float r, g, b;
      if (t < 0.5f) {
        float s = 1 - 2 * t;
        r = 0.3f + 1.2f * s;
        g = 0.5f + 1.6f * s;
        b = 0.9f + 2.4f * s + 0.05f * float(x % 3);
      } else {
        r = 0.15f;
        g = 0.12f;
        b = 0.1f;
      }
      if (x >= sun_x && x < sun_x + sun_w && y >= sun_y && y < sun_y + sun_h) r = g = b = sun_value;
      size_t i = 3 * (size_t(y) * size_t(w) + size_t(x));
      img.rgb[i] = r;
      img.rgb[i + 1] = g;
      img.rgb[i + 2] = b;
    }
  return img;
}

template <class S>
wavelengths_t<S> test_lambda() {
  return prism_test::test_lambda<S>(0.37f);
}
using prism_test::max_rel_diff;

// Integral over the sphere of the map's RGB (exact per texel solid angle).
RGB integral_of(const EnvironmentImage& img) {
  double s[3] = {0, 0, 0};
  for (int y = 0; y < img.height; ++y) {
    double omega = 2 * kPi / img.width *
                   (std::cos(kPi * y / img.height) - std::cos(kPi * (y + 1) / img.height));
    for (int x = 0; x < img.width; ++x)
      for (int c = 0; c < 3; ++c) s[c] += omega * img.rgb[3 * (size_t(y) * size_t(img.width) + size_t(x)) + size_t(c)];
  }
  return {Float(s[0]), Float(s[1]), Float(s[2])};
}

// chi-squared of sample_li over the (u, v) square, one cell per texel, so
// that the density (piecewise constant in u, v) is exact within each cell.
prism_test::Chi2Result chi2_of(const ImageInfiniteLight<RGB>& light, bool incomplete, size_t n, uint64_t seed) {
  const EnvironmentImage& img = light.image();
  PCG32 rng(seed, 7);
  LightSampleContext ctx;
  auto sample = [&]() -> std::optional<std::array<double, 2>> {
    auto ls = light.sample_li(ctx, {rng.next_float(), rng.next_float()}, RGBWavelengths{}, incomplete);
    if (!ls) return std::nullopt;
    Point2f uv = equirect_from_direction(ls->wi);
    return std::array<double, 2>{uv.x, uv.y};
  };
  // Density per du dv: the solid-angle pdf times the Jacobian 2 pi^2 sin(theta).
  auto density = [&](double u, double v) {
    Vector3f w = equirect_to_direction({Float(u), Float(v)});
    return double(light.pdf_li(ctx, w, SurfaceInteraction{}, incomplete)) * 2 * kPi * kPi * std::sin(kPi * v);
  };
  prism_test::Grid2D g{0, 1, img.width, 0, 1, img.height, 1e-6};
  return prism_test::chi2_test_2d(sample, density, g, n);
}
}  // namespace

static_assert(LightLike<ImageInfiniteLight<RGB>, RGB>);
static_assert(LightLike<ImageInfiniteLight<Spectral>, Spectral>);

TEST_CASE("equirectangular mapping follows its convention and round-trips", "[lights][image_infinite]") {
  // 1e-5: float trig of unit directions, a few roundings (≲ 1e-6) with room near the poles
  auto near = [](Vector3f a, Vector3f b) { return length(a - b) < 1e-5f; };
  CHECK(near(equirect_to_direction({0.5f, 0.5f}), {0, 0, -1}));   // image centre: -z
  CHECK(near(equirect_to_direction({0.75f, 0.5f}), {1, 0, 0}));   // to the right: +x
  CHECK(near(equirect_to_direction({0.25f, 0.5f}), {-1, 0, 0}));
  CHECK(near(equirect_to_direction({0.5f, 0.0f}), {0, 1, 0}));    // top row: +y
  CHECK(near(equirect_to_direction({0.5f, 1.0f}), {0, -1, 0}));
  // 1e-6: a few float roundings of atan2 / (2π) and acos / π (values ≤ 1); 2e-6 for a round trip of both
  CHECK(equirect_from_direction({0, 0, 1}).x == Approx(1).margin(1e-6));  // the seam behind
  PCG32 rng(3, 4);
  for (int i = 0; i < 1000; ++i) {
    Point2f uv{rng.next_float(), 0.001f + 0.998f * rng.next_float()};
    Point2f back = equirect_from_direction(equirect_to_direction(uv));
    CHECK(back.x == Approx(uv.x).margin(2e-6));
    CHECK(back.y == Approx(uv.y).margin(2e-6));
  }
}

TEST_CASE("image infinite light sampling matches pdf_li with a sun and a sky", "[lights][image_infinite][chi2]") {
  // A moderate sun (the sky above the mean keeps some light samples) and a
  // very bright one (the compensated density is the sun alone).
  const size_t n = 400000;
  for (float sun : {200.f, 1e5f}) {
    ImageInfiniteLight<RGB> light(sky_map(48, 24, sun, 30, 7), 1.5f);
    for (bool incomplete : {false, true}) {
      auto r = chi2_of(light, incomplete, n, uint64_t(sun) + (incomplete ? 1 : 0));
      INFO("sun " << sun << (incomplete ? " compensated: " : " full: ") << r.summary());
      CHECK(r.impossible == 0);
      CHECK(r.outside == 0);
      CHECK(r.p_value > alpha);
    }
  }
}

TEST_CASE("MIS compensation drops what is below the mean and keeps a constant map whole", "[lights][image_infinite]") {
  LightSampleContext ctx;
  ImageInfiniteLight<RGB> light(sky_map(48, 24, 200, 30, 7));
  Vector3f sun_dir = equirect_to_direction({(30 + 1) / 48.f, 7.5f / 24.f});
  Vector3f ground_dir = equirect_to_direction({0.3f, 0.8f});
  CHECK(light.pdf_li(ctx, sun_dir, {}, true) > light.pdf_li(ctx, sun_dir, {}, false));
  CHECK(light.pdf_li(ctx, ground_dir, {}, true) == 0);
  CHECK(light.pdf_li(ctx, ground_dir, {}, false) > 0);

  // A constant map: nothing is above the mean, so the full density is kept,
  // and it is close to uniform over the sphere.
  ImageInfiniteLight<RGB> flat(EnvironmentImage{16, 8, std::vector<float>(16 * 8 * 3, 0.7f)});
  PCG32 rng(5, 6);
  for (int i = 0; i < 100; ++i) {
    Vector3f w = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    Float a = flat.pdf_li(ctx, w, {}, true), b = flat.pdf_li(ctx, w, {}, false);
    CHECK(a == b);
    // 0.15: within |y| < 0.5 a row's sin θc / sin θ over 22.5° rows is off by ≤ 10.5%
    if (std::abs(w.y) < 0.5f) CHECK(a == Approx(inv_4pi).epsilon(0.15));  // row-centre sin(theta) weighting
  }
  // An all-black map emits nothing and samples nothing.
  ImageInfiniteLight<RGB> black(EnvironmentImage{4, 2, std::vector<float>(4 * 2 * 3, 0.f)});
  CHECK_FALSE(black.sample_li(ctx, {0.3f, 0.6f}, RGBWavelengths{}));
  CHECK(black.power(RGBWavelengths{}).is_black());
}

TEMPLATE_TEST_CASE("image infinite light pdf_li and Le agree with sample_li", "[lights][image_infinite]", RGB, Spectral) {
  using S = TestType;
  auto lambda = test_lambda<S>();
  Transform rot = rotate(0.7f, {0.3f, 1, -0.2f});
  ImageInfiniteLight<S> light(sky_map(40, 20, 500, 5, 3, 3, 2), 2, rot);
  ImageInfiniteLight<S> unrotated(sky_map(40, 20, 500, 5, 3, 3, 2), 2);
  LightSampleContext ctx;
  ctx.p = {1, 2, 3};
  PCG32 rng(8, 9);
  const int n = 20000;
  int pdf_mismatch = 0, le_mismatch = 0, rot_mismatch = 0;
  for (bool incomplete : {false, true})
    for (int i = 0; i < n; ++i) {
      auto ls = light.sample_li(ctx, {rng.next_float(), rng.next_float()}, lambda, incomplete);
      REQUIRE(ls);
      REQUIRE(ls->infinite);
      REQUIRE(ls->pdf > 0);
      // 1e-5: float normalisation, a few ulps of 1; 1e-3 and 1e-5 relative: float pdf and Le at a texel edge, counted
      CHECK(std::abs(length(ls->wi) - 1) < 1e-5f);
      Float p = light.pdf_li(ctx, ls->wi, {}, incomplete);
      // A direction within rounding of a texel edge may land in the neighbour.
      if (std::abs(p - ls->pdf) > 1e-3f * ls->pdf) ++pdf_mismatch;
      S Le = light.Le(Ray{ctx.p, ls->wi * 3.f}, lambda);
      if (max_rel_diff(Le, ls->L) > 1e-5) ++le_mismatch;
      // The rotation: the rotated map seen along wi is the unrotated one seen
      // along the inverse-rotated direction.
      S Lu = unrotated.Le(Ray{ctx.p, inverse(rot)(ls->wi)}, lambda);
      if (max_rel_diff(Lu, ls->L) > 1e-5) ++rot_mismatch;
    }
  INFO("pdf mismatches " << pdf_mismatch << ", Le " << le_mismatch << ", rotation " << rot_mismatch);
  CHECK(pdf_mismatch <= 2 * n / 1000);
  CHECK(le_mismatch <= 2 * n / 1000);
  CHECK(rot_mismatch <= 2 * n / 1000);
}

TEST_CASE("image infinite light estimates the integral of Le and of one over pdf", "[lights][image_infinite]") {
  // With the full density every direction can be drawn: E[1 / pdf] = 4 pi and
  // E[Le / pdf] = the integral of Le over the sphere (exact texel solid angles),
  // which checks the Jacobian independently of the mapping's inverse. Two
  // comparisons, one family at 10^-3 (Sidak): z = sidak_z(1e-3, 2) = 3.48.
  const double z = reference_physics::sidak_z(1e-3, 2);
  EnvironmentImage img = sky_map(32, 16, 50, 10, 4);
  RGB expected = integral_of(img) * 3;
  ImageInfiniteLight<RGB> light(img, 3, rotate(1.1f, {1, 1, 0}));
  LightSampleContext ctx;
  PCG32 rng(10, 11);
  const int n = 200000;
  double s = 0, s2 = 0, inv = 0, inv2 = 0;
  for (int i = 0; i < n; ++i) {
    auto ls = light.sample_li(ctx, {rng.next_float(), rng.next_float()}, RGBWavelengths{}, false);
    REQUIRE(ls);
    double v = ls->L.g / double(ls->pdf), q = 1 / double(ls->pdf);
    s += v;
    s2 += v * v;
    inv += q;
    inv2 += q * q;
  }
  double mean = s / n, sigma = std::sqrt((s2 / n - mean * mean) / (n - 1));
  double imean = inv / n, isigma = std::sqrt((inv2 / n - imean * imean) / (n - 1));
  INFO("integral " << expected.g << " estimate " << mean << " sigma " << sigma);
  // 1e-4·expected: each weight Le/pdf carries a few float roundings (the pdf rounded to float from double sums)
  CHECK(std::abs(mean - expected.g) <= z * sigma + 1e-4 * expected.g);
  INFO("4 pi " << 4 * kPi << " estimate " << imean << " sigma " << isigma);
  CHECK(std::abs(imean - 4 * kPi) <= z * isigma);
}

TEST_CASE("MIS with the compensated density and cosine sampling is unbiased", "[lights][image_infinite]") {
  // Irradiance on a surface with normal nrm: light samples (compensated
  // density) and cosine-weighted samples combined by the power heuristic. The
  // compensated density leaves most of the sky to the cosine samples; the sum
  // must still equal the integral of Le cos, by quadrature over the texels.
  // One comparison at 10^-3: z = sidak_z(1e-3, 1) = 3.29.
  EnvironmentImage img = sky_map(32, 16, 300, 12, 3);
  ImageInfiniteLight<RGB> light(img, 1);
  Vector3f nrm = normalize(Vector3f{0.2f, 1, 0.4f});
  double exact = 0;
  const int sub = 16;
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      for (int j = 0; j < sub; ++j)
        for (int i = 0; i < sub; ++i) {
          double u = (x + (i + 0.5) / sub) / img.width, v = (y + (j + 0.5) / sub) / img.height;
          Vector3f w = equirect_to_direction({Float(u), Float(v)});
          double c = std::max(0.0, double(dot(w, nrm)));
          double domega = 2 * kPi * kPi * std::sin(kPi * v) / (double(img.width) * img.height * sub * sub);
          exact += img.texel(x, y).g * c * domega;
        }
  Frame f = Frame::from_z(nrm);
  LightSampleContext ctx;
  PCG32 rng(12, 13);
  const int n = 200000;
  double s = 0, s2 = 0;
  for (int k = 0; k < n; ++k) {
    double est = 0;
    if (auto ls = light.sample_li(ctx, {rng.next_float(), rng.next_float()}, RGBWavelengths{})) {
      Float c = dot(ls->wi, nrm);
      if (c > 0) est += ls->L.g * c / ls->pdf * power_heuristic(ls->pdf, c * inv_pi);
    }
    Vector3f wb = f.from_local(sample_cosine_hemisphere({rng.next_float(), rng.next_float()}));
    Float cb = dot(wb, nrm);
    if (cb > 0) {
      Float pb = cb * inv_pi;
      est += light.Le(Ray{{}, wb}, RGBWavelengths{}).g * cb / pb * power_heuristic(pb, light.pdf_li(ctx, wb, {}));
    }
    s += est;
    s2 += est * est;
  }
  double mean = s / n, sigma = std::sqrt((s2 / n - mean * mean) / (n - 1));
  INFO("exact " << exact << " MIS estimate " << mean << " sigma " << sigma);
  // 2e-4·exact: the reference's midpoint rule on 16×16 subcells (h ≈ 0.012 rad: h²/24 ≈ 6e-6, more at the horizon's kink) and the float pdf's few u
  CHECK(std::abs(mean - exact) <= reference_physics::sidak_z(1e-3, 1) * sigma + 2e-4 * exact);
}

TEST_CASE("image infinite light power is pi r squared times the integral of Le", "[lights][image_infinite]") {
  EnvironmentImage img = sky_map(24, 12, 40, 3, 2);
  RGB integral = integral_of(img);
  ImageInfiniteLight<RGB> light(img, 2);
  light.set_scene_radius(3);
  RGB p = light.power(RGBWavelengths{});
  // 1e-5 relative: float π r² times the texel integral (a few roundings over 288 texels' float values)
  for (int c = 0; c < 3; ++c) CHECK(p[c] == Approx(integral[c] * 2 * kPi * 9).epsilon(1e-5));

  // A grey map: RGB and spectral agree on the power's luminance.
  ImageInfiniteLight<RGB> grey_rgb(EnvironmentImage{8, 4, std::vector<float>(8 * 4 * 3, 0.5f)});
  ImageInfiniteLight<Spectral> grey_spec(EnvironmentImage{8, 4, std::vector<float>(8 * 4 * 3, 0.5f)});
  Float y_rgb = grey_rgb.power(RGBWavelengths{}).luminance();
  CHECK(y_rgb == Approx(0.5 * 4 * kPi * kPi).epsilon(1e-5));
  double y_spec = 0;
  for (int k = 0; k < 64; ++k) {
    auto lambda = spectrum_traits<Spectral>::sample_wavelengths((Float(k) + 0.5f) / 64);
    y_spec += luminance(grey_spec.power(lambda), lambda) / 64;
  }
  // Y from these 64 x 4 fixed wavelengths is a deterministic quadrature, 2.089e-4 low for a grey
  // (D65-shaped) light (measured), plus float rounding (1e-5, as for RGB)
  CHECK(y_spec == Approx(y_rgb).epsilon(2.089e-4 + 1e-5));
}

TEST_CASE("image infinite light rejects bad input with prism Error", "[lights][image_infinite][errors]") {
  using Catch::Matchers::Contains;
  CHECK_THROWS_WITH(ImageInfiniteLight<RGB>(EnvironmentImage{0, 4, {}}), Contains("image size 0 x 4"));
  CHECK_THROWS_WITH(ImageInfiniteLight<RGB>(EnvironmentImage{2, 2, std::vector<float>(11, 1.f)}),
                    Contains("expected 12"));
  EnvironmentImage img{2, 2, std::vector<float>(12, 1.f)};
  img.rgb[4] = -0.5f;  // texel (1, 0), green
  CHECK_THROWS_WITH(ImageInfiniteLight<RGB>(img), Contains("texel (1, 0) channel g") && Contains("non-negative"));
  img.rgb[4] = 1;
  img.rgb[8] = std::numeric_limits<float>::quiet_NaN();  // texel (0, 1), blue
  CHECK_THROWS_WITH(ImageInfiniteLight<RGB>(img), Contains("texel (0, 1) channel b"));
  img.rgb[8] = std::numeric_limits<float>::infinity();
  CHECK_THROWS_AS(ImageInfiniteLight<RGB>(img), Error);
  img.rgb[8] = 1;
  CHECK_THROWS_WITH(ImageInfiniteLight<RGB>(img, -1), Contains("scale"));
  CHECK_THROWS_WITH(ImageInfiniteLight<RGB>(img, std::numeric_limits<float>::infinity()), Contains("scale"));
  CHECK_THROWS_WITH(ImageInfiniteLight<RGB>(img, 1, scale(2, 2, 2)), Contains("rotation"));
  CHECK_NOTHROW(ImageInfiniteLight<RGB>(img, 1, rotate(0.3f, {1, 2, 3}) * translate({4, 5, 6})));
  CHECK_NOTHROW(ImageInfiniteLight<Spectral>(img, 0));
}

}  // namespace image_infinite_test
