// Beer–Lambert absorption inside a closed dielectric (KHR_materials_volume):
// looking straight through a cube of side L whose glass hardly refracts
// (eta = 1.0001: Fresnel reflection ~1e-9), every pixel shows the uniform
// environment times attenuation_color^(L / attenuation_distance).
#include <catch2/catch.hpp>
#include <cmath>
#include <prism/prism.hpp>

namespace volume_test {

using namespace prism;

namespace {
template <class S, class Integrator>
void check_absorbing_cube(const Integrator& integrator, double bias) {
  const RGB color(0.5f, 0.25f, 0.8f);
  const Float distance = 2, side = 1;
  Scene<S> scene;
  DielectricMaterial glass{IOR(1.0001f), "absorbing glass"};
  glass.volume = VolumeAbsorption{color, distance};
  uint32_t m = scene.add_material(glass);
  scene.add_mesh_instance(make_box({-0.5f, -0.5f, -0.5f}, {0.5f, 0.5f, 0.5f}), m);
  scene.add_light(UniformInfiniteLight<S>(RGB(1.f)));
  scene.build();
  const int w = 8, h = 8;
  OrthographicCamera cam(look_at_camera_to_world({0, 0, 3}, {0, 0, 0}, {0, 1, 0}), 0.8f, w, h);
  Film film(w, h);
  RenderOptions opt;
  opt.spp = 256;
  render(scene, cam, integrator, film, opt);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      for (int c = 0; c < 3; ++c) {
        double expected = std::pow(double(color[c]), double(side / distance));
        double v = film.pixel(x, y)[c], sigma = std::sqrt(double(film.variance(x, y)[c]));
        INFO("pixel " << x << "," << y << " channel " << c << ": " << v << " expected " << expected << " sigma "
                      << sigma);
        // Russian roulette on the attenuated throughput makes the estimate noisy: 4 sigma.
        CHECK(std::abs(v - expected) <= 4 * sigma + bias);
      }
}
}  // namespace

TEST_CASE("absorption inside a closed glass cube follows Beer-Lambert", "[integrators][volume]") {
  check_absorbing_cube<RGB>(PathIntegrator{}, 1e-6);
  check_absorbing_cube<RGB>(BSDFPathIntegrator{}, 1e-6);
}

// Spectral: the colour is uplifted and attenuated per wavelength, so the
// film's RGB is not exactly color^(L/d) per channel (the power of a spectrum
// is not the spectrum of the power): allow 0.02 beside the 4 sigma.
TEST_CASE("absorption inside a closed glass cube follows Beer-Lambert, spectral", "[integrators][volume][spectral]") {
  check_absorbing_cube<Spectral>(PathIntegrator{}, 0.02);
}

TEST_CASE("a volume with a colour outside the unit interval or a non-positive distance is rejected", "[integrators][volume][validate]") {
  Scene<RGB> scene;
  DielectricMaterial glass{IOR(1.5f), "bad volume"};
  glass.volume = VolumeAbsorption{RGB(1.5f, 0.5f, 0.5f), 1};
  uint32_t m = scene.add_material(glass);
  scene.add_sphere(Sphere{{0, 0, 0}, 1}, m);
  CHECK_THROWS_AS(scene.build(), Error);
  Scene<RGB> scene2;
  glass.volume = VolumeAbsorption{RGB(0.5f), 0};
  scene2.add_sphere(Sphere{{0, 0, 0}, 1}, scene2.add_material(glass));
  CHECK_THROWS_AS(scene2.build(), Error);
}

}  // namespace volume_test
