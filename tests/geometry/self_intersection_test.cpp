// Rays spawned off a surface (SurfaceInteraction::spawn_ray, which starts them
// just outside the hit point's error bound with offset_ray_origin) never re-hit
// that surface, at scales from 1e-4 to 1e6: primitives of size ~s placed at
// distances ~s from the origin, random orientations, thousands of rays per
// scale. The real pipeline is used throughout: SceneAccel::intersect finds the
// hit, SceneAccel::interaction builds the SurfaceInteraction (including the
// object-to-world transform of a non-identity instance), and the spawned rays
// go back through SceneAccel::intersect and ::occluded.
//
// Triangles (one per scene, so any hit is a re-hit): reflected, straight-through,
// refracted and uniformly random directions (grazing ones included) must hit
// nothing. Spheres (closed and convex): rays leaving the surface outwards must
// hit nothing; rays entering it (straight or refracted) must hit the far side,
// at least half the chord length away, and from there internal reflections
// hit the far side again while rays leaving it hit nothing.
#include <catch2/catch.hpp>

#include <cmath>
#include <optional>
#include <sstream>
#include <string>

#include "prism/accel/scene_accel.hpp"
#include "prism/sampling/pcg32.hpp"
#include "prism/sampling/warps.hpp"

using namespace prism;

