// Texture filtering end to end: a fine checkerboard (256 x 256 texels of
// albedo 0 and 1) on a quad facing the camera, 16 x 16 pixels, so that a
// pixel spans 16 texels; a Lambertian material (metallic 0, specular 0)
// under a uniform environment of radiance 1 with BSDF sampling and no
// Russian roulette, so each sample is exactly the albedo the texture lookup
// returned. With trilinear or EWA filtering over the pixel's footprint
// (Scene::set_pixel_footprint at 1 spp: scale 1, 16 texels, level 4) every
// level from 1 on is 0.5 everywhere, so every pixel is 0.5 at 1 spp up to
// float rounding (1e-5); with the default bilinear lookup a pixel at 1 spp
// is the bilinear blend of four texels at its sample, and the pixels spread
// (variance 1/36). Without a footprint model the filters fall back to bilinear: the
// image equals the bilinear one bit for bit.
#include <catch2/catch.hpp>
#include <cmath>
#include <prism/prism.hpp>

namespace texture_filter_test {

using namespace prism;

namespace {

Film render_checker(TextureFilter filter, bool footprint, int spp) {
  std::vector<float> v(256 * 256);
  for (int y = 0; y < 256; ++y)
    for (int x = 0; x < 256; ++x) v[size_t(y) * 256 + size_t(x)] = float((x + y) % 2);
  auto textures = std::make_shared<MetalRoughTextures>();
  ImageTexture t;
  t.image = std::make_shared<const TextureImage>(TextureImage::from_f32(256, 256, 1, std::move(v)));
  t.filtering = filter;
  t.build_mipmaps();
  textures->base_color = t;
  MetalRoughMaterial m;
  m.base_color = RGB(1);
  m.metallic = 0;
  m.specular = 0;
  m.roughness = 1;
  m.textures = textures;
  Scene<RGB, bxdf_set<MetalRoughBxDF<RGB>>> scene;
  TriangleMesh quad;
  append_quad(quad, {-1, -1, 3}, {2, 0, 0}, {0, 2, 0});
  scene.add_instance(scene.add_mesh(quad), scene.add_material(m));
  scene.add_light(UniformInfiniteLight<RGB>(RGB(1)));
  scene.build();
  // The quad fills the view exactly: at distance 3, half-height 1.
  PerspectiveCamera cam(look_at_camera_to_world({0, 0, 0}, {0, 0, 1}, {0, 1, 0}), Float(2 * std::atan(1.0 / 3)), 16, 16);
  if (footprint) scene.set_pixel_footprint(PixelFootprint(cam, spp));
  Film film(16, 16);
  RenderOptions opt;
  opt.spp = spp;
  opt.seed = 3;
  PathOptions popt;
  popt.rr_min_depth = 1000;
  render(scene, cam, BSDFPathIntegrator(popt), film, opt);
  return film;
}

}  // namespace

TEST_CASE("trilinear and EWA filter a fine checkerboard to its mean at 1 spp, bilinear does not", "[render][textures][mipmap]") {
  for (TextureFilter f : {TextureFilter::trilinear, TextureFilter::ewa}) {
    Film film = render_checker(f, true, 1);
    double worst = 0;
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < 16; ++x) worst = std::max(worst, std::abs(double(film.pixel(x, y).g) - 0.5));
    INFO(texture_filter_name(f) << ": worst pixel off 0.5 by " << worst);
    CHECK(worst <= 1e-5);
  }
  Film plain = render_checker(TextureFilter::bilinear, true, 1);
  double sum = 0, sum2 = 0;
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      const double g = plain.pixel(x, y).g;
      sum += g;
      sum2 += g * g;
    }
  const double mean = sum / 256, var = sum2 / 256 - mean * mean;
  INFO("bilinear: mean " << mean << " variance " << var);
  // Bilinear on the checkerboard at a uniform position (a, b) in a texel
  // cell is a + b - 2ab: variance E[(a + b - 2ab)^2] - 1/4 = 1/36 = 0.0278.
  // (g - 1/2)^2 <= 1/4, so its variance is at most 1/4 of its mean and the
  // 256-pixel estimate's sigma at most sqrt(0.0278 / 4 / 256) = 0.0052: 4
  // sigma below 1/36 is 0.0068.
  CHECK(var > 0.0068);
  // No footprint model: every filter is the bilinear lookup, bit for bit.
  Film none = render_checker(TextureFilter::trilinear, false, 1);
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) CHECK(none.pixel(x, y) == plain.pixel(x, y));
}

}  // namespace texture_filter_test
