// bench/ab_traversal.cpp — prism against prism: the single-ray queries of two
// versions of include/ in one process, run alternately on the same rays, for
// deciding whether a change to the BVH or the triangle test pays.
//
// Why: traversal_bench compares prism with Embree, and its ratios move by
// +-5% from run to run on a VM whose speed drifts; a change worth 2% cannot be
// seen there. Here both versions share the machine's state: each repetition
// times version A then B (then B then A, alternating), and the speed-up is the
// mean of the per-repetition ratios with its standard error. Two identical
// versions (an A/A run) measure the harness itself.
//
// Built by scripts/ab_traversal.sh, which compiles this file three times: with
// AB_SIDE=a and AB_SIDE=b against the two include/ trees (the namespace
// renamed by -Dprism=prism_ab_a / prism_ab_b, so both live in one binary) and
// with AB_MAIN for the driver.
//
// Scene: the 1M-triangle displaced cube-sphere of traversal_bench
// (procedural_mesh.hpp), MeshAccel with default options on 2 threads. Rays:
// primary (a res x res pinhole raster framing the mesh, row by row), and from
// each primary hit an incoherent ray (cosine about the facing normal) and a
// shadow ray (to a random point on a sphere of radius 2, finite t_max), in
// raster order as traversal_bench makes them; and the incoherent rays once
// more in a shuffled order ("scattered": consecutive rays share no nodes, as
// in a path tracer's later bounces), closest hit; and traversal_bench's own
// primary rays of this mesh ("framed": 1024 x 1024, its framing camera, 68%
// of them hit where the raster above hits with 39%). Both versions trace the
// rays that version A made (ab_export / ab_import).
#include <chrono>
#include <cstddef>

#if defined(AB_SIDE)
#include <vector>

#include "procedural_mesh.hpp"
#include "prism/accel/scene_accel.hpp"
#include "prism/math/frame.hpp"
#include "prism/sampling/warps.hpp"

#define AB_CAT2(a, b) a##b
#define AB_CAT(a, b) AB_CAT2(a, b)
#define AB_FN(name) AB_CAT(AB_CAT(name, _), AB_SIDE)

namespace {

using namespace prism;

struct Rays {
  std::vector<Point3f> o;
  std::vector<Vector3f> d;
  std::vector<Float> t_max;
  void add(const Point3f& org, const Vector3f& dir, Float t) {
    o.push_back(org);
    d.push_back(dir);
    t_max.push_back(t);
  }
};

struct State {
  TriangleMesh mesh;
  MeshAccel accel;
  Rays rays[5];  // primary, incoherent, shadow, scattered, framed
};
State* state = nullptr;

}  // namespace

void AB_FN(ab_setup)(int res) {
  state = new State;
  state->mesh = prism_bench::make_displaced_sphere(289);
  BVHBuildOptions opt;
  opt.threads = 2;
  state->accel = MeshAccel(state->mesh, opt);
  const TriangleMesh& m = state->mesh;
  const Point3f eye{0.3f, 0.4f, 4.0f};
  for (int y = 0; y < res; ++y)
    for (int x = 0; x < res; ++x) {
      Vector3f d = prism_bench::raster_direction(x, y, res);
      state->rays[0].add(eye, d, infinity);
      Float t = infinity;
      TriangleHit h;
      uint32_t tri = 0;
      if (!state->accel.intersect(eye, d, &t, &h, &tri)) continue;
      PCG32 rng = prism_bench::pixel_rng(x, y, res);
      Vector3f n;
      prism_bench::BounceRay bounce =
          prism_bench::incoherent_ray(eye + d * t, m.positions[m.indices[3 * tri]], m.positions[m.indices[3 * tri + 1]],
                                      m.positions[m.indices[3 * tri + 2]], d, rng, &n);
      const Point3f p = bounce.o;
      state->rays[1].add(p, bounce.d, infinity);
      Vector3f u = sample_uniform_sphere({rng.next_float(), rng.next_float()});
      if (dot(u, n) < 0) u = -u;
      Vector3f to = u * 2.0f - Vector3f(p);
      Float dist = length(to);
      state->rays[2].add(p, to / dist, dist);
    }
  // Fisher-Yates with a fixed seed.
  Rays& s = state->rays[3];
  s = state->rays[1];
  PCG32 rng(11, 0xab);
  for (size_t i = s.o.size(); i > 1; --i) {
    size_t j = rng.next_u32() % i;
    std::swap(s.o[i - 1], s.o[j]);
    std::swap(s.d[i - 1], s.d[j]);
    std::swap(s.t_max[i - 1], s.t_max[j]);
  }
  const prism_bench::FramingCamera cam(state->mesh, state->accel.bounds(), prism_bench::procedural_view);
  constexpr int framed_res = 1024;  // traversal_bench's default --res
  for (int y = 0; y < framed_res; ++y)
    for (int x = 0; x < framed_res; ++x) state->rays[4].add(cam.eye, cam.direction(x, y, framed_res), infinity);
}

size_t AB_FN(ab_count)(int kind) { return state->rays[kind].o.size(); }
size_t AB_FN(ab_triangles)() { return state->mesh.triangle_count(); }

// The rays as 7 floats each (origin, direction, t_max), so that B traces A's
// rays bit for bit: each side's set-up code is compiled on its own, and may
// contract a * b + c into an FMA differently, which would move the rays.
std::vector<float> AB_FN(ab_export)(int kind) {
  const Rays& r = state->rays[kind];
  std::vector<float> v;
  for (size_t i = 0; i < r.o.size(); ++i)
    v.insert(v.end(), {r.o[i].x, r.o[i].y, r.o[i].z, r.d[i].x, r.d[i].y, r.d[i].z, r.t_max[i]});
  return v;
}
void AB_FN(ab_import)(int kind, const std::vector<float>& v) {
  Rays& r = state->rays[kind];
  r = Rays{};
  for (size_t i = 0; i + 7 <= v.size(); i += 7) r.add({v[i], v[i + 1], v[i + 2]}, {v[i + 3], v[i + 4], v[i + 5]}, v[i + 6]);
}

