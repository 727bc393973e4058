// glTF extensions that change which material a surface gets or what it does
// with light: KHR_materials_unlit, KHR_materials_variants, the fallback
// rules of KHR_texture_basisu, EXT_texture_webp (WebP images through
// libwebp, encoded losslessly here so that every texel is known) and
// KHR_draco_mesh_compression (the shared Draco twins against their plain
// files). Boxes with one material are written in code
// (tests/support/gltf_json.hpp); the shared UnlitTest and
// MaterialsVariantsShoe models are loaded when ../shared is present.
//
// Unlit, as the extension specifies: the surface shows its base colour
// (factor x texture) and takes no light. A camera ray that meets it returns
// exactly that colour, whatever lights the scene, so the RGB checks are
// exact (to float rounding), and the same box without the extension, lit by
// the same environment, must differ (the control that shows the check can
// fail).
#include <catch2/catch.hpp>
#include "support/gltf_json.hpp"
#include "support/skip.hpp"
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <nlohmann/json.hpp>
#include <stb/stb_image.h>
#include <prism/io/gltf.hpp>
#include <prism/io/image_io.hpp>
#include <prism/prism.hpp>
#if defined(PRISM_HAS_WEBP)
#include <webp/encode.h>
#endif

namespace extensions_test {

using namespace prism;
using nlohmann::json;
using gltf_json::box_gltf;

namespace {

const std::string scenes_dir = std::string(PRISM_SHARED_DIR) + "/scenes/";
bool have_scenes() { return std::filesystem::exists(scenes_dir + "README.md"); }

std::string write_temp(const std::string& name, const json& g) {
  return gltf_json::write_temp_gltf("gltf_extensions", name, g);
}

json unlit_material(std::array<double, 3> c, bool unlit = true) {
  json m;
  m["pbrMetallicRoughness"] = {{"baseColorFactor", {c[0], c[1], c[2], 1.0}}, {"metallicFactor", 0}};
  if (unlit) m["extensions"]["KHR_materials_unlit"] = json::object();
  return m;
}

// The mean colour of a 4x4 orthographic view of the box's top face (the
// window [-0.3, 0.3]^2 of the face [-0.5, 0.5]^2), with its pooled sigma.
struct Window {
  std::array<double, 3> mean{}, sigma{};
  bool finite = true;
};
template <class S, class G>
Window top_face(G& g, int spp) {
  const int w = 4, h = 4;
  OrthographicCamera cam(look_at_camera_to_world({0, 0, 10}, {0, 0, 0}, {0, 1, 0}), 0.6f, w, h);
  Film film(w, h);
  RenderOptions opt;
  opt.spp = spp;
  opt.threads = 1;
  render(g.scene, cam, PathIntegrator(), film, opt);
  Window out;
  for (int c = 0; c < 3; ++c) {
    double sum = 0, var = 0;
    for (int py = 0; py < h; ++py)
      for (int px = 0; px < w; ++px) {
        double v = film.pixel(px, py)[c];
        out.finite = out.finite && std::isfinite(v);
        sum += v;
        var += double(film.variance(px, py)[c]);
      }
    out.mean[size_t(c)] = sum / (w * h);
    out.sigma[size_t(c)] = std::sqrt(var) / (w * h);
  }
  return out;
}

// Loads the box with `material` under a white environment of radiance 2
// (bright enough that any reflected light shows) and returns the top face.
template <class S>
Window render_box(const json& material, const std::vector<std::string>& used, const GltfOptions& opt = {},
                  int spp = 16) {
  auto g = load_gltf<S>(write_temp("box.gltf", box_gltf(1, material, used)), opt);
  g.scene.add_light(UniformInfiniteLight<S>(RGB(2.f)));
  g.scene.build();
  return top_face<S>(g, spp);
}

}  // namespace

TEST_CASE("KHR_materials_unlit shows the base colour exactly and takes no light, RGB", "[gltf][unlit]") {
  const std::array<double, 3> c{0.2, 0.5, 0.8};
  Window unlit = render_box<RGB>(unlit_material(c), {"KHR_materials_unlit"});
  CHECK(unlit.finite);
  for (size_t k = 0; k < 3; ++k) {
    INFO("channel " << k << ": " << unlit.mean[k] << " expected " << c[k]);
    // 1e-5: each sample is the float base colour (within 3e-8 of c), summed in double by the film and rounded once
    CHECK(std::abs(unlit.mean[k] - c[k]) <= 1e-5);
    CHECK(unlit.sigma[k] <= 1e-6);  // every sample is the base colour
  }
  // The control: the same surface lit by the same environment reflects
  // about base x 2 + the specular layer's 0.04 x 2.
  Window lit = render_box<RGB>(unlit_material(c, false), {});
  for (size_t k = 0; k < 3; ++k) {
    INFO("lit channel " << k << ": " << lit.mean[k]);
    CHECK(lit.mean[k] > c[k] + 0.1);
  }
}

TEST_CASE("KHR_materials_unlit: the base colour texture multiplies the factor, no fallback light", "[gltf][unlit]") {
  // A 2x2 PNG of pure red (sRGB 255, 0, 0 decodes to exactly 1, 0, 0).
  std::string dir = std::string(PRISM_TEST_TMP_DIR) + "/gltf_extensions";
  std::filesystem::create_directories(dir);
  write_png(dir + "/red.png", Image{2, 2, std::vector<float>{1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0}});
  json m = unlit_material({0.5, 0.25, 1.0});
  m["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 0}};
  json g = box_gltf(1, m, {"KHR_materials_unlit"});
  g["textures"] = json::array({{{"source", 0}}});
  g["images"] = json::array({{{"uri", "red.png"}}});
  auto scene = load_gltf<RGB>(write_temp("unlit_textured.gltf", g));
  CHECK(scene.warnings.empty());
  CHECK(scene.emissive_instances == 1);
  CHECK(scene.has_lights());  // an unlit scene is lit by itself: prism-render adds no environment
  scene.scene.build();
  // The texture is red everywhere, whatever the box's texture coordinates.
  Window w = top_face<RGB>(scene, 4);
  // 1e-5 and 1e-6: as above, a float colour averaged in double and rounded once
  CHECK(std::abs(w.mean[0] - 0.5) <= 1e-5);
  CHECK(std::abs(w.mean[1]) <= 1e-6);
  CHECK(std::abs(w.mean[2]) <= 1e-6);
}

// Spectral: the base colour is emitted as an RGB illuminant spectrum, whose
// film RGB reproduces the colour up to the uplift's round trip (at most
// 5e-4 per channel: tests/spectra/uplift_test.cpp bounds it by 5.9e-4 of the
// largest component, 0.8 here) and the hero-wavelength
// noise (4 sigma, one check per channel: a family of 3, Sidak-corrected
// 4 sigma is 4.2, so 4.5 sigma is used).
TEST_CASE("KHR_materials_unlit shows the base colour, spectral", "[gltf][unlit][spectral]") {
  const std::array<double, 3> c{0.2, 0.5, 0.8};
  Window w = render_box<Spectral>(unlit_material(c), {"KHR_materials_unlit"}, {}, 256);
  CHECK(w.finite);
  for (size_t k = 0; k < 3; ++k) {
    INFO("channel " << k << ": " << w.mean[k] << " expected " << c[k] << " sigma " << w.sigma[k]);
    CHECK(std::abs(w.mean[k] - c[k]) <= 4.5 * w.sigma[k] + 5e-4);
  }
}

TEST_CASE("UnlitTest: the required KHR_materials_unlit loads, every surface emits its base colour", "[gltf][unlit]") {
  std::string path = scenes_dir + "UnlitTest/glTF-Binary/UnlitTest.glb";
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto g = load_gltf<RGB>(path);
  CHECK(g.warnings.empty());
  CHECK(g.emissive_instances == 2);
  CHECK(g.punctual_lights == 0);
  g.scene.build();
  // Camera looking at the scene: every pixel is background (0) or one of
  // the two base colours (orange 1, 0.2176, 0; blue 0, 0.2176, 1), or a
  // mixture of them at an edge: green is never above 0.2177 and the image
  // holds both colours.
  auto cam = gltf_framing_camera(g.bounds, 32, 16, 0, 1);
  Film film(32, 16);
  RenderOptions opt;
  opt.spp = 4;
  opt.threads = 1;
  render(g.scene, cam, PathIntegrator(), film, opt);
  int orange = 0, blue = 0;
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 32; ++x) {
      RGB p = film.pixel(x, y);
      CHECK(p.g <= 0.2177f);
      // 1e-4: the two colours are float sRGB decodes (ulp ≤ 1.2e-7) summed over 4 spp; an edge pixel mixes them by far more
      if (std::abs(p.r - 1) < 1e-4f && std::abs(p.g - 0.217637f) < 1e-4f && p.b < 1e-6f) ++orange;
      if (std::abs(p.b - 1) < 1e-4f && std::abs(p.g - 0.217637f) < 1e-4f && p.r < 1e-6f) ++blue;
    }
  CHECK(orange > 10);
  CHECK(blue > 10);
}

namespace {

// A box whose primitive maps materials 1 and 2 to variants "a" and "b";
// material 0 (red) is the default. All unlit, so the render tells the
// material exactly.
json variants_box() {
  json g = box_gltf(1, unlit_material({1, 0, 0}), {"KHR_materials_unlit", "KHR_materials_variants"});
  g["materials"].push_back(unlit_material({0, 1, 0}));
  g["materials"].push_back(unlit_material({0, 0, 1}));
  g["extensions"]["KHR_materials_variants"]["variants"] = json::array({{{"name", "a"}}, {{"name", "b"}}});
  g["meshes"][0]["primitives"][0]["extensions"]["KHR_materials_variants"]["mappings"] =
      json::array({{{"material", 1}, {"variants", {0}}}, {{"material", 2}, {"variants", {1}}}});
  return g;
}

std::array<double, 3> variant_colour(const json& g, const std::string& variant) {
  GltfOptions opt;
  opt.variant = variant;
  auto s = load_gltf<RGB>(write_temp("variants.gltf", g), opt);
  CHECK(s.warnings.empty());
  CHECK(s.variants == std::vector<std::string>{"a", "b"});
  CHECK(s.variant == variant);
  s.scene.build();
  return top_face<RGB>(s, 1).mean;
}

std::string load_error(const json& g, const std::string& variant) {
  GltfOptions opt;
  opt.variant = variant;
  try {
    load_gltf<RGB>(write_temp("variants_bad.gltf", g), opt);
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST_CASE("KHR_materials_variants: the default materials, each named variant, and errors", "[gltf][variants]") {
  json g = variants_box();
  CHECK(variant_colour(g, "") == std::array<double, 3>{1, 0, 0});
  CHECK(variant_colour(g, "a") == std::array<double, 3>{0, 1, 0});
  CHECK(variant_colour(g, "b") == std::array<double, 3>{0, 0, 1});

  std::string e = load_error(g, "c");
  INFO(e);
  CHECK(e.find("variants_bad.gltf") != std::string::npos);
  CHECK(e.find("no material variant named 'c'") != std::string::npos);
  CHECK(e.find("'a', 'b'") != std::string::npos);

  json plain = box_gltf(1, unlit_material({1, 0, 0}), {});
  e = load_error(plain, "a");
  CHECK(e.find("defines no variants") != std::string::npos);

  json bad = variants_box();
  bad["meshes"][0]["primitives"][0]["extensions"]["KHR_materials_variants"]["mappings"][1]["variants"][0] = 5;
  e = load_error(bad, "");  // checked whatever the variant
  CHECK(e.find("meshes[0].primitives[0].extensions.KHR_materials_variants.mappings[1].variants[0]") !=
        std::string::npos);
  CHECK(e.find("variant index 5 out of range (2 variants)") != std::string::npos);

  bad = variants_box();
  bad["meshes"][0]["primitives"][0]["extensions"]["KHR_materials_variants"]["mappings"][0]["material"] = 7;
  e = load_error(bad, "a");
  CHECK(e.find("mappings[0].material: material index 7 out of range (3 materials)") != std::string::npos);

  bad = variants_box();
  bad["extensions"]["KHR_materials_variants"]["variants"][1] = {{"name", 3}};
  e = load_error(bad, "");
  CHECK(e.find("extensions.KHR_materials_variants.variants[1]") != std::string::npos);
}

TEST_CASE("MaterialsVariantsShoe: each variant takes its own base colour image", "[gltf][variants]") {
  std::string dir = scenes_dir + "MaterialsVariantsShoe/glTF/";
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  // The expected image per variant, read from the file's JSON: the mapping's
  // material, its baseColorTexture, that texture's image.
  json j = json::parse(std::ifstream(dir + "MaterialsVariantsShoe.gltf"));
  const auto& names = j["extensions"]["KHR_materials_variants"]["variants"];
  REQUIRE(names.size() == 3);
  const auto& mappings = j["meshes"][0]["primitives"][0]["extensions"]["KHR_materials_variants"]["mappings"];
  auto image_of_material = [&](int m) {
    int tex = j["materials"][size_t(m)]["pbrMetallicRoughness"]["baseColorTexture"]["index"];
    int img = j["textures"][size_t(tex)]["source"];
    return j["images"][size_t(img)]["uri"].get<std::string>();
  };
  std::set<std::string> seen;
  for (size_t v = 0; v < names.size(); ++v) {
    std::string name = names[v]["name"];
    int material = j["meshes"][0]["primitives"][0]["material"];
    for (const auto& m : mappings)
      for (int k : m["variants"])
        if (size_t(k) == v) material = m["material"];
    std::string uri = image_of_material(material);
    seen.insert(uri);
    GltfOptions opt;
    opt.variant = name;
    auto g = load_gltf<RGB>(dir + "MaterialsVariantsShoe.gltf", opt);
    CHECK(g.variants.size() == 3);
    REQUIRE(g.scene.materials().size() == 1);  // one primitive: one material added
    const auto& mat = std::get<0>(g.scene.materials()[0]);
    REQUIRE(mat.textures);
    REQUIRE(mat.textures->base_color);
    const TextureImage& loaded = *mat.textures->base_color->image;
    int w = 0, h = 0, n = 0;
    unsigned char* px = stbi_load((dir + uri).c_str(), &w, &h, &n, 0);
    REQUIRE(px);
    INFO("variant " << name << ": " << uri);
    CHECK(loaded.width() == w);
    CHECK(loaded.height() == h);
    auto data = loaded.u8_data();
    bool same = data.size() == size_t(w) * size_t(h) * size_t(n) && std::equal(data.begin(), data.end(), px);
    stbi_image_free(px);
    CHECK(same);
  }
  CHECK(seen.size() == 3);  // three different images: the check above can tell them apart
}

namespace {

// A box with a texture whose KHR_texture_basisu source is a .ktx2 image
// that does not exist, with or without a PNG fallback in "source".
json basisu_box(bool fallback, bool required) {
  json m = unlit_material({0.5, 0.25, 1.0});
  m["pbrMetallicRoughness"]["baseColorTexture"] = {{"index", 0}};
  std::vector<std::string> used{"KHR_materials_unlit", "KHR_texture_basisu"};
  json g = box_gltf(1, m, used);
  json tex;
  tex["extensions"]["KHR_texture_basisu"] = {{"source", 1}};
  if (fallback) tex["source"] = 0;
  g["textures"] = json::array({tex});
  g["images"] = json::array({{{"uri", "red.png"}}, {{"uri", "missing.ktx2"}, {"mimeType", "image/ktx2"}}});
  if (required) g["extensionsRequired"] = {"KHR_texture_basisu"};
  return g;
}

}  // namespace

// KHR_materials_anisotropy: the factors reach MetalRoughMaterial, the
// texture is linear, bad factors are errors, the shared test models load
// without a warning about the extension.
TEST_CASE("KHR_materials_anisotropy: strength, rotation and texture load, bad values are errors", "[gltf][anisotropy]") {
  json m = unlit_material({0.5, 0.5, 0.5}, false);
  m["extensions"]["KHR_materials_anisotropy"] = {{"anisotropyStrength", 0.6}, {"anisotropyRotation", 0.5}};
  json g = box_gltf(1, m, {"KHR_materials_anisotropy"});
  auto loaded = load_gltf<RGB>(write_temp("anisotropy.gltf", g));
  CHECK(loaded.warnings.empty());
  REQUIRE(loaded.scene.materials().size() == 1);
  const auto& mat = std::get<0>(loaded.scene.materials()[0]);
  CHECK(mat.anisotropy == Approx(0.6));
  CHECK(mat.anisotropy_rotation == Approx(0.5));
  for (double bad : {-0.1, 1.5}) {
    g["materials"][0]["extensions"]["KHR_materials_anisotropy"]["anisotropyStrength"] = bad;
    std::string e;
    try {
      load_gltf<RGB>(write_temp("anisotropy_bad.gltf", g));
    } catch (const Error& err) {
      e = err.what();
    }
    CHECK(e.find("materials[0].extensions.KHR_materials_anisotropy.anisotropyStrength: must be in [0, 1]") !=
          std::string::npos);
  }
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  for (const char* model : {"AnisotropyStrengthTest", "AnisotropyRotationTest"}) {
    auto a = load_gltf<RGB>(scenes_dir + model + "/glTF-Binary/" + model + ".glb");
    for (const auto& w : a.warnings) CHECK(w.find("anisotropy") == std::string::npos);
    size_t aniso = 0, textured = 0;
    for (const auto& v : a.scene.materials()) {
      const auto& mm = std::get<0>(v);
      aniso += mm.anisotropy > 0;
      textured += mm.textures && mm.textures->anisotropy;
    }
    INFO(model);
    CHECK(aniso > 0);
    if (std::string(model) == "AnisotropyRotationTest") CHECK(textured == 2);  // "+ Texture" and "+ Texture + Rotation"
  }
}

// KHR_materials_clearcoat: factors, textures and the coat's normal map
// reach MetalRoughMaterial; bad factors are errors; ClearCoatTest loads
// without a warning about the extension, its six coated materials coated.
TEST_CASE("KHR_materials_clearcoat: factors and textures load, bad values are errors", "[gltf][clearcoat]") {
  json m = unlit_material({0.5, 0.5, 0.5}, false);
  m["extensions"]["KHR_materials_clearcoat"] = {{"clearcoatFactor", 0.7}, {"clearcoatRoughnessFactor", 0.2}};
  json g = box_gltf(1, m, {"KHR_materials_clearcoat"});
  auto loaded = load_gltf<RGB>(write_temp("clearcoat.gltf", g));
  CHECK(loaded.warnings.empty());
  const auto& mat = std::get<0>(loaded.scene.materials()[0]);
  CHECK(mat.clearcoat == Approx(0.7));
  CHECK(mat.clearcoat_roughness == Approx(0.2));
  for (const char* key : {"clearcoatFactor", "clearcoatRoughnessFactor"})
    for (double bad : {-0.5, 2.0}) {
      json b = g;
      b["materials"][0]["extensions"]["KHR_materials_clearcoat"][key] = bad;
      std::string e;
      try {
        load_gltf<RGB>(write_temp("clearcoat_bad.gltf", b));
      } catch (const Error& err) {
        e = err.what();
      }
      CHECK(e.find(std::string("materials[0].extensions.KHR_materials_clearcoat.") + key + ": must be in [0, 1]") !=
            std::string::npos);
    }
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto a = load_gltf<RGB>(scenes_dir + "ClearCoatTest/glTF-Binary/ClearCoatTest.glb");
  for (const auto& w : a.warnings) CHECK(w.find("clearcoat") == std::string::npos);
  size_t coated = 0, coat_normals = 0, coat_textures = 0;
  for (const auto& v : a.scene.materials()) {
    const auto& mm = std::get<0>(v);
    coated += mm.clearcoat > 0;
    if (mm.textures) {
      coat_normals += bool(mm.textures->clearcoat_normal);
      coat_textures += mm.textures->clearcoat || mm.textures->clearcoat_roughness;
    }
  }
  CHECK(coated == 6);
  CHECK(coat_normals == 2);
  CHECK(coat_textures == 2);
}

// KHR_materials_iridescence: factor, film ior and thickness range reach
// MetalRoughMaterial (defaults 1.3, 100 and 400 nm); bad values are errors;
// IridescenceSuzanne, which requires the extension, loads.
TEST_CASE("KHR_materials_iridescence: factors load, bad values are errors, IridescenceSuzanne loads", "[gltf][iridescence]") {
  json m = unlit_material({0.5, 0.5, 0.5}, false);
  m["extensions"]["KHR_materials_iridescence"] = {{"iridescenceFactor", 0.8}, {"iridescenceThicknessMaximum", 500}};
  json g = box_gltf(1, m, {"KHR_materials_iridescence"});
  g["extensionsRequired"] = {"KHR_materials_iridescence"};
  auto loaded = load_gltf<RGB>(write_temp("iridescence.gltf", g));
  CHECK(loaded.warnings.empty());
  const auto& mat = std::get<0>(loaded.scene.materials()[0]);
  CHECK(mat.iridescence == Approx(0.8));
  CHECK(mat.iridescence_ior == Approx(1.3));
  CHECK(mat.iridescence_thickness_min == Approx(100));
  CHECK(mat.iridescence_thickness_max == Approx(500));
  const std::pair<const char*, double> bad[] = {{"iridescenceFactor", 1.5},
                                                {"iridescenceIor", 0.5},
                                                {"iridescenceThicknessMaximum", -10}};
  for (const auto& [key, value] : bad) {
    json b = g;
    b["materials"][0]["extensions"]["KHR_materials_iridescence"][key] = value;
    std::string e;
    try {
      load_gltf<RGB>(write_temp("iridescence_bad.gltf", b));
    } catch (const Error& err) {
      e = err.what();
    }
    INFO(e);
    CHECK(e.find(std::string("materials[0].extensions.KHR_materials_iridescence.") + key) != std::string::npos);
  }
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto a = load_gltf<RGB>(scenes_dir + "IridescenceSuzanne/glTF-Binary/IridescenceSuzanne.glb");
  size_t films = 0, textured = 0;
  for (const auto& v : a.scene.materials()) {
    const auto& mm = std::get<0>(v);
    films += mm.iridescence > 0;
    textured += mm.textures && mm.textures->iridescence_thickness;
  }
  CHECK(films == 3);
  CHECK(textured == 1);
}

// KHR_materials_sheen: colour, roughness and their textures reach
// MetalRoughMaterial (defaults black and 0); bad values are errors naming
// the member; SheenChair loads both velvets, each with its sheen.
TEST_CASE("KHR_materials_sheen: factors and textures load, bad values are errors, SheenChair loads", "[gltf][sheen]") {
  json m = unlit_material({0.5, 0.5, 0.5}, false);
  m["extensions"]["KHR_materials_sheen"] = {{"sheenColorFactor", {0.8, 0.4, 0.2}}, {"sheenRoughnessFactor", 0.3}};
  json g = box_gltf(1, m, {"KHR_materials_sheen"});
  g["extensionsRequired"] = {"KHR_materials_sheen"};
  auto loaded = load_gltf<RGB>(write_temp("sheen.gltf", g));
  CHECK(loaded.warnings.empty());
  const auto& mat = std::get<0>(loaded.scene.materials()[0]);
  CHECK(mat.sheen_color == RGB(0.8f, 0.4f, 0.2f));
  CHECK(mat.sheen_roughness == Approx(0.3));
  {
    json d = g;
    d["materials"][0]["extensions"]["KHR_materials_sheen"] = json::object();
    auto dl = load_gltf<RGB>(write_temp("sheen_default.gltf", d));
    const auto& dm = std::get<0>(dl.scene.materials()[0]);
    CHECK(dm.sheen_color == RGB(0));
    CHECK(dm.sheen_roughness == 0);
  }
  const std::pair<const char*, json> bad[] = {{"sheenColorFactor", {0.5, 2.0, 0.5}},
                                              {"sheenColorFactor", {0.5, 0.5}},
                                              {"sheenColorFactor", {0.5, "red", 0.5}},
                                              {"sheenRoughnessFactor", -0.5},
                                              {"sheenRoughnessFactor", 1.5}};
  for (const auto& [key, value] : bad) {
    json b = g;
    b["materials"][0]["extensions"]["KHR_materials_sheen"][key] = value;
    std::string e;
    try {
      load_gltf<RGB>(write_temp("sheen_bad.gltf", b));
    } catch (const Error& err) {
      e = err.what();
    }
    INFO(value.dump() << ": " << e);
    CHECK(e.find(std::string("materials[0].extensions.KHR_materials_sheen.") + key) != std::string::npos);
  }
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  auto a = load_gltf<RGB>(scenes_dir + "SheenChair/glTF/SheenChair.gltf");
  for (const auto& w : a.warnings) CHECK(w.find("sheen") == std::string::npos);
  size_t sheened = 0;
  for (const auto& v : a.scene.materials()) {
    const auto& mm = std::get<0>(v);
    if (mm.sheen_color != RGB(0)) {
      ++sheened;
      CHECK(mm.sheen_roughness == Approx(0.8));
    }
  }
  CHECK(sheened >= 1);
  auto p = load_gltf<RGB>(scenes_dir + "SheenChair/glTF/SheenChair.gltf", [] {
    GltfOptions o;
    o.variant = "Peacock Velvet";
    return o;
  }());
  bool peacock = false;
  for (const auto& v : p.scene.materials())
    peacock |= std::get<0>(v).sheen_color == RGB(0.013f, 0.284f, 0.298f);
  CHECK(peacock);
}

TEST_CASE("KHR_texture_basisu: the fallback image when optional, a clear error when required", "[gltf][basisu]") {
  std::string dir = std::string(PRISM_TEST_TMP_DIR) + "/gltf_extensions";
  std::filesystem::create_directories(dir);
  write_png(dir + "/red.png", Image{2, 2, std::vector<float>{1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0}});
  auto mentions = [](const std::vector<std::string>& warnings, const std::string& what) {
    return std::any_of(warnings.begin(), warnings.end(),
                       [&](const std::string& w) { return w.find(what) != std::string::npos; });
  };
  {  // optional, with a fallback: the PNG is used
    auto g = load_gltf<RGB>(write_temp("basisu_fallback.gltf", basisu_box(true, false)));
    CHECK(mentions(g.warnings, "KHR_texture_basisu"));
    g.scene.build();
    Window w = top_face<RGB>(g, 1);
    // 1e-5: as in the unlit checks above, a float colour averaged in double and rounded once
    CHECK(std::abs(w.mean[0] - 0.5) <= 1e-5);
    CHECK(w.mean[1] == 0);
  }
  {  // optional, no fallback: the texture is dropped with a warning, the factor stays
    auto g = load_gltf<RGB>(write_temp("basisu_none.gltf", basisu_box(false, false)));
    CHECK(mentions(g.warnings, "textures[0]: no source image"));
    g.scene.build();
    Window w = top_face<RGB>(g, 1);
    CHECK(std::abs(w.mean[1] - 0.25) <= 1e-5);
  }
  {  // required: an error naming the extension
    std::string e;
    try {
      load_gltf<RGB>(write_temp("basisu_required.gltf", basisu_box(true, true)));
    } catch (const Error& err) {
      e = err.what();
    }
    INFO(e);
    CHECK(e.find("basisu_required.gltf") != std::string::npos);
    CHECK(e.find("KHR_texture_basisu") != std::string::npos);
    CHECK(e.find("KTX2") != std::string::npos);
  }
}

namespace {

// A box whose base colour texture has a PNG fallback (red) in "source" and,
// with `webp_ext`, a WebP image in EXT_texture_webp; images: red.png, and
// the WebP file `webp_name`.
json webp_box(bool webp_ext, bool fallback, bool required, const std::string& webp_name) {
  json m;
  m["pbrMetallicRoughness"] = {{"baseColorTexture", {{"index", 0}}}, {"metallicFactor", 0}};
  std::vector<std::string> used;
  if (webp_ext) used.push_back("EXT_texture_webp");
  json g = box_gltf(1, m, used);
  json tex = json::object();
  if (fallback) tex["source"] = 0;
  if (webp_ext) tex["extensions"]["EXT_texture_webp"] = {{"source", 1}};
  g["textures"] = json::array({tex});
  g["images"] = json::array({{{"uri", "red.png"}}, {{"uri", webp_name}, {"mimeType", "image/webp"}}});
  if (required) g["extensionsRequired"] = {"EXT_texture_webp"};
  return g;
}

std::string tmp_dir() {
  std::string dir = std::string(PRISM_TEST_TMP_DIR) + "/gltf_extensions";
  std::filesystem::create_directories(dir);
  write_png(dir + "/red.png", Image{2, 2, std::vector<float>{1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0}});
  return dir;
}

}  // namespace

// One test name in either build (ctest lists the names from the source):
// with libwebp the WebP texels, without it the fallback and the error.
TEST_CASE("EXT_texture_webp: the WebP image texel for texel, else the fallback or an error", "[gltf][webp]") {
#if defined(PRISM_HAS_WEBP)
  std::string dir = tmp_dir();
  // A 3 x 2 lossless WebP, every texel different; and one with alpha (none 0:
  // the lossless encoder drops the colour of fully transparent texels).
  const std::vector<uint8_t> rgb{10, 20, 30, 40, 50, 60, 70, 80, 90, 100, 110, 120, 130, 140, 150, 160, 170, 180};
  const std::vector<uint8_t> rgba{10, 20, 30, 1, 40, 50, 60, 85, 70, 80, 90, 170, 100, 110, 120, 255};
  auto write_webp = [&](const std::string& name, const std::vector<uint8_t>& px, int w, int h, bool alpha) {
    uint8_t* out = nullptr;
    size_t n = alpha ? WebPEncodeLosslessRGBA(px.data(), w, h, w * 4, &out)
                     : WebPEncodeLosslessRGB(px.data(), w, h, w * 3, &out);
    REQUIRE(n > 0);
    std::vector<char> bytes(out, out + n);
    WebPFree(out);
    std::ofstream(dir + "/" + name, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
    return bytes;
  };
  auto texture_of = [](const auto& g) -> const TextureImage& {
    const auto& mat = std::get<0>(g.scene.materials()[0]);
    REQUIRE(mat.textures);
    REQUIRE(mat.textures->base_color);
    return *mat.textures->base_color->image;
  };
  auto bytes = write_webp("texels.webp", rgb, 3, 2, false);
  write_webp("alpha.webp", rgba, 2, 2, true);
  for (bool fallback : {true, false})
    for (bool required : {false, true}) {
      INFO("fallback " << fallback << " required " << required);
      auto g = load_gltf<RGB>(write_temp("webp.gltf", webp_box(true, fallback, required, "texels.webp")));
      CHECK(g.warnings.empty());
      const TextureImage& t = texture_of(g);
      CHECK(t.width() == 3);
      CHECK(t.height() == 2);
      CHECK(t.channels() == 3);
      auto d = t.u8_data();
      CHECK(std::vector<uint8_t>(d.begin(), d.end()) == rgb);
    }
  {
    auto g = load_gltf<RGB>(write_temp("webp_alpha.gltf", webp_box(true, true, false, "alpha.webp")));
    const TextureImage& t = texture_of(g);
    CHECK(t.channels() == 4);
    auto d = t.u8_data();
    CHECK(std::vector<uint8_t>(d.begin(), d.end()) == rgba);
  }
  // Broken WebP files: an error naming the image, never a crash.
  auto load_error = [&](const std::string& name, const std::vector<char>& file) {
    std::ofstream(dir + "/" + name, std::ios::binary).write(file.data(), std::streamsize(file.size()));
    try {
      load_gltf<RGB>(write_temp("webp_bad.gltf", webp_box(true, true, false, name)));
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  std::vector<char> truncated(bytes.begin(), bytes.begin() + std::ptrdiff_t(bytes.size() / 2));
  std::string e = load_error("truncated.webp", truncated);
  INFO(e);
  CHECK(e.find("webp_bad.gltf: images[1] ('truncated.webp')") != std::string::npos);
  CHECK(e.find("truncated WebP") != std::string::npos);
  std::vector<char> garbage = bytes;
  for (size_t i = 20; i < garbage.size(); ++i) garbage[i] = char(0x5a);
  e = load_error("garbage.webp", garbage);
  CHECK(e.find("images[1] ('garbage.webp')") != std::string::npos);
  CHECK(e.find("WebP") != std::string::npos);
#else
  tmp_dir();
  auto g = load_gltf<RGB>(write_temp("webp.gltf", webp_box(true, true, false, "missing.webp")));
  CHECK(!g.warnings.empty());
  std::string e;
  try {
    load_gltf<RGB>(write_temp("webp_required.gltf", webp_box(true, true, true, "missing.webp")));
  } catch (const Error& err) {
    e = err.what();
  }
  CHECK(e.find("EXT_texture_webp") != std::string::npos);
#endif
}

namespace {

// The world-space triangles of a loaded scene, as centroids and the three
// corners, for comparing a compressed twin with its plain file whatever the
// order of vertices and triangles.
struct Tri {
  std::array<double, 3> c;
  std::array<std::array<double, 3>, 3> v;
};
template <class G>
std::vector<Tri> world_triangles(const G& g) {
  std::vector<Tri> out;
  const auto& meshes = g.scene.accel().meshes();
  for (const auto& m : meshes)
    for (size_t t = 0; t + 2 < m.indices.size(); t += 3) {
      Tri tri{};
      for (int k = 0; k < 3; ++k) {
        const Point3f& p = m.positions[m.indices[t + size_t(k)]];
        tri.v[size_t(k)] = {p.x, p.y, p.z};
        for (int a = 0; a < 3; ++a) tri.c[size_t(a)] += tri.v[size_t(k)][size_t(a)] / 3;
      }
      out.push_back(tri);
    }
  return out;
}

// Each triangle of `twin` has a triangle of `plain` whose centroid lies
// within `tol` per axis; returns the largest such distance (or infinity).
[[maybe_unused]] double worst_match(const std::vector<Tri>& twin, const std::vector<Tri>& plain, double tol) {
  // A grid of cell `tol` over the plain centroids.
  std::map<std::array<long, 3>, std::vector<size_t>> grid;
  auto cell = [&](const std::array<double, 3>& c) {
    return std::array<long, 3>{long(std::floor(c[0] / tol)), long(std::floor(c[1] / tol)), long(std::floor(c[2] / tol))};
  };
  for (size_t i = 0; i < plain.size(); ++i) grid[cell(plain[i].c)].push_back(i);
  double worst = 0;
  for (const Tri& t : twin) {
    auto c = cell(t.c);
    double best = std::numeric_limits<double>::infinity();
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy)
        for (long dz = -1; dz <= 1; ++dz) {
          auto f = grid.find({c[0] + dx, c[1] + dy, c[2] + dz});
          if (f == grid.end()) continue;
          for (size_t i : f->second) {
            double d = 0;
            for (int a = 0; a < 3; ++a) d = std::max(d, std::abs(plain[i].c[size_t(a)] - t.c[size_t(a)]));
            best = std::min(best, d);
          }
        }
    worst = std::max(worst, best);
  }
  return worst;
}

}  // namespace

// Draco quantizes positions to q bits over the mesh's bounding box (the
// Draco encoder's and gltf-pipeline's default is q = 11 or more): a vertex
// moves by at most half a step, extent / 2^(q+1), per axis, and so does a
// centroid. Tolerance: one step at 11 bits, extent / 2^11.
TEST_CASE("KHR_draco_mesh_compression: the Draco twins give the plain files' triangles", "[gltf][draco]") {
#if defined(PRISM_HAS_DRACO)
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  for (const char* model : {"CesiumMan/glTF-Draco/CesiumMan.gltf", "MorphPrimitivesTest/glTF-Draco/MorphPrimitivesTest.gltf"}) {
    std::string name = model;
    std::string plain_path = scenes_dir + name.substr(0, name.find('/')) + "/glTF-Binary/" +
                             name.substr(name.rfind('/') + 1, name.rfind('.') - name.rfind('/') - 1) + ".glb";
    INFO(model << " against " << plain_path);
    auto twin = load_gltf<RGB>(scenes_dir + model);
    auto plain = load_gltf<RGB>(plain_path);
    for (const auto& w : twin.warnings) CHECK(w.find("draco") == std::string::npos);
    CHECK(twin.mesh_triangles == plain.mesh_triangles);
    CHECK(twin.scene_triangles == plain.scene_triangles);
    auto a = world_triangles(twin), b = world_triangles(plain);
    REQUIRE(a.size() == b.size());
    Vector3f extent = plain.bounds.max - plain.bounds.min;
    double tol = std::max({extent.x, extent.y, extent.z}) / 2048.0;
    double worst = worst_match(a, b, tol);
    INFO("worst centroid distance " << worst << ", tolerance " << tol);
    CHECK(worst <= tol);
    CHECK(worst_match(b, a, tol) <= tol);  // and the other way: no triangle lost
  }
#else
  // Without libdraco the extension (always required) is refused by name.
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  std::string e;
  try {
    load_gltf<RGB>(scenes_dir + "CesiumMan/glTF-Draco/CesiumMan.gltf");
  } catch (const Error& err) {
    e = err.what();
  }
  CHECK(e.find("'KHR_draco_mesh_compression' is required") != std::string::npos);
#endif
}

TEST_CASE("KHR_draco_mesh_compression: bad Draco data is an error naming the primitive", "[gltf][draco]") {
#if defined(PRISM_HAS_DRACO)
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  std::string src = scenes_dir + "CesiumMan/glTF-Draco/";
  std::string dir = std::string(PRISM_TEST_TMP_DIR) + "/gltf_draco";
  std::filesystem::create_directories(dir);
  json j = json::parse(std::ifstream(src + "CesiumMan.gltf"));
  for (const char* f : {"CesiumMan_data.bin", "CesiumMan_img0.jpg"})
    std::filesystem::copy_file(src + f, dir + "/" + f, std::filesystem::copy_options::overwrite_existing);
  const auto& prim_ext = j["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"];
  int view = prim_ext["bufferView"];
  auto load_error = [&](const json& g) {
    std::ofstream(dir + "/bad.gltf") << g.dump();
    try {
      load_gltf<RGB>(dir + "/bad.gltf");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  {  // the compressed bytes overwritten (a copy of the buffer with the view's bytes zeroed)
    std::ifstream in(src + "CesiumMan_data.bin", std::ios::binary);
    std::vector<char> bin((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    size_t off = j["bufferViews"][size_t(view)].value("byteOffset", 0);
    size_t len = j["bufferViews"][size_t(view)]["byteLength"];
    for (size_t i = off + 8; i < off + len; ++i) bin[i] = char(0xa5);
    std::ofstream(dir + "/zeroed.bin", std::ios::binary).write(bin.data(), std::streamsize(bin.size()));
    json g = j;
    g["buffers"][0]["uri"] = "zeroed.bin";
    std::string e = load_error(g);
    INFO(e);
    CHECK(e.find("bad.gltf: meshes[0].primitives[0].extensions.KHR_draco_mesh_compression") != std::string::npos);
  }
  {
    json g = j;
    g["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["bufferView"] = 99;
    std::string e = load_error(g);
    CHECK(e.find("KHR_draco_mesh_compression.bufferView: bufferView index 99 out of range") != std::string::npos);
  }
  {
    json g = j;
    g["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"]["attributes"]["POSITION"] = 42;
    std::string e = load_error(g);
    CHECK(e.find("KHR_draco_mesh_compression.attributes.POSITION: the Draco data has no attribute") !=
          std::string::npos);
  }
#else
  SUCCEED("prism::gltf was built without libdraco: nothing to decode");
#endif
}

}  // namespace extensions_test
