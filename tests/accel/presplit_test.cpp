// Triangle pre-splitting (BVHBuildOptions::split_budget, accel/presplit.hpp):
// the references of a triangle cover it, stay inside its box and respect the
// budget; the references do not depend on the thread count; MeshAccel built
// over them finds bit for bit the hits of brute force (closest hit, any hit,
// any hit skipping a triangle) on meshes of long thin triangles, also after a
// refit; SceneAccel passes the budget on; by default a mesh of well-shaped
// triangles is built exactly as without splitting, and only triangles past
// the threshold are cut, within their caps; a bad budget or threshold is refused.
#include "support/accel_variant.hpp"
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "prism/accel/sbvh.hpp"
#include "prism/accel/scene_accel.hpp"
#include "prism/sampling/pcg32.hpp"

#include "support/random.hpp"

namespace presplit_test {

using namespace prism;

namespace {

using test::random_unit;
using test::uniform;

void add_tri(TriangleMesh& m, const Point3f& a, const Point3f& b, const Point3f& c) {
  uint32_t k = uint32_t(m.positions.size());
  m.positions.push_back(a);
  m.positions.push_back(b);
  m.positions.push_back(c);
  m.indices.insert(m.indices.end(), {k, k + 1, k + 2});
}

// A fan of n slivers around the origin: each from near the centre to a far
// rim point, a fraction of a degree wide, tilted out of the plane a little.
TriangleMesh sliver_fan(int n, PCG32& rng) {
  TriangleMesh m;
  for (int i = 0; i < n; ++i) {
    Float a = 2 * pi * Float(i) / Float(n), w = 0.3f * 2 * pi / Float(n);
    Float r = uniform(rng, 5, 20), z = uniform(rng, -1, 1);
    add_tri(m, Point3f{0.1f * std::cos(a), 0.1f * std::sin(a), 0}, Point3f{r * std::cos(a), r * std::sin(a), z},
            Point3f{r * std::cos(a + w), r * std::sin(a + w), z});
  }
  return m;
}

// A large ground square cut into 80 strips 40 x 0.5 (two triangles each),
// rotated about the vertical so that their boxes are loose (box area about 60
// times the triangle's), with n small random triangles just above it.
TriangleMesh ground_and_clutter(int n, PCG32& rng) {
  TriangleMesh m;
  Float c = std::cos(0.4f), s = std::sin(0.4f);
  auto g = [&](Float x, Float y) { return Point3f{c * x - s * y, 0.01f * x, s * x + c * y}; };
  for (int k = 0; k < 80; ++k) {
    Float y0 = -20 + 0.5f * Float(k), y1 = y0 + 0.5f;
    add_tri(m, g(-20, y0), g(20, y0), g(20, y1));
    add_tri(m, g(-20, y0), g(20, y1), g(-20, y1));
  }
  for (int i = 0; i < n; ++i) {
    Vector3f p{uniform(rng, -15, 15), uniform(rng, 0.2f, 2), uniform(rng, -15, 15)};
    for (int k = 0; k < 3; ++k) m.positions.push_back(Point3f(p + random_unit(rng) * 0.3f));
    uint32_t b = uint32_t(m.positions.size() - 3);
    m.indices.insert(m.indices.end(), {b, b + 1, b + 2});
  }
  return m;
}

// n long thin triangles in random orientations: a long edge of length up to
// 30, a short width down to 1e-3.
TriangleMesh random_long(int n, PCG32& rng) {
  TriangleMesh m;
  for (int i = 0; i < n; ++i) {
    Point3f a{uniform(rng, -10, 10), uniform(rng, -10, 10), uniform(rng, -10, 10)};
    Vector3f d = random_unit(rng) * uniform(rng, 2, 30);
    Vector3f w = random_unit(rng) * std::exp2(uniform(rng, -10, 0));
    add_tri(m, a, a + d, a + d * uniform(rng, 0, 1) + w);
  }
  return m;
}

// "" if the two have the same leaf order and wide nodes, bit for bit.
std::string layout_difference(const MeshAccel& a, const MeshAccel& b) {
  if (a.bvh().prims() != b.bvh().prims()) return "leaf order";
  if (a.bvh().wide_nodes().size() != b.bvh().wide_nodes().size()) return "wide node count";
  if (std::memcmp(a.bvh().wide_nodes().data(), b.bvh().wide_nodes().data(), a.bvh().wide_nodes().size_bytes()) != 0)
    return "wide nodes";
  return {};
}

// The meshes the brute-force comparisons run on.
struct SliverCase {
  const char* name;
  TriangleMesh mesh;
};
std::vector<SliverCase> sliver_cases(PCG32& rng) {
  std::vector<SliverCase> cases;
  cases.push_back({"sliver fan", sliver_fan(400, rng)});
  cases.push_back({"ground and clutter", ground_and_clutter(600, rng)});
  cases.push_back({"random long triangles", random_long(800, rng)});
  return cases;
}

struct Closest {
  bool hit = false;
  Float t = infinity;
  uint32_t tri = 0;
};

Point3f vtx(const TriangleMesh& m, uint32_t t, int k) { return m.positions[m.indices[3 * t + uint32_t(k)]]; }

Closest brute_closest(const TriangleMesh& m, const Point3f& o, const Vector3f& d, Float t_max) {
  RayTrianglePrecomp pc(d);
  Closest c;
  c.t = t_max;
  for (uint32_t i = 0; i < uint32_t(m.triangle_count()); ++i) {
    auto h = intersect_triangle(o, pc, c.t, vtx(m, i, 0), vtx(m, i, 1), vtx(m, i, 2));
    if (h && (!c.hit || h->t < c.t)) c = {true, h->t, i};
  }
  return c;
}
bool brute_any(const TriangleMesh& m, const Point3f& o, const Vector3f& d, Float t_max, uint32_t skip) {
  RayTrianglePrecomp pc(d);
  for (uint32_t i = 0; i < uint32_t(m.triangle_count()); ++i)
    if (i != skip && intersect_triangle(o, pc, t_max, vtx(m, i, 0), vtx(m, i, 1), vtx(m, i, 2))) return true;
  return false;
}

// Rays from around the mesh's box toward random points on random triangles
// (so that most hit, many along the slivers), plus fully random ones.
struct TestRay {
  Point3f o;
  Vector3f d;
};
TestRay random_ray(const TriangleMesh& m, const Bounds3f& box, PCG32& rng) {
  Vector3f ext = box.diagonal();
  Point3f o{uniform(rng, box.min.x - 0.2f * ext.x, box.max.x + 0.2f * ext.x),
            uniform(rng, box.min.y - 0.2f * ext.y, box.max.y + 0.2f * ext.y),
            uniform(rng, box.min.z - 0.2f * ext.z, box.max.z + 0.2f * ext.z)};
  if (rng.next_bounded(4) == 0) return {o, random_unit(rng)};
  uint32_t t = rng.next_bounded(uint32_t(m.triangle_count()));
  Float u = rng.next_float(), v = rng.next_float();
  if (u + v > 1) {
    u = 1 - u;
    v = 1 - v;
  }
  Point3f p = vtx(m, t, 0) + (vtx(m, t, 1) - vtx(m, t, 0)) * u + (vtx(m, t, 2) - vtx(m, t, 0)) * v;
  return {o, p - o};
}

// Closest hit, any hit at probes around it, and any hit skipping the closest
// triangle, against brute force; returns a description of the first mismatch
// (empty if none) and counts hits.
std::string compare(const TriangleMesh& m, const MeshAccel& acc, int rays, PCG32& rng, int* hits) {
  Bounds3f box;  // of the finite vertices (rays start around it)
  for (const Point3f& p : m.positions)
    if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) box = union_bounds(box, p);
  for (int r = 0; r < rays; ++r) {
    TestRay ray = random_ray(m, box, rng);
    Float t_max = rng.next_bounded(4) == 0 ? uniform(rng, 0, 40) : infinity;
    Closest ref = brute_closest(m, ray.o, ray.d, t_max);
    Float tm = t_max;
    TriangleHit th{};
    uint32_t tri = 0;
    bool h = acc.intersect(ray.o, ray.d, &tm, &th, &tri);
    std::ostringstream what;
    what.precision(9);
    what << "ray " << r << " o=(" << ray.o.x << "," << ray.o.y << "," << ray.o.z << ") d=(" << ray.d.x << ","
         << ray.d.y << "," << ray.d.z << ") t_max=" << t_max << ": brute force " << ref.hit << " t=" << ref.t
         << " tri " << ref.tri << ", MeshAccel " << h << " t=" << tm << " tri " << tri;
    if (h != ref.hit) return "closest hit/miss, " + what.str();
    if (!h) {
      if (acc.occluded(ray.o, ray.d, t_max)) return "occluded without a hit, " + what.str();
      continue;
    }
    ++*hits;
    if (std::memcmp(&tm, &ref.t, sizeof(Float)) != 0) return "closest t, " + what.str();
    if (tri != ref.tri) {  // only an exact tie may pick another triangle
      RayTrianglePrecomp pc(ray.d);
      auto o = intersect_triangle(ray.o, pc, infinity, vtx(m, tri, 0), vtx(m, tri, 1), vtx(m, tri, 2));
      if (!o || o->t != ref.t) return "closest triangle, " + what.str();
    }
    for (Float tp : {ref.t * 0.5f, next_float_down(ref.t), ref.t, next_float_up(ref.t), ref.t * 1.5f}) {
      if (acc.occluded(ray.o, ray.d, tp) != brute_any(m, ray.o, ray.d, tp, UINT32_MAX))
        return "occluded at " + std::to_string(tp) + ", " + what.str();
      if (acc.occluded(ray.o, ray.d, tp, ref.tri) != brute_any(m, ray.o, ray.d, tp, ref.tri))
        return "occluded skipping the closest triangle at " + std::to_string(tp) + ", " + what.str();
    }
  }
  return {};
}

BVHBuildOptions with_budget(float b, int threads = 0) {
  BVHBuildOptions o;
  o.split_budget = b;
  o.threads = threads;
  return o;
}

detail::SplitReferences refs_of(const TriangleMesh& m, float budget, int threads) {
  return detail::presplit_triangles(
      m.triangle_count(),
      [&](size_t i, Point3f* v) {
        for (int k = 0; k < 3; ++k) v[k] = vtx(m, uint32_t(i), k);
      },
      budget, BVHBuildOptions{}.split_threshold, threads);
}

// Of 400 points on triangle (a, b, c) (its vertices, points on its edges and
// inside), how many lie in none of `boxes`.
size_t uncovered_points(const Point3f& a, const Point3f& b, const Point3f& c, const std::vector<Bounds3f>& boxes,
                        PCG32& rng) {
  size_t uncovered = 0;
  for (int s = 0; s < 400; ++s) {
    Float u = rng.next_float(), v = rng.next_float();
    if (s < 3) {
      u = s == 1;
      v = s == 2;
    } else if (s < 100) {
      v = (s % 3 == 0) ? 0 : (s % 3 == 1 ? 1 - u : v);
      if (s % 3 == 2) u = 0;
    } else if (u + v > 1) {
      u = 1 - u;
      v = 1 - v;
    }
    // In double, rounded once, kept inside the triangle's box: within half a
    // float spacing of the exact point of the triangle.
    Point3f p;
    for (int k = 0; k < 3; ++k) {
      double x = double(a[k]) + (double(b[k]) - double(a[k])) * u + (double(c[k]) - double(a[k])) * v;
      p[k] = std::clamp(Float(x), std::min({a[k], b[k], c[k]}), std::max({a[k], b[k], c[k]}));
    }
    bool in = false;
    for (const Bounds3f& box : boxes) in = in || box.inside(p);
    uncovered += !in;
  }
  return uncovered;
}

// Near-equilateral triangles in random orientations: box area 2 to about 7
// times twice the triangle's area, below the default threshold of 32.
TriangleMesh well_shaped(int count, PCG32& rng) {
  TriangleMesh m;
  for (int i = 0; i < count; ++i) {
    Point3f c{uniform(rng, -10, 10), uniform(rng, -10, 10), uniform(rng, -10, 10)};
    Vector3f u = random_unit(rng), n = random_unit(rng);
    Vector3f v = normalize(cross(n, u));
    u = cross(v, normalize(n));
    Float r = std::exp2(uniform(rng, -4, 1));
    Point3f p[3];
    for (int k = 0; k < 3; ++k) {
      Float a = 2 * pi * Float(k) / 3 + uniform(rng, -0.3f, 0.3f);
      p[k] = c + (u * std::cos(a) + v * std::sin(a)) * r;
    }
    add_tri(m, p[0], p[1], p[2]);
  }
  return m;
}

}  // namespace

