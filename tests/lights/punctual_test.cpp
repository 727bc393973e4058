// Punctual lights: point light radiance I / d^2, the glTF spot falloff at
// several angles and the spot's power, the distant light, chi-squared of the
// sun's cone sampling against pdf_li (wide and Sun-sized cones), the sun's
// irradiance, and bad parameters.
#include <catch2/catch.hpp>
#include "support/light_checks.hpp"
#include <prism/prism.hpp>
#include <prism/lights/punctual.hpp>
#include "support/chi2.hpp"
#include "support/reference_physics.hpp"

namespace punctual_test {

using namespace prism;

namespace {
constexpr double kPi = 3.14159265358979323846;
// Three chi-squared tests in this file.
const double alpha = prism_test::sidak_alpha(1e-3, 3);

template <class S>
wavelengths_t<S> test_lambda() {
  return prism_test::test_lambda<S>(0.61f);
}
using prism_test::max_rel_diff;

// The glTF reference falloff, in double.
double gltf_falloff(double cos_theta, double inner, double outer) {
  double scale = 1 / std::max(0.001, std::cos(inner) - std::cos(outer));
  double offset = -std::cos(outer) * scale;
  double t = std::clamp(cos_theta * scale + offset, 0.0, 1.0);
  return t * t;
}

// chi-squared of the sun's samples in (theta, phi) about its axis; theta from
// atan2, which keeps its precision for small cones.
prism_test::Chi2Result sun_chi2(const SunLight<RGB>& sun, double theta_max, size_t n, uint64_t seed) {
  Frame f = Frame::from_z(sun.to_light());
  LightSampleContext ctx;
  PCG32 rng(seed, 3);
  auto sample = [&]() -> std::optional<std::array<double, 2>> {
    auto ls = sun.sample_li(ctx, {rng.next_float(), rng.next_float()}, RGBWavelengths{});
    if (!ls) return std::nullopt;
    Vector3f l = f.to_local(ls->wi);
    double theta = std::atan2(std::hypot(double(l.x), double(l.y)), double(l.z));
    double phi = std::atan2(double(l.y), double(l.x));
    if (phi < 0) phi += 2 * kPi;
    return std::array<double, 2>{theta, phi};
  };
  auto density = [&](double theta, double phi) {
    Vector3f l{Float(std::sin(theta) * std::cos(phi)), Float(std::sin(theta) * std::sin(phi)), Float(std::cos(theta))};
    return double(sun.pdf_li(ctx, f.from_local(l), {})) * std::sin(theta);
  };
  // Samples within float rounding of the cone's edge count as on it.
  prism_test::Grid2D g{0, theta_max, 12, 0, 2 * kPi, 16, theta_max * 1e-4};
  return prism_test::chi2_test_2d(sample, density, g, n);
}
}  // namespace

static_assert(LightLike<PointLight<RGB>, RGB> && LightLike<PointLight<Spectral>, Spectral>);
static_assert(LightLike<SpotLight<RGB>, RGB> && LightLike<SpotLight<Spectral>, Spectral>);
static_assert(LightLike<DistantLight<RGB>, RGB> && LightLike<DistantLight<Spectral>, Spectral>);
static_assert(LightLike<SunLight<RGB>, RGB> && LightLike<SunLight<Spectral>, Spectral>);

TEMPLATE_TEST_CASE("point light radiance is I over d squared", "[lights][punctual][point]", RGB, Spectral) {
  using S = TestType;
  auto lambda = test_lambda<S>();
  RGB I(2, 3, 4);
  PointLight<S> light({1, 2, 3}, I, 0.5f);
  CHECK(light.kind() == LightKind::delta_position);
  CHECK(is_delta(light.kind()));
  S I_s = spectrum_traits<S>::illuminant(I * 0.5f, lambda);
  for (Point3f at : {Point3f{0, 0, 0}, Point3f{1, 2, -7}, Point3f{1.5f, 2, 3}}) {
    LightSampleContext ctx;
    ctx.p = at;
    auto ls = light.sample_li(ctx, {0.3f, 0.7f}, lambda);
    REQUIRE(ls);
    double d2 = distance_squared(at, {1, 2, 3});
    CHECK(ls->pdf == 1);
    CHECK_FALSE(ls->infinite);
    CHECK(ls->p_light == Point3f{1, 2, 3});
    // 1e-6: a few float ulps of unit components; 1e-5 relative: I / d² with d² rounded in float at coordinates ≤ 3 (a few ulps)
    CHECK(length(ls->wi - normalize(Point3f{1, 2, 3} - at)) < 1e-6f);
    CHECK(max_rel_diff(ls->L, S(I_s / Float(d2))) < 1e-5);
    CHECK(light.pdf_li(ctx, ls->wi, {}) == 0);
  }
  LightSampleContext on;
  on.p = {1, 2, 3};
  CHECK_FALSE(light.sample_li(on, {0.5f, 0.5f}, lambda));
  CHECK(max_rel_diff(light.power(lambda), S(I_s * Float(4 * kPi))) < 1e-6);  // 1e-6: 4π I in float, 2 roundings
}

TEST_CASE("spot falloff follows the glTF formula at several angles", "[lights][punctual][spot]") {
  const double deg = kPi / 180;
  struct Cone { double inner, outer; };
  for (Cone c : {Cone{20 * deg, 35 * deg}, Cone{0, 60 * deg}, Cone{30 * deg, 30 * deg}, Cone{10 * deg, 90 * deg}}) {
    Vector3f axis = normalize(Vector3f{0.3f, -1, 0.2f});
    SpotLight<RGB> light({0, 5, 0}, axis * 3.f, RGB(2, 2, 2), 1.5f, Float(c.inner), Float(c.outer));
    CHECK(light.kind() == LightKind::delta_position);
    Frame f = Frame::from_z(axis);
    for (double a : {0., 5., 10., 19.9, 20., 25., 29.99, 30., 30.01, 34.9, 35., 40., 59., 80., 89., 95., 120., 180.}) {
      double theta = a * deg;
      // A receiver at distance 2.5 from the light, theta off the axis.
      Vector3f wl = f.from_local({Float(std::sin(theta)), 0, Float(std::cos(theta))});
      LightSampleContext ctx;
      ctx.p = Point3f{0, 5, 0} + wl * 2.5f;
      double cos_theta = dot(normalize(ctx.p - Point3f{0, 5, 0}), axis);
      double expected = 3 * gltf_falloff(cos_theta, c.inner, c.outer) / (2.5 * 2.5);
      auto ls = light.sample_li(ctx, {0.5f, 0.5f}, RGBWavelengths{});
      INFO("inner " << c.inner / deg << " outer " << c.outer / deg << " angle " << a);
      // Near the edges the falloff is steep (up to 1000 per unit of cos with
      // equal angles), so float rounding of cos theta gets an absolute margin.
      // 1e-4 relative; 2e-4 absolute = slope ≤ 1000 per unit cos × a few u (2.4e-7) of float cos θ × I/d² = 0.48: 1.2e-4
      double got = ls ? double(ls->L.g) : 0.0;
      CHECK(got == Approx(expected).epsilon(1e-4).margin(2e-4));
      if (a > c.outer / deg + 0.01) CHECK_FALSE(ls);
      if (ls) {
        CHECK(ls->pdf == 1);
        CHECK(length(ls->wi + wl) < 1e-5f);  // 1e-5: wl's float sin/cos and p at coordinates ≤ 5 (ulp 4.8e-7) over 2.5: ≲ 1e-6
      }
    }
    // Power: I times the falloff's integral over the sphere (midpoint rule in cos).
    const int m = 200000;
    double integral = 0;
    for (int i = 0; i < m; ++i) integral += gltf_falloff(-1 + 2 * (i + 0.5) / m, c.inner, c.outer) * 2.0 / m;
    integral *= 2 * kPi;
    INFO("inner " << c.inner / deg << " outer " << c.outer / deg);
    // 1e-4: the midpoint rule's error with h = 1e-5 at the falloff's kinks (≲ h · its steps, 1e-5) plus float power
    CHECK(light.power(RGBWavelengths{}).g == Approx(3 * integral).epsilon(1e-4));
  }
}

TEMPLATE_TEST_CASE("distant light arrives from one direction with its irradiance", "[lights][punctual][distant]", RGB, Spectral) {
  using S = TestType;
  auto lambda = test_lambda<S>();
  Vector3f dir{1, -2, 0.5f};
  DistantLight<S> light(dir, RGB(1, 0.5f, 0.25f), 4);
  CHECK(light.kind() == LightKind::delta_direction);
  LightSampleContext ctx;
  ctx.p = {3, 1, -2};
  auto ls = light.sample_li(ctx, {0.1f, 0.9f}, lambda);
  REQUIRE(ls);
  CHECK(ls->pdf == 1);
  CHECK(ls->infinite);
  // 1e-6: a few float ulps of unit components and of E·4π
  CHECK(length(ls->wi + normalize(dir)) < 1e-6f);
  S E = spectrum_traits<S>::illuminant(RGB(4, 2, 1), lambda);
  CHECK(max_rel_diff(ls->L, E) < 1e-6);
  CHECK(light.pdf_li(ctx, ls->wi, {}) == 0);
  light.set_scene_radius(2);
  CHECK(max_rel_diff(light.power(lambda), S(E * Float(4 * kPi))) < 1e-6);
}

TEST_CASE("sun cone sampling matches pdf_li", "[lights][punctual][sun][chi2]") {
  // A wide cone (20 degrees across) and the Sun's 0.53 degrees, the latter
  // sampled in 1 - cos theta to keep float precision.
  const double deg = kPi / 180;
  int k = 0;
  for (double diameter : {20 * deg, 0.53 * deg, 170 * deg}) {
    SunLight<RGB> sun(normalize(Vector3f{-0.4f, -1, 0.3f}), RGB(1000), 1, Float(diameter));
    auto r = sun_chi2(sun, diameter / 2, 300000, uint64_t(++k));
    INFO("diameter " << diameter / deg << " degrees: " << r.summary());
    CHECK(r.outside == 0);
    CHECK(r.impossible == 0);
    CHECK(r.p_value > alpha);
  }
}

TEMPLATE_TEST_CASE("sun sample_li agrees with Le and pdf_li and delivers its irradiance", "[lights][punctual][sun]", RGB, Spectral) {
  using S = TestType;
  auto lambda = test_lambda<S>();
  const double deg = kPi / 180;
  // The irradiance: 3 diameters, 3 comparisons per test case (each type is
  // its own test case), one family at 10^-3 (Sidak): z = sidak_z(1e-3, 3) = 3.59.
  const double z = reference_physics::sidak_z(1e-3, 3);
  for (double diameter : {0.53 * deg, 5 * deg, 90 * deg}) {
    Vector3f dir = normalize(Vector3f{0.2f, -1, -0.6f});
    SunLight<S> sun(dir, RGB(800, 700, 600), 0.5f, Float(diameter));
    CHECK(sun.kind() == LightKind::infinite);
    CHECK_FALSE(is_delta(sun.kind()));
    double one_minus_cos = 1 - std::cos(diameter / 2);
    // 1e-4 relative: float half-angle (2u in 1 − cos ∝ θ²) and 1 − cos in float near 0.27° in a stable form
    CHECK(sun.cone_pdf() == Approx(1 / (2 * kPi * one_minus_cos)).epsilon(1e-4));
    LightSampleContext ctx;
    PCG32 rng(21, 22);
    const int n = 20000;
    int mismatch = 0;
    double s = 0, s2 = 0;
    for (int i = 0; i < n; ++i) {
      auto ls = sun.sample_li(ctx, {rng.next_float(), rng.next_float()}, lambda);
      REQUIRE(ls);
      REQUIRE(ls->infinite);
      CHECK(ls->pdf == sun.cone_pdf());
      // Within rounding of the cone's edge a sample may test as just outside.
      if (sun.pdf_li(ctx, ls->wi, {}) != ls->pdf || max_rel_diff(sun.Le(Ray{{}, ls->wi * 2.f}, lambda), ls->L) > 1e-6)
        ++mismatch;
      // Irradiance on a surface facing the sun: E[L cos / pdf] = E.
      double v = double(ls->L[0]) * double(dot(ls->wi, -dir)) / double(ls->pdf);
      s += v;
      s2 += v * v;
    }
    CHECK(mismatch <= n / 1000);
    double mean = s / n, sigma = std::sqrt(std::max(0.0, s2 / n - mean * mean) / (n - 1));
    double E = spectrum_traits<S>::illuminant(RGB(400, 350, 300), lambda)[0];
    INFO("diameter " << diameter / deg << " E " << E << " estimate " << mean << " sigma " << sigma);
    // 1e-4·E: the cone pdf's allowance above (each weight divides by it)
    CHECK(std::abs(mean - E) <= z * sigma + 1e-4 * E);
    // Directions outside the cone see nothing: one at right angles to the
    // axis, one 1.01 times the half-angle off it.
    Vector3f perp = normalize(cross(-dir, Vector3f{1, 0, 0}));
    double just_out = 1.01 * diameter / 2;
    for (Vector3f away : {perp, normalize(-dir * Float(std::cos(just_out)) + perp * Float(std::sin(just_out)))}) {
      CHECK(sun.Le(Ray{{}, away}, lambda).is_black());
      CHECK(sun.pdf_li(ctx, away, {}) == 0);
    }
    double just_in = 0.99 * diameter / 2;
    Vector3f inside = normalize(-dir * Float(std::cos(just_in)) + perp * Float(std::sin(just_in)));
    CHECK(sun.pdf_li(ctx, inside, {}) == sun.cone_pdf());
    CHECK(sun.pdf_li(ctx, dir, {}) == 0);
    // Its power equals that of a distant light of the same irradiance.
    DistantLight<S> distant(dir, RGB(800, 700, 600), 0.5f);
    sun.set_scene_radius(3);
    distant.set_scene_radius(3);
    CHECK(max_rel_diff(sun.power(lambda), distant.power(lambda)) < 1e-6);  // 1e-6: the same float E·π r² in both
  }
}

TEST_CASE("punctual lights reject bad parameters with prism Error naming them", "[lights][punctual][errors]") {
  using Catch::Matchers::Contains;
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  CHECK_THROWS_WITH(PointLight<RGB>({nan, 0, 0}, RGB(1)), Contains("point light: position"));
  CHECK_THROWS_WITH(PointLight<RGB>({0, 0, 0}, RGB(1, -1, 1)), Contains("point light: intensity"));
  CHECK_THROWS_WITH(PointLight<RGB>({0, 0, 0}, RGB(1, inf, 1)), Contains("intensity"));
  CHECK_THROWS_WITH(PointLight<RGB>({0, 0, 0}, RGB(1), -2), Contains("point light: scale"));
  CHECK_THROWS_WITH(PointLight<Spectral>({0, 0, 0}, RGB(1), nan), Contains("scale"));

  Point3f p{0, 0, 0};
  Vector3f d{0, -1, 0};
  CHECK_THROWS_WITH(SpotLight<RGB>(p, {0, 0, 0}, RGB(1), 1, 0.1f, 0.5f), Contains("spot light: direction"));
  CHECK_THROWS_WITH(SpotLight<RGB>(p, {nan, 1, 0}, RGB(1), 1, 0.1f, 0.5f), Contains("direction"));
  CHECK_THROWS_WITH(SpotLight<RGB>(p, d, RGB(-1), 1, 0.1f, 0.5f), Contains("spot light: intensity"));
  CHECK_THROWS_WITH(SpotLight<RGB>(p, d, RGB(1), -1, 0.1f, 0.5f), Contains("spot light: scale"));
  CHECK_THROWS_WITH(SpotLight<RGB>(p, d, RGB(1), 1, 0.6f, 0.5f), Contains("inner cone angle"));
  CHECK_THROWS_WITH(SpotLight<RGB>(p, d, RGB(1), 1, -0.1f, 0.5f), Contains("inner cone angle"));
  CHECK_THROWS_WITH(SpotLight<RGB>(p, d, RGB(1), 1, 0, 0), Contains("outer cone angle"));
  CHECK_THROWS_WITH(SpotLight<RGB>(p, d, RGB(1), 1, 0, 4), Contains("outer cone angle"));
  CHECK_THROWS_WITH(SpotLight<RGB>(p, d, RGB(1), 1, 0, nan), Contains("outer cone angle"));
  CHECK_NOTHROW(SpotLight<RGB>(p, d, RGB(1), 1, 0.5f, 0.5f));

  CHECK_THROWS_WITH(DistantLight<RGB>({0, 0, 0}, RGB(1)), Contains("distant light: direction"));
  CHECK_THROWS_WITH(DistantLight<RGB>(d, RGB(nan)), Contains("distant light: irradiance"));
  CHECK_THROWS_WITH(DistantLight<RGB>(d, RGB(1), inf), Contains("distant light: scale"));

  CHECK_THROWS_WITH(SunLight<RGB>({0, 0, 0}, RGB(1), 1, 0.01f), Contains("sun light: direction"));
  CHECK_THROWS_WITH(SunLight<RGB>(d, RGB(-3), 1, 0.01f), Contains("sun light: irradiance"));
  CHECK_THROWS_WITH(SunLight<RGB>(d, RGB(1), -1, 0.01f), Contains("sun light: scale"));
  CHECK_THROWS_WITH(SunLight<RGB>(d, RGB(1), 1, 0), Contains("angular diameter"));
  CHECK_THROWS_WITH(SunLight<RGB>(d, RGB(1), 1, 3.5f), Contains("angular diameter"));
  CHECK_THROWS_WITH(SunLight<RGB>(d, RGB(1), 1, nan), Contains("angular diameter"));
  CHECK_THROWS_AS(SunLight<Spectral>(d, RGB(1), 1, -1), Error);
}

}  // namespace punctual_test
