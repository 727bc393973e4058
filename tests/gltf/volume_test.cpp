// KHR_materials_volume and KHR_materials_dispersion in the glTF loader:
// refracting volumes with Beer–Lambert absorption inside, checked against
// closed forms on boxes built in code (a small glTF written to a temporary
// file) and on the shared AttenuationTest model (skipped when ../shared is
// absent), in RGB and spectral mode; the Abbe-law mapping of `dispersion`.
//
// Closed form. An orthographic camera looks straight down (-z) through the
// top and bottom faces of a box of height d (normal incidence everywhere),
// under a uniform white environment of radiance 1. With tau = c^(d / D) the
// Beer–Lambert transmittance of one crossing (c = attenuationColor, D =
// attenuationDistance) and R = ((n - 1) / (n + 1))^2 the Fresnel reflectance
// of one smooth face at normal incidence, summing the paths that leave
// through the bottom after 2k inner reflections and through the top after
// 2k + 1 gives every pixel
//   L = R + (1 - R)^2 tau (1 + R tau) / (1 - R^2 tau^2) = R + (1 - R)^2 tau / (1 - R tau)
// (the 1/n^2 radiance factors of entering and leaving cancel). ior 1 gives
// L = tau exactly.
#include <catch2/catch.hpp>
#include "support/gltf_json.hpp"
#include "support/skip.hpp"
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <prism/io/gltf.hpp>
#include <prism/prism.hpp>
#include "support/reference_physics.hpp"

