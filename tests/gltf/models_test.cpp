// The shared glTF sample models (../shared/scenes) load with the triangle counts
// of their README, render without a non-finite sample, and show what their
// READMEs say is correct: texture coordinates, node orientations, instancing,
// normal-map handedness and emissive strengths. Skipped when ../shared is absent.
#include <catch2/catch.hpp>
#include "support/skip.hpp"
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <prism/io/gltf.hpp>
#include <prism/prism.hpp>

namespace models_test {

using namespace prism;


namespace {

const std::string scenes_dir = std::string(PRISM_SHARED_DIR) + "/scenes/";
bool have_scenes() { return std::filesystem::exists(scenes_dir + "README.md"); }

struct ModelCase {
  const char* file;
  size_t mesh_triangles, scene_triangles;
};
// The README's table: triangles summed over unique meshes / over the scene's instances.
const ModelCase models[] = {
    {"Box/glTF/Box.gltf", 12, 12},
    {"Box/glTF-Binary/Box.glb", 12, 12},
    {"Box/glTF-Embedded/Box.gltf", 12, 12},
    {"BoxTextured/glTF/BoxTextured.gltf", 12, 12},
    {"BoxTextured/glTF-Binary/BoxTextured.glb", 12, 12},
    {"BoxTextured/glTF-Embedded/BoxTextured.gltf", 12, 12},
    {"Duck/glTF/Duck.gltf", 4212, 4212},
    {"Duck/glTF-Binary/Duck.glb", 4212, 4212},
    {"Avocado/glTF/Avocado.gltf", 682, 682},
    {"DamagedHelmet/glTF-Binary/DamagedHelmet.glb", 15452, 15452},
    {"MetalRoughSpheresNoTextures/glTF-Binary/MetalRoughSpheresNoTextures.glb", 1040409, 1040409},
    {"NormalTangentMirrorTest/glTF/NormalTangentMirrorTest.gltf", 5240, 5240},
    {"TextureCoordinateTest/glTF/TextureCoordinateTest.gltf", 10, 10},
    {"TextureCoordinateTest/glTF-Binary/TextureCoordinateTest.glb", 10, 10},
    {"TextureTransformTest/glTF/TextureTransformTest.gltf", 18, 24},
    {"Cameras/glTF/Cameras.gltf", 2, 2},
    {"Cameras/glTF-Embedded/Cameras.gltf", 2, 2},
    {"AnimatedCube/glTF/AnimatedCube.gltf", 12, 12},
    {"OrientationTest/glTF/OrientationTest.gltf", 524, 524},
    {"OrientationTest/glTF-Binary/OrientationTest.glb", 524, 524},
    {"SimpleInstancing/glTF/SimpleInstancing.gltf", 12, 1500},
    {"SimpleInstancing/glTF-Binary/SimpleInstancing.glb", 12, 1500},
    {"EmissiveStrengthTest/glTF/EmissiveStrengthTest.gltf", 90, 90},
    {"EmissiveStrengthTest/glTF-Binary/EmissiveStrengthTest.glb", 90, 90},
    {"TransmissionTest/glTF-Binary/TransmissionTest.glb", 128775, 128775},
    {"TransmissionRoughnessTest/glTF/TransmissionRoughnessTest.gltf", 77792, 77792},
    {"TransmissionRoughnessTest/glTF-Binary/TransmissionRoughnessTest.glb", 77792, 77792},
    {"AttenuationTest/glTF/AttenuationTest.gltf", 232, 292},
    {"AttenuationTest/glTF-Binary/AttenuationTest.glb", 232, 292},
    {"ClearCoatTest/glTF-Binary/ClearCoatTest.glb", 37116, 37116},
    {"SheenChair/glTF/SheenChair.gltf", 39936, 39936},
    {"IridescenceSuzanne/glTF-Binary/IridescenceSuzanne.glb", 11808, 11808},
    // The README's scene column repeats the mesh column (7476); the file's
    // ten band nodes instance its band meshes several times: 13876.
    {"AnisotropyRotationTest/glTF-Binary/AnisotropyRotationTest.glb", 7476, 13876},
    {"AnisotropyStrengthTest/glTF-Binary/AnisotropyStrengthTest.glb", 97240, 97240},
    {"SpecularTest/glTF-Binary/SpecularTest.glb", 44828, 44828},
    {"UnlitTest/glTF-Binary/UnlitTest.glb", 88, 88},
    {"MaterialsVariantsShoe/glTF/MaterialsVariantsShoe.gltf", 22700, 22700},
    {"CesiumMan/glTF-Binary/CesiumMan.glb", 4672, 4672},
    {"MorphPrimitivesTest/glTF-Binary/MorphPrimitivesTest.glb", 32, 32},
    {"AnimatedMorphCube/glTF-Binary/AnimatedMorphCube.glb", 12, 12},
};
// Extensions prism supports: no shared model may warn about one of them.
const char* supported_extensions[] = {"KHR_materials_clearcoat", "KHR_materials_iridescence", "KHR_materials_anisotropy",
                                      "KHR_materials_specular", "KHR_materials_unlit", "KHR_materials_variants",
                                      "KHR_materials_ior", "KHR_materials_transmission", "KHR_materials_volume",
                                      "KHR_materials_sheen"};

// World bounds of instance i.
Bounds3f instance_bounds(const SceneAccel& accel, size_t i) {
  const Instance& in = accel.instances()[i];
  Bounds3f b;
  for (const auto& p : accel.meshes()[in.geometry].positions) b = union_bounds(b, in.object_to_world(p));
  return b;
}
Point3f centre(const Bounds3f& b) { return b.min + (b.max - b.min) * Float(0.5); }

nlohmann::json read_json(const std::string& path) {
  std::ifstream f(path);
  return nlohmann::json::parse(f);
}

}  // namespace

TEST_CASE("every shared model loads with its README triangle counts and renders finite", "[gltf][models]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  for (const auto& m : models) {
    INFO(m.file);
    auto g = load_gltf<RGB>(scenes_dir + m.file);
    CHECK(g.mesh_triangles == m.mesh_triangles);
    CHECK(g.scene_triangles == m.scene_triangles);
    CHECK(g.warnings.size() <= 2);
    for (const auto& w : g.warnings)
      for (const char* e : supported_extensions) {
        INFO(w);
        CHECK(w.find(e) == std::string::npos);
      }
    if (g.punctual_lights == 0) g.scene.add_light(UniformInfiniteLight<RGB>(RGB(1)));
    g.scene.build();
    Film film(64, 64);
    RenderOptions opt;
    opt.spp = 4;
    opt.seed = 7;
    RenderStats st = render(g.scene, gltf_framing_camera(g.bounds, 64, 64), PathIntegrator(), film, opt);
    CHECK(st.dropped == 0);
    CHECK(st.samples == uint64_t(64 * 64 * 4));
    double sum = 0;
    bool finite = true;
    for (float v : film.rgb_buffer()) {
      finite = finite && std::isfinite(v) && v >= 0;
      sum += v;
    }
    CHECK(finite);
    CHECK(sum > 0);  // something is visible
  }
}

