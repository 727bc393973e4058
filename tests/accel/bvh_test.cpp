// The BVH against brute force: the closest hit found through the BVH (and
// through MeshAccel, which stores the triangles in leaf order) is bit for bit
// the one found by testing every triangle with intersect_triangle; occluded()
// agrees with intersect(); degenerate inputs build and stay correct; the build
// does not depend on the thread count.
#include "support/accel_variant.hpp"
#include <catch2/catch.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <cstring>
#include <sstream>
#include <string>
#include <functional>
#include <optional>
#include <vector>

#include "prism/accel/scene_accel.hpp"
#include "prism/sampling/pcg32.hpp"
#include "prism/sampling/warps.hpp"

#include "support/random.hpp"

namespace bvh_test {

using namespace prism;

namespace {

// Options that keep the binary tree, for the tests that inspect it.
BVHBuildOptions keep_tree() {
  BVHBuildOptions o;
  o.keep_binary_tree = true;
  return o;
}

using test::random_unit;
using test::uniform;

struct Soup {
  std::vector<Point3f> v;  // 3 per triangle
  size_t size() const { return v.size() / 3; }
  std::vector<Bounds3f> bounds() const {
    std::vector<Bounds3f> b(size());
    for (size_t i = 0; i < size(); ++i) b[i] = union_bounds(union_bounds(Bounds3f(v[3 * i]), v[3 * i + 1]), v[3 * i + 2]);
    return b;
  }
  TriangleMesh mesh() const {
    TriangleMesh m;
    m.positions = v;
    for (uint32_t i = 0; i < uint32_t(v.size()); ++i) m.indices.push_back(i);
    return m;
  }
};

// n triangles with centres in [-10, 10]^3, sizes from 2^-6 to 2^2, random orientations.
Soup random_soup(size_t n, PCG32& rng) {
  Soup s;
  for (size_t i = 0; i < n; ++i) {
    Vector3f c{uniform(rng, -10, 10), uniform(rng, -10, 10), uniform(rng, -10, 10)};
    Float size = std::exp2(uniform(rng, -6, 2));
    for (int k = 0; k < 3; ++k) s.v.push_back(Point3f(c + random_unit(rng) * size));
  }
  return s;
}

struct Closest {
  bool hit = false;
  Float t = infinity;
  uint32_t tri = 0;
};

// Brute force in two steps. First, the triangles that hit with t_max = inf
// (see candidates() below). The t_max test in intersect_triangle is its only
// step that depends on t_max and it is monotone in it, so for any finite t_max
// the hits are among these candidates, and testing only them gives exactly
// what testing every triangle again would.
//
// Testing 10^4 triangles per ray with intersect_triangle costs ~30 ns each
// (its std::fma is a libm call without -mfma), too slow for 10^9 tests, so
// candidates() first discards triangles that provably cannot pass its edge
// test: intersect_triangle accepts only if its three edge functions, computed
// on its sheared 2D vertices, agree in sign. Its edge functions have the sign
// of the exact ones of those vertices (difference_of_products is accurate to
// 2 u, and exactly zero only when the exact value is), so the ray's point (0,0)
// lies in the closed triangle of the sheared vertices, hence in its bounding
// box. The prefilter recomputes the sheared vertices with the same operations;
// each computation is within gamma(5) (|x'| + 2 |z|) of the exact shear (pbrt-v4
// eq. 6.31, with |sx| <= 1), so the two differ by at most delta = 6 gamma(5) m,
// m the largest |x'|, |y'|, |z|; a box that misses (0,0) by more than 8 gamma(5) m
// (rounding of delta itself included) cannot contain the header's point.
struct SoupSoA {
  std::vector<Float> c[3][3];  // c[vertex][axis][triangle]
  explicit SoupSoA(const Soup& s) {
    for (auto& v : c)
      for (auto& a : v) a.resize(s.size());
    for (size_t i = 0; i < s.size(); ++i)
      for (int j = 0; j < 3; ++j)
        for (int a = 0; a < 3; ++a) c[j][a][i] = s.v[3 * i + size_t(j)][a];
  }
};

std::vector<uint32_t> candidates(const Soup& s, const SoupSoA& soa, const Point3f& o, const Vector3f& d) {
  RayTrianglePrecomp pc(d);
  const size_t n = s.size();
  std::vector<unsigned char> maybe(n);
  const Float ox = o[pc.kx], oy = o[pc.ky], oz = o[pc.kz], sx = pc.sx, sy = pc.sy;
  const Float* X[3] = {soa.c[0][pc.kx].data(), soa.c[1][pc.kx].data(), soa.c[2][pc.kx].data()};
  const Float* Y[3] = {soa.c[0][pc.ky].data(), soa.c[1][pc.ky].data(), soa.c[2][pc.ky].data()};
  const Float* Z[3] = {soa.c[0][pc.kz].data(), soa.c[1][pc.kz].data(), soa.c[2][pc.kz].data()};
  const Float k = 8 * gamma(5);
  for (size_t i = 0; i < n; ++i) {
    Float x0 = X[0][i] - ox, y0 = Y[0][i] - oy, z0 = Z[0][i] - oz;
    Float x1 = X[1][i] - ox, y1 = Y[1][i] - oy, z1 = Z[1][i] - oz;
    Float x2 = X[2][i] - ox, y2 = Y[2][i] - oy, z2 = Z[2][i] - oz;
    x0 += sx * z0; y0 += sy * z0;
    x1 += sx * z1; y1 += sy * z1;
    x2 += sx * z2; y2 += sy * z2;
    Float m = std::max({std::abs(x0), std::abs(x1), std::abs(x2), std::abs(y0), std::abs(y1), std::abs(y2),
                        std::abs(z0), std::abs(z1), std::abs(z2)});
    Float delta = k * m;
    Float lo_x = std::min({x0, x1, x2}), hi_x = std::max({x0, x1, x2});
    Float lo_y = std::min({y0, y1, y2}), hi_y = std::max({y0, y1, y2});
    maybe[i] = (lo_x <= delta) & (hi_x >= -delta) & (lo_y <= delta) & (hi_y >= -delta);
  }
  std::vector<uint32_t> c;
  for (uint32_t i = 0; i < uint32_t(n); ++i)
    if (maybe[i] && intersect_triangle(o, pc, infinity, s.v[3 * i], s.v[3 * i + 1], s.v[3 * i + 2])) c.push_back(i);
  return c;
}

// Closest hit: the candidates in index order, each tested against the best t
// so far, replacing it only when strictly closer.
Closest brute_force(const Soup& s, const std::vector<uint32_t>& cand, const Point3f& o, const Vector3f& d,
                    Float t_max) {
  RayTrianglePrecomp pc(d);
  Closest c;
  c.t = t_max;
  for (uint32_t i : cand) {
    auto h = intersect_triangle(o, pc, c.t, s.v[3 * i], s.v[3 * i + 1], s.v[3 * i + 2]);
    if (h && (!c.hit || h->t < c.t)) c = {true, h->t, i};
  }
  return c;
}
bool brute_force_any(const Soup& s, const std::vector<uint32_t>& cand, const Point3f& o, const Vector3f& d,
                     Float t_max) {
  RayTrianglePrecomp pc(d);
  for (uint32_t i : cand)
    if (intersect_triangle(o, pc, t_max, s.v[3 * i], s.v[3 * i + 1], s.v[3 * i + 2])) return true;
  return false;
}

// The BVH with the same callback protocol as brute_force.
Closest bvh_closest(const BVH& bvh, const Soup& s, const Point3f& o, const Vector3f& d, Float t_max) {
  RayTrianglePrecomp pc(d);
  Closest c;
  Float tm = t_max;
  bvh.intersect(o, d, tm, [&](uint32_t k, Float& t) {
    uint32_t i = bvh.prims()[k];
    auto h = intersect_triangle(o, pc, t, s.v[3 * i], s.v[3 * i + 1], s.v[3 * i + 2]);
    if (!h || (c.hit && !(h->t < c.t))) return false;
    c = {true, h->t, i};
    t = h->t;
    return true;
  });
  return c;
}
bool bvh_any(const BVH& bvh, const Soup& s, const Point3f& o, const Vector3f& d, Float t_max) {
  RayTrianglePrecomp pc(d);
  return bvh.occluded(o, d, t_max, [&](uint32_t k, Float t) {
    uint32_t i = bvh.prims()[k];
    return intersect_triangle(o, pc, t, s.v[3 * i], s.v[3 * i + 1], s.v[3 * i + 2]).has_value();
  });
}

// A mix of rays: random origins around the soup and random directions,
// unnormalised lengths, axis-aligned directions (zero components, infinite
// 1 / d), and origins on a triangle's bounding planes with a zero direction
// component there (0 * inf = NaN in the slab test).
Ray random_ray(PCG32& rng, const Soup& s) {
  Point3f o{uniform(rng, -15, 15), uniform(rng, -15, 15), uniform(rng, -15, 15)};
  Vector3f d = random_unit(rng);
  switch (rng.next_bounded(8)) {
    case 0: {  // axis-aligned
      d = {};
      d[int(rng.next_bounded(3))] = rng.next_bounded(2) ? 1.f : -1.f;
      break;
    }
    case 1:  // one zero component
      d[int(rng.next_bounded(3))] = 0;
      break;
    case 2: {  // origin on a vertex's coordinate plane, direction parallel to it
      const Point3f& v = s.v[rng.next_bounded(uint32_t(s.v.size()))];
      int axis = int(rng.next_bounded(3));
      o[axis] = v[axis];
      d[axis] = 0;
      break;
    }
    case 3:  // aimed at a random vertex
      d = s.v[rng.next_bounded(uint32_t(s.v.size()))] - o;
      break;
    case 4:  // unnormalised
      d = d * std::exp2(uniform(rng, -10, 10));
      break;
    default:
      break;
  }
  return {o, d, 0};
}

int max_depth(const std::vector<BVHNode>& nodes, uint32_t idx = 0) {
  if (nodes[idx].is_leaf()) return 1;
  return 1 + std::max(max_depth(nodes, idx + 1), max_depth(nodes, nodes[idx].offset));
}

// Checks a BVH over a soup against brute force on n rays; returns mismatch counts.
struct Mismatches {
  size_t rays = 0, hits = 0, closest = 0, mesh_accel = 0, occluded = 0, occluded_vs_intersect = 0, bad_t = 0;
  std::string first;  // the first mismatch, described
  void note(const std::string& what) {
    if (first.empty()) first = what;
  }
};
Mismatches compare(const Soup& s, const BVH& bvh, const MeshAccel* mesh_accel, size_t n, PCG32& rng) {
  Mismatches m;
  SoupSoA soa(s);
  // Same t bit for bit and the same triangle; a different triangle is accepted
  // only for an exact tie (it hits, on its own, at exactly the same t).
  auto same = [&](const Ray& ray, const Closest& a, const Closest& b) {
    if (a.hit != b.hit) return false;
    if (!a.hit) return true;
    if (std::memcmp(&a.t, &b.t, sizeof(Float)) != 0) return false;
    if (a.tri == b.tri) return true;
    RayTrianglePrecomp pc(ray.d);
    auto h = intersect_triangle(ray.o, pc, infinity, s.v[3 * b.tri], s.v[3 * b.tri + 1], s.v[3 * b.tri + 2]);
    return h && h->t == a.t;
  };
  for (size_t r = 0; r < n; ++r) {
    Ray ray = random_ray(rng, s);
    Float t_max = rng.next_bounded(4) == 0 ? uniform(rng, 0, 30) : infinity;
    std::vector<uint32_t> cand = candidates(s, soa, ray.o, ray.d);
    Closest ref = brute_force(s, cand, ray.o, ray.d, t_max);
    Closest got = bvh_closest(bvh, s, ray.o, ray.d, t_max);
    ++m.rays;
    if (ref.hit) ++m.hits;
    if (ref.hit && !(ref.t > 0 && ref.t < infinity)) ++m.bad_t;  // NaN, infinite or non-positive
    auto describe = [&](const char* what, const Closest& a, const Closest& b, Float t) {
      std::ostringstream o;
      o.precision(9);
      o << what << ": ray o=(" << ray.o.x << "," << ray.o.y << "," << ray.o.z << ") d=(" << ray.d.x << "," << ray.d.y
        << "," << ray.d.z << ") t_max=" << t << "; brute force " << a.hit << " t=" << a.t << " tri " << a.tri
        << ", tested " << b.hit << " t=" << b.t << " tri " << b.tri;
      return o.str();
    };
    if (!same(ray, ref, got)) {
      ++m.closest;
      m.note(describe("BVH closest hit", ref, got, t_max));
    }
    if (mesh_accel) {
      Float tm = t_max;
      TriangleHit th{};
      uint32_t tri = 0;
      bool h = mesh_accel->intersect(ray.o, ray.d, &tm, &th, &tri);
      Closest via{h, h ? th.t : infinity, tri};
      if (!same(ray, ref, via)) {
        ++m.mesh_accel;
        m.note(describe("MeshAccel closest hit", ref, via, t_max));
      }
    }
    // Occlusion at several distances around the closest hit: before it, at
    // it, one float either side, after it, and the ray's own t_max.
    Float probes[6] = {t_max, t_max, t_max, t_max, t_max, t_max};
    if (ref.hit) {
      probes[0] = ref.t * uniform(rng, 0, 1);
      probes[1] = next_float_down(ref.t);
      probes[2] = ref.t;
      probes[3] = next_float_up(ref.t);
      probes[4] = ref.t * uniform(rng, 1, 2);
    }
    for (Float tp : probes) {
      bool any_ref = brute_force_any(s, cand, ray.o, ray.d, tp);
      bool any_bvh = bvh_any(bvh, s, ray.o, ray.d, tp);
      bool closest_bvh = bvh_closest(bvh, s, ray.o, ray.d, tp).hit;
      if (any_ref != any_bvh) {
        ++m.occluded;
        m.note(describe("occluded", Closest{any_ref, tp, 0}, Closest{any_bvh, tp, 0}, tp));
      }
      if (any_bvh != closest_bvh) ++m.occluded_vs_intersect;
      if (mesh_accel) {
        Float tm = tp;
        TriangleHit th{};
        uint32_t tri = 0;
        if (mesh_accel->occluded(ray.o, ray.d, tp) != mesh_accel->intersect(ray.o, ray.d, &tm, &th, &tri))
          ++m.occluded_vs_intersect;
      }
    }
  }
  return m;
}

void report(const Mismatches& m) {
  INFO("rays " << m.rays << " (hitting: " << m.hits << "), closest-hit mismatches " << m.closest
               << ", MeshAccel mismatches " << m.mesh_accel << ", occluded vs brute force " << m.occluded
               << ", occluded vs intersect " << m.occluded_vs_intersect << ", non-finite or non-positive t "
               << m.bad_t << "; first mismatch: " << m.first);
  CHECK(m.bad_t == 0);
  CHECK(m.closest == 0);
  CHECK(m.mesh_accel == 0);
  CHECK(m.occluded == 0);
  CHECK(m.occluded_vs_intersect == 0);
  CHECK(m.hits > m.rays / 20);  // the rays do hit things
}

}  // namespace

TEST_CASE("BVH closest hit equals brute force on random triangles", "[accel][bvh]") {
  PCG32 rng(1, 0xb0b);
  Soup s = random_soup(10000, rng);
  std::vector<Bounds3f> b = s.bounds();
  BVH bvh = BVH::build(b);
  MeshAccel mesh_accel(s.mesh(), BVHBuildOptions{});
  REQUIRE(bvh.prims().size() == s.size());
  // Every primitive appears exactly once in leaf order.
  std::vector<int> seen(s.size(), 0);
  for (uint32_t p : bvh.prims()) ++seen[p];
  CHECK(std::count(seen.begin(), seen.end(), 1) == long(s.size()));
  report(compare(s, bvh, &mesh_accel, test::variant_count(100000), rng));
}

TEST_CASE("BVH leaves cover their primitives and nodes nest", "[accel][bvh]") {
  PCG32 rng(2, 0xb0b);
  Soup s = random_soup(5000, rng);
  std::vector<Bounds3f> b = s.bounds();
  BVH bvh = BVH::build(b, keep_tree());
  const auto& nodes = bvh.nodes();
  size_t bad = 0, leaf_prims = 0;
  auto inside = [](const Bounds3f& in, const Bounds3f& out) {
    for (int a = 0; a < 3; ++a)
      if (in.min[a] < out.min[a] || in.max[a] > out.max[a]) return false;
    return true;
  };
  for (uint32_t i = 0; i < nodes.size(); ++i) {
    const BVHNode& n = nodes[i];
    if (n.is_leaf()) {
      leaf_prims += n.count;
      for (uint32_t k = n.offset; k < n.offset + n.count; ++k)
        if (!inside(b[bvh.prims()[k]], n.bounds())) ++bad;
    } else {
      if (!inside(nodes[i + 1].bounds(), n.bounds()) || !inside(nodes[n.offset].bounds(), n.bounds())) ++bad;
    }
  }
  CHECK(bad == 0);
  CHECK(leaf_prims == s.size());
}

TEST_CASE("an empty BVH and an empty scene miss every ray", "[accel][bvh]") {
  BVH empty = BVH::build({});
  CHECK(empty.empty());
  Float t = infinity;
  auto never = [](uint32_t, Float&) { return true; };
  CHECK_FALSE(empty.intersect({0, 0, 0}, {0, 0, 1}, t, never));
  CHECK_FALSE(empty.occluded({0, 0, 0}, {0, 0, 1}, infinity, [](uint32_t, Float) { return true; }));

  SceneAccel nothing;
  nothing.build();
  PCG32 rng(3, 0xb0b);
  for (int i = 0; i < 100; ++i) {
    Ray r{{uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)}, random_unit(rng), 0};
    CHECK_FALSE(nothing.intersect(r));
    CHECK_FALSE(nothing.occluded(r, infinity));
  }

