// Triangle light sampling: by solid angle (spherical triangles) against by
// area, over the solid angle the light subtends. For a unit-radiance triangle
// above a receiver, the irradiance estimator's variance per sample and the
// time per sample_li call of each method, and their efficiency ratio
// (1 / (variance x time)), at grazing and head-on placements. One thread;
// times are the best of 5 runs. Then whole renders of the default scene (its
// ceiling lamp and slit lamp are triangles) with each method: the mean
// relative variance of the pixel estimates (the film's own estimate, pixels
// above 1e-3) times the render time, the ratio being the efficiency gain at
// equal time. Writes bench/results/triangle_light.csv and
// bench/results/triangle_light_render.csv.
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

// The default scene rendered with triangle lights sampled by solid angle or
// by area: (mean relative variance per pixel, seconds), best time of 3.
template <class S>
std::pair<double, double> render_default(bool solid_angle, int w, int h, int spp) {
  Scene<S> scene;
  build_cornell_box(scene);
  scene.set_triangle_solid_angle_sampling(solid_angle);
  scene.build();
  PerspectiveCamera cam = default_camera(w, h);
  double best = 1e30, rel = 0;
  for (int rep = 0; rep < 3; ++rep) {
    Film film(w, h);
    RenderOptions opt;
    opt.spp = spp;
    opt.threads = 1;
    RenderStats st = render(scene, cam, PathIntegrator{}, film, opt);
    best = std::min(best, st.seconds);
    double sum = 0;
    int n = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        RGB v = film.pixel(x, y), var = film.variance(x, y);
        for (int c = 0; c < 3; ++c)
          if (v[c] > 1e-3f) {
            sum += double(var[c]) / (double(v[c]) * double(v[c]));
            ++n;
          }
      }
    rel = n ? sum / n : 0;
  }
  return {rel, best};
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

  std::string out2 = out;
  auto dot = out2.rfind(".csv");
  out2 = (dot == std::string::npos ? out2 : out2.substr(0, dot)) + "_render.csv";
  FILE* g = std::fopen(out2.c_str(), "w");
  if (!g) {
    std::fprintf(stderr, "triangle_light_bench: cannot write %s\n", out2.c_str());
    return 1;
  }
  (void)srgb_to_spectrum_table();  // fitted once, before any timing
  std::fprintf(g, "colour,method,rel_variance,seconds\n");
  std::printf("\ndefault scene 96x96, 32 spp, 1 thread\n%-9s %-12s %14s %9s\n", "colour", "method", "rel variance",
              "seconds");
  for (int colour = 0; colour < 2; ++colour) {
    std::pair<double, double> r[2];
    for (int m = 0; m < 2; ++m) {
      r[m] = colour == 0 ? render_default<RGB>(m == 0, 96, 96, 32) : render_default<Spectral>(m == 0, 96, 96, 32);
      const char* cname = colour == 0 ? "rgb" : "spectral";
      const char* mname = m == 0 ? "solid-angle" : "area";
      std::printf("%-9s %-12s %14.5g %9.3f\n", cname, mname, r[m].first, r[m].second);
      std::fprintf(g, "%s,%s,%g,%.4f\n", cname, mname, r[m].first, r[m].second);
    }
    std::printf("efficiency solid-angle / area: %.3f\n", (r[1].first * r[1].second) / (r[0].first * r[0].second));
  }
  std::fclose(g);
  return 0;
}