// Whether references (box[k] of triangle tri[k]) cover their mesh: boxes
// outside their triangle's box or empty, triangles without a reference, and
// points sampled on the triangles (vertices, edges, inside) in none of their
// references' boxes.
// Points of triangle (a, b, c) on the planes of its references' faces (where
// a cut leaves one reference and the next begins): on each plane that
// crosses the triangle, the two ends and the middle of the crossing, with
// the plane's coordinate exact and the others rounded once from double. How
// many lie in none of the boxes; *points counts those tried.
size_t uncovered_plane_points(const Point3f& a, const Point3f& b, const Point3f& c,
                              const std::vector<Bounds3f>& boxes, size_t* points) {
  const Point3f v[3] = {a, b, c};
  const Bounds3f tb = triangle_box(a, b, c);
  size_t uncovered = 0;
  for (const Bounds3f& face : boxes)
    for (int axis = 0; axis < 3; ++axis)
      for (Float plane : {face.min[axis], face.max[axis]}) {
        double end[2][3];
        int ends = 0;
        for (int e = 0; e < 3 && ends < 2; ++e) {
          const Point3f &p = v[e], &q = v[(e + 1) % 3];
          if (p[axis] == q[axis] || (p[axis] - plane) * (q[axis] - plane) > 0) continue;
          const double t = (double(plane) - p[axis]) / (double(q[axis]) - p[axis]);
          for (int k = 0; k < 3; ++k) end[ends][k] = double(p[k]) + t * (double(q[k]) - double(p[k]));
          ++ends;
        }
        if (ends < 2) continue;
        for (double s : {0.0, 0.5, 1.0}) {
          Point3f x;
          for (int k = 0; k < 3; ++k)
            x[k] = std::clamp(Float(end[0][k] + s * (end[1][k] - end[0][k])), tb.min[k], tb.max[k]);
          x[axis] = plane;
          bool in = false;
          for (const Bounds3f& box : boxes) in = in || box.inside(x);
          uncovered += !in;
          ++*points;
        }
      }
  return uncovered;
}