  // Instances of a mesh without triangles, plain and transformed.
  SceneAccel hollow;
  uint32_t m = hollow.add_mesh(TriangleMesh{});
  hollow.add_mesh_instance(m);
  hollow.add_mesh_instance(m, translate({1, 2, 3}) * rotate(0.5f, {0, 1, 1}));
  hollow.build();
  for (int i = 0; i < 100; ++i) {
    Ray r{{uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)}, random_unit(rng), 0};
    CHECK_FALSE(hollow.intersect(r));
    CHECK_FALSE(hollow.occluded(r, infinity));
  }
}

TEST_CASE("BVH over triangles sharing one centroid builds and is correct", "[accel][bvh]") {
  // Each triangle's box is symmetric about the origin (vertices a, -a, b with
  // |b_i| <= |a_i|), so every centroid is exactly (0, 0, 0): no axis can be
  // binned and the builder must fall back to splitting ranges in the middle.
  PCG32 rng(4, 0xb0b);
  Soup s;
  for (int i = 0; i < 3000; ++i) {
    Vector3f a = random_unit(rng) * std::exp2(uniform(rng, -3, 2));
    Vector3f b = random_unit(rng);
    for (int k = 0; k < 3; ++k) b[k] = std::abs(a[k]) * uniform(rng, -1, 1);
    s.v.insert(s.v.end(), {Point3f(a), Point3f(-a), Point3f(b)});
  }
  std::vector<Bounds3f> bb = s.bounds();
  for (const Bounds3f& x : bb) REQUIRE(x.centroid() == Point3f{0, 0, 0});
  BVH bvh = BVH::build(bb, keep_tree());
  CHECK(bvh.prims().size() == s.size());
  CHECK(max_depth(bvh.nodes()) <= BVH::traversal_stack_size);
  MeshAccel mesh_accel(s.mesh(), BVHBuildOptions{});
  // Rays from around the cluster towards it.
  report(compare(s, bvh, &mesh_accel, 3000, rng));
}

