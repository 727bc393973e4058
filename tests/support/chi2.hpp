// tests/support/chi2.hpp — Pearson's chi-squared goodness-of-fit test for
// samplers, shared by every statistical test (warps now, BxDFs later).
//
// How to use it
// -------------
// 1. Describe the sampler's domain as a rectangle in some 2D parameterisation
//    (Grid2D), e.g. (theta, phi) for directions or (r, phi) for a disk.
// 2. Call chi2_test_2d(sample, density, grid, n) where
//      sample()      returns std::optional<std::array<double, 2>>: one sample's
//                    grid coordinates, or nullopt when the sampler fails;
//      density(x, y) is the claimed density with respect to dx dy in those
//                    coordinates (include the Jacobian: pdf * sin(theta) for
//                    directions, pdf * r for polar coordinates).
//    For directions, chi2_test_directions() does the (theta, phi) mapping: pass
//    a sampler returning unit vectors and a pdf per solid angle. For a sampler
//    confined to the upper hemisphere pass theta_max = pi / 2: over the whole
//    sphere, a sample exactly on the horizon (z = 0, which float samplers do
//    produce) lands in the first lower cell, whose expected count is 0, and
//    fails the test. Upper grid edges are closed, so z = 0 counts with theta_max.
// 3. Compare the p-value against a per-test level: with m tests in a file and
//    a family-wise level of 1e-3, use sidak_alpha(1e-3, m), so that a correct
//    sampler fails any of the file's tests with probability 1e-3 overall.
//
// What it does: the expected count of each cell is n times the density's
// integral over the cell (Gauss-Legendre quadrature on sub-cells, so edges and
// the discontinuities that sit on them are never evaluated). Samples that fail or
// land outside the grid go to an extra cell whose expected count is n times
// (1 - the density's integral over the grid); when that integral is 1 to within
// `outside_tol` (the accuracy of the numerical integral), the extra cell's
// expected count is exactly 0, so any such sample fails the test. Cells whose expected count is
// below min_expected are pooled (smallest first) until each pool reaches it, as
// the chi-squared approximation requires. A sample in a cell whose expected
// count is exactly 0 is impossible under the claimed density and fails the
// test outright (p = 0). The p-value is the upper tail of the chi-squared
// distribution with (cells - 1) degrees of freedom, from the regularised upper
// incomplete gamma function Q(dof / 2, statistic / 2) (Numerical Recipes, 3rd
// ed., section 6.2: series for x < a + 1, Lentz continued fraction otherwise).
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <numeric>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace prism_test {

// Regularised lower incomplete gamma P(a, x) by its series (valid for x < a + 1).
inline double incomplete_gamma_series(double a, double x) {
  if (x <= 0) return 0;
  double ap = a, del = 1 / a, sum = del;
  for (int i = 0; i < 100000; ++i) {
    ap += 1;
    del *= x / ap;
    sum += del;
    if (std::abs(del) < std::abs(sum) * 1e-16) break;  // stop at double's unit roundoff (2^-53 ≈ 1.1e-16)
  }
  return sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
}

// Regularised upper incomplete gamma Q(a, x) by its continued fraction (x >= a + 1).
inline double incomplete_gamma_cf(double a, double x) {
  constexpr double tiny = 1e-300;
  double b = x + 1 - a, c = 1 / tiny, d = 1 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    double an = -i * (i - a);
    b += 2;
    // tiny: Lentz's guard against a zero divisor (Numerical Recipes, 6.2); 1e-16: double's unit roundoff
    d = an * d + b;
    if (std::abs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::abs(c) < tiny) c = tiny;
    d = 1 / d;
    double del = d * c;
    h *= del;
    if (std::abs(del - 1) < 1e-16) break;
  }
  return std::exp(-x + a * std::log(x) - std::lgamma(a)) * h;
}

// Regularised upper incomplete gamma Q(a, x) = 1 - P(a, x), a > 0, x >= 0.
inline double regularized_gamma_q(double a, double x) {
  if (x <= 0) return 1;
  if (x < a + 1) return 1 - incomplete_gamma_series(a, x);
  return incomplete_gamma_cf(a, x);
}
inline double regularized_gamma_p(double a, double x) { return 1 - regularized_gamma_q(a, x); }

// P(X >= statistic) for X chi-squared with dof degrees of freedom.
inline double chi2_p_value(double statistic, int dof) {
  if (dof < 1) return 1;
  return regularized_gamma_q(0.5 * dof, 0.5 * statistic);
}

