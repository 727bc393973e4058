// prism/film/filter.hpp — pixel reconstruction filters applied by filter
// importance sampling (Ernst et al. 2006; pbrt-v4 book, section 8.8): each
// camera sample's position is drawn from a density p proportional (or close)
// to |f|, and it carries the weight f/p, so the pixel estimate is
// sum(w L) / sum(w). Every filter's f is normalised to integrate to 1 over its
// support, so E[w] = 1. Filters with negative lobes (Mitchell) give negative
// weights where f < 0, as pbrt-v4's FilterSampler does.
//
// Every filter has sample(u) -> FilterSample, eval(p) (the normalised f at an
// offset from the pixel centre), eval_1d(x) (the separable factor) and
// radius() (the square support is [-radius, radius]^2). AnyFilter holds any
// built-in one, chosen at run time by name (make_filter).
#pragma once
#include <cmath>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>
#include <vector>
#include "prism/error.hpp"
#include "prism/sampling/distribution.hpp"

namespace prism {

struct FilterSample {
  Point2f offset;  // from the pixel centre, in pixels
  Float weight;    // f / p: E[weight] = 1; negative where f is
};

namespace detail {
inline void check_filter_parameter(const char* filter, const char* what, Float v) {
  if (!(std::isfinite(v) && v > 0))
    throw Error(std::string(filter) + " filter: " + what + " " + std::to_string(v) + " must be positive and finite");
}

// A piecewise-constant density over [-radius, radius] for one axis of a
// separable filter f: 4 ceil(32 radius) cells (32 per pixel of radius, as
// pbrt-v4's FilterSampler; a multiple of 4, so the knots of the Mitchell and
// triangle filters at 0 and +-radius/2 fall on cell edges), each holding the
// integral of |f| over the cell by 5-point Gauss-Legendre on 4 sub-intervals.
// Any union of cells therefore has the probability |f| gives it; within a
// cell the weight f/p corrects the shape.
template <class F>
PiecewiseConstant1D tabulate_filter_1d(F&& f, Float radius) {
  static constexpr double node[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831,
                                     0.9061798459386640};
  static constexpr double weight[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889,
                                       0.4786286704993665, 0.2369268850561891};
  const int n = 4 * int(std::ceil(32 * double(radius)));
  const double h = 2 * double(radius) / n, sub = h / 4;
  std::vector<Float> cells(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    double x0 = -double(radius) + i * h, sum = 0;
    for (int s = 0; s < 4; ++s)
      for (int k = 0; k < 5; ++k)
        sum += weight[k] * std::abs(double(f(Float(x0 + (s + 0.5) * sub + 0.5 * sub * node[k]))));
    cells[size_t(i)] = Float(sum * 0.5 * sub / h);  // the mean of |f| over the cell
  }
  return PiecewiseConstant1D(cells, -radius, radius);
}

// Both axes drawn from one tabulated 1D density; the weight is f/p.
template <class Filter>
FilterSample sample_tabulated(const Filter& filter, const PiecewiseConstant1D& dist, Point2f u) {
  Float px = 0, py = 0;
  Float x = dist.sample(u.x, &px), y = dist.sample(u.y, &py);
  Float p = px * py;
  return {{x, y}, p > 0 ? filter.eval_1d(x) * filter.eval_1d(y) / p : 0};
}
}  // namespace detail

// Box of the given radius (0.5 = one pixel): uniform offsets, weight 1.
class BoxFilter {
 public:
  explicit BoxFilter(Float radius = 0.5f) : m_radius(radius) { detail::check_filter_parameter("box", "radius", radius); }
  FilterSample sample(Point2f u) const {
    return {{(2 * u.x - 1) * m_radius, (2 * u.y - 1) * m_radius}, 1};
  }
  Float eval_1d(Float x) const { return std::abs(x) <= m_radius ? 1 / (2 * m_radius) : 0; }
  Float eval(Point2f p) const { return eval_1d(p.x) * eval_1d(p.y); }
  Float radius() const { return m_radius; }

 private:
  Float m_radius;
};

// Gaussian exp(-x^2 / (2 sigma^2)), shifted so it reaches 0 at the radius,
// separable and normalised. Each axis is sampled from a finely tabulated
// piecewise-constant copy; the weight f/p corrects the small difference from
// the exact curve.
class GaussianFilter {
 public:
  explicit GaussianFilter(Float radius = 1.5f, Float sigma = 0.5f) : m_radius(radius), m_sigma(sigma) {
    detail::check_filter_parameter("Gaussian", "radius", radius);
    detail::check_filter_parameter("Gaussian", "sigma", sigma);
    // The integral of the shifted curve over [-r, r]:
    // sigma sqrt(2 pi) erf(r / (sigma sqrt 2)) - 2 r exp(-r^2 / (2 sigma^2)).
    double r = radius, s = sigma;
    double integral = s * std::sqrt(2 * 3.14159265358979323846) * std::erf(r / (s * std::sqrt(2.0))) -
                      2 * r * std::exp(-r * r / (2 * s * s));
    m_norm = Float(1 / integral);
    m_dist = detail::tabulate_filter_1d([this](Float x) { return eval_1d(x); }, radius);
  }
  Float eval_1d(Float x) const {
    if (!(std::abs(x) <= m_radius)) return 0;
    Float g = std::exp(-x * x / (2 * sqr(m_sigma))) - std::exp(-sqr(m_radius) / (2 * sqr(m_sigma)));
    return std::max(Float(0), g) * m_norm;
  }
  Float eval(Point2f p) const { return eval_1d(p.x) * eval_1d(p.y); }
  FilterSample sample(Point2f u) const { return detail::sample_tabulated(*this, m_dist, u); }
  Float radius() const { return m_radius; }
  Float sigma() const { return m_sigma; }

