// Beer–Lambert absorption inside a closed dielectric (KHR_materials_volume):
// looking straight through a cube of side L whose glass hardly refracts
// (eta = 1.0001: Fresnel reflection ~1e-9), every pixel shows the uniform
// environment times attenuation_color^(L / attenuation_distance) in RGB
// mode. In spectral mode the colour is uplifted and attenuated per
// wavelength, so the film's RGB is that of the spectrum
// D65(lambda) c(lambda)^(L/d) (the power of a spectrum is not the spectrum of
// the power): the expected value is that integral, summed over the CIE
// tables' 1 nm samples here.
//
// Tolerances: z sigma with z from Sidak's correction over the test case's
// comparisons (every pixel and channel, for each integrator) at a
// family-wise false-alarm rate of 10^-3, plus a bias allowance: float
// rounding (1e-6) in RGB; in spectral mode 1e-3 for the 1 nm sum against the
// renderer's linearly interpolated tables (both integrate the same
// piecewise-linear functions; the sum's error is of the order of the
// tables' second differences, below 1e-4 here) and the uplift's fit
// tolerance (1e-4 in the colour's reflectance).
#include <catch2/catch.hpp>
#include "support/reference_physics.hpp"
#include <cmath>
#include <prism/prism.hpp>

namespace volume_test {

using namespace prism;

namespace {

// The linear sRGB the film shows for the white environment seen through
// `side` of the absorber, in spectral mode: the 1 nm sum over the CIE
// tables of D65 (Y = 1) times the uplifted colour to the power side /
// distance.
RGB spectral_expected(const RGB& color, double side, double distance) {
  RGBAlbedoSpectrum c(color);
  RGBIlluminantSpectrum white(RGB(1.f));
  double x = 0, y = 0, z = 0, norm = 0;
  for (int i = 0; i < data::cie_samples; ++i) {
    Float lambda = Float(data::cie_lambda_min + i);
    double e = white(lambda);
    double t = std::pow(double(c(lambda)), side / distance);
    x += e * t * data::cie_x[i];
    y += e * t * data::cie_y[i];
    z += e * t * data::cie_z[i];
    norm += e * data::cie_y[i];
  }
  return xyz_to_linear_srgb(XYZ{Float(x / norm), Float(y / norm), Float(z / norm)});
}

template <class S, class Integrator>
void check_absorbing_cube(const Integrator& integrator, double bias, int comparisons) {
  const RGB color(0.5f, 0.25f, 0.8f);
  const Float distance = 2, side = 1;
  const double zq = reference_physics::sidak_z(1e-3, comparisons);
  const RGB spectral = spectral_expected(color, side, distance);
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
        double expected = is_spectral_v<S> ? double(spectral[c]) : std::pow(double(color[c]), double(side / distance));
        double v = film.pixel(x, y)[c], sigma = std::sqrt(double(film.variance(x, y)[c]));
        INFO("pixel " << x << "," << y << " channel " << c << ": " << v << " expected " << expected << " sigma "
                      << sigma);
        // Russian roulette on the attenuated throughput makes the estimate noisy.
        CHECK(std::abs(v - expected) <= zq * sigma + bias);  // zq: Šidák over the comparisons; bias: see the header
      }
}
}  // namespace

TEST_CASE("absorption inside a closed glass cube follows Beer-Lambert", "[integrators][volume]") {
  const int comparisons = 2 * 8 * 8 * 3;  // two integrators, every pixel and channel
  check_absorbing_cube<RGB>(PathIntegrator{}, 1e-6, comparisons);
  check_absorbing_cube<RGB>(BSDFPathIntegrator{}, 1e-6, comparisons);
}

TEST_CASE("absorption inside a closed glass cube follows Beer-Lambert, spectral", "[integrators][volume][spectral]") {
  check_absorbing_cube<Spectral>(PathIntegrator{}, 1e-3, 8 * 8 * 3);
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