namespace {

const double kScales[] = {1e-4, 1e-2, 1, 1e2, 1e4, 1e6};

Float uniform(PCG32& rng, double a, double b) { return Float(a + (b - a) * double(rng.next_float())); }
Vector3f random_unit(PCG32& rng) {
  Float a = rng.next_float();
  return sample_uniform_sphere({a, rng.next_float()});
}

// Direction lengths from 2^-10 to 2^10: spawned rays need not be unit length.
Float random_length(PCG32& rng) { return Float(std::exp2(-10 + 20 * double(rng.next_float()))); }

Vector3f reflect(const Vector3f& wo, const Vector3f& n) { return -wo + n * (2 * dot(wo, n)); }

// Refraction of wo (pointing away from the surface) through a surface with
// normal n and relative index eta (inside over outside); nullopt on total
// internal reflection.
std::optional<Vector3f> refract(const Vector3f& wo, Vector3f n, Float eta) {
  Float cos_i = dot(n, wo);
  if (cos_i < 0) {
    eta = 1 / eta;
    cos_i = -cos_i;
    n = -n;
  }
  Float sin2_t = std::max(Float(0), 1 - cos_i * cos_i) / (eta * eta);
  if (sin2_t >= 1) return std::nullopt;
  Float cos_t = std::sqrt(1 - sin2_t);
  return normalize(-wo / eta + n * (cos_i / eta - cos_t));
}

std::string describe(const char* what, double scale, const Ray& r, const SurfaceInteraction& si) {
  std::ostringstream s;
  s.precision(9);
  s << what << " at scale " << scale << ": p=(" << si.p.x << "," << si.p.y << "," << si.p.z << ") err=("
    << si.p_error.x << "," << si.p_error.y << "," << si.p_error.z << ") n=(" << si.n.x << "," << si.n.y << ","
    << si.n.z << ") o=(" << r.o.x << "," << r.o.y << "," << r.o.z << ") d=(" << r.d.x << "," << r.d.y << ","
    << r.d.z << ")";
  return s.str();
}

struct Counts {
  size_t spawned = 0, rehits = 0, primary_misses = 0;
  std::string first_failure;
  void fail(std::string msg) {
    ++rehits;
    if (first_failure.empty()) first_failure = std::move(msg);
  }
};

// A triangle of size ~1 around the origin, random orientation, not too thin.
std::array<Point3f, 3> unit_triangle(PCG32& rng) {
  Frame f = Frame::from_z(random_unit(rng));
  std::array<Point3f, 3> p;
  for (int k = 0; k < 3; ++k) {
    double a = 2 * pi * k / 3 + double(uniform(rng, -0.5, 0.5));
    Float r = uniform(rng, 0.5, 1);
    p[size_t(k)] = Point3f(f.from_local({r * Float(std::cos(a)), r * Float(std::sin(a)), 0}));
  }
  return p;
}

void triangle_trials(double s, bool instanced, PCG32& rng, Counts* c) {
  const int kTriangles = 100, kTargets = 25;
  for (int tri = 0; tri < kTriangles; ++tri) {
    std::array<Point3f, 3> q = unit_triangle(rng);
    Vector3f center = random_unit(rng) * Float(s * double(uniform(rng, 0.5, 3)));
    TriangleMesh mesh;
    Transform to_world;
    if (instanced) {
      // Object space: the unit triangle; world: rotated, scaled ~s (non-uniformly), moved ~s away.
      to_world = translate(center) * rotate(uniform(rng, -3, 3), random_unit(rng)) *
                 scale(Float(s) * uniform(rng, 0.5, 2), Float(s) * uniform(rng, 0.5, 2), Float(s) * uniform(rng, 0.5, 2));
      mesh.positions = {q[0], q[1], q[2]};
    } else {
      for (const Point3f& p : q) mesh.positions.push_back(Point3f(Vector3f(p) * Float(s) + center));
    }
    mesh.indices = {0, 1, 2};
    std::array<Point3f, 3> w;  // world vertices, for aiming
    for (int k = 0; k < 3; ++k) w[size_t(k)] = to_world(mesh.positions[size_t(k)]);
    Vector3f n_world = normalize(cross(w[1] - w[0], w[2] - w[0]));

    SceneAccel accel;
    uint32_t inst = accel.add_mesh_instance(accel.add_mesh(mesh), to_world);
    accel.build();

    for (int k = 0; k < kTargets; ++k) {
      // A target inside the triangle (barycentrics >= 0.05, uniform), hit from
      // a random side at a non-grazing angle (|cos| >= 0.05) from ~s away.
      std::array<Float, 3> b = sample_uniform_triangle({rng.next_float(), rng.next_float()});
      for (Float& bi : b) bi = 0.05f + 0.85f * bi;
      Point3f target = Point3f(Vector3f(w[0]) * b[0] + Vector3f(w[1]) * b[1] + Vector3f(w[2]) * b[2]);
      Vector3f v;
      do v = random_unit(rng);
      while (std::abs(dot(v, n_world)) < 0.05f);
      Point3f o = target + v * Float(s * double(uniform(rng, 0.5, 4)));
      // Half the rays unnormalised (|d| ~ s): nothing may depend on |d|.
      Ray ray{o, k % 2 ? target - o : normalize(target - o), 0};
      std::optional<Hit> h = accel.intersect(ray);
      if (!h) {
        ++c->primary_misses;
        continue;
      }
      SurfaceInteraction si = accel.interaction(ray, *h);
      REQUIRE(si.instance == inst);
      REQUIRE(si.primitive == 0);
      Vector3f n(si.n);
      Vector3f dirs[4] = {reflect(si.wo, n), -si.wo, -si.wo, random_unit(rng)};
      if (auto t = refract(si.wo, n, 1.5f)) dirs[2] = *t;
      const char* names[4] = {"reflected", "transmitted", "refracted", "random"};
      for (int j = 0; j < 4; ++j) {
        if (dot(dirs[j], n) == 0) continue;
        Ray r = si.spawn_ray(dirs[j] * random_length(rng));
        ++c->spawned;
        if (accel.intersect(r) || accel.occluded(r, infinity))
          c->fail(describe(names[j], s, r, si) + (instanced ? " (instanced)" : ""));
      }
    }
  }
}

void sphere_trials(double s, PCG32& rng, Counts* c) {
  const int kSpheres = 100, kTargets = 25;
  for (int sp = 0; sp < kSpheres; ++sp) {
    Sphere sphere{Point3f(random_unit(rng) * Float(s * double(uniform(rng, 0.5, 3)))), Float(s) * uniform(rng, 0.5, 2)};
    const double radius = sphere.radius;
    SceneAccel accel;
    uint32_t inst = accel.add_sphere(sphere);
    accel.build();

    // Rays from inside: the next hit must be the far side of the sphere.
    auto far_side = [&](const SurfaceInteraction& from, const Vector3f& w, const char* what) -> std::optional<SurfaceInteraction> {
      Ray r = from.spawn_ray(w * random_length(rng));
      ++c->spawned;
      std::optional<Hit> h = accel.intersect(r);
      // The chord through the sphere along w from the surface point.
      double chord = 2 * radius * std::abs(double(dot(normalize(w), Vector3f(from.n))));
      double dist = h ? double(length(r.d)) * double(h->t) : 0;
      if (!h || h->instance != inst || dist < chord / 2) {
        std::ostringstream m;
        m << describe(what, s, r, from) << (h ? " hit at distance " : " missed, chord ") << (h ? dist : chord)
          << " (chord " << chord << ")";
        c->fail(m.str());
        return std::nullopt;
      }
      return accel.interaction(r, *h);
    };
    // Rays leaving the surface outwards must hit nothing.
    auto escapes = [&](const SurfaceInteraction& from, const Vector3f& w, const char* what) {
      if (dot(w, from.n) == 0) return;
      Ray r = from.spawn_ray(w * random_length(rng));
      ++c->spawned;
      if (accel.intersect(r) || accel.occluded(r, infinity)) c->fail(describe(what, s, r, from));
    };

    for (int k = 0; k < kTargets; ++k) {
      // From 1.5 to 6 radii away, aimed within 0.95 radii of the centre, so
      // the incidence cosine is at least sqrt(1 - 0.95^2) > 0.3.
      Vector3f v = random_unit(rng);
      Point3f o = sphere.center + v * Float(radius * double(uniform(rng, 1.5, 6)));
      Frame f = Frame::from_z(v);
      Float phi = uniform(rng, 0, 2 * pi), rr = Float(0.95 * radius * std::sqrt(double(rng.next_float())));
      Point3f aim = sphere.center + f.from_local({rr * std::cos(phi), rr * std::sin(phi), 0});
      Ray ray{o, k % 2 ? aim - o : normalize(aim - o), 0};
      std::optional<Hit> h = accel.intersect(ray);
      if (!h) {
        ++c->primary_misses;
        continue;
      }
      SurfaceInteraction si = accel.interaction(ray, *h);
      Vector3f n(si.n);

      escapes(si, reflect(si.wo, n), "reflected outside");
      Vector3f w = random_unit(rng);
      escapes(si, dot(w, n) < 0 ? -w : w, "random outward");

      const Vector3f inward[2] = {-si.wo, refract(si.wo, n, 1.5f).value()};
      const char* names[2] = {"transmitted inward", "refracted inward"};
      for (int j = 0; j < 2; ++j) {
        std::optional<SurfaceInteraction> far = far_side(si, inward[j], names[j]);
        if (!far) continue;
        Vector3f n2(far->n);
        // Internal reflection stays inside: far side again.
        far_side(*far, reflect(far->wo, n2), "reflected inside");
        // Leaving: straight on, and refracted out when not totally reflected.
        escapes(*far, -far->wo, "transmitted outward");
        if (auto t = refract(far->wo, n2, 1.5f)) escapes(*far, *t, "refracted outward");
      }
    }
  }
}

}  // namespace