struct Cover {
  size_t outside = 0, missing = 0, uncovered = 0, plane_points = 0;
};
Cover cover(const TriangleMesh& mesh, const std::vector<Bounds3f>& box, const std::vector<uint32_t>& tri, PCG32& rng) {
  Cover c;
  std::vector<std::vector<Bounds3f>> of(mesh.triangle_count());
  for (size_t k = 0; k < box.size(); ++k) {
    uint32_t t = tri[k];
    Bounds3f tb = triangle_box(vtx(mesh, t, 0), vtx(mesh, t, 1), vtx(mesh, t, 2));
    if (box[k].empty() || !tb.inside(box[k].min) || !tb.inside(box[k].max)) ++c.outside;
    of[t].push_back(box[k]);
  }
  for (uint32_t t = 0; t < uint32_t(of.size()); ++t) {
    if (of[t].empty()) {
      ++c.missing;
      continue;
    }
    c.uncovered += uncovered_points(vtx(mesh, t, 0), vtx(mesh, t, 1), vtx(mesh, t, 2), of[t], rng);
    if (of[t].size() > 1)
      c.uncovered += uncovered_plane_points(vtx(mesh, t, 0), vtx(mesh, t, 1), vtx(mesh, t, 2), of[t], &c.plane_points);
  }
  return c;
}

TEST_CASE("pre-split references cover their triangle and respect the budget", "[accel][presplit]") {
  PCG32 rng(21, 0x5b1);
  TriangleMesh m = random_long(500, rng);
  TriangleMesh fan = sliver_fan(300, rng);
  for (const TriangleMesh* mesh : {&m, &fan})
    for (float budget : {0.1f, 1.0f, 8.0f}) {
      detail::SplitReferences r = refs_of(*mesh, budget, 1);
      size_t n = mesh->triangle_count();
      INFO("budget " << budget << ", " << n << " triangles, " << r.size() << " references");
      REQUIRE(r.triangles() == n);
      CHECK(r.size() <= n + size_t(double(budget) * double(n)));
      CHECK(r.size() >= n + size_t(0.5 * double(budget) * double(n)));  // the budget is mostly used
      std::vector<uint32_t> tri(r.size());
      for (size_t k = 0; k < r.size(); ++k) tri[k] = r.triangle(k);
      Cover c = cover(*mesh, r.bounds, tri, rng);
      INFO(c.plane_points << " points on cut planes");
      CHECK(c.plane_points >= 3 * (r.size() - n));
      CHECK(c.missing == 0);
      CHECK(c.outside == 0);
      CHECK(c.uncovered == 0);
    }
}