namespace volume_test {

using namespace prism;
using nlohmann::json;
using gltf_json::box_gltf;

namespace {

std::string write_temp(const std::string& name, const json& g) {
  return gltf_json::write_temp_gltf("gltf_volume", name, g);
}

const std::string scenes_dir = std::string(PRISM_SHARED_DIR) + "/scenes/";
bool have_scenes() { return std::filesystem::exists(scenes_dir + "README.md"); }

// A transmissive, smooth, white volume material.
json volume_material(double ior, std::array<double, 3> color, double distance, double thickness = 1,
                     double dispersion = 0) {
  json m;
  m["pbrMetallicRoughness"] = {{"metallicFactor", 0}, {"roughnessFactor", 0}};
  m["extensions"]["KHR_materials_transmission"] = {{"transmissionFactor", 1}};
  m["extensions"]["KHR_materials_ior"] = {{"ior", ior}};
  json v = {{"thicknessFactor", thickness}, {"attenuationColor", color}};
  if (std::isfinite(distance)) v["attenuationDistance"] = distance;
  m["extensions"]["KHR_materials_volume"] = v;
  if (dispersion != 0) m["extensions"]["KHR_materials_dispersion"] = {{"dispersion", dispersion}};
  return m;
}

double closed_form(double n, double tau) {
  double R = (n - 1) * (n - 1) / ((n + 1) * (n + 1));
  return R + (1 - R) * (1 - R) * tau / (1 - R * tau);
}

// Renders a small orthographic window, looking down -z, centred on (x, y),
// under a uniform white environment, and checks the window's mean per
// channel against expected within z sigma of the mean plus `bias` (pooled
// over the window's 16 pixels of 64 samples), z from Sidak's correction over
// the caller's test case at a family-wise false-alarm rate of 10^-3
// (sidak_z(1e-3, m), m = 3 channels x the windows it checks). Without Russian roulette: the
// samples are then 1 (reflected off the top face) or the Beer–Lambert
// product of the path inside, so the estimate is exact at ior 1 and has a
// small variance otherwise (with roulette a sample is 0 or the throughput
// over its survival probability: a sigma ~30 times larger, and a pixel whose
// samples all survived shows a sample variance of 0). Every pixel must be finite.
template <class S, class G>
void check_window(G& g, Float x, Float y, Float half, const std::array<double, 3>& expected, double bias,
                  double z, const std::string& label) {
  const int w = 4, h = 4;
  OrthographicCamera cam(look_at_camera_to_world({x, y, 10}, {x, y, 0}, {0, 1, 0}), 2 * half, w, h);
  Film film(w, h);
  RenderOptions opt;
  opt.spp = 64;
  opt.threads = 1;
  PathOptions popt;
  popt.rr_min_depth = 1000;
  render(g.scene, cam, PathIntegrator(popt), film, opt);
  for (int c = 0; c < 3; ++c) {
    double sum = 0, var = 0;
    for (int py = 0; py < h; ++py)
      for (int px = 0; px < w; ++px) {
        double v = film.pixel(px, py)[c];
        CHECK(std::isfinite(v));
        sum += v;
        var += double(film.variance(px, py)[c]);
      }
    double mean = sum / (w * h), sigma = std::sqrt(var) / (w * h);
    INFO(label << " channel " << c << ": " << mean << " expected " << expected[size_t(c)] << " sigma " << sigma);
    CHECK(std::abs(mean - expected[size_t(c)]) <= z * sigma + bias);
  }
}

template <class S>
void check_box(double ior, double d, std::array<double, 3> color, double distance, double bias, double z) {
  std::string path = write_temp("box.gltf", box_gltf(float(d), volume_material(ior, color, distance),
                                                     {"KHR_materials_transmission", "KHR_materials_ior",
                                                      "KHR_materials_volume"}));
  auto g = load_gltf<S>(path);
  CHECK(g.warnings.empty());
  const auto& mat = std::get<0>(g.scene.materials()[0]);
  CHECK(mat.is_volume());
  g.scene.add_light(UniformInfiniteLight<S>(RGB(1.f)));
  g.scene.build();
  std::array<double, 3> expected;
  for (size_t c = 0; c < 3; ++c) expected[c] = closed_form(ior, std::pow(color[c], d / distance));
  INFO("ior " << ior << " thickness " << d << " distance " << distance);
  check_window<S>(g, 0, 0, 0.3f, expected, bias, z, "box");
}

}  // namespace

TEST_CASE("glTF volume box transmits the Beer-Lambert closed form, RGB", "[gltf][volume]") {
  const std::array<double, 3> c{0.1, 0.5, 0.9};
  // 5 boxes x 3 channels = 15 comparisons, one family at 10^-3: z = 3.99.
  const double z = reference_physics::sidak_z(1e-3, 5 * 3);
  check_box<RGB>(1.0, 1.0, c, 1.0, 1e-5, z);  // no refraction: exactly tau
  check_box<RGB>(1.0, 0.5, c, 2.0, 1e-5, z);
  check_box<RGB>(1.5, 1.0, c, 1.0, 1e-5, z);  // refracting, with inner reflections
  check_box<RGB>(1.5, 2.0, c, 0.5, 1e-5, z);
  check_box<RGB>(1.5, 1.0, {1, 1, 1}, std::numeric_limits<double>::infinity(), 1e-5, z);  // no absorption
}

// Spectral: the attenuation colour is uplifted and attenuated per wavelength,
// and the power of a spectrum is not the spectrum of the power, so the film's
// RGB is allowed 0.02 beside the z sigma (2 boxes x 3 channels = 6
// comparisons at 10^-3: z = sidak_z(1e-3, 6) = 3.77).
TEST_CASE("glTF volume box transmits the Beer-Lambert closed form, spectral", "[gltf][volume][spectral]") {
  const std::array<double, 3> c{0.3, 0.6, 0.9};
  const double z = reference_physics::sidak_z(1e-3, 2 * 3);
  check_box<Spectral>(1.0, 1.0, c, 1.0, 0.02, z);
  check_box<Spectral>(1.5, 1.0, c, 2.0, 0.02, z);
}

TEST_CASE("glTF volume: thickness 0 stays thin-walled, bad attenuation values are errors", "[gltf][volume][validate]") {
  const std::vector<std::string> ext{"KHR_materials_transmission", "KHR_materials_volume"};
  {
    auto g = load_gltf<RGB>(write_temp("thin.gltf", box_gltf(1, volume_material(1.5, {0.5, 0.5, 0.5}, 1, 0), ext)));
    const auto& mat = std::get<0>(g.scene.materials()[0]);
    CHECK_FALSE(mat.is_volume());
    CHECK(bxdf_traits<MetalRoughBxDF<RGB>>::volume(mat) == nullptr);
    SurfaceInteraction si;
    CHECK_FALSE(bxdf_traits<MetalRoughBxDF<RGB>>::make(mat, si, RGBWavelengths{}).is_refractive());
  }
  {
    auto g = load_gltf<RGB>(write_temp("vol.gltf", box_gltf(1, volume_material(1.5, {0.5, 0.5, 0.5}, 1, 0.01), ext)));
    const auto& mat = std::get<0>(g.scene.materials()[0]);
    CHECK(mat.is_volume());
    CHECK(bxdf_traits<MetalRoughBxDF<RGB>>::volume(mat) != nullptr);
    SurfaceInteraction si;
    CHECK(bxdf_traits<MetalRoughBxDF<RGB>>::make(mat, si, RGBWavelengths{}).is_refractive());
    for (const auto& w : g.warnings) CHECK(w.find("thin-walled") == std::string::npos);
  }
  auto expect_error = [&](const json& material, const std::string& element) {
    std::string path = write_temp("bad_volume.gltf", box_gltf(1, material, ext));
    try {
      (void)load_gltf<RGB>(path);
      FAIL("no error for " << element);
    } catch (const Error& e) {
      std::string what = e.what();
      INFO(what);
      CHECK(what.find(element) != std::string::npos);
      CHECK(what.find("bad_volume.gltf") != std::string::npos);
    }
  };
  expect_error(volume_material(1.5, {1.5, 0.5, 0.5}, 1),
               "materials[0].extensions.KHR_materials_volume.attenuationColor");
  expect_error(volume_material(1.5, {0.5, 0.5, 0.5}, -1),
               "materials[0].extensions.KHR_materials_volume.attenuationDistance");
  expect_error(volume_material(1.5, {0.5, 0.5, 0.5}, 1, -2),
               "materials[0].extensions.KHR_materials_volume.thicknessFactor");
  expect_error(volume_material(1.5, {0.5, 0.5, 0.5}, 1, 1, -0.5),
               "materials[0].extensions.KHR_materials_dispersion.dispersion");
}

TEST_CASE("glTF dispersion 0.312 is the Abbe law with V_d = 64.1", "[gltf][volume][dispersion]") {
  const std::vector<std::string> ext{"KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume",
                                     "KHR_materials_dispersion"};
  const double n_d = 1.5168, dispersion = 0.312;
  auto g = load_gltf<Spectral>(write_temp("dispersive.gltf",
                                          box_gltf(1, volume_material(n_d, {0.9, 0.9, 0.9}, 2, 1, dispersion), ext)));
  CHECK(g.warnings.empty());
  const auto& mat = std::get<0>(g.scene.materials()[0]);
  REQUIRE(mat.is_volume());
  IOR ior = mat.volume_ior();
  CHECK(ior.is_dispersive());
  CHECK(bxdf_traits<MetalRoughBxDF<Spectral>>::needs_spectral(mat));
  const double V = 20 / dispersion;
  // 1e-3: the extension quotes V_d = 64.1 to 3 digits (20 / 0.312 = 64.103)
  CHECK(V == Approx(64.1).epsilon(1e-3));
  // The extension's closed form at two wavelengths, and the Abbe number's
  // definition (n_F - n_C = (n_d - 1) / V_d, to the rounding of its constants).
  for (double l : {450.0, 650.0}) {
    double expected = n_d + (n_d - 1) / V * (523655 / (l * l) - 1.5168);
    // 1e-6 relative: the closed form in float, a few roundings of η ≈ 1.5
    CHECK(double(ior(Float(l))) == Approx(expected).epsilon(1e-6));
  }
  // 1e-4: the constants are rounded (523655 / λd² − 1.5168 ≈ 3e-5, times (n_d − 1)/V: 2.6e-7) plus float; 2e-3: they give
  // n_F − n_C = 1.00006 (n_d − 1)/V, and its float cancellation costs 2 ulps of 1.5 over 0.008 = 3e-5
  CHECK(double(ior(lambda_d_nm)) == Approx(n_d).epsilon(1e-4));
  CHECK(double(ior(lambda_F_nm) - ior(lambda_C_nm)) == Approx((n_d - 1) / V).epsilon(2e-3));
  // The BxDF's eta is the hero wavelength's, and building it at a path vertex
  // terminates the secondary wavelengths.
  auto lambda = SampledWavelengths<4>::from({450, 520, 610, 680}, {1, 1, 1, 1});
  SurfaceInteraction si;
  auto b = bxdf_traits<MetalRoughBxDF<Spectral>>::make(mat, si, lambda);
  REQUIRE(b.is_refractive());
  // 1e-6 relative: as above, the closed form in float
  CHECK(double(b.glass().eta()) == Approx(n_d + (n_d - 1) / V * (523655 / (450.0 * 450.0) - 1.5168)).epsilon(1e-6));
  CHECK(lambda.secondary_terminated());
  // A spectral render of the dispersive volume is finite.
  g.scene.add_light(UniformInfiniteLight<Spectral>(RGB(1.f)));
  g.scene.build();
  CHECK(g.scene.needs_spectral());
  auto cam = gltf_framing_camera(g.bounds, 16, 16);
  Film film(16, 16);
  RenderOptions opt;
  opt.spp = 16;
  opt.threads = 1;
  render(g.scene, cam, PathIntegrator(), film, opt);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) CHECK(film.pixel(x, y).is_finite());
}