TEST_CASE("the three Box containers give identical scenes", "[gltf][models]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto a = load_gltf<RGB>(scenes_dir + "Box/glTF/Box.gltf");
  for (const char* other : {"Box/glTF-Binary/Box.glb", "Box/glTF-Embedded/Box.gltf"}) {
    INFO(other);
    auto b = load_gltf<RGB>(scenes_dir + other);
    const auto &ma = a.scene.accel().meshes(), &mb = b.scene.accel().meshes();
    REQUIRE(ma.size() == mb.size());
    for (size_t i = 0; i < ma.size(); ++i) {
      CHECK(ma[i].indices == mb[i].indices);
      REQUIRE(ma[i].positions.size() == mb[i].positions.size());
      for (size_t v = 0; v < ma[i].positions.size(); ++v) {
        CHECK(ma[i].positions[v] == mb[i].positions[v]);
        CHECK(ma[i].normals[v] == mb[i].normals[v]);
      }
    }
    const auto &ia = a.scene.accel().instances(), &ib = b.scene.accel().instances();
    REQUIRE(ia.size() == ib.size());
    for (size_t i = 0; i < ia.size(); ++i) CHECK(ia[i].object_to_world.matrix() == ib[i].object_to_world.matrix());
  }
}

TEST_CASE("SimpleInstancing builds one mesh BVH for its 125 instances", "[gltf][models]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto g = load_gltf<RGB>(scenes_dir + "SimpleInstancing/glTF/SimpleInstancing.gltf");
  g.scene.build();
  CHECK(g.scene.accel().meshes().size() == 1);
  CHECK(g.scene.accel().instances().size() == 125);
  // The instances are distinct: 125 different positions.
  std::vector<Point3f> centres;
  for (size_t i = 0; i < 125; ++i) centres.push_back(centre(instance_bounds(g.scene.accel(), i)));
  for (size_t i = 0; i < centres.size(); ++i)
    for (size_t j = i + 1; j < centres.size(); ++j) CHECK(distance(centres[i], centres[j]) > 0.1f);
}

