// "Model no more than a scene needs" (render/instantiation.hpp): the smallest
// instantiation renders a diffuse-only scene exactly as the full one does, and
// the rule picks the right colour model and BxDF set for scenes built in code.
#include <catch2/catch.hpp>
#include <cstring>
#include <memory>
#include <prism/prism.hpp>

namespace instantiation_test {

using namespace prism;

namespace {

template <class S, class Set>
Film render_diffuse_box(RenderStats* stats) {
  Scene<S, Set> scene;
  build_cornell_box(scene, diffuse_cornell_box_options());
  scene.build();
  const int w = 24, h = 20;
  Film film(w, h);
  RenderOptions opt;
  opt.spp = 4;
  opt.seed = 11;
  opt.threads = 1;
  *stats = render(scene, default_camera(w, h), PathIntegrator{}, film, opt);
  return film;
}

// Every pixel's three floats, bit for bit.
bool bitwise_equal(const Film& a, const Film& b) {
  if (a.width() != b.width() || a.height() != b.height()) return false;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) {
      RGB p = a.pixel(x, y), q = b.pixel(x, y);
      if (std::memcmp(&p, &q, sizeof p) != 0) return false;
    }
  return true;
}

double image_sum(const Film& f) {
  double s = 0;
  for (int y = 0; y < f.height(); ++y)
    for (int x = 0; x < f.width(); ++x) s += double(f.pixel(x, y).r + f.pixel(x, y).g + f.pixel(x, y).b);
  return s;
}

template <class S>
void check_minimal_equals_full() {
  RenderStats a, b;
  Film minimal = render_diffuse_box<S, diffuse_bxdf_set<S>>(&a);
  Film full = render_diffuse_box<S, full_bxdf_set<S>>(&b);
  REQUIRE(image_sum(minimal) > 0);
  CHECK(a.rays == b.rays);
  CHECK(a.dropped == b.dropped);
  CHECK(bitwise_equal(minimal, full));
}

using FullScene = Scene<RGB, full_bxdf_set<RGB>>;

void add_floor(FullScene& scene, uint32_t material) {
  TriangleMesh m;
  append_quad(m, {-1, 0, -1}, {0, 0, 2}, {2, 0, 0});
  scene.add_mesh_instance(std::move(m), material);
}

uint32_t add(FullScene& scene, const FullScene::material_type& m) { return scene.add_material(m); }

SceneFeatures features_of(FullScene& scene) {
  scene.build();
  return scene_features(scene);
}

}  // namespace

TEST_CASE("minimal and full RGB instantiations render a diffuse-only scene bitwise alike", "[render][instantiation]") {
  check_minimal_equals_full<RGB>();
}

TEST_CASE("minimal and full spectral instantiations render a diffuse-only scene bitwise alike",
          "[render][instantiation]") {
  check_minimal_equals_full<Spectral>();
}

TEST_CASE("the picker chooses the diffuse set for a diffuse-only scene", "[render][instantiation]") {
  FullScene scene;
  build_cornell_box(scene, diffuse_cornell_box_options());
  SceneFeatures f = features_of(scene);
  CHECK(f.bxdfs == std::vector<std::string_view>{"diffuse"});
  CHECK(f.lights == std::vector<std::string_view>{"triangle_area"});
  CHECK_FALSE(f.needs_spectral);
  CHECK_FALSE(f.textures);
  CHECK_FALSE(f.motion);
  CHECK(pick_instantiation(f) == Instantiation{ColourModel::rgb, BxDFSetKind::diffuse});
  // The colour model asked for wins; the set stays minimal.
  CHECK(pick_instantiation(f, ColourModel::spectral) == Instantiation{ColourModel::spectral, BxDFSetKind::diffuse});
}

TEST_CASE("the picker chooses the full set for a scene with a conductor", "[render][instantiation]") {
  FullScene scene;
  add_floor(scene, add(scene, DiffuseMaterial{RGB(0.5f)}));
  scene.add_sphere(Sphere{{0, 1, 0}, 0.5f}, add(scene, ConductorMaterial::from_reflectance(RGB(0.9f, 0.6f, 0.3f))));
  scene.add_light(PointLight<RGB>(Point3f{0, 3, 0}, RGB(1)));
  SceneFeatures f = features_of(scene);
  CHECK(f.bxdfs == std::vector<std::string_view>{"diffuse", "conductor"});
  CHECK(f.lights == std::vector<std::string_view>{"point"});
  CHECK(pick_instantiation(f) == Instantiation{ColourModel::rgb, BxDFSetKind::full});
  // A measured metal cannot be rendered exactly in RGB.
  FullScene gold;
  add_floor(gold, add(gold, ConductorMaterial::metal("Au")));
  gold.add_light(PointLight<RGB>(Point3f{0, 3, 0}, RGB(1)));
  CHECK(pick_instantiation(features_of(gold)) == Instantiation{ColourModel::spectral, BxDFSetKind::full});
}