// AttenuationTest: rows 2-5 (thickness factor, thickness texture, node scale,
// attenuation distance) hold volume cubes whose Beer–Lambert transmittance
// straight through is c^s in column s (s = 0.25, 0.5, 1, 1.5, 2; c = (0.1,
// 0.5, 0.9)): each cube is checked face-on against the closed form above
// (ior 1.5). Row 1, the answer key, is a thin-walled quad of base colour c^s:
// it shows F0 + (1 - F0) c^s (F0 = 0.04). The backdrop and labels are
// dropped (their nodes removed from the scene) so the cubes are seen against
// the uniform environment.
TEST_CASE("AttenuationTest cubes follow the Beer-Lambert closed form in every row", "[gltf][volume][models]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  const std::string dir = scenes_dir + "AttenuationTest/glTF/";
  {  // the model as it is: no warning about thin walls, renders finite
    auto g = load_gltf<RGB>(dir + "AttenuationTest.gltf");
    for (const auto& w : g.warnings) CHECK(w.find("thin-walled") == std::string::npos);
    int volumes = 0;
    for (const auto& m : g.scene.materials()) volumes += std::get<0>(m).is_volume() ? 1 : 0;
    CHECK(volumes == 11);
    g.scene.add_light(UniformInfiniteLight<RGB>(RGB(1.f)));
    g.scene.build();
    Film film(32, 32);
    RenderOptions opt;
    opt.spp = 4;
    opt.threads = 1;
    render(g.scene, gltf_framing_camera(g.bounds, 32, 32), PathIntegrator(), film, opt);
    for (int y = 0; y < 32; ++y)
      for (int x = 0; x < 32; ++x) CHECK(film.pixel(x, y).is_finite());
  }
  json gltf;
  {
    std::ifstream f(dir + "AttenuationTest.gltf");
    gltf = json::parse(f);
  }
  // The edited copy goes to the temporary folder, with the files it refers to.
  const std::string tmp = std::string(PRISM_TEST_TMP_DIR) + "/gltf_volume/";
  std::filesystem::create_directories(tmp);
  for (const char* f : {"AttenuationTest.bin", "AttenuationLabels.png", "PlainGrid.png", "ThicknessTexture.png"})
    std::filesystem::copy_file(dir + f, tmp + f, std::filesystem::copy_options::overwrite_existing);
  json kept = json::array();
  std::map<std::string, std::array<double, 3>> translation;
  for (size_t i = 0; i < gltf["nodes"].size(); ++i) {
    const auto& n = gltf["nodes"][i];
    std::string name = n.value("name", "");
    if (name != "Labels" && name != "MeterGrid") kept.push_back(i);
    if (n.contains("translation")) translation[name] = n["translation"].get<std::array<double, 3>>();
  }
  gltf["scenes"][0]["nodes"] = kept;
  auto g = load_gltf<RGB>(write_temp("attenuation_cubes.gltf", gltf));
  g.scene.add_light(UniformInfiniteLight<RGB>(RGB(1.f)));
  g.scene.build();
  const std::array<double, 3> c{0.1, 0.5, 0.9};
  const double F0 = 0.04;
  // 5 sizes x 5 windows x 3 channels = 75 comparisons, one family at 10^-3
  // (Sidak): z = sidak_z(1e-3, 75) = 4.36.
  const double z = reference_physics::sidak_z(1e-3, 5 * 5 * 3);
  for (const char* s : {"0.25", "0.50", "1.0", "1.5", "2.0"}) {
    double size = std::stod(s);
    std::array<double, 3> volume_expected, sample_expected;
    for (size_t k = 0; k < 3; ++k) {
      double tau = std::pow(c[k], size);
      volume_expected[k] = closed_form(1.5, tau);
      sample_expected[k] = F0 + (1 - F0) * tau;
    }
    // Row 3 is one mesh whose cubes sit under row 2's, at y = 0.
    auto r2 = translation.at(std::string("R2_Block_") + s);
    const Float half = Float(std::min(0.05, size / 8));
    for (std::string row : {"R2_Block_", "R4_Block_", "R5_Block_"}) {
      auto t = translation.at(row + s);
      check_window<RGB>(g, Float(t[0]), Float(t[1]), half, volume_expected, 1e-4, z, row + s);
    }
    check_window<RGB>(g, Float(r2[0]), 0, half, volume_expected, 1e-4, z, std::string("R3 row, column ") + s);
    auto t1 = translation.at(std::string("R1_Sample_") + s);
    check_window<RGB>(g, Float(t1[0]), Float(t1[1]), half, sample_expected, 1e-4, z, std::string("R1_Sample_") + s);
  }
}

