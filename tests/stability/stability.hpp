// Shared helpers of the stability suite (tests/stability/, ctest label
// "stability"): run a render, measure the image mean with its standard error,
// count non-finite samples and pixels, and the firefly ratio (the 99.99th
// percentile pixel of a method over the reference's). Each measurement is
// printed as one "STABILITY |" line, which docs/stability.md tabulates.
#pragma once
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <prism/prism.hpp>
#include "support/reference_physics.hpp"

namespace prism::stability {

// One render: the film and the renderer's statistics (dropped = non-finite
// samples, never written to the film).
struct Run {
  Film film;
  RenderStats stats;
};

struct RunSpec {
  int width = 16, height = 16, spp = 64;
  SamplerKind sampler = SamplerKind::independent;
  uint64_t seed = 1;
  int threads = 0;
};

template <class Scene, class Camera, class Integrator>
Run run(const Scene& scene, const Camera& camera, const Integrator& integrator, const RunSpec& spec) {
  Run r{Film(spec.width, spec.height), {}};
  RenderOptions opt;
  opt.spp = spec.spp;
  opt.seed = spec.seed;
  opt.sampler = spec.sampler;
  opt.threads = spec.threads;
  r.stats = render(scene, camera, integrator, r.film, opt);
  return r;
}

// Pixels whose value (any channel) is not finite.
inline uint64_t nonfinite_pixels(const Film& f) {
  uint64_t n = 0;
  for (int y = 0; y < f.height(); ++y)
    for (int x = 0; x < f.width(); ++x)
      if (!f.pixel(x, y).is_finite()) ++n;
  return n;
}

// Channel c of every pixel, row-major.
inline std::vector<double> channel(const Film& f, int c) {
  std::vector<double> v;
  v.reserve(size_t(f.width()) * size_t(f.height()));
  for (int y = 0; y < f.height(); ++y)
    for (int x = 0; x < f.width(); ++x) v.push_back(double(f.pixel(x, y)[c]));
  return v;
}

// An estimate of a mean with its standard error.
struct Estimate {
  double mean = 0, sigma = 0;
};

// The mean of channel c over all pixels and its standard error from the
// film's per-pixel variance (pixels are independent, so variances add).
// Valid only for renders without splats (the film's variance excludes them).
inline Estimate image_mean(const Film& f, int c) {
  double sum = 0, var = 0, n = double(f.width()) * double(f.height());
  for (int y = 0; y < f.height(); ++y)
    for (int x = 0; x < f.width(); ++x) {
      sum += double(f.pixel(x, y)[c]);
      var += double(f.variance(x, y)[c]);
    }
  return {sum / n, std::sqrt(var) / n};
}

// The mean of K independent image means (renders with different seeds) and
// its standard error from their spread: for renders with splats (the caustic
// pass), whose film variance is incomplete.
inline Estimate batch_mean(const std::vector<double>& means) {
  double k = double(means.size()), m = 0, ss = 0;
  for (double v : means) m += v;
  m /= k;
  for (double v : means) ss += (v - m) * (v - m);
  return {m, std::sqrt(ss / (k - 1) / k)};
}

inline double image_average(const Film& f, int c) {
  std::vector<double> v = channel(f, c);
  double s = 0;
  for (double x : v) s += x;
  return s / double(v.size());
}

// The q-quantile (nearest rank) of v; with fewer than 10^4 values the
// 99.99th percentile is the maximum.
inline double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  size_t k = size_t(std::ceil(q * double(v.size())));
  k = std::clamp<size_t>(k, 1, v.size());
  return v[k - 1];
}

// The firefly ratio: the 99.99th-percentile pixel of the method over the
// reference's (per-pixel reference values, analytic where known).
inline double firefly_ratio(const std::vector<double>& method, const std::vector<double>& reference) {
  double ref = percentile(reference, 0.9999);
  return ref > 0 ? percentile(method, 0.9999) / ref : (percentile(method, 0.9999) > 0 ? INFINITY : 1);
}

// Rounding allowance for estimators whose every sample is the same number
// (a smooth mirror in a uniform environment, a white furnace): their standard
// error is 0 and the mean can differ from the reference only by the rounding
// of the per-sample arithmetic and the film's accumulation, bounded by
// gamma(64) (a few dozen float operations per sample, each rounding by at
// most u) relative to the value.
inline double rounding_allowance(double reference) { return double(gamma(64)) * std::abs(reference); }

// The rows of the suite's table (docs/stability.md) are one family of
// comparisons: at most stability_rows of them (90 today), each mean checked
// within z sigma, z from Sidak's correction at a family-wise false-alarm
// rate of 10^-3 (4.47).
inline constexpr int stability_rows = 128;
inline double stability_z() { return reference_physics::sidak_z(1e-3, stability_rows); }