TEST_CASE("TextureCoordinateTest: uv (0,0) is the image's top left, on the object at the top left", "[gltf][models]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  std::string path = scenes_dir + "TextureCoordinateTest/glTF/TextureCoordinateTest.gltf";
  auto g = load_gltf<RGB>(path);
  g.scene.build();
  auto json = read_json(path);
  // Instances follow the scene's node order, one primitive per node here.
  const auto& roots = json["scenes"][0]["nodes"];
  std::map<std::string, size_t> instance;
  for (size_t i = 0; i < roots.size(); ++i) instance[json["nodes"][roots[i].get<int>()]["name"]] = i;
  auto probe = [&](const std::string& name) {
    Point3f c = centre(instance_bounds(g.scene.accel(), instance.at(name)));
    Ray r{Point3f(c.x, c.y, c.z + 10), Vector3f(0, 0, -1)};
    auto si = g.scene.intersect(r);
    REQUIRE(si);
    CHECK(si->instance == instance.at(name));
    return std::make_pair(c, si->uv);
  };
  auto [tl, uv_tl] = probe("TopLeftObj");
  auto [tr, uv_tr] = probe("TopRightObj");
  auto [bl, uv_bl] = probe("BottomLeftObj");
  auto [br, uv_br] = probe("BottomRightObj");
  // Placement as the README's screenshot shows it.
  CHECK(tl.x < tr.x);
  CHECK(bl.x < br.x);
  CHECK(tl.y > bl.y);
  CHECK(tr.y > br.y);
  // The upper-left object shows the upper-left of the image: uv near (0.2, 0.2).
  CHECK(uv_tl.x < 0.5f);
  CHECK(uv_tl.y < 0.5f);
  CHECK(uv_tr.x > 0.5f);
  CHECK(uv_tr.y < 0.5f);
  CHECK(uv_bl.x < 0.5f);
  CHECK(uv_bl.y > 0.5f);
  CHECK(uv_br.x > 0.5f);
  CHECK(uv_br.y > 0.5f);
}

TEST_CASE("OrientationTest: every arrow points at the target of its colour", "[gltf][models]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  for (const char* file : {"OrientationTest/glTF/OrientationTest.gltf", "OrientationTest/glTF-Binary/OrientationTest.glb"}) {
    INFO(file);
    std::string path = scenes_dir + file;
    auto g = load_gltf<RGB>(path);
    g.scene.build();
    auto json = read_json(scenes_dir + "OrientationTest/glTF/OrientationTest.gltf");
    const auto& roots = json["scenes"][0]["nodes"];
    std::map<std::string, size_t> instance;
    for (size_t i = 0; i < roots.size(); ++i) instance[json["nodes"][roots[i].get<int>()]["name"]] = i;
    const auto& accel = g.scene.accel();
    std::map<std::string, Point3f> target_centre;
    for (const auto& [name, i] : instance)
      if (name.rfind("Target", 0) == 0) target_centre[name.substr(6)] = centre(instance_bounds(accel, i));
    REQUIRE(target_centre.size() == 6);
    for (const char* id : {"X1", "X2", "Y1", "Y2", "Z1", "Z2"}) {
      INFO(id);
      size_t a = instance.at(std::string("Arrow") + id);
      const Instance& in = accel.instances()[a];
      // The arrow's vertex nearest its own target, against the other targets.
      Float own = infinity, other = infinity;
      for (const auto& p : accel.meshes()[in.geometry].positions) {
        Point3f w = in.object_to_world(p);
        for (const auto& [tid, tc] : target_centre) {
          Float d = distance(w, tc);
          if (tid == id) own = std::min(own, d);
          else other = std::min(other, d);
        }
      }
      Float extent = length(instance_bounds(accel, a).diagonal());
      CHECK(own < other);
      CHECK(own < Float(0.25) * extent);
    }
  }
}