TEST_CASE("a split triangle's references cover it also when its polygons are clipped anew", "[accel][presplit]") {
  // split_triangle clips each reference's polygon by one plane; a polygon
  // that has no room for another vertex is clipped anew from the triangle.
  // With room for only 4 vertices that path runs at almost every split.
  PCG32 rng(27, 0x5b1);
  TriangleMesh m = random_long(300, rng);
  size_t differ = 0;
  for (uint32_t extra : {3u, 12u, 40u}) {
    size_t outside = 0, uncovered = 0;
    for (uint32_t t = 0; t < uint32_t(m.triangle_count()); ++t) {
      Point3f a = vtx(m, t, 0), b = vtx(m, t, 1), c = vtx(m, t, 2);
      Bounds3f tb = triangle_box(a, b, c);
      std::vector<Bounds3f> boxes[2];
      std::vector<uint32_t> tri;
      for (int cap = 0; cap < 2; ++cap) {
        detail::split_triangle(a, b, c, t, extra, boxes[cap], tri, cap == 0 ? 4 : detail::SplitPiece::max_vertices);
        for (const Bounds3f& box : boxes[cap])
          if (box.empty() || !tb.inside(box.min) || !tb.inside(box.max)) ++outside;
        uncovered += uncovered_points(a, b, c, boxes[cap], rng);
      }
      differ += boxes[0].size() != boxes[1].size() ||
                !std::equal(boxes[0].begin(), boxes[0].end(), boxes[1].begin(), [](const Bounds3f& x, const Bounds3f& y) {
                  return std::memcmp(&x, &y, sizeof(Bounds3f)) == 0;
                });
    }
    INFO(extra << " extra references per triangle");
    CHECK(outside == 0);
    CHECK(uncovered == 0);
  }
  CHECK(differ > 0);  // the clipping anew did run
}

TEST_CASE("pre-split references do not depend on the thread count", "[accel][presplit]") {
  PCG32 rng(22, 0x5b1);
  // Above parallel_chunk_count's one-chunk limit; below it (the pieces are
  // still cut on several threads); the slivers all in the first 4% of a mesh
  // (chunks balanced by work, not by triangle count, so not at the middle).
  TriangleMesh clustered = random_long(3000, rng);
  TriangleMesh rest = well_shaped(70000, rng);
  for (size_t t = 0; t < rest.triangle_count(); ++t)
    add_tri(clustered, vtx(rest, uint32_t(t), 0), vtx(rest, uint32_t(t), 1), vtx(rest, uint32_t(t), 2));
  for (const TriangleMesh& m : {random_long(70000, rng), random_long(3000, rng), clustered}) {
    INFO(m.triangle_count() << " triangles");
    detail::SplitReferences a = refs_of(m, 0.3f, 1);
    for (int threads : {2, 3}) {
      detail::SplitReferences b = refs_of(m, 0.3f, threads);
      REQUIRE(a.size() == b.size());
      CHECK(a.extra_tri == b.extra_tri);
      CHECK(std::memcmp(a.bounds.data(), b.bounds.data(), a.bounds.size() * sizeof(Bounds3f)) == 0);
    }
    CHECK(a.size() > m.triangle_count());
  }
}

TEST_CASE("MeshAccel with and without pre-splitting finds the hits of brute force", "[accel][presplit]") {
  // Budget 0 is the unsplit layout, where skipping a triangle compares the
  // packet's leaf-order entries at once.
  PCG32 rng(23, 0x5b1);
  for (const SliverCase& c : sliver_cases(rng))
    for (float budget : test::variant_sweep({0.0f, 0.1f, 0.5f, 3.0f}, {0.0f, 0.5f})) {
      MeshAccel acc(c.mesh, with_budget(budget));
      INFO(c.name << ", budget " << budget << ": " << acc.reference_count() << " references for "
                  << c.mesh.triangle_count() << " triangles");
      if (budget > 0)
        CHECK(acc.reference_count() > c.mesh.triangle_count());
      else
        CHECK(acc.reference_count() == c.mesh.triangle_count());
      int hits = 0;
      CHECK(compare(c.mesh, acc, 1500, rng, &hits) == "");
      CHECK(hits > 300);
    }
}

TEST_CASE("a pre-split MeshAccel after refit gives the hits of a rebuild", "[accel][presplit][refit]") {
  PCG32 rng(24, 0x5b1);
  TriangleMesh m = random_long(1500, rng);
  MeshAccel refitted(m, with_budget(0.5f));
  for (Point3f& p : m.positions) p = p + Vector3f{std::sin(p.y), 0.5f * std::cos(p.z), uniform(rng, -1, 1)};
  refitted.refit(m);
  int hits = 0;
  CHECK(compare(m, refitted, 1500, rng, &hits) == "");
  CHECK(hits > 300);
  MeshAccel rebuilt(m, with_budget(0.5f));
  Bounds3f box;
  for (const Point3f& p : m.positions) box = union_bounds(box, p);
  size_t differ = 0;
  for (int i = 0; i < 3000; ++i) {
    TestRay r = random_ray(m, box, rng);
    Float ta = infinity, tb = infinity;
    TriangleHit ha{}, hb{};
    uint32_t a = 0, b = 0;
    bool hita = refitted.intersect(r.o, r.d, &ta, &ha, &a), hitb = rebuilt.intersect(r.o, r.d, &tb, &hb, &b);
    if (hita != hitb || (hita && (ta != tb || a != b))) ++differ;
  }
  CHECK(differ == 0);
}

