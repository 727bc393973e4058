// Deforming meshes (accel/deforming_mesh.hpp): SceneAccel finds exactly the
// hit that testing every triangle at the ray's time finds, the triangle's
// vertices blended between the two keys around that time as the test writes
// it here from the definition (keys evenly spaced over [time0, time1],
// straight-line motion between them); for 2, 3 and 5 keys, still, transformed
// and moving instances; occluded() agrees; the interaction lies on the
// triangle at that time with the blended normal; bad keys throw
// (tests/render/motion_blur_test.cpp renders one, and refuses one that emits).
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "prism/accel/scene_accel.hpp"

#include "support/random.hpp"

namespace deforming_mesh_test {

using namespace prism;

namespace {

using test::random_unit;
using test::uniform;

// A blob of separate triangles, every vertex wandering independently from
// key to key (a motion no rigid transform describes).
struct Blob {
  TriangleMesh mesh;
  VertexMotion motion;
};

Blob random_blob(PCG32& rng, int triangles, int keys, Float wander, Float time0 = 0.1f, Float time1 = 0.9f) {
  Blob b;
  for (int i = 0; i < triangles; ++i) {
    Point3f c = Point3f{0, 0, 0} + random_unit(rng) * Float(0.8);
    for (int j = 0; j < 3; ++j) {
      b.mesh.positions.push_back(c + random_unit(rng) * Float(0.25));
      b.mesh.normals.push_back(Normal3f(random_unit(rng)));
      b.mesh.indices.push_back(uint32_t(b.mesh.positions.size() - 1));
    }
  }
  b.motion.time0 = time0;
  b.motion.time1 = time1;
  for (int k = 0; k < keys; ++k) {
    std::vector<Point3f> p = b.mesh.positions;
    std::vector<Normal3f> n = b.mesh.normals;
    if (k > 0)
      for (size_t v = 0; v < p.size(); ++v) {
        p[v] = b.motion.positions[size_t(k - 1)][v] + random_unit(rng) * wander;
        n[v] = Normal3f(random_unit(rng));
      }
    b.motion.positions.push_back(std::move(p));
    b.motion.normals.push_back(std::move(n));
  }
  return b;
}

struct World {
  SceneAccel accel;
  std::vector<Blob> blobs;  // per mesh
};

// The two meshes deform over different intervals: [0.1, 0.45] and [0.5, 0.95].
// Without `moving`, no instance moves: only the meshes deform.
World make_world(int keys, int motion_segments = 0, int slices = 0, bool moving = true) {
  PCG32 rng(uint64_t(keys), 17);
  World w;
  for (int m = 0; m < 2; ++m) {
    w.blobs.push_back(random_blob(rng, 50, keys, 0.3f, m == 0 ? 0.1f : 0.5f, m == 0 ? 0.45f : 0.95f));
    w.accel.add_deforming_mesh(w.blobs.back().mesh, w.blobs.back().motion);
  }
  w.accel.add_mesh_instance(0);  // identity
  for (int i = 0; i < 12; ++i) {
    Vector3f p{uniform(rng, -5, 5), uniform(rng, -5, 5), uniform(rng, -5, 5)};
    TransformKey k0 = TransformKey::trs(p, Quaternion::from_axis_angle(random_unit(rng), uniform(rng, 0, 6)));
    if (i % 2 == 0 || !moving) {
      w.accel.add_mesh_instance(uint32_t(i % 3 == 0), AnimatedTransform(k0, k0, 0, 1).at(0));
    } else {  // deforming and moving
      TransformKey k1 = k0;
      k1.translation += random_unit(rng) * uniform(rng, 0, 2);
      w.accel.add_mesh_instance(uint32_t(i % 3 == 0), AnimatedTransform(k0, k1, 0, 1));
    }
  }
  BVHBuildOptions opt;
  opt.motion_segments = motion_segments;
  opt.deformation_slices = slices;
  w.accel.build(opt);
  return w;
}

// Triangle t of blob b at `time`, written from the definition.
std::array<Point3f, 3> triangle_at(const Blob& b, uint32_t t, Float time) {
  const VertexMotion& m = b.motion;
  const int segments = int(m.positions.size()) - 1;
  Float u = std::clamp((time - m.time0) / (m.time1 - m.time0), Float(0), Float(1)) * Float(segments);
  int k = std::min(int(std::floor(u)), segments - 1);
  Float f = u - Float(k);
  std::array<Point3f, 3> p;
  for (int j = 0; j < 3; ++j) {
    uint32_t v = b.mesh.indices[3 * t + uint32_t(j)];
    const Point3f &a = m.positions[size_t(k)][v], &c = m.positions[size_t(k) + 1][v];
    p[size_t(j)] = Point3f(a.x + f * (c.x - a.x), a.y + f * (c.y - a.y), a.z + f * (c.z - a.z));
  }
  return p;
}

std::optional<Hit> brute_force(const World& w, const Ray& ray) {
  std::optional<Hit> best;
  Float t_max = infinity;
  for (size_t i = 0; i < w.accel.instances().size(); ++i) {
    const Instance& in = w.accel.instances()[i];
    const Blob& b = w.blobs[in.geometry];
    // An untransformed instance meets the world ray itself, as SceneAccel does.
    Float dt = 0;
    Ray r = in.identity ? ray : transform_ray(inverse(w.accel.instance_transform(in, ray.time)), ray, &dt);
    RayTrianglePrecomp pc(r.d);
    for (uint32_t t = 0; t < b.mesh.triangle_count(); ++t) {
      auto p = triangle_at(b, t, ray.time);
      Float t_obj = t_max - dt;
      auto h = intersect_triangle(r.o, pc, t_obj, p[0], p[1], p[2]);
      if (!h) continue;
      t_max = h->t + dt;
      best = Hit{t_max, h->b0, h->b1, h->b2, uint32_t(i), t};
    }
  }
  return best;
}

}  // namespace

// Configurations: key counts; one top-level tree with nothing but the
// meshes moving (their different intervals must both be covered by it);
// eleven slices per interval (slice ends that f * slices rounds across).
TEST_CASE("deforming meshes: closest hit equals brute force at every time and key count", "[accel][motion][deform]") {
  struct Config {
    int keys, segments, slices;
    bool moving;
  };
  for (Config c : {Config{2, 0, 0, true}, Config{3, 0, 0, true}, Config{5, 0, 0, true}, Config{3, 1, 0, false},
                   Config{3, 3, 11, true}}) {
    const int keys = c.keys;
    World w = make_world(keys, c.segments, c.slices, c.moving);
    REQUIRE(w.accel.has_motion());
    REQUIRE(w.accel.instances()[0].kind == Instance::Kind::deforming_mesh);
    PCG32 rng(uint64_t(keys + 10 * c.segments + 100 * c.slices), 5);
    // Times on the boundaries of top-level segments, keys and slices, and
    // an ulp either side of them.
    std::vector<Float> edges;
    for (Float e : {0.f, 0.1f, 0.25f, 0.275f, 0.45f, 0.5f, 0.725f, 0.75f, 0.95f, 1.f, 0.1f + 0.35f / 11, 0.5f + 0.45f * 6 / 11})
      for (Float t : {std::nextafter(e, -1.f), e, std::nextafter(e, 2.f)}) edges.push_back(t);
    int hits = 0, mismatches = 0, occl_mismatches = 0;
    for (int k = 0; k < 3000; ++k) {
      Ray ray;
      // outside [time0, time1] clamps
      ray.time = k % 4 == 3 ? edges[rng.next_u32() % edges.size()] : uniform(rng, -0.1f, 1.1f);
      ray.o = Point3f{uniform(rng, -7, 7), uniform(rng, -7, 7), uniform(rng, -7, 7)};
      if (k % 2 == 0) {
        // Aim at a point of a random triangle where it is at this time.
        size_t i = rng.next_u32() % w.accel.instances().size();
        const Instance& in = w.accel.instances()[i];
        uint32_t t = rng.next_u32() % uint32_t(w.blobs[in.geometry].mesh.triangle_count());
        auto p = triangle_at(w.blobs[in.geometry], t, ray.time);
        Point3f c = p[0] * Float(0.4) + Vector3f(p[1]) * Float(0.3) + Vector3f(p[2]) * Float(0.3);
        ray.d = normalize(w.accel.instance_transform(in, ray.time)(c) - ray.o);
      } else {
        ray.d = random_unit(rng);
      }
      auto expect = brute_force(w, ray);
      auto got = w.accel.intersect(ray);
      if (expect) ++hits;
      bool same = expect.has_value() == got.has_value() &&
                  (!expect || (expect->t == got->t && expect->instance == got->instance &&
                               expect->primitive == got->primitive));
      if (!same) ++mismatches;
      Float t_shadow = expect ? expect->t * Float(1.5) : Float(100);
      if (w.accel.occluded(ray, t_shadow) != expect.has_value()) ++occl_mismatches;
    }
    INFO(keys << " keys, " << c.segments << " top-level segments, " << c.slices << " slices: " << hits
              << " hits of 3000 rays");
    CHECK(hits > 1200);
    CHECK(mismatches == 0);
    CHECK(occl_mismatches == 0);
  }
}

// Two triangles that travel far, over different intervals: B slides 5
// units along y over [0.5, 0.95], then A 5 units along x over [0.1, 0.45]
// (added in that order; B starts 10 units from A). At every time a ray straight at each one's
// centroid meets it, whatever the number of top-level trees.
TEST_CASE("meshes deforming over different intervals are each found over their own", "[accel][motion][deform]") {
  for (int segments : {0, 1, 3}) {
    SceneAccel accel;
    TriangleMesh tri;
    tri.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
    tri.indices = {0, 1, 2};
    auto keyed = [&](Float t0, Float t1, Vector3f start, Vector3f travel) {
      VertexMotion m;
      m.time0 = t0;
      m.time1 = t1;
      for (int k = 0; k < 3; ++k) {
        m.positions.push_back(tri.positions);
        for (auto& p : m.positions.back()) p += start + travel * (Float(k) / 2);
      }
      return m;
    };
    // B starts 10 units along x from A: they never overlap.
    VertexMotion mb = keyed(0.5f, 0.95f, {10, 0, 0}, {0, 5, 0}), ma = keyed(0.1f, 0.45f, {0, 0, 0}, {5, 0, 0});
    accel.add_mesh_instance(accel.add_deforming_mesh(tri, mb));
    accel.add_mesh_instance(accel.add_deforming_mesh(tri, ma));
    BVHBuildOptions opt;
    opt.motion_segments = segments;
    accel.build(opt);
    int missed = 0;
    for (int i = 0; i <= 100; ++i) {
      const Float time = Float(i) / 100;
      for (int m = 0; m < 2; ++m) {
        const VertexMotion& vm = m == 0 ? mb : ma;
        Float u = std::clamp((time - vm.time0) / (vm.time1 - vm.time0), Float(0), Float(1));
        Vector3f travel = m == 0 ? Vector3f(0, 5, 0) : Vector3f(5, 0, 0);
        Point3f c = Point3f(Float(1) / 3, Float(1) / 3, 0) + Vector3f(m == 0 ? 10 : 0, 0, 0) + travel * u;
        auto h = accel.intersect(Ray{c - Vector3f(0, 0, 5), {0, 0, 1}, time});
        if (!h || h->instance != uint32_t(m)) ++missed;
      }
    }
    INFO(segments << " top-level trees");
    CHECK(missed == 0);
  }
}

TEST_CASE("a deforming hit lies on the triangle at the ray's time, with the blended normal", "[accel][motion][deform]") {
  World w = make_world(3);
  PCG32 rng(3, 3);
  int checked = 0;
  for (int k = 0; k < 6000; ++k) {
    Ray ray{{uniform(rng, -7, 7), uniform(rng, -7, 7), uniform(rng, -7, 7)}, random_unit(rng), uniform(rng, 0, 1)};
    auto h = w.accel.intersect(ray);
    if (!h) continue;
    SurfaceInteraction si = w.accel.interaction(ray, *h);
    const Instance& in = w.accel.instances()[h->instance];
    const Blob& b = w.blobs[in.geometry];
    Transform x = w.accel.instance_transform(in, ray.time);
    auto q = triangle_at(b, h->primitive, ray.time);
    Point3f p0 = x(q[0]), p1 = x(q[1]), p2 = x(q[2]);
    Normal3f n(normalize(cross(p1 - p0, p2 - p0)));
    // 1e-4: the corners through the transform and the hit point, each ~10
    // float roundings of coordinates up to ~10 (ulp 9.5e-7).
    CHECK(std::abs(dot(Vector3f(n), si.p - p0)) < 1e-4f);
    CHECK(length(si.p - (ray.o + ray.d * h->t)) < 1e-4f);
    // The shading normal: the keys' normals blended to the time, then
    // interpolated with the barycentrics.
    const VertexMotion& m = b.motion;
    Float u = std::clamp((ray.time - m.time0) / (m.time1 - m.time0), Float(0), Float(1)) * 2;
    size_t s = std::min(size_t(u), size_t(1));
    Float f = u - Float(s);
    Vector3f ns(0, 0, 0);
    Float bary[3] = {h->b0, h->b1, h->b2};
    for (int j = 0; j < 3; ++j) {
      uint32_t v = b.mesh.indices[3 * h->primitive + uint32_t(j)];
      ns += (Vector3f(m.normals[s][v]) * (1 - f) + Vector3f(m.normals[s + 1][v]) * f) * bary[j];
    }
    Vector3f expect_ns(normalize(x(Normal3f(ns))));
    if (length(ns) > 1e-2f) CHECK(length(Vector3f(si.ns) - expect_ns) < 1e-3f);
    ++checked;
  }
  CHECK(checked > 200);
}

TEST_CASE("deforming meshes: bad keys throw", "[accel][motion][deform]") {
  PCG32 rng(4, 4);
  Blob b = random_blob(rng, 4, 2, 0.1f);
  SceneAccel accel;
  auto bad = [&](auto&& change) {
    VertexMotion m = b.motion;
    change(m);
    CHECK_THROWS_AS(accel.add_deforming_mesh(b.mesh, m), Error);
  };
  bad([](VertexMotion& m) { m.positions.pop_back(); });                // one key
  bad([](VertexMotion& m) { m.positions[1].pop_back(); });             // a key too short
  bad([](VertexMotion& m) { m.normals.pop_back(); });                  // normals keyed differently
  bad([](VertexMotion& m) { m.time1 = m.time0; });                     // an empty interval
  bad([](VertexMotion& m) { m.time0 = std::nanf(""); });               // a NaN time
  bad([](VertexMotion& m) { m.positions[1][2].y = infinity; });         // a vertex at infinity
  CHECK_NOTHROW(accel.add_deforming_mesh(b.mesh, b.motion));
}

}  // namespace deforming_mesh_test
