// prism/sampling/distribution.hpp — piecewise-constant 1D and 2D distributions
// sampled by inverting their CDF (pbrt-v4 book, sections A.4.2 and A.5.5).
// Densities are with respect to the domain's measure ([min,max] in 1D, the
// rectangle's area in 2D).
#pragma once
#include <numeric>
#include <span>
#include <vector>
#include "prism/math/vector.hpp"

namespace prism {

class PiecewiseConstant1D {
 public:
  PiecewiseConstant1D() = default;
  // f holds non-negative values; negative inputs are taken by absolute value.
  // An all-zero function becomes uniform so that sampling stays defined.
  PiecewiseConstant1D(std::span<const Float> f, Float min = 0, Float max = 1)
      : m_func(f.begin(), f.end()), m_cdf(f.size() + 1), m_min(min), m_max(max) {
    for (Float& v : m_func) v = std::abs(v);
    size_t n = m_func.size();
    m_cdf[0] = 0;
    for (size_t i = 1; i <= n; ++i) m_cdf[i] = m_cdf[i - 1] + double(m_func[i - 1]) * (max - min) / double(n);
    m_integral = m_cdf[n];
    if (m_integral == 0) {
      for (size_t i = 1; i <= n; ++i) m_cdf[i] = double(i) / double(n);
    } else {
      for (size_t i = 1; i <= n; ++i) m_cdf[i] /= m_integral;
    }
  }

  size_t size() const { return m_func.size(); }
  Float integral() const { return Float(m_integral); }
  Float min() const { return m_min; }
  Float max() const { return m_max; }

  // Returns x in [min, max); *pdf is the density at x, *offset the segment index.
  Float sample(Float u, Float* pdf = nullptr, int* offset = nullptr) const {
    size_t n = m_func.size();
    // Largest index o with cdf[o] <= u.
    size_t o = size_t(std::upper_bound(m_cdf.begin(), m_cdf.end(), double(u)) - m_cdf.begin());
    o = std::clamp<size_t>(o, 1, n) - 1;
    if (offset) *offset = int(o);
    double du = double(u) - m_cdf[o];
    double w = m_cdf[o + 1] - m_cdf[o];
    if (w > 0) du /= w;
    if (pdf) *pdf = segment_pdf(o);
    Float x = Float((double(o) + du) / double(n));
    return std::min(lerp(x, m_min, m_max), next_float_down(m_max));
  }
  Float pdf(Float x) const {
    size_t n = m_func.size();
    Float t = (x - m_min) / (m_max - m_min);
    if (!(t >= 0 && t <= 1)) return 0;
    size_t o = std::min(size_t(t * Float(n)), n - 1);
    return segment_pdf(o);
  }
  // The inverse of sample(): the u that maps to x.
  Float invert(Float x) const {
    size_t n = m_func.size();
    Float t = std::clamp((x - m_min) / (m_max - m_min), Float(0), Float(1));
    size_t o = std::min(size_t(t * Float(n)), n - 1);
    double frac = double(t) * double(n) - double(o);
    return Float(m_cdf[o] + frac * (m_cdf[o + 1] - m_cdf[o]));
  }

 private:
  Float segment_pdf(size_t o) const {
    if (m_integral == 0) return 1 / (m_max - m_min);
    return Float(double(m_func[o]) / m_integral);
  }
  std::vector<Float> m_func;
  std::vector<double> m_cdf;
  double m_integral = 0;
  Float m_min = 0, m_max = 1;
};

// f given row-major as nu columns by nv rows over [0,1]^2: a marginal over rows
// and one conditional per row.
class PiecewiseConstant2D {
 public:
  PiecewiseConstant2D() = default;
  PiecewiseConstant2D(std::span<const Float> f, int nu, int nv) {
    m_conditional.reserve(size_t(nv));
    for (int v = 0; v < nv; ++v) m_conditional.emplace_back(f.subspan(size_t(v) * size_t(nu), size_t(nu)));
    std::vector<Float> marginal(static_cast<size_t>(nv));
    for (int v = 0; v < nv; ++v) marginal[size_t(v)] = m_conditional[size_t(v)].integral();
    m_marginal = PiecewiseConstant1D(marginal);
  }
  Float integral() const { return m_marginal.integral(); }
  // Returns a point in [0,1)^2 and its density per unit area.
  Point2f sample(Point2f u, Float* pdf = nullptr) const {
    Float pdfs[2];
    int v;
    Float d1 = m_marginal.sample(u.y, &pdfs[1], &v);
    Float d0 = m_conditional[size_t(v)].sample(u.x, &pdfs[0]);
    if (pdf) *pdf = pdfs[0] * pdfs[1];
    return {d0, d1};
  }
  Float pdf(Point2f p) const {
    size_t nv = m_conditional.size();
    size_t iv = std::min(size_t(std::clamp(p.y, Float(0), Float(1)) * Float(nv)), nv - 1);
    return m_marginal.pdf(p.y) * m_conditional[iv].pdf(p.x);
  }

 private:
  std::vector<PiecewiseConstant1D> m_conditional;
  PiecewiseConstant1D m_marginal;
};

}  // namespace prism