namespace {

// A small triangle at x whose box is symmetric in y and z about 0, so that
// only x can be binned: vertices (x, s, s), (x, -s, -s), (x + dx, s/2, -s/2).
void add_x_only_triangle(Soup& s, Float x, Float size, Float dx) {
  s.v.insert(s.v.end(), {Point3f{x, size, size}, Point3f{x, -size, -size}, Point3f{x + dx, size / 2, -size / 2}});
}

}  // namespace

TEST_CASE("BVH over exponentially spaced triangles stays within its stack", "[accel][bvh]") {
  // Centroids at x = 2^(60 - 3k): each SAH level can split off only the
  // largest one or two, so the tree is as deep as the builder allows (48 SAH
  // levels, then halving) and traversal needs its whole stack budget.
  Soup s;
  for (int k = 0; k < 60; ++k) {
    Float x = std::ldexp(1.0f, 60 - 3 * k);
    add_x_only_triangle(s, x, x / 64, x / 64);
  }
  BVH bvh = BVH::build(s.bounds(), keep_tree());
  int depth = max_depth(bvh.nodes());
  INFO("depth " << depth);
  CHECK(depth > 48);                          // the depth limit was reached...
  CHECK(depth <= BVH::traversal_stack_size);  // ...and respected
  PCG32 rng(5, 0xb0b);
  Mismatches m = compare(s, bvh, nullptr, 3000, rng);
  m.hits = m.rays;  // most of these rays miss such a sparse scene; that is fine here
  report(m);
}

