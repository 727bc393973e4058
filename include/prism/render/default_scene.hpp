// prism/render/default_scene.hpp — the built-in default scene: a Cornell box
// (white floor, ceiling and back wall, red left wall, green right wall) lit by
// a square area light under the ceiling, holding a tall rotated box and a
// sphere. The box spans [-1, 1]^3; the camera looks into it along -z.
#pragma once
#include "prism/cameras/perspective.hpp"
#include "prism/geometry/shapes.hpp"
#include "prism/render/scene.hpp"

namespace prism {

struct DefaultSceneDesc {
  Point3f eye{0, 0, 3.75f};
  Point3f target{0, 0, 0};
  Vector3f up{0, 1, 0};
  Float fov_y = radians(39.3f);
  Float lens_radius = 0;         // thin lens aperture radius (0: pinhole)
  Float focus_distance = 3.75f;  // distance of the plane in focus (the box's centre)
};

inline PerspectiveCamera default_camera(int width, int height, const DefaultSceneDesc& d = {}) {
  if (!(d.lens_radius >= 0) || !std::isfinite(d.lens_radius))
    throw Error("camera: the aperture radius must be zero or positive, got " + std::to_string(d.lens_radius));
  if (!(d.focus_distance > 0) || !std::isfinite(d.focus_distance))
    throw Error("camera: the focus distance must be positive, got " + std::to_string(d.focus_distance));
  return PerspectiveCamera(look_at_camera_to_world(d.eye, d.target, d.up), d.fov_y, width, height, d.lens_radius,
                           d.focus_distance);
}

struct CornellBoxOptions {
  AreaEmission light{RGB(17.f, 12.f, 4.f), 1.f, false};  // the ceiling light
  // An SF11 glass prism hanging from the ceiling in the beam of a slit lamp on
  // the left wall: the prism spreads the lamp's white light into a spectrum on
  // the back wall (in spectral mode; RGB mode refracts at the d line only).
  bool prism = true;
  AreaEmission slit{RGB(1.f), 80.f, false};
  Float lens_x = -0.62f, lens_radius = 0.3f, prism_turn = -33;
  bool gold_sphere = true;  // false: the sphere is white and diffuse, and no frosted sphere
  Float gold_alpha = 0.2f;  // GGX alpha of the gold sphere
  // Motion blur: the tall box slides 0.3 towards the centre and turns a
  // further 30 degrees between times 0 and 1 (at time 0 it stands where it
  // does without motion). Off by default: a still box costs no motion work.
  bool box_motion = false;
};

// A biconvex cylindrical lens whose axis is vertical (y0..y1): its cross-section
// in the xz-plane is bounded by two circular arcs of radius R across an
// aperture of width `aperture`, centred on `centre`, with the optical axis along
// the unit xz-direction `axis`. The curved faces carry smooth vertex normals
// (`segments` facets per face); the ends are flat.
inline TriangleMesh make_cylindrical_lens(Point2f centre, Point2f axis, Float aperture, Float R, Float y0, Float y1,
                                          int segments = 48) {
  TriangleMesh m;
  const Float half = aperture / 2, sag = R - std::sqrt(R * R - half * half);
  const Point2f side{-axis.y, axis.x};  // across the aperture
  auto to3 = [&](Float along, Float across, Float y) {
    return Point3f{centre.x + along * axis.x + across * side.x, y, centre.y + along * axis.y + across * side.y};
  };
  // Face f = +1 bulges along +axis, f = -1 along -axis; its circle's centre
  // lies at -f (R - sag) on the axis (edges touch at along = 0).
  std::vector<uint32_t> rim[2];
  for (int f = 0; f < 2; ++f) {
    Float sgn = f == 0 ? 1.f : -1.f, c = -sgn * (R - sag);
    uint32_t base = uint32_t(m.positions.size());
    for (int i = 0; i <= segments; ++i) {
      Float across = -half + aperture * Float(i) / Float(segments);
      Float along = c + sgn * std::sqrt(R * R - across * across);
      Vector3f n{(along - c) * axis.x + across * side.x, 0, (along - c) * axis.y + across * side.y};
      n = n / R;
      for (Float y : {y0, y1}) {
        m.positions.push_back(to3(along, across, y));
        m.normals.push_back(Normal3f(n.x, n.y, n.z));
      }
    }
    for (int i = 0; i < segments; ++i) {
      uint32_t a = base + 2 * uint32_t(i);
      m.indices.insert(m.indices.end(), {a, a + 2, a + 3, a, a + 3, a + 1});
      rim[f].push_back(a);
    }
    rim[f].push_back(base + 2 * uint32_t(segments));
  }
  // Flat ends: fans between the two faces' profiles, with their own vertices
  // (normals -y and +y) so that the smooth side normals do not bend them.
  for (int top = 0; top < 2; ++top) {
    Float y = top ? y1 : y0;
    Normal3f n{0, top ? 1.f : -1.f, 0};
    uint32_t base = uint32_t(m.positions.size());
    for (int f = 0; f < 2; ++f)
      for (uint32_t v : rim[f]) {
        Point3f p = m.positions[v];
        m.positions.push_back({p.x, y, p.z});
        m.normals.push_back(n);
      }
    uint32_t k = uint32_t(rim[0].size());
    for (uint32_t i = 0; i + 1 < k; ++i)
      m.indices.insert(m.indices.end(), {base + i, base + i + 1, base + k + i + 1, base + i, base + k + i + 1, base + k + i});
  }
  return m;
}

// The default scene without its prism, lens, gold and glass: every material
// diffuse, so that a renderer with only DiffuseBxDF renders it
// (render/instantiation.hpp).
inline CornellBoxOptions diffuse_cornell_box_options() {
  CornellBoxOptions o;
  o.prism = false;
  o.gold_sphere = false;
  return o;
}

namespace detail {
// Adds m if the scene's BxDF set has a BxDF for it; otherwise throws naming
// what the options asked for.
template <class Scene, class M>
uint32_t add_cornell_material(Scene& scene, const M& m, const char* what) {
  if constexpr (std::is_constructible_v<typename Scene::material_type, const M&>) {
    const typename Scene::material_type v(m);
    return scene.add_material(v);
  } else {
    (void)scene;
    (void)m;
    throw Error(std::string("default scene: the ") + what +
                " needs a BxDF set with its BxDF (use default_bxdf_set or full_bxdf_set, or turn it off in "
                "CornellBoxOptions)");
  }
}
}  // namespace detail

// Fills a scene. Its BxDF set needs DiffuseBxDF, and ConductorBxDF and
// DielectricBxDF for the options that add gold, glass and the prism (as
// default_bxdf_set has); diffuse_bxdf_set suffices for
// diffuse_cornell_box_options().
template <class Scene>
void build_cornell_box(Scene& scene, const CornellBoxOptions& opt = {}) {
  const AreaEmission& light = opt.light;
  uint32_t white = detail::add_cornell_material(scene, DiffuseMaterial{RGB(0.73f, 0.73f, 0.73f)}, "white wall");
  uint32_t red = detail::add_cornell_material(scene, DiffuseMaterial{RGB(0.65f, 0.05f, 0.05f)}, "red wall");
  uint32_t green = detail::add_cornell_material(scene, DiffuseMaterial{RGB(0.12f, 0.45f, 0.15f)}, "green wall");
  uint32_t black = detail::add_cornell_material(scene, DiffuseMaterial{RGB(0.f)}, "lamp");

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
  if (opt.box_motion) {
    TransformKey k0 = TransformKey::trs({-0.35f, 0, -0.3f}, Quaternion::from_axis_angle({0, 1, 0}, radians(18)));
    TransformKey k1 = TransformKey::trs({-0.05f, 0, -0.3f}, Quaternion::from_axis_angle({0, 1, 0}, radians(48)));
    scene.add_instance(box, white, AnimatedTransform(k0, k1, 0, 1, "default scene: box motion"));
  } else {
    scene.add_instance(box, white, translate({-0.35f, 0, -0.3f}) * rotate(radians(18), {0, 1, 0}));
  }
  // A rough gold sphere (measured eta and k) on the floor at the front right.
  uint32_t sphere_m =
      opt.gold_sphere ? detail::add_cornell_material(
                            scene, ConductorMaterial::metal("Au", MicrofacetRoughness(opt.gold_alpha), "rough gold"),
                            "gold sphere")
                      : white;
  scene.add_sphere(Sphere{{0.4f, -0.6f, 0.35f}, 0.4f}, sphere_m);
  // A small rough (frosted) glass sphere on the floor at the front left.
  if (opt.gold_sphere) {
    uint32_t frosted = detail::add_cornell_material(
        scene, DielectricMaterial{IOR(1.5f), "frosted glass", MicrofacetRoughness(0.15f)}, "frosted glass sphere");
    scene.add_sphere(Sphere{{-0.55f, -0.8f, 0.6f}, 0.2f}, frosted);
  }

  if (!opt.prism) return;
  // The spectrometer: a narrow vertical slit lamp on the left wall, a
  // cylindrical lens that images the slit onto the back wall, and an SF11
  // prism between them that spreads the image into a spectrum. (The lens
  // gathers the slit's light over a wide angle, so the caustic that a path
  // tracer must find by BSDF sampling is bright and converges quickly.)
  const Float zs = 0.55f, half_w = 0.01f, y0 = -0.55f, y1 = 0.95f;
  TriangleMesh slit;
  append_quad(slit, {-0.999f, y0, zs - half_w}, {0, y1 - y0, 0}, {0, 0, 2 * half_w});  // normal +x
  scene.add_mesh_instance(std::move(slit), black, opt.slit);
  uint32_t lens_glass = detail::add_cornell_material(scene, DielectricMaterial{IOR(1.5f), "lens glass"}, "lens");
  scene.add_mesh_instance(make_cylindrical_lens({opt.lens_x, zs}, {1, 0}, 0.24f, opt.lens_radius, y0, y1), lens_glass);
  // The prism: apex angle 60 degrees, side 0.36, its cross-section turned so
  // that the beam meets the first face at a steep angle and leaves towards the
  // back wall.
  uint32_t glass =
      detail::add_cornell_material(scene, DielectricMaterial{SellmeierIOR::glass("N-SF11"), "SF11 glass prism"}, "prism");
  const Float side = 0.36f, r = side / std::sqrt(3.f), turn = radians(opt.prism_turn), cx = -0.25f, cz = 0.5f;
  Point2f v[3];
  for (int i = 0; i < 3; ++i) {
    Float a = radians(90 + 120 * Float(i)) + turn;
    v[i] = {cx + r * std::cos(a), cz + r * std::sin(a)};
  }
  scene.add_mesh_instance(make_triangular_prism(v[0], v[1], v[2], -0.65f, 0.999f), glass);
}

}  // namespace prism
