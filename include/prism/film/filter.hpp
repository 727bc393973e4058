// prism/film/filter.hpp — pixel reconstruction filters applied by filter
// importance sampling (Ernst et al. 2006; pbrt-v4 book, section 8.8): each
// camera sample's position is drawn from the filter, and it carries the weight
// f/p, so the pixel estimate is sum(w L) / sum(w). For non-negative filters that
// are sampled exactly, w is constant.
#pragma once
#include <vector>
#include "prism/sampling/distribution.hpp"

namespace prism {

struct FilterSample {
  Point2f offset;  // from the pixel centre, in pixels
  Float weight;
};

// Box of the given radius (0.5 = one pixel): uniform offsets, weight 1.
class BoxFilter {
 public:
  explicit BoxFilter(Float radius = 0.5f) : m_radius(radius) {}
  FilterSample sample(Point2f u) const {
    return {{(2 * u.x - 1) * m_radius, (2 * u.y - 1) * m_radius}, 1};
  }
  Float radius() const { return m_radius; }

 private:
  Float m_radius;
};

// Gaussian exp(-x^2 / (2 sigma^2)), shifted so it reaches 0 at the radius, and
// separable. Each axis is sampled from a finely tabulated piecewise-constant
// copy; the weight f/p corrects the small difference from the exact curve.
class GaussianFilter {
 public:
  explicit GaussianFilter(Float radius = 1.5f, Float sigma = 0.5f) : m_radius(radius), m_sigma(sigma) {
    constexpr int n = 256;
    std::vector<Float> f(n);
    for (int i = 0; i < n; ++i) {
      Float x = -radius + (Float(i) + 0.5f) * 2 * radius / Float(n);
      f[size_t(i)] = eval_1d(x);
    }
    m_dist = PiecewiseConstant1D(f, -radius, radius);
  }
  Float eval_1d(Float x) const {
    return std::max(Float(0), std::exp(-x * x / (2 * sqr(m_sigma))) - std::exp(-sqr(m_radius) / (2 * sqr(m_sigma))));
  }
  FilterSample sample(Point2f u) const {
    Float px, py;
    Float x = m_dist.sample(u.x, &px), y = m_dist.sample(u.y, &py);
    Float p = px * py;
    Float w = p > 0 ? eval_1d(x) * eval_1d(y) / p : 0;
    return {{x, y}, w};
  }
  Float radius() const { return m_radius; }

 private:
  Float m_radius, m_sigma;
  PiecewiseConstant1D m_dist;
};

}  // namespace prism