TEST_CASE("BVH builds over centroids closer than any float bin width", "[accel][bvh]") {
  // Centroid extents below 16 / FLT_MAX (denormal differences) overflow the
  // bin scale; the builder must treat such an axis as flat (regression: it
  // used to index a bin with int(NaN)). Mixed with ordinary triangles.
  PCG32 rng(8, 0xb0b);
  Soup s = random_soup(500, rng);
  // Flat in x (dx = 0), so each centroid is exactly its denormal x.
  for (int k = 0; k < 40; ++k) add_x_only_triangle(s, Float(k) * std::numeric_limits<Float>::denorm_min(), 1e-3f, 0);
  BVH bvh = BVH::build(s.bounds());
  CHECK(bvh.prims().size() == s.size());
  std::vector<int> seen(s.size(), 0);
  for (uint32_t p : bvh.prims()) ++seen[p];
  CHECK(std::count(seen.begin(), seen.end(), 1) == long(s.size()));
  report(compare(s, bvh, nullptr, 2000, rng));
}

TEST_CASE("the root split is the cheapest binned SAH split with empty bins and any leaf block", "[accel][bvh]") {
  // The builder sweeps its bins without branching on empty ones and counts
  // leaf costs in blocks with a shift (power-of-two blocks) or a division.
  // Here the root's split is recomputed by brute force over the same 16 bins
  // per axis: clustered centroids leave most bins empty, and leaf blocks of
  // 1, 3 and 8 take both ways of counting blocks.
  PCG32 rng(21, 0x5a4);
  constexpr int bins = 16;
  int checked = 0, mismatched = 0, unmatched = 0;
  for (int trial = 0; trial < 300; ++trial) {
    int block = trial % 3 == 0 ? 1 : trial % 3 == 1 ? 3 : 8;
    // (From 256 references on, the builder bins even and odd references into
    // two sets of bins and merges them: half the trials go there.)
    size_t n = trial % 2 == 0 ? 20 + size_t(rng.next_bounded(236)) : 256 + size_t(rng.next_bounded(1000));
    int clusters = 1 + int(rng.next_bounded(4));
    std::vector<Point3f> centre(size_t(clusters) + 1);
    for (auto& c : centre) c = {uniform(rng, -50, 50), uniform(rng, -50, 50), uniform(rng, -50, 50)};
    std::vector<Bounds3f> b(n);
    for (auto& x : b) {
      Point3f c = centre[rng.next_bounded(uint32_t(centre.size()))];
      Vector3f jitter{uniform(rng, -0.5f, 0.5f), uniform(rng, -0.5f, 0.5f), uniform(rng, -0.5f, 0.5f)};
      // (Sizes over a wider range for the larger sets, so that a box left
      // out of a bin moves the costs.)
      Float emin = n < 256 ? -5 : -8, emax = n < 256 ? 1 : 4;
      Vector3f e{std::exp2(uniform(rng, emin, emax)), std::exp2(uniform(rng, emin, emax)),
                 std::exp2(uniform(rng, emin, emax))};
      x = Bounds3f(c + jitter - e, c + jitter + e);
    }
    BVHBuildOptions opt = keep_tree();
    opt.leaf_block = block;
    opt.threads = 1;
    BVH bvh = BVH::build(b, opt);
    const auto& nd = bvh.nodes();
    REQUIRE(!nd[0].is_leaf());
    // The primitives under the root's first child.
    std::vector<uint32_t> left, todo{1};
    while (!todo.empty()) {
      uint32_t i = todo.back();
      todo.pop_back();
      if (nd[i].is_leaf()) {
        for (uint32_t k = 0; k < nd[i].count; ++k) left.push_back(bvh.prims()[nd[i].offset + k]);
      } else {
        todo.push_back(i + 1);
        todo.push_back(nd[i].offset);
      }
    }
    std::sort(left.begin(), left.end());
    // Every candidate split of the same bins and its cost.
    Bounds3f cb;
    for (const auto& x : b) cb = union_bounds(cb, x.centroid());
    auto blocks = [&](size_t k) { return Float((k + size_t(block) - 1) / size_t(block)); };
    Float best = infinity, chosen = -1;
    for (int a = 0; a < 3; ++a) {
      Float lo = cb.min[a];
      if (!(cb.max[a] > lo)) continue;
      Float k = Float(bins) * (1 - 1e-6f) / (cb.max[a] - lo);
      std::vector<int> bin(n);
      for (size_t i = 0; i < n; ++i) bin[i] = std::min(bins - 1, int((b[i].centroid()[a] - lo) * k));
      for (int s = 0; s + 1 < bins; ++s) {
        Bounds3f lb, rb;
        std::vector<uint32_t> side;
        for (size_t i = 0; i < n; ++i) {
          if (bin[i] <= s) {
            lb = union_bounds(lb, b[i]);
            side.push_back(uint32_t(i));
          } else {
            rb = union_bounds(rb, b[i]);
          }
        }
        if (side.empty() || side.size() == n) continue;
        Float cost = blocks(side.size()) * lb.surface_area() + blocks(n - side.size()) * rb.surface_area();
        best = std::min(best, cost);
        if (side == left) chosen = cost;
      }
    }
    ++checked;
    if (chosen < 0) {
      ++unmatched;
    } else if (!(chosen <= best * (1 + 1e-5f))) {
      ++mismatched;
    }
  }
  INFO(checked << " roots, " << unmatched << " not a binned split, " << mismatched << " not the cheapest");
  CHECK(unmatched == 0);
  CHECK(mismatched == 0);
}