TEST_CASE("SceneAccel passes the split budget to its meshes and keeps triangle indices", "[accel][presplit]") {
  PCG32 rng(25, 0x5b1);
  TriangleMesh m = ground_and_clutter(300, rng);
  SceneAccel plain, split;
  for (SceneAccel* s : {&plain, &split}) {
    s->add_mesh_instance(s->add_mesh(m));
    s->add_mesh_instance(0, translate({1, 2, 3}));
  }
  plain.build(with_budget(0));
  split.build(with_budget(0.5f));
  CHECK(split.mesh_accels()[0].reference_count() > m.triangle_count());
  CHECK(plain.mesh_accels()[0].reference_count() == m.triangle_count());
  size_t differ = 0;
  for (int i = 0; i < 3000; ++i) {
    Ray r{Point3f{uniform(rng, -25, 25), uniform(rng, 5, 10), uniform(rng, -25, 25)},
          Vector3f{uniform(rng, -1, 1), -1, uniform(rng, -1, 1)}, 0};
    auto a = plain.intersect(r), b = split.intersect(r);
    if (a.has_value() != b.has_value()) ++differ;
    if (a && b && (a->t != b->t || a->instance != b->instance || a->primitive != b->primitive)) ++differ;
    if (a && split.occluded(r, infinity, a->instance, a->primitive) !=
                 plain.occluded(r, infinity, a->instance, a->primitive))
      ++differ;
  }
  CHECK(differ == 0);
}

TEST_CASE("by default pre-splitting leaves a mesh of well-shaped triangles alone", "[accel][presplit]") {
  PCG32 rng(27, 0x5b1);
  TriangleMesh m = well_shaped(4000, rng);
  MeshAccel by_default(m, BVHBuildOptions{}), off(m, with_budget(0));
  CHECK(BVHBuildOptions{}.split_budget > 0);
  CHECK(by_default.reference_count() == m.triangle_count());
  CHECK(by_default.memory_bytes() == off.memory_bytes());
  CHECK(layout_difference(by_default, off) == "");
}

TEST_CASE("a sliver in a large mesh costs only its own references", "[accel][presplit]") {
  // One sliver (box area 41 times twice its area: at most 10 extra pieces)
  // among 4000 well-shaped triangles: only its pieces are added, with 4 bytes
  // of map each and no map for the other triangles (which would be 16 KB or
  // more), and hits stay exact.
  PCG32 rng(29, 0x5b1);
  TriangleMesh m = well_shaped(4000, rng);
  add_tri(m, {0, 0, 0}, {4, 4, 0}, {4.1f, 3.9f, 0});
  MeshAccel split(m, BVHBuildOptions{}), off(m, with_budget(0));
  size_t n = m.triangle_count(), extra = split.reference_count() - n;
  INFO(extra << " extra references, " << split.memory_bytes() << " bytes against " << off.memory_bytes());
  CHECK(extra >= 1);
  CHECK(extra <= 10);
  // Each piece: at most a packet, its leaf-order entries and its map entry,
  // plus a few nodes; far less than 4 bytes for every triangle.
  CHECK(split.memory_bytes() < off.memory_bytes() + 12 * 1024);
  int hits = 0;
  CHECK(compare(m, split, 1500, rng, &hits) == "");
  CHECK(hits > 100);
}

TEST_CASE("only triangles past the threshold are cut, each at most a quarter of its ratio times", "[accel][presplit]") {
  // Well-shaped triangles and slivers of known box-to-area ratios (width w,
  // length 8 along a diagonal of the xy plane: box area about 2 * 32 / (8 w)
  // times twice the triangle's area).
  PCG32 rng(28, 0x5b1);
  TriangleMesh m;
  std::vector<double> ratio;
  auto add = [&](const Point3f& a, const Point3f& b, const Point3f& c) {
    add_tri(m, a, b, c);
    Bounds3f box = union_bounds(union_bounds(Bounds3f(a), b), c);
    ratio.push_back(double(box.surface_area()) / double(length(cross(b - a, c - a))));
  };
  for (int i = 0; i < 300; ++i) {
    Point3f c{uniform(rng, -10, 10), uniform(rng, -10, 10), uniform(rng, -10, 10)};
    if (i % 3 == 0) {
      Float w = std::exp2(uniform(rng, -7, -1));
      Vector3f d{4, 4, uniform(rng, -1, 1)};
      add(c, c + d, c + d * 0.5f + Vector3f{w, -w, 0});
    } else {
      add(c, c + Vector3f{1, 0, 0.1f}, c + Vector3f{0.5f, 0.9f, 0});
    }
  }
  size_t n = m.triangle_count(), slivers = 0, at_cap = 0;
  for (double r : ratio) slivers += r >= 32;
  REQUIRE(slivers > 50);
  REQUIRE(slivers < n);
  for (float budget : {0.2f, 100.0f}) {
    detail::SplitReferences refs = refs_of(m, budget, 1);
    std::vector<size_t> count(n, 0);
    REQUIRE(refs.triangles() == n);
    for (size_t k = 0; k < refs.size(); ++k) ++count[refs.triangle(k)];
    size_t over = 0, cut_below = 0;
    at_cap = 0;
    for (size_t t = 0; t < n; ++t) {
      size_t cap = ratio[t] >= 32 ? size_t(std::floor(ratio[t] / 4)) : 0;
      over += count[t] > cap + 1;
      cut_below += ratio[t] < 32 && count[t] != 1;
      at_cap += count[t] == cap + 1;
    }
    INFO("budget " << budget << ": " << refs.size() << " references for " << n << " triangles, " << slivers
                   << " past the threshold, " << at_cap << " at their cap");
    CHECK(refs.size() <= n + size_t(double(budget) * double(n)));
    CHECK(over == 0);
    CHECK(cut_below == 0);
    // With a budget that no cap limits, every triangle gets its cap.
    if (budget > 10) CHECK(at_cap == n);
  }
}

