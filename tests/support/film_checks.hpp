// tests/support/film_checks.hpp — helpers shared by the integrator tests that
// compare two renders region by region, and the sky-with-a-sun environment
// several of them light their scenes with.
#pragma once
#include <catch2/catch.hpp>
#include <cmath>
#include <utility>
#include <prism/prism.hpp>
#include "support/reference_physics.hpp"

namespace prism_test {

// The mean of channel c over the size x size region at (x0, y0) of a film,
// and the variance of that mean (from the film's per-pixel variance).
inline std::pair<double, double> region_mean(const prism::Film& f, int c, int x0, int y0, int size) {
  double m = 0, v = 0, n = double(size) * double(size);
  for (int y = y0; y < y0 + size; ++y)
    for (int x = x0; x < x0 + size; ++x) {
      m += double(f.pixel(x, y)[c]) / n;
      v += double(f.variance(x, y)[c]) / (n * n);
    }
  return {m, v};
}

// Two unbiased renders of one scene agree in every region and channel within
// z sigma of their difference, z from Sidak's correction over the m = 3 x
// regions comparisons at a family-wise false-alarm rate of 10^-3 (4.2 for 48
// comparisons). `what_a` and `what_b` name them in messages.
inline void check_regions_agree(const prism::Film& a, const prism::Film& b, int region, const char* what_a,
                                const char* what_b) {
  int compared = 0;
  const double z = reference_physics::sidak_z(1e-3, 3 * (a.width() / region) * (a.height() / region));
  for (int ry = 0; ry < a.height(); ry += region)
    for (int rx = 0; rx < a.width(); rx += region)
      for (int c = 0; c < 3; ++c) {
        auto [ma, va] = region_mean(a, c, rx, ry, region);
        auto [mb, vb] = region_mean(b, c, rx, ry, region);
        double sigma = std::sqrt(va + vb);
        INFO("region " << rx << "," << ry << " channel " << c << ": " << what_a << " " << ma << " " << what_b << " "
                       << mb << " sigma " << sigma);
        CHECK(std::abs(ma - mb) <= z * sigma);
        ++compared;
      }
  CHECK(compared == 3 * (a.width() / region) * (a.height() / region));
}

// A 64x32 equirectangular sky (brighter towards the zenith, bluish) with a
// 4x4-texel sun 100 times the sky: bright enough for the map's importance
// sampling to matter, large enough for BSDF sampling to find it often (a
// 2-texel sun of 200 needs ~4096 spp before a BSDF-only estimate's variance
// is estimated reliably).
inline prism::EnvironmentImage sky_with_sun() {
  prism::EnvironmentImage env;
  env.width = 64;
  env.height = 32;
  env.rgb.resize(size_t(env.width) * size_t(env.height) * 3);
  for (int y = 0; y < env.height; ++y)
    for (int x = 0; x < env.width; ++x) {
      float sky = 0.2f + 0.8f * float(env.height - y) / float(env.height);
      bool sun = x >= 40 && x < 44 && y >= 8 && y < 12;
      for (int c = 0; c < 3; ++c)
        env.rgb[(size_t(y) * size_t(env.width) + size_t(x)) * 3 + size_t(c)] = sun ? 20.f : sky * (c == 2 ? 1.f : 0.7f);
    }
  return env;
}

}  // namespace prism_test
