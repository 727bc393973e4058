// The convergence harness's own scenes (issue 8, item 1), built in code: each
// isolates one case where rendering methods differ. All are small (a few
// dozen primitives) and rendered at 64x64 by convergence.cpp.
//
//   tiny_light  a sphere light of radius 0.004 (1e-3 of the 4-unit scene)
//               carrying the power of a radius-0.2 sphere of radiance 20,
//               over a diffuse floor and back wall, with a diffuse, a glossy
//               (GGX alpha 0.05) and a rough (alpha 0.3) metal sphere; a
//               large dim panel overhead (1/40 of the tiny light's power)
//               whose reflection in the glossy sphere is where MIS matters.
//   caustic     a smooth glass sphere (IOR 1.5) and a rough one (alpha 0.1)
//               on a diffuse floor under a small sphere light: the smooth
//               sphere focuses it into a caustic that only the light-traced
//               caustic pass reaches; the rough one into a soft caustic that
//               the camera paths find through glossy transmission.
//   prism       spectral only: a small white lamp behind a slit in a black
//               mask (the front of a closed black lamp house), an N-SF11 prism (apex 60 degrees, near minimum
//               deviation) and a white screen 3 units away that receives the
//               spectrum (about 6 degrees from 440 to 650 nm), with a dim
//               panel overhead so that the room is visible.
//   env_sun     (convergence.cpp) a shared glTF model under the shared HDR
//               plus a distant sun light, over a diffuse ground.
#pragma once
#include <cmath>
#include <prism/prism.hpp>

