// Shares of a render (RenderOptions::first_sample / sample_count and
// tile_stride / tile_offset), merged with Film::merge, give the whole render:
// the sample index stays global, so each share draws the whole render's random
// numbers. What distributed rendering (render/mpi.hpp) rests on, checked here
// in one process. The default scene has a glass prism and area lights, so the
// caustic light-tracing pass runs and is split too.
#include <catch2/catch.hpp>
#include <cmath>
#include <string>
#include <vector>
#include <prism/prism.hpp>
#include "support/scenes.hpp"

namespace slice_test {

using namespace prism;

namespace {

constexpr int W = 24, H = 20;

struct Rendered {
  Film film{W, H};
  RenderStats st;
};

Rendered render_share(const Scene<RGB>& scene, RenderOptions opt) {
  Rendered r;
  opt.threads = 2;
  opt.tile_size = 8;
  r.st = render(scene, default_camera(W, H), PathIntegrator{}, r.film, opt);
  return r;
}

// Largest relative difference over pixel values above 1e-3 (the tolerance of
// docs/distributed.md: summation order only).
double max_relative_difference(const Film& a, const Film& b) {
  double worst = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      RGB p = a.pixel(x, y), q = b.pixel(x, y);
      for (int c = 0; c < 3; ++c) {
        double m = std::max(std::abs(double(p[c])), std::abs(double(q[c])));
        if (m > 1e-3) worst = std::max(worst, std::abs(double(p[c]) - double(q[c])) / m);
      }
    }
  return worst;
}

bool bitwise_equal(const Film& a, const Film& b) {
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      RGB p = a.pixel(x, y), q = b.pixel(x, y);
      for (int c = 0; c < 3; ++c)
        if (p[c] != q[c]) return false;
      if (a.sample_count(x, y) != b.sample_count(x, y)) return false;
    }
  return true;
}

}  // namespace

TEST_CASE("sample ranges merged equal the whole render", "[render][slice]") {
  const Scene<RGB>& scene = test::cornell_box();
  auto kind = GENERATE(SamplerKind::independent, SamplerKind::sobol);
  RenderOptions opt;
  opt.spp = 7;  // split 3 + 4, and 0 + 7
  opt.seed = 11;
  opt.sampler = kind;
  Rendered whole = render_share(scene, opt);
  REQUIRE(whole.st.light_paths == uint64_t(W) * H * 7);
  for (int a : {3, 0}) {
    RenderOptions first = opt, second = opt;
    first.first_sample = 0;
    first.sample_count = a;
    second.first_sample = a;  // sample_count -1: up to spp
    Rendered p = render_share(scene, first), q = render_share(scene, second);
    CHECK(p.st.samples == uint64_t(W) * H * uint64_t(a));
    CHECK(p.st.light_paths + q.st.light_paths == whole.st.light_paths);
    Film merged(W, H);
    merged.merge(p.film);
    merged.merge(q.film);
    // 1e-5 relative: the same samples summed in double in another order, then rounded to float (≤ 1 ulp apart)
    CHECK(max_relative_difference(merged, whole.film) <= 1e-5);
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) REQUIRE(merged.sample_count(x, y) == 7);
  }
}

TEST_CASE("tile strides merged equal the whole render bitwise", "[render][slice]") {
  // Each pixel belongs to one share, and splats are fixed-point sums (exact in
  // double), so the merged film is the whole render's bit for bit.
  const Scene<RGB>& scene = test::cornell_box();
  RenderOptions opt;
  opt.spp = 4;
  opt.seed = 5;
  Rendered whole = render_share(scene, opt);
  Film merged(W, H);
  uint64_t samples = 0, paths = 0;
  for (int offset = 0; offset < 3; ++offset) {
    RenderOptions share = opt;
    share.tile_stride = 3;
    share.tile_offset = offset;
    Rendered r = render_share(scene, share);
    samples += r.st.samples;
    paths += r.st.light_paths;
    merged.merge(r.film);
  }
  CHECK(samples == whole.st.samples);
  CHECK(paths == whole.st.light_paths);
  CHECK(bitwise_equal(merged, whole.film));
}

TEST_CASE("more shares than tiles or samples leave some empty", "[render][slice]") {
  const Scene<RGB>& scene = test::cornell_box();
  RenderOptions opt;
  opt.spp = 2;
  opt.tile_stride = 64;  // 3 x 3 tiles of 8x8: offset 40 has none
  opt.tile_offset = 40;
  Rendered r = render_share(scene, opt);
  CHECK(r.st.samples == 0);
  CHECK(r.st.light_paths == 0);
  RenderOptions none = opt;
  none.tile_stride = 1;
  none.tile_offset = 0;
  none.first_sample = 2;
  none.sample_count = 0;
  CHECK(render_share(scene, none).st.samples == 0);
}