TEST_CASE("a range of one leaf block is a leaf unless node visits cost less than a block", "[accel][bvh]") {
  // Eight boxes in two far clusters, leaf blocks of 8: one block, so with the
  // default traversal cost (1) the whole range is one leaf, the shortcut the
  // builder takes before binning; with traversal cost 0.1 splitting the
  // clusters apart is cheaper, and the builder must still find that.
  std::vector<Bounds3f> b;
  for (int i = 0; i < 8; ++i) {
    Float x = i < 4 ? -100.0f : 100.0f;
    Point3f c{x + Float(i % 4), 0, 0};
    b.push_back(Bounds3f(c - Vector3f{0.25f, 0.25f, 0.25f}, c + Vector3f{0.25f, 0.25f, 0.25f}));
  }
  BVHBuildOptions opt = keep_tree();
  opt.leaf_block = 8;
  BVH whole = BVH::build(b, opt);
  CHECK(whole.nodes().size() == 1);
  opt.traversal_cost = 0.1f;
  BVH split = BVH::build(b, opt);
  REQUIRE(split.nodes().size() >= 3);
  CHECK(!split.nodes()[0].is_leaf());
  CHECK(split.nodes()[1].is_leaf());
  CHECK(split.nodes()[1].count == 4);
}

TEST_CASE("BVH build is deterministic across thread counts", "[accel][bvh]") {
  // Enough primitives for every parallel part of the build: subtrees on their
  // own threads (16K per subtree), chunked binning of the top levels (256K),
  // the chunked leaf padding and the parallel collapse into wide nodes.
  PCG32 rng(6, 0xb0b);
  std::vector<Bounds3f> b(300000);
  for (auto& x : b) {
    Point3f c{uniform(rng, -100, 100), uniform(rng, -100, 100), uniform(rng, -100, 100)};
    Vector3f e{std::exp2(uniform(rng, -4, 2)), std::exp2(uniform(rng, -4, 2)), std::exp2(uniform(rng, -4, 2))};
    x = Bounds3f(c - e, c + e);
  }
  for (int block : test::variant_sweep({1, 3, 4}, {3})) {
    auto build = [&](int threads) {
      BVHBuildOptions opt = keep_tree();
      opt.threads = threads;
      opt.leaf_block = block;
      return BVH::build(b, opt);
    };
    BVH one = build(1), two = build(2), two_again = build(2), four = build(4);
    auto identical = [](const BVH& x, const BVH& y) {
      return x.nodes().size() == y.nodes().size() && x.prims() == y.prims() &&
             std::memcmp(x.nodes().data(), y.nodes().data(), x.nodes().size() * sizeof(BVHNode)) == 0 &&
             x.wide_nodes().size() == y.wide_nodes().size() &&
             std::memcmp(x.wide_nodes().data(), y.wide_nodes().data(), x.wide_nodes().size_bytes()) == 0;
    };
    INFO("leaf_block " << block << ", " << one.nodes().size() << " nodes, " << one.wide_nodes().size() << " wide");
    CHECK(one.wide_nodes().size() > 1000);
    CHECK(identical(one, two));
    CHECK(identical(two, two_again));
    CHECK(identical(one, four));
    // The wide layout indexes every wide node once, each after its parent.
    std::vector<int> parents(one.wide_nodes().size(), 0);
    size_t leaf_prims = 0, bad_links = 0;
    for (size_t w = 0; w < one.wide_nodes().size(); ++w) {
      const auto& nd = one.wide_nodes()[w];
      for (int l = 0; l < detail::wide_width; ++l) {
        if (nd.count[l] == nd.interior) {
          if (nd.child[l] <= w || nd.child[l] >= one.wide_nodes().size()) {
            ++bad_links;
            continue;
          }
          ++parents[nd.child[l]];
        } else {
          leaf_prims += nd.count[l];
        }
      }
    }
    CHECK(bad_links == 0);
    CHECK(parents[0] == 0);
    CHECK(std::count(parents.begin() + 1, parents.end(), 1) == long(parents.size()) - 1);
    CHECK(leaf_prims == b.size());
  }
}