TEST_CASE("a negative, non-finite or too large split budget is refused", "[accel][presplit]") {
  PCG32 rng(26, 0x5b1);
  TriangleMesh m = random_long(10, rng);
  CHECK_THROWS_AS(MeshAccel(m, with_budget(-0.5f)), Error);
  CHECK_THROWS_AS(MeshAccel(m, with_budget(std::nanf(""))), Error);
  CHECK_THROWS_AS(MeshAccel(m, with_budget(infinity)), Error);
  CHECK_THROWS_AS(MeshAccel(m, with_budget(1e9f)), Error);  // more than 2^32 references
  CHECK_NOTHROW(MeshAccel(TriangleMesh{}, with_budget(0.5f)));
  for (float threshold : {0.5f, -1.0f, std::nanf(""), infinity}) {
    BVHBuildOptions o;
    o.split_threshold = threshold;
    CHECK_THROWS_AS(MeshAccel(m, o), Error);
    o.split_budget = 0;  // refused with splitting off too
    CHECK_THROWS_AS(MeshAccel(m, o), Error);
  }
}

// ---------------------------------------------------------------- spatial splits
// (accel/sbvh.hpp: BVHBuildOptions::spatial_splits)

namespace {
BVHBuildOptions with_spatial(float budget, float alpha = BVHBuildOptions{}.spatial_alpha, int threads = 0) {
  BVHBuildOptions o = with_budget(budget, threads);
  o.spatial_splits = spatial_split_builder;
  o.spatial_alpha = alpha;
  return o;
}
}  // namespace

TEST_CASE("MeshAccel with spatial splits finds the hits of brute force", "[accel][sbvh]") {
  // Three quarters of compare()'s rays aim at a point on a triangle, so cut
  // triangles are hit at and near the planes they were cut at. alpha 0 looks
  // at a spatial split at every node; a budget of 3 lets triangles be cut
  // many times over.
  PCG32 rng(31, 0x5b1);
  for (const SliverCase& c : sliver_cases(rng))
    for (float budget : test::variant_sweep({0.1f, 0.5f, 3.0f}, {0.5f}))
      for (float alpha : {0.0f, BVHBuildOptions{}.spatial_alpha}) {
        MeshAccel acc(c.mesh, with_spatial(budget, alpha));
        const size_t n = c.mesh.triangle_count(), pre = MeshAccel(c.mesh, with_budget(budget)).reference_count();
        INFO(c.name << ", budget " << budget << ", alpha " << alpha << ": " << acc.reference_count()
                    << " references for " << n << " triangles, " << pre << " after pre-splitting");
        // The builder cut, on top of pre-splitting, within its own budget
        // (at 0.1 it finds no cut that fits on these meshes).
        CHECK(acc.reference_count() >= pre);
        if (budget > 0.1f) CHECK(acc.reference_count() > pre);
        CHECK(acc.reference_count() <= pre + size_t(double(budget) * double(n)));
        int hits = 0;
        CHECK(compare(c.mesh, acc, 1500, rng, &hits) == "");
        CHECK(hits > 300);
      }
}

TEST_CASE("spatial splits do not depend on the thread count", "[accel][sbvh]") {
  // Large enough for the top subtrees to be built on threads of their own
  // and the top nodes' passes to be cut into chunks (from 64K references).
  PCG32 rng(32, 0x5b1);
  TriangleMesh m = random_long(52000, rng);
  MeshAccel one(m, with_spatial(0.3f, BVHBuildOptions{}.spatial_alpha, 1));
  CHECK(one.reference_count() > m.triangle_count());
  CHECK(one.reference_count() >= 64 * 1024);
  for (int threads : test::variant_sweep({2, 3}, {3})) {
    MeshAccel more(m, with_spatial(0.3f, BVHBuildOptions{}.spatial_alpha, threads));
    INFO(threads << " threads");
    REQUIRE(more.reference_count() == one.reference_count());
    CHECK(layout_difference(more, one) == "");
    bool same_map = true;
    for (size_t k = 0; k < one.bvh().prims().size(); ++k) same_map &= one.leaf_triangle(k) == more.leaf_triangle(k);
    CHECK(same_map);
  }
}

TEST_CASE("spatial splits trace slivers through fewer boxes than pre-splitting", "[accel][sbvh]") {
  // What the option is for: on long diagonal slivers the tree is better by
  // the SAH measure that traversal pays, the expected boxes a ray crosses
  // (the sum of the wide nodes' lane areas over the root's; a leaf lane
  // counts once per packet it holds, for the triangle test). The spatial
  // build must beat pre-splitting alone, and the references it adds must be
  // the builder's: pre-splitting's are the same in both.
  PCG32 rng(33, 0x5b1);
  TriangleMesh m = random_long(20000, rng);
  auto cost = [](const MeshAccel& a) {
    double sum = 0;
    for (const detail::BVHWideNode& n : a.bvh().wide_nodes())
      for (int l = 0; l < detail::wide_width; ++l) {
        if (n.count[l] == 0) continue;
        double packets = n.count[l] == detail::BVHWideNode::interior
                             ? 1
                             : double((n.count[l] + triangle_packet_width - 1) / triangle_packet_width);
        sum += packets * double(detail::lane_box(n, l).surface_area());
      }
    return sum / double(a.bounds().surface_area());
  };
  MeshAccel pre(m, with_budget(0.3f)), spatial(m, with_spatial(0.3f));
  INFO("pre-split " << cost(pre) << " (" << pre.reference_count() << " references), spatial " << cost(spatial)
                    << " (" << spatial.reference_count() << ")");
  CHECK(spatial.reference_count() > pre.reference_count());
  CHECK(cost(spatial) < cost(pre));
}