TEST_CASE("EmissiveStrengthTest: the cubes' radiances in the image are 1 2 4 8 16 within 2 percent", "[gltf][models]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  std::string path = scenes_dir + "EmissiveStrengthTest/glTF/EmissiveStrengthTest.gltf";
  auto g = load_gltf<RGB>(path);
  g.scene.build();  // no other light: the cubes light the scene
  auto json = read_json(path);
  const auto& roots = json["scenes"][0]["nodes"];
  std::map<std::string, size_t> instance;
  for (size_t i = 0; i < roots.size(); ++i) instance[json["nodes"][roots[i].get<int>()]["name"]] = i;
  std::vector<double> green;
  for (const char* name : {"Cube1", "Cube2", "Cube4", "Cube8", "Cube16"}) {
    // A camera facing the cube's +z face from close by; the face fills the
    // middle of a 32 x 32 image, and the middle 8 x 8 pixels are averaged.
    Bounds3f b = instance_bounds(g.scene.accel(), instance.at(name));
    Point3f c = centre(b);
    Float half = (b.max.y - b.min.y) / 2;
    Float fov = Float(30) * pi / 180, dist = half / std::tan(fov / 2) * 2;
    PerspectiveCamera camera(
        look_at_camera_to_world(Point3f(c.x, c.y, b.max.z + dist), Point3f(c.x, c.y, b.max.z), Vector3f(0, 1, 0)), fov,
        32, 32);
    Film film(32, 32);
    RenderOptions opt;
    opt.spp = 16;
    opt.seed = 3;
    render(g.scene, camera, PathIntegrator(), film, opt);
    double sum = 0;
    for (int y = 12; y < 20; ++y)
      for (int x = 12; x < 20; ++x) sum += film.pixel(x, y).g;
    green.push_back(sum / 64);
  }
  for (size_t i = 1; i < green.size(); ++i) {
    INFO("cube " << i << ": " << green[i] << " over " << green[0]);
    CHECK(green[i] / green[0] == Approx(double(1 << i)).epsilon(0.02));
  }
  // And the absolute value: emissiveFactor g = 0.5 times strength 1.
  CHECK(green[0] == Approx(0.5).epsilon(0.02));
}

TEST_CASE("NormalTangentMirrorTest: normal-mapped cells tilt like the geometry cells", "[gltf][models]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  // Each row of the model holds a real bump (geometry) and three normal-mapped
  // flat cells (normal, V mirrored, U mirrored) that must look the same. Probe
  // each cell a little above and to the right of its centre: the shading
  // normal must tilt up and right there, as the geometry's does.
  auto g = load_gltf<RGB>(scenes_dir + "NormalTangentMirrorTest/glTF/NormalTangentMirrorTest.gltf");
  g.scene.build();
  Bounds3f b = g.bounds;
  // Find the cells: scan a row of rays across the model and collect runs of
  // hits on shading normals that differ from the flat backing's +z.
  using Traits = bxdf_traits<MetalRoughBxDF<RGB>>;
  auto shading_normal = [&](Float x, Float y) -> std::optional<Vector3f> {
    Ray r{Point3f(x, y, b.max.z + 1), Vector3f(0, 0, -1)};
    auto si = g.scene.intersect(r);
    if (!si) return std::nullopt;
    const auto& mat = std::get<0>(g.scene.materials()[size_t(si->material)]);
    return Vector3f(Traits::shading_frame(mat, *si).z);
  };
  // Bumps and mapped bumps are domes: inside one, n.x grows to the right and
  // n.y grows upwards. A flipped green channel or handedness reverses n.y
  // (or n.x) in the mapped cells. Scan rows and columns and count the steps
  // between neighbouring probes that agree with a dome.
  int n = 400, agree = 0, disagree = 0;
  auto scan = [&](bool horizontal) {
    for (int j = 0; j < 120; ++j) {
      std::optional<Vector3f> prev;
      for (int i = 0; i < n; ++i) {
        Float s = (Float(i) + 0.5f) / Float(n), t = (Float(j) + 0.5f) / 120;
        Float x = b.min.x + (b.max.x - b.min.x) * (horizontal ? s : t);
        Float y = b.min.y + (b.max.y - b.min.y) * (horizontal ? t : s);
        auto nn = shading_normal(x, y);
        if (nn && prev && nn->z > 0.5f && prev->z > 0.5f) {
          Float step = horizontal ? nn->x - prev->x : nn->y - prev->y;
          if (std::abs(step) > 0.02f && std::abs(step) < 0.3f) {
            if (step > 0) ++agree;
            else ++disagree;
          }
        }
        prev = nn;
      }
    }
  };
  scan(true);
  scan(false);
  INFO("agree " << agree << " disagree " << disagree);
  CHECK(agree > 1000);
  CHECK(double(disagree) < 0.1 * double(agree));
}

}  // namespace models_test
