// Thin-film reflectance (bxdfs/thin_film.hpp, KHR_materials_iridescence):
// the Airy summation against the characteristic-matrix method written in
// tests/support/reference_physics.hpp (Born & Wolf 1.6.2, an independent
// derivation), closed forms (no film, a quarter-wave antireflection layer,
// a half-wave layer), and the RGB reduction against a 1 nm sum over the
// CIE tables.
#include <catch2/catch.hpp>
#include <cmath>
#include <prism/bxdfs/thin_film.hpp>
#include "support/reference_physics.hpp"

namespace thin_film_test {

using namespace prism;

// Tolerance: thin_film_reflectance computes in double and rounds R to float
// once (R <= 1: 6e-8); 1e-6 leaves room for the reference's own rounding.
TEST_CASE("thin film: the Airy sum against the characteristic-matrix method", "[bxdfs][thin_film]") {
  int compared = 0;
  double worst = 0;
  for (double c : {1.0, 0.8, 0.5, 0.2, 0.02})
    for (double n2 : {1.0, 1.3, 1.8, 2.4})
      for (double d : {0.0, 50.0, 230.0, 400.0, 1200.0})
        for (double n3 : {1.0, 1.5, 3.0, 12.0})
          for (double lambda : {380.0, 455.0, 550.0, 640.0, 780.0}) {
            // The reference sees the float inputs prism sees: the phase,
            // up to 4 pi n d / lambda = 95 rad here, magnifies an input's
            // rounding (6e-8 relative) to ~1e-5 in R.
            auto f = [](double x) { return double(Float(x)); };
            double want = reference_physics::thin_film_tmm(f(c), 1, f(n2), f(d), f(n3), f(lambda));
            double got = thin_film_reflectance(Float(c), Float(n2), Float(d), Float(n3), Float(lambda));
            INFO("cos " << c << " n_film " << n2 << " d " << d << " n_base " << n3 << " lambda " << lambda);
            CHECK(std::abs(got - want) <= 1e-6);
            worst = std::max(worst, std::abs(got - want));
            ++compared;
          }
  CHECK(compared == 2000);
  WARN("thin film against the matrix method: largest difference " << worst);
}

TEST_CASE("thin film: no film, a quarter-wave and a half-wave layer", "[bxdfs][thin_film]") {
  for (double c : {1.0, 0.6, 0.1})
    for (double n3 : {1.33, 1.5, 2.4}) {
      // Thickness 0: the bare substrate's Fresnel reflectance.
      double bare = reference_physics::fresnel_dielectric(c, n3);
      CHECK(std::abs(thin_film_reflectance(Float(c), 1.8f, 0, Float(n3), 550) - bare) <= 1e-6);
    }
  // At normal incidence a film of index sqrt(n3) a quarter wave thick
  // cancels the reflection at that wavelength (R = ((n3 - n2^2) / (n3 +
  // n2^2))^2 = 0); a half-wave film is absent (R = the bare substrate's).
  for (double n3 : {1.5, 2.25}) {
    const double lambda = 550, n2 = std::sqrt(n3);
    CHECK(thin_film_reflectance(1, Float(n2), Float(lambda / (4 * n2)), Float(n3), Float(lambda)) <= 1e-6);
    const double bare = std::pow((n3 - 1) / (n3 + 1), 2);
    CHECK(std::abs(thin_film_reflectance(1, 1.7f, Float(lambda / (2 * 1.7)), Float(n3), Float(lambda)) - bare) <= 1e-6);
  }
}

// The RGB reduction: a film of index 1 leaves the substrate's reflectance,
// the same at every wavelength, so each channel must give it exactly (the
// weights sum to 1: float rounding over 41 terms, 1e-6). A real film
// against a 1 nm sum of the same integrand over the tables (360-830 nm):
// the 10 nm sum samples an integrand whose oscillation period in lambda,
// lambda^2 / (2 n d) >= 380^2 / (2 x 1.8 x 600) = 67 nm, 6.7 times a period.
TEST_CASE("thin film: the RGB reduction of a flat spectrum is exact, of a film close to a 1 nm sum", "[bxdfs][thin_film]") {
  for (double c : {1.0, 0.3}) {
    Float R = thin_film_reflectance(Float(c), 1, 300, 1.5f, 550);
    RGB rgb = thin_film_reflectance_rgb(Float(c), 1, 300, RGB(1.5f));
    CHECK(std::abs(rgb.r - R) <= 1e-6);
    CHECK(std::abs(rgb.g - R) <= 1e-6);
    CHECK(std::abs(rgb.b - R) <= 1e-6);
  }
  double worst = 0;
  for (double c : {1.0, 0.7, 0.3})
    for (double d : {100.0, 250.0, 400.0, 600.0})
      for (double n2 : {1.33, 1.8}) {
        XYZ xyz{0, 0, 0}, white{0, 0, 0};
        for (int l = 360; l <= 830; ++l) {
          Float e = illuminant_d65()(Float(l));
          Float R = thin_film_reflectance(Float(c), Float(n2), Float(d), 1.5f, Float(l));
          xyz.x += cie_x(Float(l)) * e * R;
          xyz.y += cie_y(Float(l)) * e * R;
          xyz.z += cie_z(Float(l)) * e * R;
          white.x += cie_x(Float(l)) * e;
          white.y += cie_y(Float(l)) * e;
          white.z += cie_z(Float(l)) * e;
        }
        RGB want = xyz_to_linear_srgb(xyz), w = xyz_to_linear_srgb(white);
        want = RGB(std::clamp(want.r / w.r, Float(0), Float(1)), std::clamp(want.g / w.g, Float(0), Float(1)),
                   std::clamp(want.b / w.b, Float(0), Float(1)));
        RGB got = thin_film_reflectance_rgb(Float(c), Float(n2), Float(d), RGB(1.5f));
        for (int k = 0; k < 3; ++k) worst = std::max(worst, double(std::abs(got[k] - want[k])));
      }
  // Measured 1.0e-4 over this grid (deterministic); twice that covers the
  // thicknesses between the grid's points.
  WARN("thin film RGB: 10 nm sum against 1 nm sum, largest difference " << worst);
  CHECK(worst <= 2e-4);
}

}  // namespace thin_film_test