TEST_CASE("a MeshAccel with spatial splits after refit gives the hits of brute force", "[accel][sbvh][refit]") {
  PCG32 rng(34, 0x5b1);
  TriangleMesh m = random_long(1500, rng);
  MeshAccel refitted(m, with_spatial(0.5f));
  CHECK(refitted.reference_count() > m.triangle_count());
  for (Point3f& p : m.positions) p = p + Vector3f{std::sin(p.y), 0.5f * std::cos(p.z), uniform(rng, -1, 1)};
  refitted.refit(m);
  int hits = 0;
  CHECK(compare(m, refitted, 1500, rng, &hits) == "");
  CHECK(hits > 300);
}

TEST_CASE("degenerate input builds with spatial splits", "[accel][sbvh]") {
  PCG32 rng(35, 0x5b1);
  Float nan = std::nanf("");
  // Slivers with zero-area, NaN and infinite triangles among them, and a
  // plane of triangles: built, the bad triangles never hit, the others as
  // brute force finds them.
  TriangleMesh m = random_long(600, rng);
  for (int i = 0; i < 50; ++i) {
    Point3f a{uniform(rng, -10, 10), uniform(rng, -10, 10), uniform(rng, -10, 10)};
    add_tri(m, a, a + Vector3f{20, 0, 0}, a + Vector3f{10, 0, 0});  // zero area
    add_tri(m, a, Point3f{nan, 0, 0}, a + Vector3f{1, 1, 0});
    add_tri(m, a, Point3f{infinity, 0, 0}, a + Vector3f{0, 1, 1});
    // First: the triangle's box then starts from the NaN and keeps it (a
    // failed comparison keeps the box's bound), a NaN box that the node's
    // finite box hides. Second (above): the box skips the NaN.
    add_tri(m, Point3f{nan, 0, 0}, a, a + Vector3f{15, 1, 0});
    add_tri(m, Point3f{-infinity, a.y, a.z}, a, a + Vector3f{0, 12, 1});
  }
  MeshAccel acc(m, with_spatial(0.5f, 0.0f));
  int hits = 0;
  CHECK(compare(m, acc, 1500, rng, &hits) == "");
  CHECK(hits > 200);
  // A million references of one triangle is the BVH tests' case; here 20,000
  // copies of one sliver and a plane of slivers.
  TriangleMesh copies;
  for (int i = 0; i < 20000; ++i) add_tri(copies, {0, 0, 0}, {30, 20, 1}, {30.1f, 20, 1});
  MeshAccel c(copies, with_spatial(0.5f, 0.0f));
  // No split separates equal references: the builder halves them (median
  // splits) and adds none; the tree stays smaller than its references.
  const size_t copies_pre = MeshAccel(copies, with_budget(0.5f)).reference_count();
  INFO(c.reference_count() << " references, " << copies_pre << " after pre-splitting, " << c.bvh().wide_node_count()
                           << " wide nodes");
  CHECK(c.reference_count() == copies_pre);
  CHECK(c.bvh().wide_node_count() < c.reference_count());
  Float t = infinity;
  TriangleHit h{};
  uint32_t tri = 0;
  CHECK(c.intersect({15, 9.985f, -5}, {0, 0, 1}, &t, &h, &tri));  // (y from 9.967 to 10 at x = 15)
  TriangleMesh plane;  // slivers in the plane z = 0.3 x + 0.2 y
  auto on_plane = [](Float x, Float y) { return Point3f{x, y, 0.3f * x + 0.2f * y}; };
  for (int i = 0; i < 2000; ++i) {
    Float x = uniform(rng, -10, 10), y = uniform(rng, -10, 10);
    add_tri(plane, on_plane(x, y), on_plane(x + uniform(rng, 5, 20), y + uniform(rng, 5, 20)), on_plane(x + 0.1f, y));
  }
  MeshAccel p(plane, with_spatial(0.5f, 0.0f));
  hits = 0;
  CHECK(compare(plane, p, 1000, rng, &hits) == "");
  CHECK(hits > 100);
}

TEST_CASE("a negative or NaN spatial_alpha is refused", "[accel][sbvh]") {
  PCG32 rng(36, 0x5b1);
  TriangleMesh m = random_long(10, rng);
  for (float alpha : {-1.0f, std::nanf(""), infinity}) CHECK_THROWS_AS(MeshAccel(m, with_spatial(0.3f, alpha)), Error);
  CHECK_NOTHROW(MeshAccel(TriangleMesh{}, with_spatial(0.3f)));
  CHECK_NOTHROW(MeshAccel(m, with_spatial(0.0f)));  // no budget: object splits only
  // No builder named: object splits only, whatever spatial_alpha says.
  BVHBuildOptions off = with_spatial(0.3f, -1.0f);
  off.spatial_splits = nullptr;
  CHECK_NOTHROW(MeshAccel(m, off));
}