TEST_CASE("SceneAccel occluded agrees with intersect through instances", "[accel][scene]") {
  // Two instances of one random mesh (one transformed) and a few spheres:
  // occluded(ray, t) must be true exactly when intersect(ray, t) finds a hit.
  PCG32 rng(7, 0xb0b);
  Soup s = random_soup(2000, rng);
  SceneAccel accel;
  uint32_t m = accel.add_mesh(s.mesh());
  accel.add_mesh_instance(m);
  accel.add_mesh_instance(m, translate({5, -3, 2}) * rotate(1.1f, {1, -2, 0.5f}) * scale(0.7f, 1.3f, 1));
  for (int i = 0; i < 20; ++i)
    accel.add_sphere({{uniform(rng, -10, 10), uniform(rng, -10, 10), uniform(rng, -10, 10)}, std::exp2(uniform(rng, -3, 1))});
  accel.build();
  size_t disagree = 0, hits = 0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    Ray r = random_ray(rng, s);
    std::optional<Hit> full = accel.intersect(r);
    if (full) ++hits;
    Float probes[4] = {infinity, uniform(rng, 0, 30), full ? full->t * uniform(rng, 0, 1) : Float(1),
                       full ? full->t * uniform(rng, 1, 2) : Float(1)};
    for (Float t : probes)
      if (accel.occluded(r, t) != accel.intersect(r, t).has_value()) ++disagree;
  }
  INFO("hits " << hits << " of " << n);
  CHECK(disagree == 0);
  CHECK(hits > n / 20);
}

TEST_CASE("a scene of one mesh answers as the same mesh among other instances", "[accel][scene]") {
  // A lone untransformed mesh takes SceneAccel's shortcut to its MeshAccel;
  // the same mesh beside a sphere far from every ray goes through the top
  // level. Both must give the same hits, and honour the same skips.
  PCG32 rng(21, 0xb0b);
  Soup s = random_soup(3000, rng);
  SceneAccel lone, shared;
  lone.add_mesh_instance(lone.add_mesh(s.mesh()));
  shared.add_mesh_instance(shared.add_mesh(s.mesh()));
  shared.add_sphere({{1e4f, 1e4f, 1e4f}, 1});
  lone.build();
  shared.build();
  const MeshAccel& mesh = lone.mesh_accels()[0];
  size_t hits = 0, differ = 0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    Ray r = random_ray(rng, s);
    std::optional<Hit> a = lone.intersect(r), b = shared.intersect(r);
    Float tm = infinity;
    TriangleHit th{};
    uint32_t tri = 0;
    bool direct = mesh.intersect(r.o, r.d, &tm, &th, &tri);
    if (a.has_value() != b.has_value() || a.has_value() != direct) {
      ++differ;
      continue;
    }
    Float probe = uniform(rng, 0, 30);
    if (lone.occluded(r, probe) != shared.occluded(r, probe)) ++differ;
    if (!a) continue;
    ++hits;
    if (a->t != b->t || a->primitive != b->primitive || a->instance != 0 || b->instance != 0 || a->b0 != b->b0 ||
        a->b1 != b->b1 || a->t != tm || a->primitive != tri)
      ++differ;
    // Skipping the hit triangle of instance 0 (the only one that can skip it),
    // and a skip aimed at another instance, which must change nothing.
    Float beyond = a->t * 1.5f;
    if (lone.occluded(r, beyond, 0, a->primitive) != shared.occluded(r, beyond, 0, a->primitive)) ++differ;
    if (lone.occluded(r, beyond, 0, a->primitive) != mesh.occluded(r.o, r.d, beyond, a->primitive)) ++differ;
    if (!lone.occluded(r, beyond, 1, a->primitive) || !shared.occluded(r, beyond, 1, a->primitive)) ++differ;
  }
  INFO("hits " << hits << " of " << n);
  CHECK(differ == 0);
  CHECK(hits > n / 20);
}

