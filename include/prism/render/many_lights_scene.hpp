// prism/render/many_lights_scene.hpp — a test scene with many small lights:
// `count` emitters of random colours and powers (a fixed seed) hovering over a
// diffuse floor with a few boxes casting shadows. Even-numbered emitters are
// small spheres, odd-numbered ones single one-sided triangles facing down at
// a random tilt, so the scene has exactly `count` lights, some of which face
// away from much of the floor. The total power does not depend on `count`, so
// images with different counts are alike in brightness. Used by the light
// selection tests and bench/light_bench.cpp.
#pragma once
#include <cmath>
#include "prism/cameras/perspective.hpp"
#include "prism/render/default_scene.hpp"
#include "prism/render/scene.hpp"
#include "prism/sampling/pcg32.hpp"

namespace prism {

struct ManyLightsOptions {
  int count = 1000;
  uint64_t seed = 7;
  Float total_scale = 64;  // the emission scales sum to about this much
};

template <class S, class Set>
void build_many_lights_scene(Scene<S, Set>& scene, const ManyLightsOptions& opt = {}) {
  if (opt.count < 0) throw Error("many-lights scene: the light count must be non-negative");
  using material = typename Scene<S, Set>::material_type;
  const material floor_m = DiffuseMaterial{RGB(0.5f)};
  const material box_m = DiffuseMaterial{RGB(0.6f, 0.55f, 0.5f)};
  const material black_m = DiffuseMaterial{RGB(0.f)};
  uint32_t floor_id = scene.add_material(floor_m);
  uint32_t box_id = scene.add_material(box_m);
  uint32_t black = scene.add_material(black_m);
  TriangleMesh floor;
  append_quad(floor, {-12, 0, -12}, {0, 0, 24}, {24, 0, 0});  // facing +y
  scene.add_mesh_instance(std::move(floor), floor_id);
  PCG32 rng(opt.seed, 0x5eed);
  auto uniform = [&](Float a, Float b) { return a + (b - a) * rng.next_float(); };
  for (int i = 0; i < 8; ++i) {
    Float x = uniform(-4, 4), z = uniform(-4, 4), s = uniform(0.2f, 0.5f), h = uniform(0.2f, 0.8f);
    scene.add_mesh_instance(make_box({x - s, 0, z - s}, {x + s, h, z + s}), box_id);
  }
  const Float per_light = opt.total_scale / Float(std::max(1, opt.count));
  for (int i = 0; i < opt.count; ++i) {
    Point3f c{uniform(-5, 5), uniform(0.9f, 2.2f), uniform(-5, 5)};
    // A colour of random hue and a power spread over two decades.
    RGB colour(uniform(0.2f, 1), uniform(0.2f, 1), uniform(0.2f, 1));
    Float scale = per_light * std::exp(uniform(std::log(0.1f), std::log(10.f))) * 4;
    if (i % 2 == 0) {
      Float r = uniform(0.03f, 0.07f);
      // Emission scaled so that a sphere and a triangle of the same scale carry about the same power.
      scene.add_sphere(Sphere{c, r}, black, AreaEmission(colour, scale * 0.02f / (r * r), false));
    } else {
      // A triangle of side about 0.25 whose normal points down, tilted by up to 70 degrees.
      Float tilt = uniform(0, radians(70.f)), turn = uniform(0, 2 * pi);
      Vector3f n{std::sin(tilt) * std::cos(turn), -std::cos(tilt), std::sin(tilt) * std::sin(turn)};
      Frame f = Frame::from_z(n);
      Float a = uniform(0.18f, 0.3f);
      Point3f p[3];
      for (int k = 0; k < 3; ++k) {
        Float ang = Float(k) * 2 * pi / 3;
        p[k] = c + f.from_local(Vector3f{a * std::cos(ang), a * std::sin(ang), 0}) * Float(0.577f);
      }
      TriangleMesh m;
      m.positions = {p[0], p[1], p[2]};
      // Winding so that the front side (p1 - p0) x (p2 - p0) faces along n.
      if (dot(cross(p[1] - p[0], p[2] - p[0]), n) < 0) std::swap(m.positions[1], m.positions[2]);
      m.indices = {0, 1, 2};
      scene.add_mesh_instance(std::move(m), black, AreaEmission(colour, scale * 3.f, false));
    }
  }
}

// A view of the floor from above and in front.
inline PerspectiveCamera many_lights_camera(int width, int height) {
  return PerspectiveCamera(look_at_camera_to_world({0, 9, 7}, {0, 0, -0.5f}, {0, 1, 0}), radians(45.f), width,
                           height);
}

}  // namespace prism
