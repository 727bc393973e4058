// Deformation blur: what a deforming mesh costs against the same mesh
// standing still, in prism (SceneAccel::add_deforming_mesh) and in Embree 3
// (a triangle geometry with several time steps), on identical rays.
//
// The mesh: a UV sphere of radius 1 with 256 x 192 quads (98,304
// triangles), rippled along its normal by a wave that travels during the
// shutter: r(θ, φ, t) = 1 + A sin(8θ + πt) sin(6φ), for amplitudes A of
// 0.01, 0.05 and 0.2 (the triangles' edges are about 0.025 long; over the
// shutter a vertex moves by up to 2A: about 0.8, 4 and 16 edges). The wave
// is sampled at K evenly spaced times (K = 2, 3, 5, 9); both renderers blend
// vertices linearly between them. prism runs with each number of time
// slices per interval between keys (BVHBuildOptions::deformation_slices: 0
// = its automatic choice, 1, 2, 4, 8). Rays: 200,000 from random points on a sphere of
// radius 3 towards random points within radius 1.2, each at a random time in
// [0, 1]. Figures: build time and closest-hit throughput on one thread
// (median of 5), bytes of
// the structures, and each throughput against the still mesh's in the same
// renderer. Hits are compared between the two renderers (hit or miss, and t
// within 1e-4 relative). Writes bench/results/deformation.csv.
//
// Usage: deformation_bench [--out FILE] [--embree-config STR] (e.g. isa=avx2)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>
#include <prism/accel/scene_accel.hpp>
#include <prism/sampling/pcg32.hpp>
#include <prism/sampling/warps.hpp>
#if defined(PRISM_BENCH_HAS_EMBREE)
#include <embree3/rtcore.h>
#endif

using namespace prism;

namespace {

constexpr int kU = 256, kV = 192;
constexpr double kPi = 3.14159265358979323846;

Vector3f random_unit(PCG32& rng) {
  Float a = rng.next_float();
  return sample_uniform_sphere({a, rng.next_float()});
}

// The sphere's vertices at time t (a (kU + 1) x (kV + 1) grid; the seam and
// the poles repeat vertices, which changes nothing here).
std::vector<Point3f> sphere_at(double amplitude, double t) {
  std::vector<Point3f> p;
  p.reserve(size_t(kU + 1) * (kV + 1));
  for (int j = 0; j <= kV; ++j)
    for (int i = 0; i <= kU; ++i) {
      double theta = kPi * j / kV, phi = 2 * kPi * i / kU;
      double r = 1 + amplitude * std::sin(8 * theta + kPi * t) * std::sin(6 * phi);
      p.push_back(Point3f(Float(r * std::sin(theta) * std::cos(phi)), Float(r * std::sin(theta) * std::sin(phi)),
                          Float(r * std::cos(theta))));
    }
  return p;
}

TriangleMesh sphere_mesh(double amplitude) {
  TriangleMesh m;
  m.positions = sphere_at(amplitude, 0);
  for (int j = 0; j < kV; ++j)
    for (int i = 0; i < kU; ++i) {
      uint32_t a = uint32_t(j * (kU + 1) + i), b = a + 1, c = a + kU + 1, d = c + 1;
      m.indices.insert(m.indices.end(), {a, c, b, b, c, d});
    }
  return m;
}

template <class F>
double median_mrays(size_t rays, F&& trace) {
  std::vector<double> runs;
  for (int rep = 0; rep < 5; ++rep) {
    auto t0 = std::chrono::steady_clock::now();
    trace();
    double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    runs.push_back(double(rays) / s * 1e-6);
  }
  std::sort(runs.begin(), runs.end());
  return runs[runs.size() / 2];
}

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

struct Row {
  std::string renderer;
  double amplitude;
  int keys;  // 1: still
  int slices;  // prism's deformation_slices (the count used)
  double build_ms, mrays, bytes;
  int hits;
};

}  // namespace

int main(int argc, char** argv) {
  std::string out = "bench/results/deformation.csv", embree_config;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--out") && i + 1 < argc) out = argv[++i];
    else if (!std::strcmp(argv[i], "--embree-config") && i + 1 < argc) embree_config = argv[++i];
    else {
      std::fprintf(stderr, "usage: deformation_bench [--out FILE] [--embree-config STR]\n");
      return 2;
    }
  }
  PCG32 rng(5, 5);
  std::vector<Ray> rays(200000);
  for (Ray& r : rays) {
    Point3f o = Point3f(0, 0, 0) + random_unit(rng) * Float(3);
    Point3f target = Point3f(0, 0, 0) + random_unit(rng) * Float(1.2f * std::cbrt(rng.next_float()));
    r = Ray{o, normalize(target - o), rng.next_float()};
  }
  std::vector<Row> rows;
  std::vector<Float> prism_t(rays.size());

#if defined(PRISM_BENCH_HAS_EMBREE)
  std::string cfg = "threads=1" + (embree_config.empty() ? std::string() : "," + embree_config);
  RTCDevice device = rtcNewDevice(cfg.c_str());
  if (!device) {
    std::fprintf(stderr, "deformation_bench: rtcNewDevice(\"%s\") failed\n", cfg.c_str());
    return 1;
  }
