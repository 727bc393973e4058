// Pixel filters by filter importance sampling, all of them: the sampled
// offsets follow |f| (chi-squared), the weights f/p have expectation 1 (the
// normalised filter's integral) and carry f's sign (a weighted moment), the
// triangle filter stays inside its radius, AnyFilter and make_filter, bad
// parameters, and a constant image stays constant through render().
#include <catch2/catch.hpp>
#include <prism/prism.hpp>
#include "support/chi2.hpp"
#include "support/reference_physics.hpp"

namespace filters_more_test {

using namespace prism;
using Catch::Matchers::Contains;

namespace {

struct NamedFilter {
  std::string label;
  AnyFilter filter;
};

std::vector<NamedFilter> all_filters() {
  return {{"box", BoxFilter{}},
          {"box r=1", BoxFilter{1}},
          {"gaussian", GaussianFilter{}},
          {"gaussian r=2 sigma=0.8", GaussianFilter{2, 0.8f}},
          {"triangle", TriangleFilter{}},
          {"triangle r=1.5", TriangleFilter{1.5f}},
          {"mitchell", MitchellFilter{}},
          {"mitchell r=1.5 B=0 C=0.5 (Catmull-Rom)", MitchellFilter{1.5f, 0, 0.5f}}};
}

// The separable factor of a filter, whatever its type.
Float eval_1d(const AnyFilter& f, Float x) {
  return std::visit([&](const auto& g) { return g.eval_1d(x); }, f.variant());
}

// Integral over [-r, r] of g(x) times f's 1D factor (or |factor|), by 5-point
// Gauss-Legendre on 4096 sub-intervals: accurate to ~1e-9 even across the kinks.
template <class G>
double integrate_1d(const AnyFilter& f, G&& g, bool absolute) {
  const double r = f.radius();
  const int m = 4096;
  double sum = 0;
  for (int i = 0; i < m; ++i) {
    double a = -r + 2 * r * i / m, b = a + 2 * r / m;
    sum += prism_test::integrate_2d(
               [&](double x, double) {
                 double v = eval_1d(f, Float(x));
                 return (absolute ? std::abs(v) : v) * g(x);
               },
               a, b, 0, 1, 1);
  }
  return sum;
}

// One chi-squared test per filter of all_filters().
const double alpha = prism_test::sidak_alpha(1e-3, 8);

}  // namespace

TEST_CASE("filter sampling draws offsets with density proportional to the absolute filter", "[film][filter][chi2]") {
  uint64_t seed = 1;
  for (const NamedFilter& nf : all_filters()) {
    const AnyFilter& f = nf.filter;
    const double r = f.radius();
    const double norm = integrate_1d(f, [](double) { return 1.0; }, true);  // integral of |f| per axis
    PCG32 rng(seed++, 17);
    auto sample = [&]() -> std::optional<std::array<double, 2>> {
      FilterSample s = f.sample({rng.next_float(), rng.next_float()});
      return std::array<double, 2>{s.offset.x, s.offset.y};
    };
    auto density = [&](double x, double y) {
      return std::abs(double(f.eval({Float(x), Float(y)}))) / (norm * norm);
    };
    // 16 x 16 cells: each is a whole number of the tabulated cells (32 per
    // pixel of radius), so even the tabulated filters must match exactly.
    prism_test::Grid2D g{-r, r, 16, -r, r, 16, 0};
    prism_test::Chi2Options opt;
    opt.sub = 8;  // the zero crossings of the Mitchell filter lie inside cells
    auto res = prism_test::chi2_test_2d(sample, density, g, 400000, opt);
    INFO(nf.label << ": " << res.summary());
    CHECK(res.outside == 0);
    CHECK(res.impossible == 0);
    CHECK(res.p_value > alpha);
    WARN(nf.label << ": chi2 p = " << res.p_value);
  }
}

TEST_CASE("filter weights average to the normalised integral and carry the sign of the filter", "[film][filter]") {
  uint64_t seed = 100;
  // 2 moments per filter of all_filters() (8: m = 16), one family at 10^-3
  // (Sidak): z = sidak_z(1e-3, 16) = 4.00.
  const double z = reference_physics::sidak_z(1e-3, 2 * int(all_filters().size()));
  for (const NamedFilter& nf : all_filters()) {
    const AnyFilter& f = nf.filter;
    // The filter is normalised: its integral over the square is 1.
    const double integral = integrate_1d(f, [](double) { return 1.0; }, false);
    // 1e-5: the filter integral by Gauss–Legendre quadrature (integrate_1d) on a piecewise-polynomial or Gaussian kernel, far below
    CHECK(integral == Approx(1).epsilon(1e-5));
    // E[w] = integral^2 = 1, and E[w x^2] = the integral of f(x, y) x^2,
    // whose sign pattern would be lost if the negative lobes were sampled as
    // positive (the Mitchell filter's second moment is below the positive
    // part's alone).
    const double moment = integrate_1d(f, [](double x) { return x * x; }, false) * integral;
    PCG32 rng(seed++, 3);
    const int n = 400000;
    double sw = 0, sw2 = 0, sm = 0, sm2 = 0;
    int negative = 0;
    for (int i = 0; i < n; ++i) {
      FilterSample s = f.sample({rng.next_float(), rng.next_float()});
      double w = s.weight, m = w * double(s.offset.x) * double(s.offset.x);
      sw += w;
      sw2 += w * w;
      sm += m;
      sm2 += m * m;
      negative += w < 0;
    }
    double mw = sw / n, sigma_w = std::sqrt(std::max(0.0, sw2 / n - mw * mw) / (n - 1));
    double mm = sm / n, sigma_m = std::sqrt(std::max(0.0, sm2 / n - mm * mm) / (n - 1));
    INFO(nf.label << ": E[w] " << mw << " sigma " << sigma_w << ", E[w x^2] " << mm << " expected " << moment
                  << " sigma " << sigma_m << ", negative weights " << negative);
    // +1e-5: the float weights' rounding (a few u of values ≤ ~2, summed in double)
    CHECK(std::abs(mw - integral * integral) <= z * sigma_w + 1e-5);
    CHECK(std::abs(mm - moment) <= z * sigma_m + 1e-5 * std::abs(moment));
    WARN(nf.label << ": E[w] - 1 = " << mw - 1 << " (" << (sigma_w > 0 ? (mw - 1) / sigma_w : 0.0)
                  << " sigma), E[w x^2] - expected = " << (mm - moment) / sigma_m << " sigma, negative "
                  << double(negative) / n);
    // Only the Mitchell filters have negative lobes.
    bool mitchell = std::holds_alternative<MitchellFilter>(f.variant());
    CHECK((negative > 0) == mitchell);
  }
}

TEST_CASE("the triangle filter honours its support radius", "[film][filter]") {
  for (Float r : {0.5f, 1.f, 1.5f, 2.5f}) {
    TriangleFilter f(r);
    CHECK(f.radius() == r);
    CHECK(f.eval({r, 0}) == 0);
    CHECK(f.eval({0, -r}) == 0);
    CHECK(f.eval({next_float_up(r), 0}) == 0);
    // bare Approx: Catch's 100·FLT_EPSILON ≈ 1.2e-5 relative, a few float roundings
    CHECK(f.eval({0, 0}) == Approx(1 / (r * r)));
    // The extreme sample values land on or inside the support.
    for (Float u : {0.f, 1e-7f, next_float_down(0.5f), 0.5f, next_float_down(1.f)}) {
      FilterSample s = f.sample({u, u});
      CHECK(std::abs(s.offset.x) <= r);
      CHECK(s.weight == 1);
    }
    CHECK(f.sample({0, 0}).offset.x == -r);
    CHECK(f.sample({0.5f, 0.5f}).offset.x == 0);
    PCG32 rng(uint64_t(r * 10), 5);
    Float largest = 0;
    for (int i = 0; i < 100000; ++i) {
      FilterSample s = f.sample({rng.next_float(), rng.next_float()});
      REQUIRE(std::abs(s.offset.x) <= r);
      REQUIRE(std::abs(s.offset.y) <= r);
      largest = std::max({largest, std::abs(s.offset.x), std::abs(s.offset.y)});
    }
    // The density near the edge is small but not zero: 2e5 draws come within 1%.
    CHECK(largest > 0.99f * r);
  }
  // Every tabulated filter also stays inside its radius.
  for (const NamedFilter& nf : all_filters()) {
    PCG32 rng(9, 9);
    for (int i = 0; i < 20000; ++i) {
      FilterSample s = nf.filter.sample({rng.next_float(), rng.next_float()});
      REQUIRE(std::abs(s.offset.x) <= nf.filter.radius());
      REQUIRE(std::abs(s.offset.y) <= nf.filter.radius());
    }
  }
}

TEST_CASE("the Mitchell filter is the Mitchell-Netravali cubic", "[film][filter]") {
  MitchellFilter f;  // radius 2, B = C = 1/3: k(t) on [-2, 2] with t = x
  // bare Approx (100·FLT_EPSILON relative): the cubic's float Horner evaluation; 1e-4 relative one ulp past 1, where the slope is -1/3;
  // 1e-6 at the zero crossing 8/7, whose float argument is off by ≤ 6e-8 (slope ~ 0.3)
  CHECK(f.eval_1d(0) == Approx(8.0 / 9));  // (6 - 2 B) / 6
  CHECK(f.eval_1d(1) == Approx(1.0 / 18));  // B / 6, from both pieces
  CHECK(f.eval_1d(next_float_up(1.f)) == Approx(1.0 / 18).epsilon(1e-4));
  CHECK(f.eval_1d(8.f / 7) == Approx(0).margin(1e-6));  // the zero crossing
  CHECK(f.eval_1d(1.5f) < 0);
  CHECK(f.eval_1d(2) == 0);
  CHECK(f.eval_1d(-1.5f) == f.eval_1d(1.5f));
  // Scaling the radius scales the argument and keeps the integral.
  MitchellFilter g(1);
  CHECK(g.eval_1d(0.25f) == Approx(2 * f.eval_1d(0.5f)));
}

TEST_CASE("make_filter names the built-in filters and rejects others", "[film][filter][errors]") {
  for (const char* name : {"box", "gaussian", "triangle", "mitchell"}) {
    AnyFilter f = make_filter(name);
    CHECK(f.name() == name);
    PCG32 a(1, 2), b(1, 2);
    // AnyFilter forwards to the filter it holds.
    FilterSample s = f.sample({a.next_float(), a.next_float()});
    FilterSample t = std::visit([&](const auto& g) { return g.sample({b.next_float(), b.next_float()}); }, f.variant());
    CHECK(s.offset.x == t.offset.x);
    CHECK(s.weight == t.weight);
  }
  CHECK(make_filter("box").radius() == 0.5f);
  CHECK(make_filter("gaussian").radius() == 1.5f);
  CHECK(make_filter("triangle").radius() == 1.f);
  CHECK(make_filter("mitchell").radius() == 2.f);
  CHECK_THROWS_WITH(make_filter("lanczos"), Contains("'lanczos'") && Contains("mitchell"));
  CHECK_THROWS_AS(make_filter(""), Error);
  CHECK_THROWS_WITH(TriangleFilter(0), Contains("triangle filter: radius"));
  CHECK_THROWS_WITH(MitchellFilter(-1), Contains("Mitchell filter: radius"));
  CHECK_THROWS_WITH(MitchellFilter(2, std::numeric_limits<float>::quiet_NaN()), Contains("Mitchell filter: B"));
  CHECK_THROWS_WITH(GaussianFilter(1.5f, 0), Contains("Gaussian filter: sigma"));
  CHECK_THROWS_WITH(BoxFilter(std::numeric_limits<float>::infinity()), Contains("box filter: radius"));
}

TEST_CASE("every filter keeps a constant image constant through render", "[film][filter][render]") {
  // A camera inside a uniform environment: every sample is L, so sum(w L) /
  // sum(w) = L whatever the weights (negative ones included).
  Scene<RGB> scene;
  scene.add_light(UniformInfiniteLight<RGB>(RGB(0.25f, 0.5f, 0.75f)));
  scene.build();
  PerspectiveCamera cam(look_at_camera_to_world({0, 0, 0}, {0, 0, -1}, {0, 1, 0}), radians(40), 6, 4);
  for (const char* name : {"box", "gaussian", "triangle", "mitchell"}) {
    Film film(6, 4);
    RenderOptions opt;
    opt.spp = 16;
    opt.threads = 1;
    render(scene, cam, PathIntegrator{}, film, opt, make_filter(name));
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 6; ++x) {
        INFO(name << " pixel " << x << "," << y);
        // 1e-5 relative: a uniform scene: each pixel is a weighted mean of equal float values, summed in double, rounded once
        CHECK(film.pixel(x, y).b == Approx(0.75f).epsilon(1e-5));
        CHECK(film.pixel(x, y).r == Approx(0.25f).epsilon(1e-5));
      }
  }
}

}  // namespace filters_more_test