TEST_CASE("BVH::from_binary_tree refuses what is not a tree", "[accel][sbvh]") {
  auto leaf = [](uint32_t first, uint32_t count) {
    BVHNode n{};
    n.bmax[0] = n.bmax[1] = n.bmax[2] = 1;
    n.offset = first;
    n.count = count;
    return n;
  };
  auto inner = [](uint32_t second) {
    BVHNode n{};
    n.bmax[0] = n.bmax[1] = n.bmax[2] = 1;
    n.offset = second;
    n.count = 0;
    return n;
  };
  std::vector<uint32_t> prims{0, 1, 2};
  // A good one: a root over two leaves.
  BVH ok = BVH::from_binary_tree({inner(2), leaf(0, 2), leaf(2, 1)}, prims);
  CHECK(ok.wide_node_count() == 1);
  CHECK(ok.prims() == prims);
  auto refused = [&](std::vector<BVHNode> nodes, const char* what) {
    INFO(what);
    CHECK_THROWS_AS(BVH::from_binary_tree(std::move(nodes), prims), Error);
  };
  refused({inner(7), leaf(0, 2), leaf(2, 1)}, "second child out of range");
  refused({inner(1), leaf(0, 2)}, "both children the same node");
  refused({inner(2), leaf(0, 2), leaf(2, 5)}, "a leaf past the primitives");
  refused({inner(2), leaf(0, 2), leaf(2, 1), leaf(0, 1)}, "a node outside the tree");
  refused({inner(2), inner(0), leaf(0, 1)}, "a cycle");
  refused({inner(1)}, "first child past the end");
  refused({inner(2), leaf(0, 2), leaf(1, 2)}, "an entry in two leaves");
  refused({inner(2), leaf(0, 1), leaf(2, 1)}, "an entry in no leaf");
  refused({inner(2), leaf(0, 2), leaf(UINT32_MAX, 2)}, "a leaf whose end wraps past 2^32");
  {
    // Padded to blocks of 2^30, four leaves would need 2^32 entries.
    BVHBuildOptions huge_blocks;
    huge_blocks.leaf_block = 1 << 30;
    std::vector<uint32_t> four{0, 1, 2, 3};
    CHECK_THROWS_AS(BVH::from_binary_tree({inner(4), inner(3), leaf(0, 1), leaf(1, 1), inner(6), leaf(2, 1), leaf(3, 1)},
                                          four, huge_blocks),
                    Error);
    CHECK_NOTHROW(BVH::from_binary_tree({inner(4), inner(3), leaf(0, 1), leaf(1, 1), inner(6), leaf(2, 1), leaf(3, 1)},
                                        four));
  }
  // A caterpillar: each inner node's first child a leaf, its second the next
  // inner node, the last leaf at depth `levels`. Traversal's stack holds 80
  // levels (Builder::max_sah_depth + 32): 80 are taken, 81 refused.
  auto caterpillar = [&](int levels) {
    std::vector<BVHNode> t;
    for (int i = 0; i < levels; ++i) {
      t.push_back(inner(uint32_t(t.size()) + 2));
      t.push_back(leaf(uint32_t(i), 1));
    }
    t.push_back(leaf(uint32_t(levels), 1));
    return t;
  };
  auto entries = [](int levels) {
    std::vector<uint32_t> e(size_t(levels) + 1);
    for (size_t i = 0; i < e.size(); ++i) e[i] = uint32_t(i);
    return e;
  };
  CHECK_NOTHROW(BVH::from_binary_tree(caterpillar(80), entries(80)));
  CHECK_THROWS_AS(BVH::from_binary_tree(caterpillar(81), entries(81)), Error);
}

TEST_CASE("spatial-split references cover their triangles", "[accel][sbvh]") {
  // Every reference box, from the builder's cuts on top of pre-splitting's,
  // inside its triangle's box; every point sampled on a triangle (vertices,
  // edges, inside) inside one of its references. alpha 0 and a large budget:
  // many cuts, at every depth.
  PCG32 rng(37, 0x5b1);
  TriangleMesh m = random_long(1500, rng);
  TriangleMesh fan = sliver_fan(600, rng);
  TriangleMesh ground = ground_and_clutter(800, rng);
  for (const TriangleMesh* mesh : {&m, &fan, &ground})
    for (float budget : {0.0f, 0.3f, 3.0f}) {
      size_t n = mesh->triangle_count();
      auto vertices = [&](size_t i, Point3f* v) {
        for (int k = 0; k < 3; ++k) v[k] = vtx(*mesh, uint32_t(i), k);
      };
      BVHBuildOptions o = with_spatial(3.0f, 0.0f, 1);
      o.leaf_block = triangle_packet_width;
      detail::SplitReferences pre = refs_of(*mesh, budget, 1);
      detail::SpatialBVH s = detail::build_spatial_bvh(n, vertices, o, &pre, true);
      INFO("pre-split budget " << budget << ": " << pre.size() << " references before the build, "
                               << s.ref_box.size() << " after");
      REQUIRE(s.ref_box.size() == s.ref_tri.size());
      // The builder cut (the fan's whole wedges, all meeting at its centre,
      // give no plane that pays by the SAH: it cuts them once pre-split).
      if (mesh != &fan || budget > 0) CHECK(s.ref_box.size() > std::max(n, pre.size()));
      Cover c = cover(*mesh, s.ref_box, s.ref_tri, rng);
      // Each extra reference adds a cut plane across its triangle: 3 points at least.
      INFO(c.plane_points << " points on cut planes");
      CHECK(c.plane_points >= 3 * (s.ref_box.size() - n));
      CHECK(c.missing == 0);
      CHECK(c.outside == 0);
      CHECK(c.uncovered == 0);
      // The references in leaf order are the BVH's, a triangle's first its own number.
      REQUIRE(s.bvh.prims().size() >= s.ref_tri.size());
      CHECK(s.extra_tri.size() == s.ref_tri.size() - n);
    }
}

}  // namespace presplit_test