TEST_CASE("GltfOptions multiple_scattering turns on energy compensation of every material", "[gltf][bxdf]") {
  const std::vector<std::string> ext{"KHR_materials_transmission", "KHR_materials_volume"};
  json m = volume_material(1.5, {0.5, 0.5, 0.5}, 1, 0.01);
  m["pbrMetallicRoughness"]["roughnessFactor"] = 1;  // rough enough to be compensated
  std::string path = write_temp("ms.gltf", box_gltf(1, m, ext));
  GltfOptions opt;
  opt.multiple_scattering = true;
  auto off = load_gltf<RGB>(path);
  auto on = load_gltf<RGB>(path, opt);
  const auto& mat_off = std::get<0>(off.scene.materials()[0]);
  const auto& mat_on = std::get<0>(on.scene.materials()[0]);
  CHECK_FALSE(mat_off.multiple_scattering);
  CHECK(mat_on.multiple_scattering);
  // The BxDFs made from them: only the second compensates.
  SurfaceInteraction si;
  si.n = si.ns = Normal3f(0, 0, 1);
  CHECK_FALSE(bxdf_traits<MetalRoughBxDF<RGB>>::make(mat_off, si, RGBWavelengths{}).multiple_scattering());
  CHECK(bxdf_traits<MetalRoughBxDF<RGB>>::make(mat_on, si, RGBWavelengths{}).multiple_scattering());
}

}  // namespace volume_test
