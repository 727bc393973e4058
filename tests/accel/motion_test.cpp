// Moving instances: SceneAccel finds exactly the hit that testing every
// triangle of every instance (placed where it is at the ray's time) finds,
// for any number of motion segments; occluded() agrees; the hit lies on the
// world-space triangle at that time; a time outside the motion clamps.
#include <catch2/catch.hpp>

#include <vector>

#include "prism/accel/scene_accel.hpp"
#include "prism/sampling/pcg32.hpp"
#include "prism/sampling/warps.hpp"

#include "support/random.hpp"

namespace motion_test {

using namespace prism;

namespace {

using test::random_unit;
using test::uniform;

TriangleMesh random_blob(PCG32& rng, int triangles) {
  TriangleMesh m;
  for (int i = 0; i < triangles; ++i) {
    Point3f c = Point3f{0, 0, 0} + random_unit(rng) * Float(0.8);
    for (int j = 0; j < 3; ++j) {
      m.positions.push_back(c + random_unit(rng) * Float(0.25));
      m.indices.push_back(uint32_t(m.positions.size() - 1));
    }
  }
  return m;
}

struct World {
  SceneAccel accel;
  std::vector<AnimatedTransform> motion;  // per instance (still ones too)
};

World make_world(int segments) {
  PCG32 rng(1, 99);
  World w;
  uint32_t a = w.accel.add_mesh(random_blob(rng, 60));
  uint32_t b = w.accel.add_mesh(random_blob(rng, 40));
  for (int i = 0; i < 40; ++i) {
    Vector3f p{uniform(rng, -6, 6), uniform(rng, -6, 6), uniform(rng, -6, 6)};
    TransformKey k0 = TransformKey::trs(p, Quaternion::from_axis_angle(random_unit(rng), uniform(rng, 0, 6)),
                                        {uniform(rng, 0.5f, 1.5f), uniform(rng, 0.5f, 1.5f), uniform(rng, 0.5f, 1.5f)});
    TransformKey k1 = k0;
    if (i % 4 != 3) {  // every fourth stays still
      k1.translation += random_unit(rng) * uniform(rng, 0, 4);
      k1.rotation = Quaternion::from_axis_angle(random_unit(rng), uniform(rng, 0, 3));
      k1.stretch[1][1] *= 1.3f;
    }
    // Different intervals: the scene's motion range is their union.
    Float t0 = i % 3 == 0 ? 0.25f : 0, t1 = i % 5 == 0 ? 0.75f : 1;
    AnimatedTransform m(k0, k1, t0, t1);
    w.accel.add_mesh_instance(i % 2 ? a : b, m);
    w.motion.push_back(m);
  }
  BVHBuildOptions opt;
  opt.motion_segments = segments;
  w.accel.build(opt);
  return w;
}

// Every triangle of every instance, in the instance's object space at the
// ray's time, the way SceneAccel transforms rays.
std::optional<Hit> brute_force(const World& w, const Ray& ray) {
  std::optional<Hit> best;
  Float t_max = infinity;
  for (size_t i = 0; i < w.accel.instances().size(); ++i) {
    const Instance& in = w.accel.instances()[i];
    const TriangleMesh& mesh = w.accel.meshes()[in.geometry];
    Float dt;
    Ray r = transform_ray(inverse(w.accel.instance_transform(in, ray.time)), ray, &dt);
    RayTrianglePrecomp pc(r.d);
    for (size_t t = 0; t < mesh.triangle_count(); ++t) {
      Float t_obj = t_max - dt;
      auto h = intersect_triangle(r.o, pc, t_obj, mesh.positions[mesh.indices[3 * t]],
                                  mesh.positions[mesh.indices[3 * t + 1]], mesh.positions[mesh.indices[3 * t + 2]]);
      if (!h) continue;
      t_max = h->t + dt;
      best = Hit{t_max, h->b0, h->b1, h->b2, uint32_t(i), uint32_t(t)};
    }
  }
  return best;
}

}  // namespace

TEST_CASE("moving instances: closest hit equals brute force at every time and segment count", "[accel][motion]") {
  for (int segments : {1, 3, 16}) {
    World w = make_world(segments);
    REQUIRE(w.accel.has_motion());
    CHECK(w.accel.motion_segments() == segments);
    PCG32 rng(uint64_t(segments), 5);
    int hits = 0, mismatches = 0, occl_mismatches = 0;
    for (int k = 0; k < 4000; ++k) {
      Ray ray;
      ray.time = uniform(rng, -0.2f, 1.2f);  // outside the range clamps
      ray.o = Point3f{uniform(rng, -9, 9), uniform(rng, -9, 9), uniform(rng, -9, 9)};
      if (k % 2 == 0) {
        // Aim at a point of a random instance where it is at this time.
        const Instance& in = w.accel.instances()[size_t(rng.next_u32() % w.accel.instances().size())];
        const TriangleMesh& mesh = w.accel.meshes()[in.geometry];
        size_t t = rng.next_u32() % mesh.triangle_count();
        Point3f c = mesh.positions[mesh.indices[3 * t]] * Float(0.4) +
                    Vector3f(mesh.positions[mesh.indices[3 * t + 1]]) * Float(0.3) +
                    Vector3f(mesh.positions[mesh.indices[3 * t + 2]]) * Float(0.3);
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
    INFO("segments " << segments << ": " << hits << " hits of 4000 rays");
    CHECK(hits > 1500);
    CHECK(mismatches == 0);
    CHECK(occl_mismatches == 0);
  }
}

TEST_CASE("a moving hit lies on the world-space triangle at the ray's time", "[accel][motion]") {
  World w = make_world(4);
  PCG32 rng(3, 3);
  int checked = 0;
  for (int k = 0; k < 2000; ++k) {
    Ray ray{{uniform(rng, -9, 9), uniform(rng, -9, 9), uniform(rng, -9, 9)}, random_unit(rng), uniform(rng, 0, 1)};
    auto h = w.accel.intersect(ray);
    if (!h) continue;
    SurfaceInteraction si = w.accel.interaction(ray, *h);
    const Instance& in = w.accel.instances()[h->instance];
    const TriangleMesh& mesh = w.accel.meshes()[in.geometry];
    Transform x = w.accel.instance_transform(in, ray.time);
    Point3f p0 = x(mesh.positions[mesh.indices[3 * h->primitive]]);
    Point3f p1 = x(mesh.positions[mesh.indices[3 * h->primitive + 1]]);
    Point3f p2 = x(mesh.positions[mesh.indices[3 * h->primitive + 2]]);
    Normal3f n(normalize(cross(p1 - p0, p2 - p0)));
    // On the plane of the moved triangle (to rounding) and where the ray is.
    // 1e-4: corners through the interpolated transform and the hit point, each ~10 float roundings of coordinates ≲ 10 (ulp 9.5e-7)
    CHECK(std::abs(dot(Vector3f(n), si.p - p0)) < 1e-4f);
    CHECK(length(si.p - (ray.o + ray.d * h->t)) < 1e-4f);
    CHECK(std::abs(std::abs(dot(Vector3f(n), Vector3f(si.n))) - 1) < 1e-4f);
    CHECK(si.time == ray.time);
    ++checked;
  }
  CHECK(checked > 50);
}

TEST_CASE("a still AnimatedTransform is stored as a plain instance", "[accel][motion]") {
  SceneAccel accel;
  PCG32 rng(2, 2);
  uint32_t m = accel.add_mesh(random_blob(rng, 10));
  accel.add_mesh_instance(m, AnimatedTransform(TransformKey::trs({1, 2, 3}), TransformKey::trs({1, 2, 3}), 0, 1));
  accel.build();
  CHECK_FALSE(accel.has_motion());
  CHECK(accel.instances()[0].motion == -1);
  CHECK(accel.motion_segments() == 1);
}

}  // namespace motion_test