// Šidák correction: the per-test level that keeps the probability of any false
// rejection among m independent tests at family_alpha.
inline double sidak_alpha(double family_alpha, int m) { return 1 - std::pow(1 - family_alpha, 1.0 / m); }

struct Chi2Result {
  double statistic = 0;
  int dof = 0;
  double p_value = 1;
  double integral = 0;       // the density's integral over the grid
  size_t impossible = 0;     // samples in cells whose expected count is exactly 0
  size_t outside = 0;        // samples that failed or fell outside the grid
  int pooled_cells = 0;      // cells after pooling

  std::string summary() const {
    std::ostringstream s;
    s << "chi2 = " << statistic << ", dof = " << dof << ", p = " << p_value << ", integral = " << integral
      << ", impossible samples = " << impossible << ", outside = " << outside;
    return s.str();
  }
};

// Pearson's test on given counts; expected counts come from the caller.
inline Chi2Result chi2_from_counts(const std::vector<double>& observed, const std::vector<double>& expected,
                                   double min_expected = 5) {
  if (observed.size() != expected.size()) throw std::invalid_argument("chi2: size mismatch");
  Chi2Result r;
  std::vector<size_t> order(observed.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) { return expected[a] < expected[b]; });
  std::vector<std::array<double, 2>> cells;  // (observed, expected) after pooling
  double po = 0, pe = 0;
  for (size_t i : order) {
    double o = observed[i], e = expected[i];
    if (e <= 0) {
      r.impossible += size_t(o);
      continue;
    }
    if (e < min_expected) {
      po += o;
      pe += e;
      if (pe >= min_expected) {
        cells.push_back({po, pe});
        po = pe = 0;
      }
      continue;
    }
    cells.push_back({o + po, e + pe});  // a pool left short joins the next cell
    po = pe = 0;
  }
  if (pe > 0) {
    if (cells.empty())
      cells.push_back({po, pe});
    else
      cells.back() = {cells.back()[0] + po, cells.back()[1] + pe};
  }
  for (const auto& c : cells) r.statistic += (c[0] - c[1]) * (c[0] - c[1]) / c[1];
  r.pooled_cells = int(cells.size());
  r.dof = r.pooled_cells - 1;
  r.p_value = r.impossible > 0 ? 0.0 : chi2_p_value(r.statistic, r.dof);
  return r;
}

// A rectangle of nx by ny cells in a 2D parameterisation of the domain.
struct Grid2D {
  double x0 = 0, x1 = 1;
  int nx = 1;
  double y0 = 0, y1 = 1;
  int ny = 1;
  // Samples up to this far outside the rectangle (in grid units) are clamped into
  // the edge cells; set it to the sampler's own rounding error, nothing more.
  double slack = 0;
};

// Integral of f over [x0,x1]x[y0,y1] by 5-point Gauss-Legendre on sub x sub
// sub-cells (interior nodes only).
template <class F>
double integrate_2d(F&& f, double x0, double x1, double y0, double y1, int sub = 2) {
  static constexpr double node[5] = {-0.9061798459386640, -0.5384693101056831, 0.0, 0.5384693101056831,
                                     0.9061798459386640};
  static constexpr double weight[5] = {0.2369268850561891, 0.4786286704993665, 0.5688888888888889,
                                       0.4786286704993665, 0.2369268850561891};
  double hx = (x1 - x0) / sub, hy = (y1 - y0) / sub, sum = 0;
  for (int i = 0; i < sub; ++i)
    for (int j = 0; j < sub; ++j) {
      double cx = x0 + (i + 0.5) * hx, cy = y0 + (j + 0.5) * hy;
      for (int a = 0; a < 5; ++a)
        for (int b = 0; b < 5; ++b)
          sum += weight[a] * weight[b] * f(cx + 0.5 * hx * node[a], cy + 0.5 * hy * node[b]);
    }
  return sum * 0.25 * hx * hy;
}

// Expected probability of each cell (row-major, y outer) under density.
template <class Density>
std::vector<double> cell_probabilities(Density&& density, const Grid2D& g, int sub = 2) {
  std::vector<double> p(size_t(g.nx) * size_t(g.ny));
  double dx = (g.x1 - g.x0) / g.nx, dy = (g.y1 - g.y0) / g.ny;
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i)
      p[size_t(j) * size_t(g.nx) + size_t(i)] =
          integrate_2d(density, g.x0 + i * dx, g.x0 + (i + 1) * dx, g.y0 + j * dy, g.y0 + (j + 1) * dy, sub);
  return p;
}