#endif

  std::printf("%-8s %6s %5s %6s %10s %10s %8s %10s\n", "renderer", "A", "keys", "slices", "build ms", "Mrays/s", "hits",
              "MB");
  for (double amplitude : {0.01, 0.05, 0.2}) {
    const TriangleMesh mesh = sphere_mesh(amplitude);
    for (int keys : {1, 2, 3, 5, 9}) {
     for (int slices : {0, 1, 2, 4, 8}) {
      if (keys == 1 && slices > 0) break;
      // prism
      SceneAccel accel;
      if (keys == 1) {
        accel.add_mesh(mesh);
      } else {
        VertexMotion vm;
        vm.time0 = 0;
        vm.time1 = 1;
        for (int k = 0; k < keys; ++k) vm.positions.push_back(sphere_at(amplitude, double(k) / (keys - 1)));
        accel.add_deforming_mesh(mesh, std::move(vm));
      }
      accel.add_mesh_instance(0);
      BVHBuildOptions opt;
      opt.threads = 1;
      opt.deformation_slices = slices;
      auto t0 = std::chrono::steady_clock::now();
      accel.build(opt);
      double build_ms = ms_since(t0);
      int hits = 0;
      double mr = median_mrays(rays.size(), [&] {
        hits = 0;
        for (size_t i = 0; i < rays.size(); ++i) {
          auto h = accel.intersect(rays[i]);
          hits += h.has_value();
          prism_t[i] = h ? h->t : -1;
        }
      });
      double bytes = keys == 1 ? double(accel.mesh_accels()[0].memory_bytes())
                               : double(accel.deforming_mesh_accels()[0].memory_bytes());
      int used = keys == 1 ? 0 : accel.deforming_mesh_accels()[0].slices();
      rows.push_back({slices == 0 ? "prism" : "prism_fixed", amplitude, keys, used, build_ms, mr, bytes, hits});
      std::printf("%-8s %6.2f %5d %4d%s %10.1f %10.3f %8d %10.1f\n", "prism", amplitude, keys, used,
                  slices == 0 ? "a" : " ", build_ms, mr, hits, bytes / 1e6);
      if (slices != 0) continue;
#if defined(PRISM_BENCH_HAS_EMBREE)
      // Embree: the same vertices at the same time steps.
      RTCScene scene = rtcNewScene(device);
      rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_MEDIUM);
      RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
      rtcSetGeometryTimeStepCount(g, unsigned(keys));
      for (int k = 0; k < keys; ++k) {
        std::vector<Point3f> p = keys == 1 ? mesh.positions : sphere_at(amplitude, double(k) / (keys - 1));
        float* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, unsigned(k),
                                                               RTC_FORMAT_FLOAT3, 3 * sizeof(float), p.size()));
        for (size_t i = 0; i < p.size(); ++i) {
          v[3 * i] = p[i].x;
          v[3 * i + 1] = p[i].y;
          v[3 * i + 2] = p[i].z;
        }
      }
      auto* idx = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                 3 * sizeof(unsigned), mesh.triangle_count()));
      std::copy(mesh.indices.begin(), mesh.indices.end(), idx);
      rtcCommitGeometry(g);
      rtcAttachGeometry(scene, g);
      rtcReleaseGeometry(g);
      t0 = std::chrono::steady_clock::now();
      rtcCommitScene(scene);
      double ebuild = ms_since(t0);
      int ehits = 0, disagree = 0;
      double emr = median_mrays(rays.size(), [&] {
        ehits = 0;
        disagree = 0;
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        for (size_t i = 0; i < rays.size(); ++i) {
          const Ray& r = rays[i];
          RTCRayHit rh;
          rh.ray.org_x = r.o.x;
          rh.ray.org_y = r.o.y;
          rh.ray.org_z = r.o.z;
          rh.ray.dir_x = r.d.x;
          rh.ray.dir_y = r.d.y;
          rh.ray.dir_z = r.d.z;
          rh.ray.tnear = 0;
          rh.ray.tfar = infinity;
          rh.ray.time = r.time;
          rh.ray.mask = ~0u;
          rh.ray.flags = 0;
          rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
          rtcIntersect1(scene, &ctx, &rh);
          bool hit = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
          ehits += hit;
          if (hit != (prism_t[i] >= 0) || (hit && std::abs(rh.ray.tfar - prism_t[i]) > 1e-4f * prism_t[i]))
            ++disagree;
        }
      });
      rtcReleaseScene(scene);
      rows.push_back({"embree", amplitude, keys, 0, ebuild, emr, 0, ehits});
      std::printf("%-8s %6.2f %5d %6s %10.1f %10.3f %8d %10s   (disagree with prism: %d)\n", "embree", amplitude, keys,
                  "", ebuild, emr, ehits, "-", disagree);
#endif
     }
    }
  }
#if defined(PRISM_BENCH_HAS_EMBREE)
  rtcReleaseDevice(device);
#endif
  FILE* f = std::fopen(out.c_str(), "w");
  if (!f) {
    std::fprintf(stderr, "deformation_bench: cannot write %s\n", out.c_str());
    return 1;
  }
  std::fprintf(f, "renderer,amplitude,keys,slices,build_ms,mrays_per_s,vs_still,hits,bytes\n");
  for (const Row& r : rows) {
    double still = 0;
    std::string base = r.renderer == "prism_fixed" ? "prism" : r.renderer;
    for (const Row& s : rows)
      if (s.renderer == base && s.amplitude == r.amplitude && s.keys == 1) still = s.mrays;
    std::fprintf(f, "%s,%g,%d,%d,%.2f,%.4f,%.4f,%d,%.0f\n", r.renderer.c_str(), r.amplitude, r.keys, r.slices,
                 r.build_ms, r.mrays, r.mrays / still, r.hits, r.bytes);
  }
  std::fclose(f);
  std::printf("wrote %s\n", out.c_str());
  return 0;
}