 private:
  Float m_radius, m_sigma, m_norm = 1;
  PiecewiseConstant1D m_dist;
};

// Triangle (tent) max(0, r - |x|) / r^2 per axis, separable; sampled exactly
// by inverting its CDF, so the weight is 1. The default radius 1 (Mitsuba's
// "tent") is bilinear reconstruction; pbrt-v4 defaults to 2.
class TriangleFilter {
 public:
  explicit TriangleFilter(Float radius = 1) : m_radius(radius) {
    detail::check_filter_parameter("triangle", "radius", radius);
  }
  Float eval_1d(Float x) const { return std::max(Float(0), m_radius - std::abs(x)) / sqr(m_radius); }
  Float eval(Point2f p) const { return eval_1d(p.x) * eval_1d(p.y); }
  FilterSample sample(Point2f u) const { return {{sample_tent(u.x), sample_tent(u.y)}, 1}; }
  Float radius() const { return m_radius; }

 private:
  // The left half for u < 1/2 (CDF 2 u = (1 + x/r)^2), the right one mirrored,
  // so that |x| <= r always and x = 0 only at u = 1/2.
  Float sample_tent(Float u) const {
    if (u < Float(0.5)) return m_radius * (std::sqrt(2 * u) - 1);
    return m_radius * (1 - std::sqrt(2 * (1 - u)));
  }
  Float m_radius;
};

// Mitchell-Netravali cubic (Mitchell and Netravali 1988; pbrt-v4 section
// 8.8.4), separable, with B = C = 1/3 by default, the pair its authors
// recommend. The cubic k(t) on [-2, 2] integrates to 1 for every B and C; the
// filter is (2 / r) k(2 x / r), which keeps that integral. With B = C = 1/3 it
// is negative for 4/7 r < |x| < r (k has roots at 8/7 and a double one at 2):
// samples are drawn from a tabulation of |f| and those lobes give negative
// weights.
class MitchellFilter {
 public:
  explicit MitchellFilter(Float radius = 2, Float b = Float(1) / 3, Float c = Float(1) / 3)
      : m_radius(radius), m_b(b), m_c(c) {
    detail::check_filter_parameter("Mitchell", "radius", radius);
    if (!std::isfinite(b) || !std::isfinite(c))
      throw Error("Mitchell filter: B " + std::to_string(b) + " and C " + std::to_string(c) + " must be finite");
    m_dist = detail::tabulate_filter_1d([this](Float x) { return eval_1d(x); }, radius);
  }
  Float eval_1d(Float x) const { return 2 / m_radius * cubic(2 * x / m_radius); }
  Float eval(Point2f p) const { return eval_1d(p.x) * eval_1d(p.y); }
  FilterSample sample(Point2f u) const { return detail::sample_tabulated(*this, m_dist, u); }
  Float radius() const { return m_radius; }
  Float b() const { return m_b; }
  Float c() const { return m_c; }

 private:
  // Mitchell and Netravali's equation 8, on [-2, 2]. The outer piece
  // ((-B - 6C) t^3 + (6B + 30C) t^2 - (12B + 48C) t + 8B + 24C) / 6 has a
  // double root at 2 for every B and C; factored, it reaches exactly 0 there
  // without cancellation.
  Float cubic(Float t) const {
    t = std::abs(t);
    const Float b = m_b, c = m_c;
    if (t <= 1) return ((12 - 9 * b - 6 * c) * t * t * t + (-18 + 12 * b + 6 * c) * t * t + (6 - 2 * b)) / 6;
    if (t < 2) return sqr(2 - t) * ((-b - 6 * c) * t + 2 * b + 6 * c) / 6;
    return 0;
  }
  Float m_radius, m_b, m_c;
  PiecewiseConstant1D m_dist;
};

// Any built-in filter, chosen at run time: one render() instantiation serves
// all of them, for the cost of a switch per camera sample.
class AnyFilter {
 public:
  using Variant = std::variant<BoxFilter, GaussianFilter, TriangleFilter, MitchellFilter>;
  AnyFilter() = default;
  template <class F>
    requires std::is_constructible_v<Variant, F>
  AnyFilter(F f) : m_filter(std::move(f)) {}  // NOLINT: implicit on purpose, as a variant is

  FilterSample sample(Point2f u) const {
    return std::visit([&](const auto& f) { return f.sample(u); }, m_filter);
  }
  Float eval(Point2f p) const {
    return std::visit([&](const auto& f) { return f.eval(p); }, m_filter);
  }
  Float radius() const {
    return std::visit([](const auto& f) { return f.radius(); }, m_filter);
  }
  // "box", "gaussian", "triangle" or "mitchell".
  std::string_view name() const {
    constexpr std::string_view names[] = {"box", "gaussian", "triangle", "mitchell"};
    return names[m_filter.index()];
  }
  const Variant& variant() const { return m_filter; }

 private:
  Variant m_filter;
};

// The built-in filters by name, with their default parameters: "box" (radius
// 0.5: one pixel), "gaussian" (radius 1.5, sigma 0.5), "triangle" (radius 1),
// "mitchell" (radius 2, B = C = 1/3). Throws prism::Error for other names.
inline AnyFilter make_filter(std::string_view name) {
  if (name == "box") return BoxFilter{};
  if (name == "gaussian") return GaussianFilter{};
  if (name == "triangle") return TriangleFilter{};
  if (name == "mitchell") return MitchellFilter{};
  throw Error("pixel filter '" + std::string(name) + "' is unknown (use box, gaussian, triangle or mitchell)");
}

}  // namespace prism