// Cell index of a point, or -1 outside the grid (beyond its slack). Upper edges
// are closed so that a sample exactly on the far boundary counts.
inline long grid_cell(const Grid2D& g, double x, double y) {
  if (!(x >= g.x0 - g.slack && x <= g.x1 + g.slack && y >= g.y0 - g.slack && y <= g.y1 + g.slack)) return -1;
  long i = long(std::floor((x - g.x0) / (g.x1 - g.x0) * g.nx));
  long j = long(std::floor((y - g.y0) / (g.y1 - g.y0) * g.ny));
  i = std::clamp(i, 0L, long(g.nx) - 1);
  j = std::clamp(j, 0L, long(g.ny) - 1);
  return j * g.nx + i;
}

// Options of the test; the defaults suit a sampler whose density integrates to
// 1 over the grid.
struct Chi2Options {
  double min_expected = 5;  // pool cells until their expected count reaches this
  int sub = 2;              // quadrature sub-cells per cell and axis
  // A density integrating to more than 1 - outside_tol over the grid leaves
  // nothing outside it: the pdfs are evaluated in float, so their integral is
  // accurate to a few float roundings (16 * 2^-24 < 1e-6).
  double outside_tol = 1e-6;
};

template <class Sample, class Density>
Chi2Result chi2_test_2d(Sample&& sample, Density&& density, const Grid2D& g, size_t n,
                        const Chi2Options& opt = {}) {
  std::vector<double> prob = cell_probabilities(density, g, opt.sub);
  double integral = std::accumulate(prob.begin(), prob.end(), 0.0);
  std::vector<double> observed(prob.size() + 1, 0.0), expected(prob.size() + 1, 0.0);
  for (size_t k = 0; k < prob.size(); ++k) expected[k] = prob[k] * double(n);
  // The extra cell: failed samples and samples outside the grid.
  expected.back() = integral > 1 - opt.outside_tol ? 0.0 : (1 - integral) * double(n);
  size_t outside = 0;
  for (size_t s = 0; s < n; ++s) {
    std::optional<std::array<double, 2>> p = sample();
    long c = p ? grid_cell(g, (*p)[0], (*p)[1]) : -1;
    if (c < 0) {
      ++outside;
      observed.back() += 1;
    } else {
      observed[size_t(c)] += 1;
    }
  }
  Chi2Result r = chi2_from_counts(observed, expected, opt.min_expected);
  r.integral = integral;
  r.outside = outside;
  return r;
}

// Directions binned in (theta, phi), theta in [0, theta_max], phi in [0, 2 pi).
// sample() returns std::optional<std::array<double, 3>> (a unit vector); pdf(w)
// takes a std::array<double, 3> and returns the density per solid angle.
// z_slack: samples with cos(theta) up to this much below cos(theta_max) (the
// sampler's rounding) count as theta = theta_max.
template <class Sample, class Pdf>
Chi2Result chi2_test_directions(Sample&& sample, Pdf&& pdf, size_t n, int n_theta, int n_phi,
                                double theta_max = 3.14159265358979323846, double z_slack = 0,
                                const Chi2Options& opt = {}) {
  constexpr double two_pi = 2 * 3.14159265358979323846;
  Grid2D g{0, theta_max, n_theta, 0, two_pi, n_phi, 0};
  const double z_min = std::cos(theta_max);
  auto sample_grid = [&]() -> std::optional<std::array<double, 2>> {
    std::optional<std::array<double, 3>> w = sample();
    if (!w) return std::nullopt;
    double z = std::clamp((*w)[2], -1.0, 1.0);
    double theta = z < z_min && z >= z_min - z_slack ? theta_max : std::acos(z);
    double phi = std::atan2((*w)[1], (*w)[0]);
    if (phi < 0) phi += two_pi;
    return std::array<double, 2>{theta, std::min(phi, two_pi)};
  };
  auto density = [&](double theta, double phi) {
    double st = std::sin(theta);
    std::array<double, 3> w{st * std::cos(phi), st * std::sin(phi), std::cos(theta)};
    return pdf(w) * st;
  };
  return chi2_test_2d(sample_grid, density, g, n, opt);
}

}  // namespace prism_test
