// prism/render/default_scene.hpp — the built-in default scene: a Cornell box
// (white floor, ceiling and back wall, red left wall, green right wall) lit by
// a square area light under the ceiling, holding a tall rotated box and a
// sphere. The box spans [-1, 1]^3; the camera looks into it along -z.
#pragma once
#include "prism/cameras/perspective.hpp"
#include "prism/render/scene.hpp"

namespace prism {

// Two triangles spanning the parallelogram p, p + a, p + a + b, p + b; the front
// side is that of a x b.
inline void append_quad(TriangleMesh& m, const Point3f& p, const Vector3f& a, const Vector3f& b) {
  uint32_t base = uint32_t(m.positions.size());
  m.positions.insert(m.positions.end(), {p, p + a, p + a + b, p + b});
  m.uvs.insert(m.uvs.end(), {{0, 0}, {1, 0}, {1, 1}, {0, 1}});
  m.indices.insert(m.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
}

// An axis-aligned box with outward-facing triangles.
inline TriangleMesh make_box(const Point3f& lo, const Point3f& hi) {
  TriangleMesh m;
  Vector3f d = hi - lo;
  Vector3f ex{d.x, 0, 0}, ey{0, d.y, 0}, ez{0, 0, d.z};
  append_quad(m, lo, ey, ex);                  // -z
  append_quad(m, lo + ez, ex, ey);             // +z
  append_quad(m, lo, ez, ey);                  // -x
  append_quad(m, lo + ex, ey, ez);             // +x
  append_quad(m, lo, ex, ez);                  // -y
  append_quad(m, lo + ey, ez, ex);             // +y
  return m;
}

struct DefaultSceneDesc {
  Point3f eye{0, 0, 3.75f};
  Point3f target{0, 0, 0};
  Vector3f up{0, 1, 0};
  Float fov_y = radians(39.3f);
};

inline PerspectiveCamera default_camera(int width, int height, const DefaultSceneDesc& d = {}) {
  return PerspectiveCamera(look_at_camera_to_world(d.eye, d.target, d.up), d.fov_y, width, height);
}

// Fills a scene whose BxDF set includes DiffuseBxDF.
template <class Scene>
void build_cornell_box(Scene& scene, const AreaEmission& light = {RGB(17.f, 12.f, 4.f), 1.f, false}) {
  uint32_t white = scene.add_material(DiffuseMaterial{RGB(0.73f, 0.73f, 0.73f)});
  uint32_t red = scene.add_material(DiffuseMaterial{RGB(0.65f, 0.05f, 0.05f)});
  uint32_t green = scene.add_material(DiffuseMaterial{RGB(0.12f, 0.45f, 0.15f)});
  uint32_t black = scene.add_material(DiffuseMaterial{RGB(0.f)});

  TriangleMesh whites;  // floor, ceiling, back wall, facing into the box
  append_quad(whites, {-1, -1, -1}, {0, 0, 2}, {2, 0, 0});   // floor, normal +y
  append_quad(whites, {-1, 1, -1}, {2, 0, 0}, {0, 0, 2});    // ceiling, normal -y
  append_quad(whites, {-1, -1, -1}, {2, 0, 0}, {0, 2, 0});   // back, normal +z
  scene.add_mesh_instance(std::move(whites), white);
  TriangleMesh left;
  append_quad(left, {-1, -1, -1}, {0, 2, 0}, {0, 0, 2});     // normal +x
  scene.add_mesh_instance(std::move(left), red);
  TriangleMesh right;
  append_quad(right, {1, -1, -1}, {0, 0, 2}, {0, 2, 0});     // normal -x
  scene.add_mesh_instance(std::move(right), green);

  // The light: a square just below the ceiling, facing down.
  TriangleMesh lamp;
  append_quad(lamp, {-0.25f, 0.998f, -0.25f}, {0.5f, 0, 0}, {0, 0, 0.5f});
  scene.add_mesh_instance(std::move(lamp), black, light);

  // A tall box, rotated about y, standing on the floor at the back left.
  uint32_t box = scene.add_mesh(make_box({-0.3f, -1, -0.3f}, {0.3f, 0.2f, 0.3f}));
  scene.add_instance(box, white, translate({-0.35f, 0, -0.3f}) * rotate(radians(18), {0, 1, 0}));
  // A sphere on the floor at the front right.
  scene.add_sphere(Sphere{{0.4f, -0.6f, 0.35f}, 0.4f}, white);
}

}  // namespace prism