namespace prism::convergence {

template <class Scene, class M>
uint32_t add_material(Scene& scene, const M& m) {
  const typename Scene::material_type v(m);  // named, not a temporary: a GCC 12 -Wmaybe-uninitialized false positive
  return scene.add_material(v);
}

// A one-sided quad light of size a x b (a along `ea`, b along `eb`) centred at c,
// facing along ea x eb.
inline TriangleMesh centred_quad(Point3f c, Vector3f ea, Vector3f eb) {
  TriangleMesh m;
  append_quad(m, c - ea * Float(0.5) - eb * Float(0.5), ea, eb);
  return m;
}

template <class Scene>
void build_tiny_light_scene(Scene& scene) {
  const uint32_t floor_m = add_material(scene, DiffuseMaterial{RGB(0.5f)});
  const uint32_t wall_m = add_material(scene, DiffuseMaterial{RGB(0.6f, 0.6f, 0.55f)});
  const uint32_t black = add_material(scene, DiffuseMaterial{RGB(0.f)});
  const uint32_t diffuse_ball = add_material(scene, DiffuseMaterial{RGB(0.7f, 0.3f, 0.2f)});
  const uint32_t glossy =
      add_material(scene, ConductorMaterial::from_reflectance(RGB(0.9f, 0.8f, 0.6f), MicrofacetRoughness(0.05f), "glossy"));
  const uint32_t rough =
      add_material(scene, ConductorMaterial::from_reflectance(RGB(0.6f, 0.7f, 0.9f), MicrofacetRoughness(0.3f), "rough"));
  TriangleMesh room;
  append_quad(room, {-2, 0, -2}, {0, 0, 4}, {4, 0, 0});  // floor, normal +y
  scene.add_mesh_instance(std::move(room), floor_m);
  TriangleMesh back;
  append_quad(back, {-2, 0, -1.5f}, {4, 0, 0}, {0, 3, 0});  // back wall, normal +z
  scene.add_mesh_instance(std::move(back), wall_m);
  scene.add_sphere(Sphere{{-0.9f, 0.35f, 0}, 0.35f}, diffuse_ball);
  scene.add_sphere(Sphere{{0, 0.4f, 0.1f}, 0.4f}, glossy);
  scene.add_sphere(Sphere{{0.9f, 0.35f, 0}, 0.35f}, rough);
  // The tiny light: radius 0.004 with the power of radius 0.2 at radiance 20.
  const Float r = 0.004f, Le = 20 * (0.2f / r) * (0.2f / r);
  scene.add_sphere(Sphere{{0.3f, 1.6f, 0.9f}, r}, black, AreaEmission(RGB(1.f, 0.95f, 0.85f), Le));
  // The panel: 2 x 1 at height 2.9, facing down; its power (radiance x area x
  // pi) is 1/40 of the tiny light's (radiance x 4 pi r^2 x pi).
  const Float panel_Le = Le * 4 * pi * r * r / 2 / 40;
  scene.add_mesh_instance(centred_quad({0, 2.9f, 0}, {2, 0, 0}, {0, 0, 1}), black,
                          AreaEmission(RGB(0.8f, 0.9f, 1.f), panel_Le));
}

inline PerspectiveCamera tiny_light_camera(int w, int h) {
  return PerspectiveCamera(look_at_camera_to_world({0, 1.3f, 3.4f}, {0, 0.45f, 0}, {0, 1, 0}), radians(40.f), w, h);
}

template <class Scene>
void build_caustic_scene(Scene& scene) {
  const uint32_t floor_m = add_material(scene, DiffuseMaterial{RGB(0.6f)});
  const uint32_t black = add_material(scene, DiffuseMaterial{RGB(0.f)});
  const uint32_t glass = add_material(scene, DielectricMaterial{IOR(1.5f), "smooth glass"});
  const uint32_t frosted = add_material(scene, DielectricMaterial{IOR(1.5f), "rough glass", MicrofacetRoughness(0.1f)});
  TriangleMesh floor;
  append_quad(floor, {-3, 0, -3}, {0, 0, 6}, {6, 0, 0});
  scene.add_mesh_instance(std::move(floor), floor_m);
  scene.add_sphere(Sphere{{-0.6f, 0.5f, 0}, 0.5f}, glass);
  scene.add_sphere(Sphere{{0.6f, 0.5f, 0}, 0.5f}, frosted);
  scene.add_sphere(Sphere{{0, 2.4f, -0.3f}, 0.05f}, black, AreaEmission(RGB(1.f), 1500.f));
}

inline PerspectiveCamera caustic_camera(int w, int h) {
  return PerspectiveCamera(look_at_camera_to_world({0, 2.0f, 3.0f}, {0, 0.3f, 0.1f}, {0, 1, 0}), radians(38.f), w, h);
}

// The prism's layout in the xz-plane (from a 2D trace of the design): the
// lamp's beam runs along +x at z = 0.06 into the prism centred at the origin
// (side 0.4, turned -34 degrees), which sends 550 nm out at about -67 degrees
// from +x (towards +x, -z) from near (0.11, -0.11); the screen faces back
// along that direction 3 units away.
struct PrismLayout {
  static constexpr Float beam_z = 0.06f, beam_y = 0.5f;
  static constexpr Float exit_x = 0.108f, exit_z = -0.107f, exit_deg = -67.2f, screen_dist = 3.f;
  static Vector3f out_dir() { return {std::cos(radians(exit_deg)), 0, std::sin(radians(exit_deg))}; }
  static Point3f screen_centre() {
    return Point3f{exit_x, beam_y, exit_z} + out_dir() * screen_dist;
  }
};

template <class Scene>
void build_prism_scene(Scene& scene) {
  const uint32_t floor_m = add_material(scene, DiffuseMaterial{RGB(0.35f)});
  const uint32_t screen_m = add_material(scene, DiffuseMaterial{RGB(0.8f)});
  const uint32_t black = add_material(scene, DiffuseMaterial{RGB(0.f)});
  const uint32_t sf11 = add_material(scene, DielectricMaterial{SellmeierIOR::glass("N-SF11"), "SF11 prism"});
  using L = PrismLayout;
  TriangleMesh floor;
  append_quad(floor, {-4, 0, -5}, {0, 0, 9}, {8, 0, 0});
  scene.add_mesh_instance(std::move(floor), floor_m);
  // The lamp: a 0.01 x 0.1 quad facing +x, 0.6 behind the slit.
  const Float zc = L::beam_z, yc = L::beam_y;
  scene.add_mesh_instance(centred_quad({-1.0f, yc, zc}, {0, 0.1f, 0}, {0, 0, 0.01f}), black,
                          AreaEmission(RGB(1.f), 2.0e5f));
  // The lamp house: a black box around the lamp from x = -1.05 to the mask
  // at x = -0.4, whose only opening is a slit 0.02 wide and 0.1 tall in the
  // mask, around the beam.
  const Float xm = -0.4f, xb = -1.05f, sw = 0.01f, sh = 0.05f, hz = 0.3f, hy = 0.25f;
  TriangleMesh house;
  auto mask = [&](Float z0, Float z1, Float y0, Float y1) {
    append_quad(house, {xm, y0, z0}, {0, y1 - y0, 0}, {0, 0, z1 - z0});
  };
  mask(zc - hz, zc - sw, yc - hy, yc + hy);
  mask(zc + sw, zc + hz, yc - hy, yc + hy);
  mask(zc - sw, zc + sw, yc - hy, yc - sh);
  mask(zc - sw, zc + sw, yc + sh, yc + hy);
  append_quad(house, {xb, yc - hy, zc - hz}, {0, 0, 2 * hz}, {0, 2 * hy, 0});     // back
  append_quad(house, {xb, yc - hy, zc - hz}, {xm - xb, 0, 0}, {0, 0, 2 * hz});     // bottom
  append_quad(house, {xb, yc + hy, zc - hz}, {0, 0, 2 * hz}, {xm - xb, 0, 0});     // top
  append_quad(house, {xb, yc - hy, zc - hz}, {0, 2 * hy, 0}, {xm - xb, 0, 0});     // side -z
  append_quad(house, {xb, yc - hy, zc + hz}, {xm - xb, 0, 0}, {0, 2 * hy, 0});     // side +z
  scene.add_mesh_instance(std::move(house), black);
  // The prism.
  const Float side = 0.4f, r = side / std::sqrt(3.f), turn = radians(-34.f);
  Point2f v[3];
  for (int i = 0; i < 3; ++i) {
    Float a = radians(90 + 120 * Float(i)) + turn;
    v[i] = {r * std::cos(a), r * std::sin(a)};
  }
  scene.add_mesh_instance(make_triangular_prism(v[0], v[1], v[2], 0, 1.0f), sf11);
  // The screen: 1.6 wide, 1.4 tall, facing back towards the prism.
  const Vector3f d = L::out_dir(), across{-d.z, 0, d.x};
  Point3f c = L::screen_centre();
  c.y = 0.7f;
  // Front side along -d: the parallelogram's a x b must point along -d.
  Vector3f ea = across * Float(1.6f), eb{0, 1.4f, 0};
  if (dot(cross(ea, eb), d) > 0) ea = -ea;
  scene.add_mesh_instance(centred_quad(c, ea, eb), screen_m);
  // A dim panel overhead so that the room is visible.
  scene.add_mesh_instance(centred_quad({0.5f, 3.0f, -1.5f}, {2, 0, 0}, {0, 0, 2}), black,
                          AreaEmission(RGB(1.f), 0.15f));
}

inline PerspectiveCamera prism_camera(int w, int h) {
  using L = PrismLayout;
  const Vector3f d = L::out_dir(), across{-d.z, 0, d.x};
  Point3f target = L::screen_centre();
  target.y = 0.6f;
  Point3f eye = target - d * Float(2.2f) + across * Float(0.7f);
  eye.y = 1.3f;
  return PerspectiveCamera(look_at_camera_to_world(eye, target, {0, 1, 0}), radians(42.f), w, h);
}

}  // namespace prism::convergence