TEST_CASE("a share with caustic chunks and no tiles runs them on every thread", "[render][slice]") {
  // 3 x 3 tiles of 8x8; at 200 spp the caustic pass has 24 chunks of 4096
  // light paths. Share 9 of 10 holds no tile and chunks 9 and 19: two units
  // of work for two threads (a thread count once capped by the tiles alone).
  const Scene<RGB>& scene = test::cornell_box();
  RenderOptions opt;
  opt.spp = 200;
  opt.seed = 3;
  opt.tile_stride = 10;
  opt.tile_offset = 9;
  Rendered two = render_share(scene, opt);
  CHECK(two.st.samples == 0);
  CHECK(two.st.light_paths == 2 * 4096);
  CHECK(two.st.threads == 2);
  // The same share on one thread: the same image, bit for bit.
  Rendered one;
  RenderOptions o1 = opt;
  o1.threads = 1;
  o1.tile_size = 8;
  one.st = render(scene, default_camera(W, H), PathIntegrator{}, one.film, o1);
  CHECK(one.st.threads == 1);
  REQUIRE(two.film.splats().size() == size_t(W) * H * 3);
  CHECK(one.film.splats() == two.film.splats());
  double sum = 0;
  for (double v : two.film.splats()) sum += v;
  CHECK(sum > 0);  // the chunks' paths reached the image
}

TEST_CASE("bad shares are rejected with the option named", "[render][slice]") {
  const Scene<RGB>& scene = test::cornell_box();
  auto expect = [&](RenderOptions opt, const std::string& what) {
    opt.spp = 4;
    try {
      render_share(scene, opt);
      FAIL("no error for " << what);
    } catch (const Error& e) {
      CHECK_THAT(e.what(), Catch::Matchers::Contains(what));
    }
  };
  RenderOptions o;
  o.first_sample = 5;
  expect(o, "first_sample");
  o = {};
  o.first_sample = -1;
  expect(o, "first_sample");
  o = {};
  o.first_sample = 2;
  o.sample_count = 3;
  expect(o, "exceed spp");
  o = {};
  o.tile_stride = 2;
  o.tile_offset = 2;
  expect(o, "tile_offset");
  o = {};
  o.tile_stride = 0;
  expect(o, "tile_stride");
}

TEST_CASE("films and AOV films of other sizes do not merge", "[render][slice]") {
  Film a(4, 4), b(4, 5);
  CHECK_THROWS_AS(a.merge(b), Error);
  AovFilm c(4, 4), d(5, 4);
  CHECK_THROWS_AS(c.merge(d), Error);
  Film rgb(2, 2), xyz(2, 2);
  rgb.prepare(FilmEncoding::rgb);
  rgb.add_sample(0, 0, RGB(1), 1);
  xyz.prepare(FilmEncoding::xyz);
  xyz.add_sample(0, 0, RGB(1), 1);
  CHECK_THROWS_AS(rgb.merge(xyz), Error);
}

TEST_CASE("AOVs of sample ranges merge into the whole render's", "[render][slice]") {
  const Scene<RGB>& scene = test::cornell_box();
  RenderOptions opt;
  opt.spp = 5;
  opt.seed = 2;
  AovFilm whole_aov(W, H);
  opt.aovs = &whole_aov;
  Rendered whole = render_share(scene, opt);
  AovFilm a1(W, H), a2(W, H), merged(W, H);
  RenderOptions p = opt, q = opt;
  p.sample_count = 2;
  p.aovs = &a1;
  q.first_sample = 2;
  q.aovs = &a2;
  render_share(scene, p);
  render_share(scene, q);
  merged.merge(a1);
  merged.merge(a2);
  double worst = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      RGB u = merged.albedo(x, y), v = whole_aov.albedo(x, y);
      for (int c = 0; c < 3; ++c) worst = std::max(worst, double(std::abs(u[c] - v[c])));
      worst = std::max(worst, double(std::abs(merged.depth(x, y) - whole_aov.depth(x, y))) /
                                  std::max(1.0, double(whole_aov.depth(x, y))));
    }
  // 1e-5: as above, the AOVs' double sums in another order, rounded to float
  CHECK(worst <= 1e-5);
}

}  // namespace slice_test