TEST_CASE("spawned rays never re-hit their own triangle at any scale", "[geometry][self_intersection]") {
  for (double s : kScales) {
    for (bool instanced : {false, true}) {
      PCG32 rng(uint64_t(std::log10(s) + 10) * 2 + (instanced ? 1 : 0), 0x5e1f);
      Counts c;
      triangle_trials(s, instanced, rng, &c);
      INFO("scale " << s << (instanced ? " (instanced, non-identity transform)" : " (world space)") << ": "
                    << c.spawned << " spawned rays, " << c.rehits << " re-hits, " << c.primary_misses
                    << " primary misses; first failure: " << c.first_failure);
      CHECK(c.spawned >= 4000);
      CHECK(c.rehits == 0);
      CHECK(c.primary_misses == 0);
    }
  }
}

TEST_CASE("spawned rays leave a sphere or reach its far side at any scale", "[geometry][self_intersection]") {
  for (double s : kScales) {
    PCG32 rng(uint64_t(std::log10(s) + 10), 0x5b4e);
    Counts c;
    sphere_trials(s, rng, &c);
    INFO("scale " << s << ": " << c.spawned << " spawned rays, " << c.rehits << " failures, " << c.primary_misses
                  << " primary misses; first failure: " << c.first_failure);
    CHECK(c.spawned >= 4000);
    CHECK(c.rehits == 0);
    CHECK(c.primary_misses == 0);
  }
}
