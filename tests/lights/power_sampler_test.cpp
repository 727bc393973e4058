// PowerLightSampler: pmfs proportional to power and summing to 1, sampling
// frequencies (chi-squared), zero-power lights never chosen, edge values of u,
// bad power; light_power_luminance for every light type, RGB and spectral
// agreeing for grey lights.
#include <catch2/catch.hpp>
#include <prism/prism.hpp>
#include <prism/lights/image_infinite.hpp>
#include <prism/lights/power_sampler.hpp>
#include <prism/lights/punctual.hpp>
#include "support/chi2.hpp"

namespace power_sampler_test {

using namespace prism;

namespace {
constexpr double kPi = 3.14159265358979323846;

template <class S>
using TestLight = std::variant<PointLight<S>, SpotLight<S>, DistantLight<S>, SunLight<S>, ImageInfiniteLight<S>,
                               TriangleAreaLight<S>, SphereAreaLight<S>, UniformInfiniteLight<S>>;

// One light of each type, grey, with analytic power luminance (RGB mode).
template <class S>
std::vector<TestLight<S>> grey_lights(std::vector<double>* expected) {
  std::vector<TestLight<S>> l;
  l.push_back(PointLight<S>({0, 1, 0}, RGB(2), 1.5f));
  expected->push_back(3 * 4 * kPi);
  SpotLight<S> spot({0, 2, 0}, {0, -1, 0}, RGB(5), 1, 0, Float(kPi / 3));
  l.push_back(spot);
  expected->push_back(5 * 2 * kPi * (1 - 0.5) / 3);  // the t^2 ramp over cos in [0.5, 1]
  DistantLight<S> distant({0, -1, 0}, RGB(0.5f), 2);
  distant.set_scene_radius(4);
  l.push_back(distant);
  expected->push_back(1 * kPi * 16);
  SunLight<S> sun({0.3f, -1, 0}, RGB(3), 1, 0.01f);
  sun.set_scene_radius(4);
  l.push_back(sun);
  expected->push_back(3 * kPi * 16);
  ImageInfiniteLight<S> env(EnvironmentImage{8, 4, std::vector<float>(8 * 4 * 3, 0.25f)}, 2);
  env.set_scene_radius(4);
  l.push_back(env);
  expected->push_back(0.5 * 4 * kPi * kPi * 16);
  l.push_back(TriangleAreaLight<S>({0, 0, 0}, {2, 0, 0}, {0, 0, 3}, AreaEmission{RGB(4), 1, false}, 0, 0));
  expected->push_back(4 * kPi * 3);
  l.push_back(SphereAreaLight<S>(Sphere{{0, 0, 0}, 0.5f}, AreaEmission{RGB(1), 10, true}, 1));
  expected->push_back(10 * kPi * 2 * 4 * kPi * 0.25);
  UniformInfiniteLight<S> uni(RGB(0.1f));
  uni.set_scene_radius(4);
  l.push_back(uni);
  expected->push_back(0.1 * 4 * kPi * kPi * 16);
  return l;
}
}  // namespace

TEST_CASE("power light sampler pmfs are proportional to power and sum to one", "[lights][power_sampler]") {
  std::vector<Float> power{3, 0, 1, 6, 0, 0.5f, 0};
  PowerLightSampler s(power);
  REQUIRE(s.size() == power.size());
  double total = 10.5, sum = 0;
  for (uint32_t i = 0; i < power.size(); ++i) {
    // 1e-6 relative: one float division by the float total (a sum of 7 powers: ≤ 7u = 4e-7)
    CHECK(s.pmf(i) == Approx(power[i] / total).epsilon(1e-6));
    sum += s.pmf(i);
  }
  CHECK(sum == Approx(1).epsilon(1e-6));  // 1e-6: the float pmfs above, summed
  CHECK(s.pmf(100) == 0);

  // Sampling frequencies against the pmfs; zero-power lights never come up.
  std::vector<double> observed(power.size(), 0), expected(power.size(), 0);
  const size_t n = 200000;
  PCG32 rng(1, 2);
  for (size_t k = 0; k < n; ++k) {
    auto sl = s.sample(rng.next_float());
    REQUIRE(sl);
    REQUIRE(sl->pmf == s.pmf(sl->index));
    observed[sl->index] += 1;
  }
  for (size_t i = 0; i < power.size(); ++i) expected[i] = double(s.pmf(uint32_t(i))) * double(n);
  auto r = prism_test::chi2_from_counts(observed, expected);
  INFO(r.summary());
  CHECK(r.impossible == 0);
  CHECK(r.p_value > 1e-3);  // one χ² test at the suite's false-alarm rate 1e-3

  // Edge values of u: 0 and the largest float below 1 land on lights with power.
  CHECK(s.sample(0)->index == 0);
  CHECK(s.sample(one_minus_epsilon)->index == 5);
  CHECK(s.sample(1)->index == 5);  // out of contract, still a light with power
  PowerLightSampler lead(std::vector<Float>{0, 0, 2, 0});
  CHECK(lead.sample(0)->index == 2);
  CHECK(lead.sample(one_minus_epsilon)->index == 2);
  CHECK(lead.sample(0.5f)->pmf == 1);
}

TEST_CASE("power light sampler is uniform without power and empty without lights", "[lights][power_sampler]") {
  PowerLightSampler zero(std::vector<Float>{0, 0, 0, 0});
  for (uint32_t i = 0; i < 4; ++i) CHECK(zero.pmf(i) == 0.25f);
  CHECK(zero.sample(0.6f)->index == 2);
  PowerLightSampler none;
  CHECK_FALSE(none.sample(0.5f));
  CHECK(none.pmf(0) == 0);
  PowerLightSampler empty(std::vector<Float>{});
  CHECK_FALSE(empty.sample(0.5f));
}

TEST_CASE("power light sampler rejects negative or non-finite power", "[lights][power_sampler][errors]") {
  using Catch::Matchers::Contains;
  CHECK_THROWS_WITH(PowerLightSampler(std::vector<Float>{1, 2, -1}), Contains("light 2"));
  CHECK_THROWS_WITH(PowerLightSampler(std::vector<Float>{std::numeric_limits<Float>::quiet_NaN()}),
                    Contains("light 0") && Contains("finite"));
  CHECK_THROWS_AS(PowerLightSampler(std::vector<Float>{1, std::numeric_limits<Float>::infinity()}), Error);
}

TEMPLATE_TEST_CASE("power light sampler follows every light type's power", "[lights][power_sampler]", RGB, Spectral) {
  using S = TestType;
  std::vector<double> expected;
  auto lights = grey_lights<S>(&expected);
  double total = 0;
  for (double e : expected) total += e;
  for (size_t i = 0; i < lights.size(); ++i) {
    INFO("light " << i);
    // Spectral luminance is a 128-wavelength quadrature of CIE Y, deterministic: for the grey lights' shape
    // (D65's) it is 1.575e-4 high (measured; the same for all eight). RGB: 1e-5 relative, a few float
    // roundings of the power, which the spectral bound adds.
    double tol = is_spectral_v<S> ? 1.575e-4 + 1e-5 : 1e-5;
    CHECK(light_power_luminance<S>(lights[i]) == Approx(expected[i]).epsilon(tol));
  }
  PowerLightSampler s = make_power_light_sampler<S>(lights);
  for (uint32_t i = 0; i < lights.size(); ++i) {
    INFO("light " << i);
    // The quadrature's error is common to all the lights and cancels in the pmf: float rounding only.
    CHECK(s.pmf(i) == Approx(expected[i] / total).epsilon(1e-5));
  }
}

TEST_CASE("RGB and spectral power luminance agree for grey lights", "[lights][power_sampler]") {
  std::vector<double> e1, e2;
  auto rgb = grey_lights<RGB>(&e1);
  auto spec = grey_lights<Spectral>(&e2);
  for (size_t i = 0; i < rgb.size(); ++i) {
    // As above: the 128-wavelength quadrature's 1.575e-4 for grey lights plus float rounding.
    INFO("light " << i);
    CHECK(light_power_luminance<Spectral>(spec[i]) == Approx(light_power_luminance<RGB>(rgb[i])).epsilon(1.575e-4 + 1e-5));
  }
}

}  // namespace power_sampler_test
