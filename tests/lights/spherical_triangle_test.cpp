// Spherical-triangle sampling (sampling/warps.hpp) and its use by triangle
// area lights: the directions are uniform over the solid angle (chi-squared
// over a barycentric subdivision whose cells' solid angles are exact), the
// density is 1 / solid angle, and next-event estimation of the irradiance
// from a triangle matches the closed form with a lower variance than area
// sampling where the light is large and near.
#include <catch2/catch.hpp>
#include <prism/prism.hpp>
#include "support/chi2.hpp"
#include "support/reference_physics.hpp"

namespace spherical_triangle_test {

using namespace prism;

namespace {

struct Tri {
  Point3f p0, p1, p2;
};

// Barycentrics of where the ray from o along w meets the triangle's plane.
std::array<double, 3> plane_barycentrics(const Tri& t, const Point3f& o, const Vector3f& w) {
  double e1[3] = {t.p1.x - t.p0.x, t.p1.y - t.p0.y, t.p1.z - t.p0.z};
  double e2[3] = {t.p2.x - t.p0.x, t.p2.y - t.p0.y, t.p2.z - t.p0.z};
  double d[3] = {w.x, w.y, w.z}, s[3] = {o.x - t.p0.x, o.y - t.p0.y, o.z - t.p0.z};
  auto cr = [](const double* a, const double* b, double* r) {
    r[0] = a[1] * b[2] - a[2] * b[1];
    r[1] = a[2] * b[0] - a[0] * b[2];
    r[2] = a[0] * b[1] - a[1] * b[0];
  };
  auto dt = [](const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
  double pv[3], qv[3];
  cr(d, e2, pv);
  double det = dt(e1, pv);
  double b1 = dt(s, pv) / det;
  cr(s, e1, qv);
  double b2 = dt(d, qv) / det;
  return {1 - b1 - b2, b1, b2};
}

Point3f lerp3(const Tri& t, double b1, double b2) {
  double b0 = 1 - b1 - b2;
  return {Float(b0 * t.p0.x + b1 * t.p1.x + b2 * t.p2.x), Float(b0 * t.p0.y + b1 * t.p1.y + b2 * t.p2.y),
          Float(b0 * t.p0.z + b1 * t.p1.z + b2 * t.p2.z)};
}

// Irradiance at o (normal n) from a triangle of unit radiance, seen entirely
// above the receiver's horizon: Lambert's polygon formula
// E = 1/2 sum_i angle(v_i, v_i+1) (n . unit(v_i x v_i+1)).
double polygon_irradiance(const Tri& t, const Point3f& o, const Vector3f& n) {
  using V = std::array<double, 3>;
  auto sub = [&](const Point3f& p) { return V{double(p.x) - o.x, double(p.y) - o.y, double(p.z) - o.z}; };
  auto cr = [](const V& a, const V& b) {
    return V{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
  };
  auto dt = [](const V& a, const V& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };
  V v[3] = {sub(t.p0), sub(t.p1), sub(t.p2)}, nd{n.x, n.y, n.z};
  double e = 0;
  for (int i = 0; i < 3; ++i) {
    V c = cr(v[i], v[(i + 1) % 3]);
    double lc = std::sqrt(dt(c, c));
    double angle = std::atan2(lc, dt(v[i], v[(i + 1) % 3]));
    e += angle * dt(nd, c) / lc;
  }
  return std::abs(e) / 2;
}

}  // namespace

TEST_CASE("spherical triangle sampling is uniform over the solid angle", "[lights][area][chi2][spherical]") {
  // A near, large triangle (about 2 sr), a moderate one and a small one
  // (about 2e-3 sr) seen from the origin.
  const Tri tris[] = {{{-1, 1, 0.3f}, {1.5f, 0.8f, -0.5f}, {0.2f, 0.6f, 1.5f}},
                      {{-1, 3, -1}, {1.5f, 3.2f, -0.5f}, {0, 3.5f, 1.5f}},
                      {{-0.1f, 8, 0}, {0.15f, 8.2f, 0}, {0, 8, 0.2f}}};
  const double alpha = prism_test::sidak_alpha(1e-3, 3);
  const Point3f o{0, 0, 0};
  const int N = 6;  // the triangle cut into N^2 similar cells
  for (const Tri& t : tris) {
    double omega = spherical_triangle_area(t.p0 - o, t.p1 - o, t.p2 - o);
    // Each cell's exact probability: its solid angle over the whole.
    std::vector<double> expected, observed(size_t(N * N), 0);
    auto cell_of = [&](double b1, double b2) {
      int i = std::clamp(int(b1 * N), 0, N - 1), j = std::clamp(int(b2 * N), 0, N - 1);
      // Cells: upright (i, j) with i + j < N, and inverted ones.
      double f1 = b1 * N - i, f2 = b2 * N - j;
      bool upper = f1 + f2 > 1;
      if (i + j >= N - 1) upper = false;  // the last diagonal has only upright cells
      return size_t((i * N + j) * 2 + (upper ? 1 : 0)) % size_t(2 * N * N);
    };
    std::vector<double> cell_p(size_t(2 * N * N), 0);
    double sum_p = 0;
    for (int i = 0; i < N; ++i)
      for (int j = 0; i + j < N; ++j) {
        Point3f a = lerp3(t, double(i) / N, double(j) / N), b = lerp3(t, double(i + 1) / N, double(j) / N),
                c = lerp3(t, double(i) / N, double(j + 1) / N);
        double w = spherical_triangle_area(a - o, b - o, c - o) / omega;
        cell_p[size_t((i * N + j) * 2)] = w;
        sum_p += w;
        if (i + j < N - 1) {
          Point3f d = lerp3(t, double(i + 1) / N, double(j + 1) / N);
          double w2 = spherical_triangle_area(b - o, d - o, c - o) / omega;
          cell_p[size_t((i * N + j) * 2 + 1)] = w2;
          sum_p += w2;
        }
      }
    // 1e-6: the cells' solid angles, each a few roundings, summed and divided by ω
    REQUIRE(sum_p == Approx(1).epsilon(1e-6));
    PCG32 rng(7, 11);
    const int n = 200000;
    std::vector<double> counts(cell_p.size(), 0);
    size_t outside = 0;
    for (int k = 0; k < n; ++k) {
      auto s = sample_spherical_triangle(t.p0 - o, t.p1 - o, t.p2 - o, {rng.next_float(), rng.next_float()});
      REQUIRE(s);
      // 1e-6 relative: the sampler's float solid angle against the double one (a few u); -1e-5: float directions' rounding on the plane
      CHECK(s->area == Approx(omega).epsilon(1e-6));
      auto bc = plane_barycentrics(t, o, s->w);
      if (bc[0] < -1e-5 || bc[1] < -1e-5 || bc[2] < -1e-5) ++outside;
      counts[cell_of(std::clamp(bc[1], 0.0, 1.0), std::clamp(bc[2], 0.0, 1.0))] += 1;
    }
    CHECK(outside == 0);
    for (double& p : cell_p) p *= n;
    auto r = prism_test::chi2_from_counts(counts, cell_p);
    INFO("solid angle " << omega << ": " << r.summary());
    CHECK(r.p_value >= alpha);
  }
}

TEST_CASE("spherical triangle sampling rejects degenerate triangles", "[lights][area][spherical][errors]") {
  // Collinear corners and a zero corner give no sample rather than NaN.
  CHECK_FALSE(sample_spherical_triangle({1, 0, 0}, {2, 0, 0}, {3, 0, 0}, {0.5f, 0.5f}));
  CHECK_FALSE(sample_spherical_triangle({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.5f, 0.5f}));
  CHECK(spherical_triangle_area({1, 0, 0}, {2, 0, 0}, {3, 0, 0}) == 0);
  // The octant: pi / 2 exactly.
  // 1e-12: double arithmetic, ~10 roundings of 2^-53
  CHECK(spherical_triangle_area({1, 0, 0}, {0, 1, 0}, {0, 0, 1}) == Approx(1.5707963267948966).epsilon(1e-12));
}

TEST_CASE("triangle light NEE: closed-form irradiance, pdf_li agrees, lower variance near a large light",
          "[lights][area][spherical]") {
  // A unit-radiance triangle above receivers on the plane y = 0 (normal +y).
  const Tri t{{-1, 0.4f, -1}, {1.5f, 0.5f, -0.5f}, {0, 0.6f, 1.5f}};
  TriangleAreaLight<RGB> light(t.p0, t.p1, t.p2, AreaEmission{RGB(1), 1, true}, 0, 0);
  const Vector3f n{0, 1, 0};
  // 3 receivers x 2 estimators = 6 comparisons with the closed form, one
  // family at 10^-3 (Sidak): z = sidak_z(1e-3, 6) = 3.77.
  const double z = reference_physics::sidak_z(1e-3, 6);
  // Near (spherical sampling) and far (area sampling: below the threshold).
  for (Point3f at : {Point3f{0.1f, 0, 0.2f}, Point3f{0.3f, -0.1f, 0.1f}, Point3f{400, -300, 100}}) {
    LightSampleContext ctx;
    ctx.p = at;
    double omega = spherical_triangle_area(t.p0 - at, t.p1 - at, t.p2 - at);
    bool spherical = light.spherical_solid_angle(at) > 0;
    // Solid-angle sampling needs a large enough solid angle and a light
    // whose distance varies enough over it; the far receiver has neither.
    if (omega < TriangleAreaLight<RGB>::kMinSphericalSolidAngle) CHECK_FALSE(spherical);
    double ref = polygon_irradiance(t, at, n);
    PCG32 rng(3, 4);
    const int count = 100000;
    double s = 0, s2 = 0, a = 0, a2 = 0;
    for (int k = 0; k < count; ++k) {
      Point2f u{rng.next_float(), rng.next_float()};
      auto ls = light.sample_li(ctx, u, RGBWavelengths{});
      double v = 0;
      if (ls) {
        v = double(ls->L.g) * std::max(0.0, double(dot(ls->wi, n))) / double(ls->pdf);
        // pdf_li at the point the sample found gives the same density.
        SurfaceInteraction si;
        si.p = ls->p_light;
        // 1e-3: the area path's d²/(|cos| A) in float has relative error ≈ u/|cos|, ≤ 1e-3 for |cos| ≥ 6e-5
        CHECK(light.pdf_li(ctx, ls->wi, si) == Approx(ls->pdf).epsilon(1e-3));
      }
      s += v;
      s2 += v * v;
      // The area-sampling estimator of the same integral, for comparison.
      auto b = sample_uniform_triangle(u);
      Point3f p = lerp3(t, b[1], b[2]);
      Vector3f d = p - at;
      double d2 = double(length_squared(d));
      Vector3f w = normalize(d);
      double tri_area = double(length(cross(t.p1 - t.p0, t.p2 - t.p0))) / 2;
      Vector3f ln = normalize(cross(t.p1 - t.p0, t.p2 - t.p0));
      double e = std::max(0.0, double(dot(w, n))) * std::abs(double(dot(ln, w))) * tri_area / d2;
      a += e;
      a2 += e * e;
    }
    double mean = s / count, var = s2 / count - mean * mean, sigma = std::sqrt(var / (count - 1));
    double amean = a / count, avar = a2 / count - amean * amean, asigma = std::sqrt(avar / (count - 1));
    INFO("at (" << at.x << ", " << at.y << ", " << at.z << "): solid angle " << omega << ", E = " << ref
                << ", light sampler " << mean << " +- " << sigma << " (variance " << var << "), area sampling "
                << amean << " +- " << asigma << " (variance " << avar << ")");
    // z from Šidák (above); 1e-6·ref: the float pdf and L of each weight (a few u)
    CHECK(std::abs(mean - ref) <= z * sigma + 1e-6 * ref);
    CHECK(std::abs(amean - ref) <= z * asigma);
    if (spherical) CHECK(var < avar);
    WARN("triangle light at solid angle " << omega << ": variance spherical/area = " << var / avar);
  }
}

}  // namespace spherical_triangle_test
