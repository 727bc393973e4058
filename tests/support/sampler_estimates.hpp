// tests/support/sampler_estimates.hpp — per-pixel Monte Carlo estimates of a
// 2D integral with a sampler, for comparing samplers' variances.
#pragma once
#include "prism/math/vector.hpp"

namespace prism_test {

struct EstimateStats {
  double mean = 0, variance = 0;
};

// Per-pixel estimates of the integral of f over the unit square with spp
// samples, the point taken from the third call (the "lens" call of the
// renderer's order: 1D, 2D, 2D); mean and variance of the estimates over pixels.
template <class Sampler, class F>
EstimateStats pixel_estimates(Sampler& s, int pixels, int spp, F&& f) {
  double mean = 0, m2 = 0;
  for (int p = 0; p < pixels; ++p) {
    double sum = 0;
    for (int i = 0; i < spp; ++i) {
      s.start_pixel_sample(p % 64, p / 64, i);
      s.get_1d();
      s.get_2d();
      prism::Point2f u = s.get_2d();
      sum += f(double(u.x), double(u.y));
    }
    double e = sum / spp, delta = e - mean;
    mean += delta / (p + 1);
    m2 += delta * (e - mean);
  }
  return {mean, m2 / (pixels - 1)};
}

}  // namespace prism_test
