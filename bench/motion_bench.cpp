// Motion blur traversal: how many top-level motion segments to build.
//
// 2,000 instances of a 320-triangle blob scattered in a 40-unit cube; each
// moves between two keys (translation of a given length and a turn of up to
// 90 degrees). Rays start at random points with random directions and
// random times. For each motion length and segment count: the top-level
// build time and closest-hit throughput (one thread, median of 5 runs), and
// the same scene standing still as the baseline. Writes bench/results/motion.csv.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>
#include <prism/accel/scene_accel.hpp>
#include <prism/sampling/pcg32.hpp>
#include <prism/sampling/warps.hpp>

using namespace prism;

namespace {

Vector3f random_unit(PCG32& rng) {
  Float a = rng.next_float();
  return sample_uniform_sphere({a, rng.next_float()});
}

TriangleMesh blob(PCG32& rng) {
  TriangleMesh m;
  for (int i = 0; i < 320; ++i) {
    Point3f c = Point3f{0, 0, 0} + random_unit(rng) * Float(0.5);
    for (int j = 0; j < 3; ++j) {
      m.positions.push_back(c + random_unit(rng) * Float(0.15));
      m.indices.push_back(uint32_t(m.positions.size() - 1));
    }
  }
  return m;
}

SceneAccel make_scene(Float travel, int segments, double* build_ms) {
  PCG32 rng(11, 3);
  SceneAccel accel;
  uint32_t mesh = accel.add_mesh(blob(rng));
  for (int i = 0; i < 2000; ++i) {
    Vector3f p{40 * rng.next_float() - 20, 40 * rng.next_float() - 20, 40 * rng.next_float() - 20};
    TransformKey k0 = TransformKey::trs(p, Quaternion::from_axis_angle(random_unit(rng), 6.28f * rng.next_float()));
    TransformKey k1 = k0;
    Vector3f dir = random_unit(rng);
    Float turn = 1.57f * rng.next_float();
    Vector3f axis = random_unit(rng);
    if (travel > 0) {
      k1.translation += dir * travel;
      Quaternion dq = Quaternion::from_axis_angle(axis, turn);
      const Quaternion& q = k0.rotation;
      k1.rotation = Quaternion{dq.w * q.x + dq.x * q.w + dq.y * q.z - dq.z * q.y,
                               dq.w * q.y - dq.x * q.z + dq.y * q.w + dq.z * q.x,
                               dq.w * q.z + dq.x * q.y - dq.y * q.x + dq.z * q.w,
                               dq.w * q.w - dq.x * q.x - dq.y * q.y - dq.z * q.z};
    }
    accel.add_mesh_instance(mesh, AnimatedTransform(k0, k1, 0, 1));
  }
  BVHBuildOptions opt;
  opt.motion_segments = segments;
  opt.threads = 1;
  auto t0 = std::chrono::steady_clock::now();
  accel.build(opt);
  *build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return accel;
}

double trace_mrays(const SceneAccel& accel, const std::vector<Ray>& rays, int* hits) {
  std::vector<double> runs;
  for (int rep = 0; rep < 5; ++rep) {
    int h = 0;
    auto t0 = std::chrono::steady_clock::now();
    for (const Ray& r : rays) h += accel.intersect(r).has_value();
    double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    runs.push_back(double(rays.size()) / s * 1e-6);
    *hits = h;
  }
  std::sort(runs.begin(), runs.end());
  return runs[runs.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  std::string out = argc > 1 ? argv[1] : "bench/results/motion.csv";
  PCG32 rng(5, 5);
  std::vector<Ray> rays(200000);
  for (Ray& r : rays)
    r = Ray{{40 * rng.next_float() - 20, 40 * rng.next_float() - 20, 40 * rng.next_float() - 20}, random_unit(rng),
            rng.next_float()};
  FILE* f = std::fopen(out.c_str(), "w");
  if (!f) {
    std::fprintf(stderr, "motion_bench: cannot write %s\n", out.c_str());
    return 1;
  }
  std::fprintf(f, "travel,segments,build_ms,mrays_per_s,hits\n");
  std::printf("%8s %8s %10s %12s %8s\n", "travel", "segments", "build ms", "Mrays/s", "hits");
  for (Float travel : {0.f, 0.25f, 1.f, 4.f}) {
    for (int segments : {1, 2, 4, 8, 16}) {
      if (travel == 0 && segments > 1) continue;  // a still scene has one tree
      double build_ms;
      SceneAccel accel = make_scene(travel, segments, &build_ms);
      int hits = 0;
      double mr = trace_mrays(accel, rays, &hits);
      std::printf("%8.2f %8d %10.2f %12.3f %8d\n", double(travel), segments, build_ms, mr, hits);
      std::fprintf(f, "%g,%d,%.3f,%.4f,%d\n", double(travel), segments, build_ms, mr, hits);
    }
  }
  std::fclose(f);
  return 0;
}