TEST_CASE("a deforming mesh after refit gives the hits of a rebuild", "[accel][bvh][refit]") {
  PCG32 rng(9, 0xb0b);
  Soup s = random_soup(3000, rng);
  TriangleMesh mesh = s.mesh();
  MeshAccel refitted(mesh, BVHBuildOptions{});
  BVH bvh = BVH::build(s.bounds());
  // Move every vertex (triangles stretch, shrink and swap places locally):
  // the old tree stays valid only through its refitted boxes.
  for (Point3f& p : s.v) p = p + Vector3f{std::sin(p.y), 0.5f * std::cos(p.z), uniform(rng, -1, 1)};
  mesh.positions = s.v;
  refitted.refit(mesh);
  bvh.refit([&](size_t i) {
    return union_bounds(union_bounds(Bounds3f(s.v[3 * i]), s.v[3 * i + 1]), s.v[3 * i + 2]);
  });
  report(compare(s, bvh, &refitted, 4000, rng));
  // The same answers as a MeshAccel built over the moved mesh.
  MeshAccel rebuilt(mesh, BVHBuildOptions{});
  size_t differ = 0;
  for (int i = 0; i < 4000; ++i) {
    Ray r = random_ray(rng, s);
    Float ta = infinity, tb = infinity;
    TriangleHit ha{}, hb{};
    uint32_t a = 0, b = 0;
    bool hita = refitted.intersect(r.o, r.d, &ta, &ha, &a), hitb = rebuilt.intersect(r.o, r.d, &tb, &hb, &b);
    if (hita != hitb || (hita && ta != tb)) ++differ;
  }
  CHECK(differ == 0);
  // A mesh with another triangle count is refused, not read out of bounds.
  TriangleMesh smaller = mesh;
  smaller.indices.resize(smaller.indices.size() - 3);
  CHECK_THROWS_AS(refitted.refit(smaller), Error);
}

TEST_CASE("the binary tree is freed unless kept, and refit recomputes the wide boxes in place", "[accel][bvh][refit]") {
  // Enough primitives for the refit's parallel pass (more than 1024 wide nodes).
  PCG32 rng(11, 0xb0b);
  Soup s = random_soup(100000, rng);
  std::vector<Bounds3f> b = s.bounds();
  BVH lean = BVH::build(b), kept = BVH::build(b, keep_tree());
  CHECK(lean.nodes().empty());
  REQUIRE(kept.nodes().size() > 1000);
  REQUIRE(lean.wide_node_count() > 1024);
  CHECK(kept.memory_bytes() - lean.memory_bytes() == kept.nodes().size() * sizeof(BVHNode));
  CHECK(lean.prims() == kept.prims());
  auto same_layout = [](const BVH& x, const BVH& y) {
    return x.wide_nodes().size() == y.wide_nodes().size() &&
           std::memcmp(x.wide_nodes().data(), y.wide_nodes().data(), x.wide_nodes().size_bytes()) == 0;
  };
  CHECK(same_layout(lean, kept));
  auto same_box = [](const Bounds3f& x, const Bounds3f& y) { return x.min == y.min && x.max == y.max; };
  CHECK(same_box(lean.bounds(), kept.nodes()[0].bounds()));
  // Refit over the same bounds: every box comes out bit for bit as built.
  BVH before = lean;
  lean.refit([&](size_t i) { return b[i]; }, 2);
  CHECK(same_layout(lean, before));
  // Refit over moved bounds: both BVHs get the same wide boxes, the kept
  // binary tree is refitted too, and the root box is the union of all.
  std::vector<Bounds3f> moved = b;
  Bounds3f all;
  for (Bounds3f& x : moved) {
    Vector3f d{uniform(rng, -2, 2), uniform(rng, -2, 2), uniform(rng, -2, 2)};
    x = Bounds3f(x.min + d, x.max + d * 1.5f);
    all = union_bounds(all, x);
  }
  lean.refit([&](size_t i) { return moved[i]; }, 1);
  // Each primitive's box is asked for once, though the kept tree needs it twice.
  std::vector<std::atomic<int>> asked(moved.size());
  kept.refit(
      [&](size_t i) {
        asked[i].fetch_add(1);
        return moved[i];
      },
      2);
  CHECK(std::all_of(asked.begin(), asked.end(), [](const std::atomic<int>& k) { return k.load() == 1; }));
  CHECK(same_layout(lean, kept));
  CHECK(!same_layout(lean, before));
  CHECK(same_box(lean.bounds(), all));
  CHECK(same_box(kept.nodes()[0].bounds(), all));
}