// One row of the suite's table; printed and checked. `z` is (mean - ref) /
// sigma (0 when both differences and sigma vanish); the check is
// |mean - ref| <= stability_z() sigma + rounding_allowance(ref). A firefly
// bound <= 0 means "reported, not bounded".
struct Row {
  std::string case_name, method;
  Estimate est;
  double reference = 0;
  double firefly = 0, firefly_bound = 0;
  uint64_t dropped = 0, nonfinite = 0;
  std::string note;

  double z() const {
    double d = est.mean - reference;
    if (est.sigma > 0) return d / est.sigma;
    return d == 0 ? 0 : (d > 0 ? INFINITY : -INFINITY);
  }
  void print() const {
    std::printf("STABILITY | %s | %s | mean %.6g | ref %.6g | sigma %.3g | z %+.2f | firefly %.3g | bound %s | "
                "non-finite %llu+%llu | %s\n",
                case_name.c_str(), method.c_str(), est.mean, reference, est.sigma, z(), firefly,
                firefly_bound > 0 ? std::to_string(firefly_bound).c_str() : "-",
                static_cast<unsigned long long>(dropped), static_cast<unsigned long long>(nonfinite), note.c_str());
  }
  // The suite's assertions for this row.
  void check(bool check_mean = true) const {
    print();
    INFO(case_name << " / " << method << ": mean " << est.mean << " reference " << reference << " sigma "
                   << est.sigma << " z " << z() << " firefly " << firefly << " (bound " << firefly_bound << ") "
                   << note);
    CHECK(dropped == 0);
    CHECK(nonfinite == 0);
    CHECK(std::isfinite(est.mean));
    if (check_mean) CHECK(std::abs(est.mean - reference) <= stability_z() * est.sigma + rounding_allowance(reference));
    if (firefly_bound > 0) CHECK(firefly <= firefly_bound);
  }
};

// A row from one render without splats: image mean of channel c with the
// film's standard error; firefly ratio against per-pixel reference values.
inline Row make_row(std::string case_name, std::string method, const Run& r, int c, double reference,
                    const std::vector<double>& ref_pixels) {
  Row row;
  row.case_name = std::move(case_name);
  row.method = std::move(method);
  row.est = image_mean(r.film, c);
  row.reference = reference;
  row.firefly = firefly_ratio(channel(r.film, c), ref_pixels);
  row.dropped = r.stats.dropped;
  row.nonfinite = nonfinite_pixels(r.film);
  return row;
}

// Two films are identical pixel for pixel (bitwise equal floats).
inline bool identical(const Film& a, const Film& b) {
  if (a.width() != b.width() || a.height() != b.height()) return false;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) {
      RGB p = a.pixel(x, y), q = b.pixel(x, y);
      for (int c = 0; c < 3; ++c)
        if (std::memcmp(&p[c], &q[c], sizeof(float)) != 0) return false;
    }
  return true;
}

// A closed axis-aligned box as 12 outward-facing triangles.
inline void append_box(TriangleMesh& m, const Point3f& lo, const Point3f& hi) {
  // append_quad's normal is cross(a, b).
  Vector3f dx{hi.x - lo.x, 0, 0}, dy{0, hi.y - lo.y, 0}, dz{0, 0, hi.z - lo.z};
  append_quad(m, lo, dx, dz);       // bottom (y = lo), normal -y
  append_quad(m, lo + dy, dz, dx);  // top (y = hi), normal +y
  append_quad(m, lo, dy, dx);       // front (z = lo), normal -z
  append_quad(m, lo + dz, dx, dy);  // back (z = hi), normal +z
  append_quad(m, lo, dz, dy);       // left (x = lo), normal -x
  append_quad(m, lo + dx, dy, dz);  // right (x = hi), normal +x
}

// The solid angle of the rectangle [x0, x1] x [z0, z1] of a plane, seen from a
// point at height h > 0 above the plane's origin: the integral of
// h / (x^2 + z^2 + h^2)^(3/2) over it, by inclusion-exclusion of the corner
// rectangles, F(x, z) = atan(x z / (h sqrt(x^2 + z^2 + h^2))).
inline double rectangle_solid_angle(double x0, double x1, double z0, double z1, double h) {
  auto F = [h](double x, double z) { return std::atan(x * z / (h * std::sqrt(x * x + z * z + h * h))); };
  return F(x1, z1) - F(x0, z1) - F(x1, z0) + F(x0, z0);
}

}  // namespace prism::stability