// Seconds to trace every ray of a kind; *check gets the hit count plus the
// sum of the closest hits' t (the same for versions that agree).
double AB_FN(ab_trace)(int kind, double* check) {
  const Rays& r = state->rays[kind];
  const MeshAccel& accel = state->accel;
  size_t hits = 0;
  double t_sum = 0;
  auto start = std::chrono::steady_clock::now();
  for (size_t i = 0; i < r.o.size(); ++i) {
    if (kind == 2) {
      hits += accel.occluded(r.o[i], r.d[i], r.t_max[i]);
      continue;
    }
    Float t = r.t_max[i];
    TriangleHit h;
    uint32_t tri = 0;
    if (accel.intersect(r.o[i], r.d[i], &t, &h, &tri)) {
      ++hits;
      t_sum += t;
    }
  }
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  *check = double(hits) + t_sum;
  return seconds;
}

// Seconds to build the mesh's MeshAccel (default options) on `threads`
// threads; *check gets the wide node count (equal when the trees are).
double AB_FN(ab_build)(int threads, double* check) {
  BVHBuildOptions opt;
  opt.threads = threads;
  auto start = std::chrono::steady_clock::now();
  MeshAccel accel(state->mesh, opt);
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  *check = double(accel.bvh().wide_node_count());
  return seconds;
}

#elif defined(AB_MAIN)
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

void ab_setup_a(int res);
void ab_setup_b(int res);
size_t ab_count_a(int kind);
std::vector<float> ab_export_a(int kind);
void ab_import_b(int kind, const std::vector<float>& v);
double ab_trace_a(int kind, double* check);
double ab_trace_b(int kind, double* check);
size_t ab_triangles_a();
double ab_build_a(int threads, double* check);
double ab_build_b(int threads, double* check);

int main(int argc, char** argv) {
  int res = 724, reps = 20;
  bool build = false;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--res" && i + 1 < argc) {
      res = std::atoi(argv[++i]);
    } else if (a == "--reps" && i + 1 < argc) {
      reps = std::atoi(argv[++i]);
    } else if (a == "--build") {
      build = true;
    } else {
      std::fprintf(stderr, "usage: ab_traversal [--res N (724)] [--reps N (20)] [--build]\n");
      return 2;
    }
  }
  if (res < 16 || reps < 2) {
    std::fprintf(stderr, "ab_traversal: --res must be >= 16 and --reps >= 2\n");
    return 2;
  }
  ab_setup_a(res);
  ab_setup_b(res);
  for (int kind = 0; kind < 5; ++kind) ab_import_b(kind, ab_export_a(kind));
  std::printf("%d reps, A then B alternating with B then A; speed-up = time A / time B per repetition\n", reps);
  int status = 0;
  // Times A and B alternately; `per_rep` items per repetition for the rate.
  // A differing check fails the run when `strict` (rays must give the same
  // hits); for builds it only says that the trees differ.
  auto measure = [&](const char* name, auto&& run_a, auto&& run_b, double per_rep, const char* unit, bool strict) {
    std::vector<double> ratio;
    double time_a = 0, time_b = 0;
    bool differ = false;
    for (int i = 0; i < reps; ++i) {
      double ca = 0, cb = 0, ta, tb;
      if (i % 2 == 0) {
        ta = run_a(&ca);
        tb = run_b(&cb);
      } else {
        tb = run_b(&cb);
        ta = run_a(&ca);
      }
      if (ca != cb) differ = true;
      ratio.push_back(ta / tb);
      time_a += ta;
      time_b += tb;
    }
    double mean = 0, var = 0;
    for (double r : ratio) mean += r;
    mean /= reps;
    for (double r : ratio) var += (r - mean) * (r - mean);
    double se = std::sqrt(var / (reps - 1) / reps);
    std::sort(ratio.begin(), ratio.end());
    double items = per_rep * reps;
    std::printf("%-10s %8.0f %-6s A %6.3f  B %6.3f M%s/s  speed-up B/A %.4f +- %.4f (median %.4f, %.3f..%.3f)%s\n",
                name, per_rep, unit, items / time_a * 1e-6, items / time_b * 1e-6, unit, mean, se,
                ratio[ratio.size() / 2], ratio.front(), ratio.back(),
                differ ? (strict ? "  RESULTS DIFFER" : "  (trees differ)") : "");
    if (differ && strict) status = 1;
  };
  const char* names[5] = {"primary", "incoherent", "shadow", "scattered", "framed"};
  for (int kind = 0; kind < 5; ++kind)
    measure(
        names[kind], [&](double* c) { return ab_trace_a(kind, c); }, [&](double* c) { return ab_trace_b(kind, c); },
        double(ab_count_a(kind)), "rays", true);
  if (build) {
    const double tris = double(ab_triangles_a());
    for (int threads = 1; threads <= 2; ++threads)
      measure(
          threads == 1 ? "build 1t" : "build 2t", [&](double* c) { return ab_build_a(threads, c); },
          [&](double* c) { return ab_build_b(threads, c); }, tris, "tris", false);
  }
  return status;
}
#else
#error "compile with -DAB_SIDE=a, -DAB_SIDE=b or -DAB_MAIN (see scripts/ab_traversal.sh)"
#endif