TEST_CASE("SceneAccel refit_mesh moves a mesh and its instances", "[accel][scene][refit]") {
  PCG32 rng(10, 0xb0b);
  Soup s = random_soup(500, rng);
  SceneAccel accel;
  uint32_t m = accel.add_mesh(s.mesh());
  accel.add_mesh_instance(m);
  accel.add_mesh_instance(m, translate({30, 0, 0}));
  accel.build();
  std::vector<Point3f> moved = s.v;
  for (Point3f& p : moved) p = p + Vector3f{0, 0, 100};
  accel.refit_mesh(m, moved);
  // The old place is empty, the new one is hit, through both instances.
  Ray down{{0, 0, 50}, {0, 0, -1}, 0};
  CHECK_FALSE(accel.occluded(down, 40));  // nothing left between z = 10 and z = 50
  size_t hits_old = 0, hits_new = 0;
  for (int i = 0; i < 2000; ++i) {
    Point3f o{uniform(rng, -10, 40), uniform(rng, -10, 10), -50};
    if (accel.intersect(Ray{o, {0, 0, 1}, 0}, 60)) ++hits_old;
    if (accel.intersect(Ray{o, {0, 0, 1}, 0})) ++hits_new;
  }
  CHECK(hits_old == 0);
  CHECK(hits_new > 100);
  CHECK_THROWS_AS(accel.refit_mesh(m, std::vector<Point3f>(3)), Error);
  CHECK_THROWS_AS(accel.refit_mesh(7, moved), Error);
}

TEST_CASE("degenerate triangles build a bounded tree and never corrupt hits", "[accel][bvh][degenerate]") {
  // Ordinary triangles mixed with zero-area ones (coincident and collinear
  // vertices), triangles with NaN or infinite vertices, and a large
  // coplanar sheet: the build finishes, every triangle is in the tree (none
  // silently dropped), depth is bounded, and hits equal brute force.
  PCG32 rng(11, 0xb0b);
  Soup s = random_soup(1500, rng);
  const Float nan = std::numeric_limits<Float>::quiet_NaN();
  for (int i = 0; i < 200; ++i) {
    Point3f a{uniform(rng, -10, 10), uniform(rng, -10, 10), uniform(rng, -10, 10)};
    Vector3f d{uniform(rng, -1, 1), uniform(rng, -1, 1), uniform(rng, -1, 1)};
    s.v.insert(s.v.end(), {a, a, a});                  // a point
    s.v.insert(s.v.end(), {a, a + d, a + d * 2.0f});   // a segment
  }
  for (int i = 0; i < 50; ++i) {
    Point3f a{uniform(rng, -10, 10), uniform(rng, -10, 10), uniform(rng, -10, 10)};
    s.v.insert(s.v.end(), {a, Point3f{nan, a.y, a.z}, a + Vector3f{1, 0, 0}});
    s.v.insert(s.v.end(), {a, Point3f{a.x, infinity, a.z}, a + Vector3f{0, 0, 1}});
  }
  for (int i = 0; i < 1500; ++i) {  // all in the plane z = 0.5
    Point3f a{uniform(rng, -10, 10), uniform(rng, -10, 10), 0.5f};
    s.v.insert(s.v.end(), {a, a + Vector3f{uniform(rng, 0, 1), 0, 0}, a + Vector3f{0, uniform(rng, 0, 1), 0}});
  }
  BVH bvh = BVH::build(s.bounds(), keep_tree());
  std::vector<int> seen(s.size(), 0);
  for (uint32_t p : bvh.prims()) ++seen[p];
  CHECK(std::count(seen.begin(), seen.end(), 1) == long(s.size()));
  CHECK(max_depth(bvh.nodes()) <= BVH::traversal_stack_size);
  MeshAccel mesh_accel(s.mesh(), BVHBuildOptions{});
  report(compare(s, bvh, &mesh_accel, 4000, rng));
}

TEST_CASE("a million copies of one triangle build a bounded tree", "[accel][bvh][degenerate]") {
  Soup s;
  const size_t n = size_t(1) << 20;
  s.v.reserve(3 * n);
  for (size_t i = 0; i < n; ++i) s.v.insert(s.v.end(), {Point3f{0, 0, 1}, Point3f{1, 0, 1}, Point3f{0, 1, 1}});
  MeshAccel accel(s.mesh(), keep_tree());
  CHECK(max_depth(accel.bvh().nodes()) <= BVH::traversal_stack_size);
  // Every copy is in the tree once (padding repeats a leaf's last triangle
  // inside its own block only).
  std::vector<int> seen(n, 0);
  for (const BVHNode& nd : accel.bvh().nodes())
    if (nd.is_leaf())
      for (uint32_t k = nd.offset; k < nd.offset + nd.count; ++k) ++seen[accel.bvh().prims()[k]];
  CHECK(std::count(seen.begin(), seen.end(), 1) == long(n));
  RayTrianglePrecomp pc(Vector3f{0, 0, 1});
  auto ref = intersect_triangle({0.2f, 0.2f, 0}, pc, infinity, s.v[0], s.v[1], s.v[2]);
  REQUIRE(ref);
  Float t = infinity;
  TriangleHit h{};
  uint32_t tri = 0;
  REQUIRE(accel.intersect({0.2f, 0.2f, 0}, {0, 0, 1}, &t, &h, &tri));
  CHECK(t == ref->t);
  CHECK(accel.occluded({0.2f, 0.2f, 0}, {0, 0, 1}, 2));
  Float t2 = infinity;
  CHECK_FALSE(accel.intersect({0.7f, 0.7f, 0}, {0, 0, 1}, &t2, &h, &tri));  // beyond the hypotenuse
}

}  // namespace bvh_test
