// Triangle light sampling: by solid angle (spherical triangles) against by
// area, over the solid angle the light subtends. For a unit-radiance triangle
// above a receiver, the irradiance estimator's variance per sample and the
// time per sample_li call of each method, and their efficiency ratio
// (1 / (variance x time)), at grazing and head-on placements. One thread;
// times are the best of 5 runs. Writes bench/results/triangle_light.csv.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>
#include <prism/prism.hpp>

using namespace prism;

namespace {

struct Result {
  double var, ns;
};

Result run(const TriangleAreaLight<RGB>& light, const LightSampleContext& ctx, const Vector3f& n, int count) {
  double best = 1e30, s = 0, s2 = 0;
  for (int rep = 0; rep < 5; ++rep) {
    PCG32 rng(3, 4);
    double ls_sum = 0, ls_sum2 = 0;
    auto t0 = std::chrono::steady_clock::now();
    for (int k = 0; k < count; ++k) {
      auto ls = light.sample_li(ctx, {rng.next_float(), rng.next_float()}, RGBWavelengths{});
      double v = ls ? double(ls->L.g) * std::max(0.0, double(dot(ls->wi, n))) / double(ls->pdf) : 0;
      ls_sum += v;
      ls_sum2 += v * v;
    }
    double sec = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    best = std::min(best, sec);
    s = ls_sum;
    s2 = ls_sum2;
  }
  double mean = s / count;
  return {s2 / count - mean * mean, best / count * 1e9};
}

}  // namespace

int main(int argc, char** argv) {
  std::string out = argc > 1 ? argv[1] : "bench/results/triangle_light.csv";
  FILE* f = std::fopen(out.c_str(), "w");
  if (!f) {
    std::fprintf(stderr, "triangle_light_bench: cannot write %s\n", out.c_str());
    return 1;
  }
  // A unit-ish triangle in the plane y = 1; receivers on a ray away from it,
  // looking straight up (head-on) or with the light near their horizon.
  Point3f p0{-0.5f, 1, -0.4f}, p1{0.6f, 1, -0.3f}, p2{0, 1, 0.6f};
  TriangleAreaLight<RGB> light(p0, p1, p2, AreaEmission{RGB(1), 1, true}, 0, 0);
  TriangleAreaLight<RGB> by_area = light;
  by_area.set_solid_angle_sampling(false);
  std::fprintf(f, "placement,distance,solid_angle,var_solid_angle,var_area,ns_solid_angle,ns_area,efficiency_ratio\n");
  std::printf("%-9s %9s %12s %12s %12s %8s %8s %10s\n", "placement", "distance", "solid angle", "var sa",
              "var area", "ns sa", "ns area", "eff ratio");
  const int count = 400000;
  for (const char* placement : {"head-on", "grazing"}) {
    for (double d : {0.05, 0.2, 0.5, 1.0, 3.0, 10.0, 30.0, 100.0}) {
      LightSampleContext ctx;
      Vector3f n;
      if (std::string(placement) == "head-on") {
        ctx.p = Point3f{0, Float(1 - d), 0};
        n = {0, 1, 0};
      } else {
        // Beside the light, slightly below its plane, the normal turned so
        // that the light sits 10 degrees above the receiver's horizon.
        ctx.p = Point3f{Float(d + 0.6), Float(1 - 0.1 * d), 0};
        n = normalize(Vector3f{-0.1736f, 0.9848f, 0});
      }
      double omega = spherical_triangle_area(p0 - ctx.p, p1 - ctx.p, p2 - ctx.p);
      ctx.n = ctx.ns = Normal3f(n);
      Result a = run(light, ctx, n, count), b = run(by_area, ctx, n, count);
      double eff = (b.var * b.ns) / (a.var * a.ns);
      std::printf("%-9s %9.2f %12.4g %12.4g %12.4g %8.1f %8.1f %10.3f\n", placement, d, omega, a.var, b.var, a.ns,
                  b.ns, eff);
      std::fprintf(f, "%s,%g,%g,%g,%g,%.2f,%.2f,%.4f\n", placement, d, omega, a.var, b.var, a.ns, b.ns, eff);
    }
  }
  std::fclose(f);
  return 0;
}
