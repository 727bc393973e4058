// The light BVH (lights/bvh_sampler.hpp) and the bounds it is built on
// (lights/light_bounds.hpp): pmfs summing to one, sampling frequencies against
// the pmf (chi-squared), pmf(sample) equal to the returned pmf, zero-power
// lights never chosen, importance that is zero only where a light cannot
// shine, cone unions that hold both cones, and the Scene's dispatch.
#include <catch2/catch.hpp>
#include <prism/prism.hpp>
#include "support/chi2.hpp"
#include "support/random.hpp"

namespace light_bvh_test {

using namespace prism;
using prism::test::random_unit;
using prism::test::uniform;

namespace {

using L = Light<RGB>;

// A mixed set of lights: triangles facing random ways (some two-sided),
// spheres, points and spots of random powers, two zero-power lights and two
// unbounded ones (an environment and a distant light).
std::vector<L> mixed_lights(PCG32& rng, int bounded) {
  std::vector<L> lights;
  for (int i = 0; i < bounded; ++i) {
    Point3f c{uniform(rng, -4, 4), uniform(rng, -1, 3), uniform(rng, -4, 4)};
    RGB col(uniform(rng, 0.1f, 1), uniform(rng, 0.1f, 1), uniform(rng, 0.1f, 1));
    Float scale = std::exp(uniform(rng, -2, 2));
    switch (i % 4) {
      case 0: {
        Vector3f a = random_unit(rng) * uniform(rng, 0.05f, 0.5f), b = random_unit(rng) * uniform(rng, 0.05f, 0.5f);
        lights.emplace_back(TriangleAreaLight<RGB>(c, c + a, c + b, AreaEmission(col, scale, i % 8 == 4), 0, 0));
        break;
      }
      case 1: lights.emplace_back(SphereAreaLight<RGB>(Sphere{c, uniform(rng, 0.02f, 0.3f)}, AreaEmission(col, scale), 0)); break;
      case 2: lights.emplace_back(PointLight<RGB>(c, col, scale)); break;
      default:
        lights.emplace_back(SpotLight<RGB>(c, random_unit(rng), col, scale, uniform(rng, 0, 0.3f), uniform(rng, 0.4f, 1.2f)));
    }
  }
  lights.emplace_back(PointLight<RGB>({1, 1, 1}, RGB(0)));  // zero power
  lights.emplace_back(TriangleAreaLight<RGB>({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, AreaEmission(RGB(0.f), 1), 0, 0));
  lights.emplace_back(UniformInfiniteLight<RGB>(RGB(0.2f)));
  lights.emplace_back(DistantLight<RGB>({0, -1, 0}, RGB(1)));
  return lights;
}

BVHLightSampler make_sampler(const std::vector<L>& lights) {
  std::vector<std::optional<LightBounds>> b;
  for (const auto& l : lights) b.push_back(light_bounds<RGB>(l));
  return BVHLightSampler(b);
}

LightSampleContext context(const Point3f& p, const Normal3f& n) {
  LightSampleContext c;
  c.p = p;
  c.n = c.ns = n;
  return c;
}
LightSampleContext random_context(PCG32& rng, bool with_normal) {
  Point3f p{uniform(rng, -6, 6), uniform(rng, -2, 4), uniform(rng, -6, 6)};
  return context(p, with_normal ? Normal3f(random_unit(rng)) : Normal3f{});
}

}  // namespace

TEST_CASE("light BVH pmfs sum to one over all lights", "[lights][light_bvh]") {
  // Points and spheres light every point, so every node holding one has a
  // positive importance everywhere and sampling never fails: the pmfs sum to 1.
  PCG32 rng(1, 11);
  std::vector<L> lights;
  for (int i = 0; i < 61; ++i) {
    Point3f c{uniform(rng, -4, 4), uniform(rng, -1, 3), uniform(rng, -4, 4)};
    RGB col(uniform(rng, 0.1f, 1), uniform(rng, 0.1f, 1), uniform(rng, 0.1f, 1));
    if (i % 2) lights.emplace_back(PointLight<RGB>(c, col, std::exp(uniform(rng, -2, 2))));
    else lights.emplace_back(SphereAreaLight<RGB>(Sphere{c, uniform(rng, 0.02f, 0.3f)}, AreaEmission(col, 2), 0));
  }
  lights.emplace_back(UniformInfiniteLight<RGB>(RGB(0.2f)));
  lights.emplace_back(DistantLight<RGB>({0, -1, 0}, RGB(1)));
  BVHLightSampler s = make_sampler(lights);
  REQUIRE(s.size() == lights.size());
  // bare Approx: Catch's 100·FLT_EPSILON ≈ 1.2e-5 relative, a float ratio of counts
  CHECK(s.infinite_probability() == Approx(2.0 / 3));
  for (int k = 0; k < 300; ++k) {
    LightSampleContext ctx = random_context(rng, k % 3 != 0);
    double sum = 0;
    for (uint32_t i = 0; i < lights.size(); ++i) sum += s.pmf(ctx, i);
    INFO("point " << k << " at " << ctx.p.x << ", " << ctx.p.y << ", " << ctx.p.z);
    // 1e-4: each pmf is a product of ≲ 10 float branch probabilities (~30 roundings: 2e-6 relative); the sum keeps that, 50x inside
    CHECK(sum == Approx(1).epsilon(1e-4));
  }
}

TEST_CASE("light BVH pmfs sum to the probability that sampling succeeds", "[lights][light_bvh]") {
  // With one-sided triangles and spots, a node may be bright for a point while
  // both its children are dark there: sampling then fails (no light, as
  // pbrt-v4 does), which costs a sample but no bias, as long as the pmfs sum
  // to the probability of success. Stratified u over m values finds that
  // probability to within (leaves + 1) / m.
  PCG32 rng(1, 12);
  auto lights = mixed_lights(rng, 61);
  BVHLightSampler s = make_sampler(lights);
  constexpr int m = 20000;
  double worst = 0;
  for (int k = 0; k < 100; ++k) {
    LightSampleContext ctx = random_context(rng, k % 3 != 0);
    double sum = 0;
    for (uint32_t i = 0; i < lights.size(); ++i) sum += s.pmf(ctx, i);
    int ok = 0;
    for (int j = 0; j < m; ++j) ok += s.sample(ctx, (Float(j) + Float(0.5)) / Float(m)) ? 1 : 0;
    INFO("point " << k);
    // 1e-5: float pmfs, as above (≲ 2e-6); stratified u finds the success probability to within (leaves + 1) / m (see above)
    CHECK(sum <= 1 + 1e-5);
    CHECK(std::abs(sum - double(ok) / m) <= double(lights.size() + 1) / m);
    worst = std::max(worst, 1 - sum);
  }
  WARN("light BVH on random points among mixed lights: at worst " << worst << " of the samples find no light");
}

TEST_CASE("light BVH sampling frequencies follow its pmf", "[lights][light_bvh]") {
  PCG32 rng(2, 22);
  auto lights = mixed_lights(rng, 37);
  BVHLightSampler s = make_sampler(lights);
  constexpr int points = 4, n = 100000;
  for (int k = 0; k < points; ++k) {
    LightSampleContext ctx = random_context(rng, k != 0);
    std::vector<double> observed(lights.size(), 0), expected(lights.size(), 0);
    for (uint32_t i = 0; i < lights.size(); ++i) expected[i] = n * double(s.pmf(ctx, i));
    // A last cell for samples that find no light.
    observed.push_back(0);
    double sum = 0;
    for (double e : expected) sum += e;
    expected.push_back(std::max(0.0, n - sum));
    int mismatched = 0;
    for (int j = 0; j < n; ++j) {
      auto sl = s.sample(ctx, rng.next_float());
      if (!sl) {
        observed.back() += 1;
        continue;
      }
      observed[sl->index] += 1;
      // The pmf of the sample, recomputed from its bit trail, is the returned one.
      // 1e-6 relative: the same branch products recomputed, a few float roundings (≲ 4e-7)
      if (!(std::abs(s.pmf(ctx, sl->index) - sl->pmf) <= 1e-6f * sl->pmf)) ++mismatched;
    }
    CHECK(mismatched == 0);
    auto r = prism_test::chi2_from_counts(observed, expected);
    INFO(r.summary());
    CHECK(r.impossible == 0);
    CHECK(r.p_value > prism_test::sidak_alpha(1e-3, points));
  }
}

TEST_CASE("light BVH never chooses a light of zero power", "[lights][light_bvh]") {
  PCG32 rng(3, 33);
  auto lights = mixed_lights(rng, 20);
  BVHLightSampler s = make_sampler(lights);
  const uint32_t zero_point = uint32_t(lights.size() - 4), zero_tri = uint32_t(lights.size() - 3);
  for (int k = 0; k < 50; ++k) {
    LightSampleContext ctx = random_context(rng, true);
    CHECK(s.pmf(ctx, zero_point) == 0);
    CHECK(s.pmf(ctx, zero_tri) == 0);
    for (int j = 0; j < 200; ++j) {
      auto sl = s.sample(ctx, rng.next_float());
      if (!sl) continue;
      CHECK(sl->index != zero_point);
      CHECK(sl->index != zero_tri);
    }
  }
  CHECK(s.pmf(random_context(rng, true), uint32_t(lights.size())) == 0);  // out of range
}

TEST_CASE("light importance is zero only where the light cannot shine", "[lights][light_bvh]") {
  PCG32 rng(4, 44);
  auto lights = mixed_lights(rng, 40);
  BVHLightSampler s = make_sampler(lights);
  int inside = 0, front = 0;
  for (size_t i = 0; i + 4 < lights.size(); ++i) {
    auto b = light_bounds<RGB>(lights[i]);
    REQUIRE(b);
    REQUIRE(b->phi > 0);
    for (int k = 0; k < 100; ++k) {
      // A point inside the light's box: its importance and its pmf are positive.
      Vector3f o{rng.next_float(), rng.next_float(), rng.next_float()};
      Vector3f d = b->bounds.diagonal();
      Point3f p = b->bounds.min + Vector3f{o.x * d.x, o.y * d.y, o.z * d.z};
      Normal3f n(random_unit(rng));
      CHECK(b->importance(p, n) > 0);
      CHECK(s.pmf(context(p, n), uint32_t(i)) > 0);
      ++inside;
      // A point anywhere the light sends light to (by its own sample_li):
      // importance positive there too.
      LightSampleContext ctx = random_context(rng, true);
      auto ls = std::visit([&](const auto& l) { return l.sample_li(ctx, {rng.next_float(), rng.next_float()}, wavelengths_t<RGB>{}); },
                           lights[i]);
      if (ls && !ls->L.is_black() && abs_dot(ls->wi, ctx.ns) > 1e-3f) {
        ++front;
        INFO("light " << i << " point " << ctx.p.x << ", " << ctx.p.y << ", " << ctx.p.z);
        CHECK(b->importance(ctx.p, ctx.ns) > 0);
        CHECK(s.pmf(ctx, uint32_t(i)) > 0);
      }
    }
  }
  CHECK(inside > 1000);
  CHECK(front > 500);
}

TEST_CASE("light bounds of each light kind", "[lights][light_bvh]") {
  // A one-sided unit right triangle of radiance 2: intensity L A = 1 along its normal +z.
  TriangleAreaLight<RGB> tri({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, AreaEmission(RGB(2), 1, false), 0, 0);
  auto b = light_bounds<RGB>(tri);
  REQUIRE(b);
  // 1e-5 relative, 1e-6 absolute: a few float roundings of the triangle's area and normal; bare Approx: 100·FLT_EPSILON relative
  CHECK(b->phi == Approx(1).epsilon(1e-5));
  CHECK(b->w.z == Approx(1));
  CHECK(b->cos_theta_o == 1);
  CHECK(b->cos_theta_e == Approx(0).margin(1e-6));
  CHECK_FALSE(b->two_sided);
  CHECK(b->importance({0.3f, 0.3f, 5}, Normal3f{}) > 0);
  CHECK(b->importance({0.3f, 0.3f, -5}, Normal3f{}) == 0);  // behind a one-sided emitter
  // Two-sided: both sides.
  auto b2 = light_bounds<RGB>(TriangleAreaLight<RGB>({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, AreaEmission(RGB(2), 1, true), 0, 0));
  REQUIRE(b2);
  CHECK(b2->importance({0.3f, 0.3f, -5}, Normal3f{}) > 0);
  // A point light of intensity 3: phi 3, importance I / d^2 facing it.
  auto bp = light_bounds<RGB>(PointLight<RGB>({0, 2, 0}, RGB(3)));
  REQUIRE(bp);
  // 1e-5 and 1e-4 relative: float intensity and I / d² (a few roundings); the spot's and sphere's φ add a float cone or π r²
  CHECK(bp->phi == Approx(3).epsilon(1e-5));
  CHECK(bp->importance({0, 0, 0}, Normal3f(0, 1, 0)) == Approx(3.0 / 4).epsilon(1e-4));
  // A spot pointing down with a 30 degree outer cone: dark outside it.
  auto bs = light_bounds<RGB>(SpotLight<RGB>({0, 2, 0}, {0, -1, 0}, RGB(3), 1, 0.2f, radians(30.f)));
  REQUIRE(bs);
  CHECK(bs->phi == Approx(3).epsilon(1e-4));
  CHECK(bs->importance({0, 0, 0}, Normal3f{}) > 0);
  CHECK(bs->importance({0.9f, 0, 0}, Normal3f{}) > 0);   // 24 degrees off the axis
  CHECK(bs->importance({1.6f, 0, 0}, Normal3f{}) == 0);  // 39 degrees
  // A sphere of radius 0.5 and radiance 1: intensity L pi r^2.
  auto bsph = light_bounds<RGB>(SphereAreaLight<RGB>(Sphere{{0, 0, 0}, 0.5f}, AreaEmission(RGB(1)), 0));
  REQUIRE(bsph);
  CHECK(bsph->phi == Approx(pi * 0.25).epsilon(1e-4));
  // Environments and distant lights have no bounds.
  CHECK_FALSE(light_bounds<RGB>(UniformInfiniteLight<RGB>(RGB(1))));
  CHECK_FALSE(light_bounds<RGB>(DistantLight<RGB>({0, -1, 0}, RGB(1))));
}

TEST_CASE("the union of two cones holds both", "[lights][light_bvh]") {
  PCG32 rng(5, 55);
  for (int k = 0; k < 2000; ++k) {
    Vector3f wa = random_unit(rng), wb = random_unit(rng);
    Float ca = std::cos(uniform(rng, 0, pi)), cb = std::cos(uniform(rng, 0, pi));
    if (k % 4 == 0) cb = 1;  // single directions, as triangles have
    if (k % 8 == 0) ca = 1;
    Vector3f w;
    Float co;
    union_cones(wa, ca, wb, cb, &w, &co);
    Float theta = safe_acos(co);
    if (co <= -1) continue;  // the whole sphere holds everything
    // The far edges of both cones lie inside the union (to rounding).
    for (int side = 0; side < 2; ++side) {
      Vector3f axis = side ? wb : wa;
      Float t = safe_acos(side ? cb : ca);
      CHECK(detail::angle_between(w, axis) + t <= theta + 1e-3f);
    }
  }
}

TEST_CASE("light BVH edge cases", "[lights][light_bvh]") {
  LightSampleContext ctx = context({0, 0, 0}, Normal3f(0, 1, 0));
  BVHLightSampler empty;
  CHECK_FALSE(empty.sample(ctx, 0.5f));
  CHECK(empty.pmf(ctx, 0) == 0);
  // Only unbounded lights: uniform among them.
  std::vector<std::optional<LightBounds>> inf(3);
  BVHLightSampler only_inf(inf);
  for (Float u : {0.f, 0.4f, 0.99999f}) {
    auto sl = only_inf.sample(ctx, u);
    REQUIRE(sl);
    // bare Approx: 100·FLT_EPSILON relative, one float division
    CHECK(sl->pmf == Approx(1.0 / 3));
  }
  // One light, facing down, above the point: always it.
  std::vector<L> one{TriangleAreaLight<RGB>({0, 1, 0}, {1, 1, 0}, {0, 1, 1}, AreaEmission(RGB(1)), 0, 0)};
  BVHLightSampler s1 = make_sampler(one);
  auto sl = s1.sample(ctx, 0.7f);
  REQUIRE(sl);
  CHECK(sl->index == 0);
  CHECK(sl->pmf == 1);
  // The triangle (normal -y) faces down: a point above it is never lit.
  LightSampleContext above = context({0.2f, 3, 0.2f}, Normal3f(0, -1, 0));
  CHECK_FALSE(s1.sample(above, 0.3f));
  CHECK(s1.pmf(above, 0) == 0);
  // Many lights on one spot (identical centroids): the build halves by count.
  std::vector<L> same(300, L(PointLight<RGB>({1, 2, 3}, RGB(1))));
  BVHLightSampler ss = make_sampler(same);
  double sum = 0;
  for (uint32_t i = 0; i < same.size(); ++i) sum += ss.pmf(ctx, i);
  // 1e-4: float pmf products as above, here over a 9-level tree of 300 lights
  CHECK(sum == Approx(1).epsilon(1e-4));
}

TEST_CASE("scene light selection dispatch", "[lights][light_bvh]") {
  for (int count : {4, 64}) {
    for (LightSelection sel : {LightSelection::automatic, LightSelection::bvh, LightSelection::power,
                               LightSelection::uniform}) {
      Scene<RGB> scene;
      build_many_lights_scene(scene, {count, 3, 64});
      scene.set_light_selection(sel);
      scene.build();
      REQUIRE(scene.lights().size() == size_t(count));
      LightSelection want = sel;
      if (sel == LightSelection::automatic)
        want = size_t(count) >= bvh_light_threshold ? LightSelection::bvh : LightSelection::power;
      CHECK(scene.light_selection() == want);
      PCG32 rng(6, uint64_t(count));
      for (int k = 0; k < 20; ++k) {
        LightSampleContext ctx = context({uniform(rng, -5, 5), 0, uniform(rng, -5, 5)}, Normal3f(0, 1, 0));
        double sum = 0;
        for (uint32_t i = 0; i < scene.lights().size(); ++i) sum += scene.light_pmf(ctx, i);
        // 1e-5 / 1e-4: float pmf products as above; 1e-6 relative for the same pmf recomputed
        // The BVH may find no light for a point (see above), the others always do.
        if (want == LightSelection::bvh) CHECK(sum <= 1 + 1e-5);
        else CHECK(sum == Approx(1).epsilon(1e-4));
        auto sl = scene.sample_light(ctx, rng.next_float());
        if (!sl) continue;
        CHECK(scene.light_pmf(ctx, sl->index) == Approx(sl->pmf).epsilon(1e-6));
        if (want == LightSelection::uniform) CHECK(sl->pmf == Approx(1.0 / count));
      }
    }
  }
}

}  // namespace light_bvh_test