TEST_CASE("the picker chooses the full set, in RGB, for non-dispersive glass", "[render][instantiation]") {
  FullScene scene;
  add_floor(scene, add(scene, DiffuseMaterial{RGB(0.5f)}));
  scene.add_sphere(Sphere{{0, 1, 0}, 0.5f}, add(scene, DielectricMaterial{IOR(1.5f), "glass"}));
  scene.add_light(UniformInfiniteLight<RGB>(RGB(1)));
  SceneFeatures f = features_of(scene);
  CHECK(f.bxdfs == std::vector<std::string_view>{"diffuse", "dielectric"});
  CHECK(f.lights == std::vector<std::string_view>{"uniform_environment"});
  CHECK_FALSE(f.dispersion);
  CHECK(pick_instantiation(f) == Instantiation{ColourModel::rgb, BxDFSetKind::full});
}

TEST_CASE("the picker chooses spectral and the full set for dispersive glass", "[render][instantiation]") {
  FullScene scene;
  add_floor(scene, add(scene, DiffuseMaterial{RGB(0.5f)}));
  scene.add_sphere(Sphere{{0, 1, 0}, 0.5f},
                   add(scene, DielectricMaterial{SellmeierIOR::glass("N-SF11"), "SF11"}));
  AreaEmission lamp{RGB(4.f), 1.f, false};
  scene.add_sphere(Sphere{{0, 3, 0}, 0.2f}, add(scene, DiffuseMaterial{RGB(0.f)}), lamp);
  SceneFeatures f = features_of(scene);
  CHECK(f.dispersion);
  CHECK(f.needs_spectral);
  CHECK(f.lights == std::vector<std::string_view>{"sphere_area"});
  CHECK(pick_instantiation(f) == Instantiation{ColourModel::spectral, BxDFSetKind::full});
  // The default scene likewise (SF11 prism, measured gold).
  FullScene box;
  build_cornell_box(box);
  SceneFeatures fb = features_of(box);
  CHECK(fb.bxdfs == std::vector<std::string_view>{"diffuse", "dielectric", "conductor"});
  CHECK(pick_instantiation(fb) == Instantiation{ColourModel::spectral, BxDFSetKind::full});
}

TEST_CASE("the picker chooses the metal_rough set for glTF-style materials", "[render][instantiation]") {
  FullScene scene;
  MetalRoughMaterial m;
  m.textures = std::make_shared<MetalRoughTextures>();
  add_floor(scene, add(scene, m));
  uint32_t mesh = scene.add_mesh(make_box({-0.2f, 0, -0.2f}, {0.2f, 0.4f, 0.2f}));
  TransformKey k0 = TransformKey::trs({0, 0, 0}, Quaternion::from_axis_angle({0, 1, 0}, 0));
  TransformKey k1 = TransformKey::trs({0.3f, 0, 0}, Quaternion::from_axis_angle({0, 1, 0}, 0));
  scene.add_instance(mesh, 0, AnimatedTransform(k0, k1, 0, 1, "test motion"));
  scene.add_light(SunLight<RGB>(Vector3f{0, 1, 0}, RGB(1), 1, radians(0.53f)));
  SceneFeatures f = features_of(scene);
  CHECK(f.bxdfs == std::vector<std::string_view>{"metal_rough"});
  CHECK(f.textures);
  CHECK(f.motion);
  CHECK(pick_instantiation(f) == Instantiation{ColourModel::rgb, BxDFSetKind::metal_rough});
  // Without the metal_rough set among the candidates: the full one.
  CHECK(pick_instantiation(f, std::nullopt, {BxDFSetKind::diffuse, BxDFSetKind::full}).bxdfs == BxDFSetKind::full);
}

TEST_CASE("a scene without materials takes the smallest set", "[render][instantiation]") {
  FullScene scene;
  scene.add_light(UniformInfiniteLight<RGB>(RGB(1)));
  CHECK(pick_instantiation(features_of(scene)) == Instantiation{ColourModel::rgb, BxDFSetKind::diffuse});
}

TEST_CASE("the default scene cannot be built in the diffuse set", "[render][instantiation]") {
  Scene<RGB, diffuse_bxdf_set<RGB>> scene;
  CHECK_THROWS_AS(build_cornell_box(scene), Error);
  Scene<RGB, diffuse_bxdf_set<RGB>> plain;
  CHECK_NOTHROW(build_cornell_box(plain, diffuse_cornell_box_options()));
}

}  // namespace instantiation_test
