// bench/traversal_bench.cpp — BVH build time and single-ray traversal speed of
// prism (SceneAccel) against Embree 3 (rtcCommitScene at RTC_BUILD_QUALITY_MEDIUM,
// rtcIntersect1 / rtcOccluded1) on identical meshes and identical rays.
//
// Cases: a deterministic ~1M-triangle displaced cube-sphere, and the glTF sample
// MetalRoughSpheresNoTextures flattened to world space (skipped if absent).
// Rays: primary (pinhole camera framing the object), incoherent (cosine
// hemisphere about the geometric normal at the primary hits) and shadow (from
// the primary hits to random points on a sphere around the scene, finite t_max);
// for the procedural mesh also the incoherent rays shuffled ("scattered": no
// two consecutive rays share nodes, as in a path tracer's later bounces).
// Fourth ray set, glTF case only: rays recorded from prism's own path tracer
// while it renders the model (prism's glTF loader, RGB, PathIntegrator with
// its defaults, the framing camera, lit by the shared HDR environment;
// 512x512 at 64 spp on one thread): the camera rays, the bounce rays at
// depths 1, 2 and 3 (closest hit) and the next-event shadow rays (any hit,
// with the integrator's t_max: infinite here, the only light being the
// environment). A wrapper scene (RecordingScene) writes down every ray that
// the unchanged renderer hands to intersect()/occluded(); each kind keeps
// every s-th ray, at most --record-cap. They are traced against the same
// flattened mesh as the other sets (CSV rows recorded_camera_<case>,
// recorded_bounce1..3_<case>, recorded_shadow_<case>).
// Every figure is the median over repetitions (6 by default), each a pair of
// runs of prism and Embree back to back. Which runs first alternates from one
// repetition to the next (--first), as in scripts/ab_traversal.sh: on this
// project's VM the order moved the primary-ray ratio by up to 8%
// (docs/performance.md, twenty-third step), so a fixed order could bias it
// either way. The CSV's ratio is
// the medians' ratio, and ratio_min / ratio_max the smallest and largest
// ratio of one repetition's pair (the run's own spread).
// Results are checked: hit/miss and closest-hit t (relative 1e-4) must agree
// for more than 99.9% of the rays, otherwise a warning is printed.
//
// Usage: traversal_bench [--reps N] [--res N] [--threads 1,2] [--out FILE] [--gltf FILE]
//                        [--env FILE] [--record-res N] [--record-spp N] [--record-cap N]
//                        [--split-budget F] [--cases LIST] [--embree-config STR] [--procedural-n N]
//                        [--first alternate|prism|embree] [--layout-csv FILE]
// --embree-config is appended to Embree's device configuration (isa=avx2 holds
// it to its AVX2 kernels); --procedural-n sets the procedural mesh's size for
// the traversal rows (12 N^2 triangles; small meshes keep the BVH in cache).
// Second code-built case, "slivers" (make_sliver_scene): long thin triangles
// where triangle pre-splitting (--split-budget, BVHBuildOptions::split_budget,
// on by default for slivers only) pays. "slivers_nosplit": the same scene
// with prism's pre-splitting off (split budget 0), its fastest build, against
// Embree's default build: the other side of the trade. "slivers_sbvh": prism
// with spatial splits in its builder (BVHBuildOptions::spatial_splits)
// against Embree's high-quality build, which has them too.
// --record-res 0 leaves out the recorded rays; without prism::gltf (tinyexr,
// stb or tinygltf missing) they are left out too.
// Run from the project root; writes bench/results/traversal.csv by default, and
// watertight.csv (edge rays: misses of each library, at the procedural mesh
// and at a closed tube of slivers that pre-splitting cuts) beside it.
// --layout-csv FILE appends every row of the run to FILE with this binary's
// BVH layout (a compile-time choice: -DPRISM_BVH_WIDTH, -DPRISM_BVH_QUANTIZED)
// and the BVH's bytes per triangle; scripts/bench.sh gathers the default
// binary's rows (every case) and the other layouts' (the procedural mesh) in
// bench/results/layouts.csv.
#include <embree3/rtcore.h>
#ifdef PRISM_BENCH_HAS_GLTF
#include <tiny_gltf.h>
#endif

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <string>
#include <system_error>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

#include "procedural_mesh.hpp"
#include "prism/accel/sbvh.hpp"
#include "prism/accel/scene_accel.hpp"
#include "prism/math/frame.hpp"
#include "prism/sampling/pcg32.hpp"
#include "prism/sampling/warps.hpp"
#include "support/meshes.hpp"
#ifdef PRISM_HAS_GLTF
#include "prism/io/gltf.hpp"
#include "prism/io/image_io.hpp"
#include "prism/prism.hpp"
#endif

using namespace prism;
using prism_bench::make_displaced_sphere;
namespace fs = std::filesystem;

namespace {

// ---------------------------------------------------------------- utilities

double now_seconds() {
  using clock = std::chrono::steady_clock;
  return std::chrono::duration<double>(clock::now().time_since_epoch()).count();
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Runs body(begin, end) over [0, n) on `threads` std::threads, handing out
// chunks from a shared counter so that slow rays do not idle a thread.
void parallel_for(size_t n, int threads, const std::function<void(size_t, size_t)>& body) {
  constexpr size_t chunk = 1024;
  std::atomic<size_t> next{0};
  auto worker = [&] {
    for (;;) {
      size_t b = next.fetch_add(chunk);
      if (b >= n) return;
      body(b, std::min(n, b + chunk));
    }
  };
  std::vector<std::thread> pool;
  for (int i = 1; i < threads; ++i) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
}

// ------------------------------------------------------- procedural mesh
// (bench/procedural_mesh.hpp: make_displaced_sphere)

// A scene of long thin triangles, where triangle pre-splitting
// (BVHBuildOptions::split_budget) should pay: a 40 x 40 ground square turned
// 30 degrees about the vertical (so its triangles' boxes are loose), cut into
// 256 strips the length of the square (512 slivers 40 long, 0.16 wide);
// 20000 straws, thin triangles 2 to 10 long and 0.01 wide in random
// directions above the ground; and 64 small displaced cube-spheres
// (make_displaced_sphere(24), radius 0.4 to 1.2) standing on the ground.
// About 463k triangles; deterministic.
TriangleMesh make_sliver_scene() {
  TriangleMesh m;
  Float c = std::cos(0.5236f), s = std::sin(0.5236f);
  auto ground = [&](Float x, Float z) { return Point3f{c * x - s * z, 0, s * x + c * z}; };
  const int strips = 256;
  for (int i = 0; i < strips; ++i) {
    Float z0 = -20 + 40 * Float(i) / strips, z1 = -20 + 40 * Float(i + 1) / strips;
    uint32_t b = uint32_t(m.positions.size());
    for (Point3f p : {ground(-20, z0), ground(20, z0), ground(20, z1), ground(-20, z1)}) m.positions.push_back(p);
    m.indices.insert(m.indices.end(), {b, b + 1, b + 2, b, b + 2, b + 3});
  }
  PCG32 rng(7, 0x511e);
  auto uni = [&](Float a, Float b) { return a + (b - a) * rng.next_float(); };
  for (int i = 0; i < 20000; ++i) {
    Point3f a{uni(-18, 18), uni(0.1f, 6), uni(-18, 18)};
    Vector3f d = sample_uniform_sphere({rng.next_float(), rng.next_float()}) * uni(2, 10);
    Vector3f w = normalize(cross(d, sample_uniform_sphere({rng.next_float(), rng.next_float()}))) * 0.01f;
    uint32_t b = uint32_t(m.positions.size());
    m.positions.insert(m.positions.end(), {a, a + d, a + d * 0.5f + w});
    m.indices.insert(m.indices.end(), {b, b + 1, b + 2});
  }
  TriangleMesh ball = make_displaced_sphere(24);
  for (int k = 0; k < 64; ++k) {
    Float r = uni(0.4f, 1.2f);
    Vector3f at{uni(-15, 15), 1.35f * r, uni(-15, 15)};
    uint32_t b = uint32_t(m.positions.size());
    for (const Point3f& p : ball.positions) m.positions.push_back(Point3f(Vector3f(p) * r + at));
    for (uint32_t i : ball.indices) m.indices.push_back(b + i);
  }
  return m;
}

// A closed tube of n long slivers around a diagonal axis (about 54 long, radius
// 4), each end a fan of n thin triangles: 4n triangles, every one a
// candidate for pre-splitting. For the edge rays with pre-splitting on.
constexpr Point3f tube_c0{-16, -12, -18}, tube_c1{16, 12, 18};  // about 54 apart
TriangleMesh make_sliver_tube(int n) { return prism::test::sliver_tube(n, 4, tube_c0, tube_c1); }

// ------------------------------------------------------------- glTF scene

#ifdef PRISM_BENCH_HAS_GLTF
using Mat4d = std::array<double, 16>;  // row-major

Mat4d mat_mul(const Mat4d& a, const Mat4d& b) {
  Mat4d r{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k) r[i * 4 + j] += a[i * 4 + k] * b[k * 4 + j];
  return r;
}

Mat4d node_matrix(const tinygltf::Node& node) {
  Mat4d m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  if (node.matrix.size() == 16) {  // column-major in glTF
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) m[i * 4 + j] = node.matrix[size_t(j * 4 + i)];
    return m;
  }
  double s[3] = {1, 1, 1}, t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1};
  for (size_t i = 0; i < node.scale.size() && i < 3; ++i) s[i] = node.scale[i];
  for (size_t i = 0; i < node.translation.size() && i < 3; ++i) t[i] = node.translation[i];
  for (size_t i = 0; i < node.rotation.size() && i < 4; ++i) q[i] = node.rotation[i];
  double x = q[0], y = q[1], z = q[2], w = q[3];
  double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - z * w),     2 * (x * z + y * w),
                 2 * (x * y + z * w),     1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                 2 * (x * z - y * w),     2 * (y * z + x * w),     1 - 2 * (x * x + y * y)};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) m[i * 4 + j] = r[i * 3 + j] * s[j];
    m[i * 4 + 3] = t[i];
  }
  return m;
}

// Reads an accessor's element e as doubles (float or normalised/plain integer components).
const unsigned char* accessor_element(const tinygltf::Model& model, const tinygltf::Accessor& acc, size_t e) {
  const auto& view = model.bufferViews[size_t(acc.bufferView)];
  const auto& buf = model.buffers[size_t(view.buffer)];
  size_t stride = size_t(acc.ByteStride(view));
  return buf.data.data() + view.byteOffset + acc.byteOffset + e * stride;
}

void append_primitive(const tinygltf::Model& model, const tinygltf::Primitive& prim, const Mat4d& m,
                      TriangleMesh& out) {
  if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != -1) return;
  auto it = prim.attributes.find("POSITION");
  if (it == prim.attributes.end()) return;
  const auto& pacc = model.accessors[size_t(it->second)];
  if (pacc.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT || pacc.type != TINYGLTF_TYPE_VEC3 || pacc.bufferView < 0)
    return;
  uint32_t base = uint32_t(out.positions.size());
  for (size_t v = 0; v < pacc.count; ++v) {
    float p[3];
    std::memcpy(p, accessor_element(model, pacc, v), sizeof p);
    double w[3];
    for (int i = 0; i < 3; ++i)
      w[i] = m[size_t(i * 4)] * p[0] + m[size_t(i * 4 + 1)] * p[1] + m[size_t(i * 4 + 2)] * p[2] + m[size_t(i * 4 + 3)];
    out.positions.push_back({Float(w[0]), Float(w[1]), Float(w[2])});
  }
  if (prim.indices < 0) {
    for (size_t v = 0; v + 2 < pacc.count; v += 3)
      out.indices.insert(out.indices.end(), {base + uint32_t(v), base + uint32_t(v + 1), base + uint32_t(v + 2)});
    return;
  }
  const auto& iacc = model.accessors[size_t(prim.indices)];
  for (size_t k = 0; k < iacc.count; ++k) {
    const unsigned char* e = accessor_element(model, iacc, k);
    uint32_t i = 0;
    switch (iacc.componentType) {
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: i = *e; break;
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: { uint16_t s; std::memcpy(&s, e, 2); i = s; break; }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: std::memcpy(&i, e, 4); break;
      default: return;
    }
    out.indices.push_back(base + i);
  }
  out.indices.resize(out.indices.size() - (out.indices.size() % 3));
}

void append_node(const tinygltf::Model& model, int node_index, const Mat4d& parent, TriangleMesh& out, int depth) {
  if (depth > 64) return;
  const auto& node = model.nodes[size_t(node_index)];
  Mat4d m = mat_mul(parent, node_matrix(node));
  if (node.mesh >= 0)
    for (const auto& prim : model.meshes[size_t(node.mesh)].primitives) append_primitive(model, prim, m, out);
  for (int c : node.children) append_node(model, c, m, out, depth + 1);
}

// All mesh primitives of the default scene, with node transforms applied.
bool load_gltf_flat(const std::string& path, TriangleMesh* out) {
  tinygltf::Model model;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  bool ok = path.ends_with(".glb") ? loader.LoadBinaryFromFile(&model, &err, &warn, path)
                                   : loader.LoadASCIIFromFile(&model, &err, &warn, path);
  if (!ok) {
    std::fprintf(stderr, "glTF: cannot load %s: %s\n", path.c_str(), err.c_str());
    return false;
  }
  Mat4d id{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  int scene = model.defaultScene >= 0 ? model.defaultScene : 0;
  if (model.scenes.empty()) {
    for (size_t i = 0; i < model.nodes.size(); ++i) append_node(model, int(i), id, *out, 0);
  } else {
    for (int n : model.scenes[size_t(scene)].nodes) append_node(model, n, id, *out, 0);
  }
  return out->triangle_count() > 0;
}
#endif

// ------------------------------------------------------------------ Embree

void embree_error(void*, RTCError code, const char* msg) {
  std::fprintf(stderr, "Embree error %d: %s\n", int(code), msg ? msg : "");
}

// A device and a one-mesh scene over shared (padded) buffers.
struct EmbreeScene {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  std::vector<float> verts;  // padded: Embree reads 16 bytes at the last vertex
  std::vector<uint32_t> indices;

  // MEDIUM is Embree's default (binned SAH); HIGH adds its spatial splits,
  // the counterpart of prism's pre-splitting.
  RTCBuildQuality quality = RTC_BUILD_QUALITY_MEDIUM;

  EmbreeScene(const TriangleMesh& m, int threads, const std::string& extra_config = "",
              RTCBuildQuality q = RTC_BUILD_QUALITY_MEDIUM)
      : quality(q) {
    std::string cfg = "threads=" + std::to_string(threads);
    if (!extra_config.empty()) cfg += "," + extra_config;
    device = rtcNewDevice(cfg.c_str());
    rtcSetDeviceErrorFunction(device, embree_error, nullptr);
    verts.resize(3 * m.positions.size() + 4);
    for (size_t i = 0; i < m.positions.size(); ++i) {
      verts[3 * i] = m.positions[i].x;
      verts[3 * i + 1] = m.positions[i].y;
      verts[3 * i + 2] = m.positions[i].z;
    }
    indices = m.indices;
  }
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;
  ~EmbreeScene() {
    if (scene) rtcReleaseScene(scene);
    rtcReleaseDevice(device);
  }

  // Creates a fresh scene and returns the time of rtcCommitScene alone.
  double build() {
    if (scene) rtcReleaseScene(scene);
    scene = rtcNewScene(device);
    rtcSetSceneBuildQuality(scene, quality);
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    rtcSetGeometryBuildQuality(g, quality);
    size_t nv = (verts.size() - 4) / 3, nt = indices.size() / 3;
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, verts.data(), 0, 3 * sizeof(float), nv);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, indices.data(), 0,
                               3 * sizeof(uint32_t), nt);
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
    double t0 = now_seconds();
    rtcCommitScene(scene);
    return now_seconds() - t0;
  }
};

// --------------------------------------------------------------- ray sets

struct BenchRay {
  Point3f o;
  Vector3f d;
  Float t_max;
};

// traversal_bench's pinhole camera (procedural_mesh.hpp), res x res rays in raster order.
std::vector<BenchRay> primary_rays(const TriangleMesh& mesh, const Bounds3f& b, Vector3f view_dir, int res) {
  const prism_bench::FramingCamera cam(mesh, b, view_dir);
  std::vector<BenchRay> rays;
  rays.reserve(size_t(res) * size_t(res));
  for (int y = 0; y < res; ++y)
    for (int x = 0; x < res; ++x) rays.push_back({cam.eye, cam.direction(x, y, res), infinity});
  return rays;
}

struct HitRecord {
  Float t = infinity;  // infinity on a miss
  uint32_t prim = UINT32_MAX;
};

// ------------------------------------------------ rays recorded from prism

// The rays prism's own path tracer traces while it renders a model: the
// camera rays, the bounce rays at depths 1, 2 and 3 (closest hit) and the
// shadow rays of next-event estimation (any hit, with the t_max the
// integrator gave). Deeper bounces are only counted.
//
// Each kind keeps every s-th of its rays in the order the renderer traced
// them, s the smallest power of two that keeps at most `cap` (a set halves,
// dropping every other ray, whenever it would exceed the cap): a uniform
// subsample of the whole image, so that the shallow kinds stay bounded while
// the render runs long enough to give the deep ones enough rays.
struct RayReservoir {
  std::vector<BenchRay> rays;
  size_t seen = 0, stride = 1, cap = 1000000;
  void add(const BenchRay& r) {
    if (seen++ % stride != 0) return;
    rays.push_back(r);
    if (rays.size() > cap) {
      for (size_t i = 0; 2 * i < rays.size(); ++i) rays[i] = rays[2 * i];
      rays.resize((rays.size() + 1) / 2);
      stride *= 2;
    }
  }
};

struct RecordedRays {
  RayReservoir camera, bounce[3], shadow;
  size_t deeper = 0;                // bounce rays at depth 4 and beyond (not kept)
  size_t shadow_at[5] = {};         // shadow rays by path vertex: 0, 1, 2, 3, 4+
  size_t shadow_infinite = 0;       // shadow rays with t_max = infinity (to the environment)
  size_t shadow_skip = 0;           // shadow rays ending on an area light (skip primitive)
};

#ifdef PRISM_HAS_GLTF
// A scene that forwards everything to prism's Scene and writes down every
// ray handed to intersect() and occluded(). PathIntegrator::Li takes its
// scene as a template parameter, so the renderer runs unchanged on it; the
// library has no hook for this. Single-threaded (the recording render runs
// on one thread, so the sets come out in the renderer's deterministic order).
template <class SceneT>
class RecordingScene {
 public:
  using spectrum_type = typename SceneT::spectrum_type;
  RecordingScene(const SceneT& s, RecordedRays& out) : m_scene(s), m_out(&out) {}

  void begin_path() const { m_depth = 0; }

  std::optional<SurfaceInteraction> intersect(const Ray& ray, Float t_max = infinity) const {
    BenchRay r{ray.o, ray.d, t_max};
    if (m_depth == 0)
      m_out->camera.add(r);
    else if (m_depth <= 3)
      m_out->bounce[m_depth - 1].add(r);
    else
      ++m_out->deeper;
    ++m_depth;
    return m_scene.intersect(ray, t_max);
  }
  bool occluded(const Ray& ray, Float t_max, uint32_t skip_instance = UINT32_MAX,
                uint32_t skip_primitive = UINT32_MAX) const {
    m_out->shadow.add({ray.o, ray.d, t_max});
    // NEE happens at the vertex found by the last intersect() of the path.
    ++m_out->shadow_at[std::min(4, std::max(0, m_depth - 1))];
    m_out->shadow_infinite += t_max == infinity;
    m_out->shadow_skip += skip_instance != UINT32_MAX;
    return m_scene.occluded(ray, t_max, skip_instance, skip_primitive);
  }

  template <class W>
  auto bsdf(const SurfaceInteraction& si, W&& lambda) const {
    return m_scene.bsdf(si, std::forward<W>(lambda));
  }
  template <class W>
  auto interior_absorption(const SurfaceInteraction& si, const W& lambda) const {
    return m_scene.interior_absorption(si, lambda);
  }
  bool has_specular() const { return m_scene.has_specular(); }
  bool has_area_lights() const { return m_scene.has_area_lights(); }
  const auto& lights() const { return m_scene.lights(); }
  const auto& infinite_lights() const { return m_scene.infinite_lights(); }
  auto sample_light(const LightSampleContext& ctx, Float u) const { return m_scene.sample_light(ctx, u); }
  Float light_pmf(const LightSampleContext& ctx, uint32_t light) const { return m_scene.light_pmf(ctx, light); }

 private:
  const SceneT& m_scene;
  RecordedRays* m_out;
  mutable int m_depth = 0;
};

// PathIntegrator, telling the recording scene where each camera path starts.
// It has no caustics_active(), so the renderer runs no light-tracing pass
// (which this model, without area lights, would not have anyway).
struct RecordingIntegrator {
  PathIntegrator path;
  template <class Scene, class Sampler, class W>
  typename Scene::spectrum_type Li(const Scene& scene, Ray ray, W& lambda, Sampler& sampler,
                                   RayCounter& counter) const {
    scene.begin_path();
    return path.Li(scene, ray, lambda, sampler, counter);
  }
};

// Renders the glTF model as prism's front end would (RGB, PathIntegrator with
// its defaults, independent sampler, the framing camera, lit by the HDR
// environment, or a uniform white sky when the map is absent) at res x res
// and spp samples on one thread, recording every ray. Returns false if the
// model cannot be loaded.
bool record_rays(const std::string& model, const std::string& env, int res, int spp, size_t cap,
                 RecordedRays* out) {
  for (RayReservoir* r : {&out->camera, &out->bounce[0], &out->bounce[1], &out->bounce[2], &out->shadow}) r->cap = cap;
  try {
    auto g = load_gltf<RGB>(model);
    if (fs::exists(env)) {
      g.scene.add_light(ImageInfiniteLight<RGB>(read_environment(env), 1));
    } else {
      std::printf("  (environment %s not found: a uniform white sky lights the model)\n", env.c_str());
      g.scene.add_light(UniformInfiniteLight<RGB>(RGB(1, 1, 1)));
    }
    g.scene.build();
    RecordingScene rec(g.scene, *out);
    Film film(res, res);
    RenderOptions ro;
    ro.spp = spp;
    ro.threads = 1;
    double t0 = now_seconds();
    RenderStats st = render(rec, gltf_framing_camera(g.bounds, res, res), RecordingIntegrator{}, film, ro);
    std::printf("  recorded from a %dx%d, %d spp render of %s (%zu triangles in %zu meshes, %s): %.2f s, %llu rays\n",
                res, res, spp, fs::path(model).filename().string().c_str(), g.scene_triangles,
                g.scene.accel().meshes().size(), fs::exists(env) ? fs::path(env).filename().string().c_str() : "white sky",
                now_seconds() - t0, (unsigned long long)st.rays);
  } catch (const Error& e) {
    std::fprintf(stderr, "recorded rays: %s\n", e.what());
    return false;
  }
  std::printf("  traced by the renderer: %zu camera, %zu / %zu / %zu bounce at depth 1 / 2 / 3 (%zu deeper, not "
              "kept), %zu shadow (at vertex 0 / 1 / 2 / 3 / 4+: %zu / %zu / %zu / %zu / %zu; %zu to the environment)\n",
              out->camera.seen, out->bounce[0].seen, out->bounce[1].seen, out->bounce[2].seen, out->deeper,
              out->shadow.seen, out->shadow_at[0], out->shadow_at[1], out->shadow_at[2], out->shadow_at[3],
              out->shadow_at[4], out->shadow_infinite);
  std::printf("  kept (every s-th, at most %zu a kind): camera %zu (s=%zu), bounce1 %zu (s=%zu), bounce2 %zu (s=%zu), "
              "bounce3 %zu (s=%zu), shadow %zu (s=%zu)\n",
              cap, out->camera.rays.size(), out->camera.stride, out->bounce[0].rays.size(), out->bounce[0].stride,
              out->bounce[1].rays.size(), out->bounce[1].stride, out->bounce[2].rays.size(), out->bounce[2].stride,
              out->shadow.rays.size(), out->shadow.stride);
  if (out->shadow_skip)
    std::printf("  WARNING: %zu shadow rays end on an area light; Embree traces them without the skip\n",
                out->shadow_skip);
  std::fflush(stdout);
  return true;
}
#endif

// ----------------------------------------------------------- the runners

void trace_prism(const SceneAccel& s, const std::vector<BenchRay>& rays, int threads, std::vector<HitRecord>& out) {
  out.assign(rays.size(), {});
  parallel_for(rays.size(), threads, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) {
      auto h = s.intersect(Ray{rays[i].o, rays[i].d}, rays[i].t_max);
      if (h) out[i] = {h->t, h->primitive};
    }
  });
}
void occluded_prism(const SceneAccel& s, const std::vector<BenchRay>& rays, int threads, std::vector<uint8_t>& out) {
  out.assign(rays.size(), 0);
  parallel_for(rays.size(), threads, [&](size_t b, size_t e) {
    for (size_t i = b; i < e; ++i) out[i] = s.occluded(Ray{rays[i].o, rays[i].d}, rays[i].t_max);
  });
}
void trace_embree(RTCScene s, const std::vector<BenchRay>& rays, int threads, std::vector<HitRecord>& out) {
  out.assign(rays.size(), {});
  parallel_for(rays.size(), threads, [&](size_t b, size_t e) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (size_t i = b; i < e; ++i) {
      RTCRayHit rh;
      const BenchRay& r = rays[i];
      rh.ray.org_x = r.o.x; rh.ray.org_y = r.o.y; rh.ray.org_z = r.o.z;
      rh.ray.dir_x = r.d.x; rh.ray.dir_y = r.d.y; rh.ray.dir_z = r.d.z;
      rh.ray.tnear = 0;
      rh.ray.tfar = r.t_max;
      rh.ray.time = 0;
      rh.ray.mask = UINT32_MAX;
      rh.ray.id = 0;
      rh.ray.flags = 0;
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(s, &ctx, &rh);
      if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) out[i] = {rh.ray.tfar, rh.hit.primID};
    }
  });
}
void occluded_embree(RTCScene s, const std::vector<BenchRay>& rays, int threads, std::vector<uint8_t>& out) {
  out.assign(rays.size(), 0);
  parallel_for(rays.size(), threads, [&](size_t b, size_t e) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (size_t i = b; i < e; ++i) {
      RTCRay ray;
      const BenchRay& r = rays[i];
      ray.org_x = r.o.x; ray.org_y = r.o.y; ray.org_z = r.o.z;
      ray.dir_x = r.d.x; ray.dir_y = r.d.y; ray.dir_z = r.d.z;
      ray.tnear = 0;
      ray.tfar = r.t_max;
      ray.time = 0;
      ray.mask = UINT32_MAX;
      ray.id = 0;
      ray.flags = 0;
      rtcOccluded1(s, &ctx, &ray);
      out[i] = ray.tfar < 0;
    }
  });
}

// ------------------------------------------------------- watertightness

// Rays aimed exactly at the shared vertices and (as nearly as floats allow) at
// points on the shared edges of a closed mesh, from outside its bounding
// sphere: every one must hit something, so a miss is a ray that slipped
// through a crack between triangles. Half the rays go to vertices, half to
// edge points. Counts the misses of prism and of Embree (default, non-robust
// build) on the same rays.
//
// Each ray must also pass into the mesh at its target: one that only touches
// the mesh there (a tangent at a silhouette or along a crease) may miss by
// its rounding. Without `inside`, the ray comes from the target's direction
// as seen from the centre (the mesh must be star-shaped about it, like the
// displaced sphere); with it, the ray goes from the target towards the point
// inside(target, rng), which must lie well inside a convex mesh.
struct WatertightRow {
  std::string mesh;
  size_t rays, prism_misses, embree_misses;
};

WatertightRow run_watertight(const std::string& name, const TriangleMesh& mesh, size_t count,
                             const std::function<Point3f(const Point3f&, PCG32&)>& inside = {}) {
  SceneAccel prism_scene;
  prism_scene.add_mesh_instance(prism_scene.add_mesh(mesh));
  prism_scene.build();
  EmbreeScene em(mesh, 2);
  em.build();
  Bounds3f b = prism_scene.bounds();
  Point3f c = b.centroid();
  Float far = 2 * length(b.diagonal());
  std::vector<BenchRay> rays;
  rays.reserve(count);
  PCG32 rng(7, 0xed9e);
  size_t ntri = mesh.triangle_count();
  for (size_t i = 0; i < count; ++i) {
    size_t t = std::min(ntri - 1, size_t(rng.next_float() * Float(ntri)));
    int k = std::min(2, int(rng.next_float() * 3));
    Point3f p0 = mesh.positions[mesh.indices[3 * t + size_t(k)]];
    Point3f p1 = mesh.positions[mesh.indices[3 * t + size_t((k + 1) % 3)]];
    Float u = rng.next_float();
    Point3f target = i % 2 == 0 ? p0 : p0 + (p1 - p0) * u;
    if (inside) {
      Vector3f d = normalize(inside(target, rng) - target);
      Point3f o = target - d * far;
      rays.push_back({o, normalize(target - o), infinity});
      continue;
    }
    // From outside, roughly from the direction of the target as seen from the centre.
    Vector3f dir = normalize(target - c) + sample_uniform_sphere({rng.next_float(), rng.next_float()}) * 0.5f;
    Point3f o = c + normalize(dir) * far;
    rays.push_back({o, normalize(target - o), infinity});
  }
  std::vector<HitRecord> hp, he;
  trace_prism(prism_scene, rays, 2, hp);
  trace_embree(em.scene, rays, 2, he);
  WatertightRow row{name, count, 0, 0};
  for (size_t i = 0; i < count; ++i) {
    row.prism_misses += hp[i].t == infinity;
    row.embree_misses += he[i].t == infinity;
  }
  std::printf("  watertight %s: %zu rays at shared vertices and edges: prism %zu misses, embree %zu misses\n",
              name.c_str(), count, row.prism_misses, row.embree_misses);
  return row;
}

// ------------------------------------------------------------ the driver

struct Options {
  int reps = 6;  // even, so that each library runs first in half the pairs
  int res = 1024;
  std::vector<int> threads = {1, 2};
  std::string out = "bench/results/traversal.csv";
  std::string gltf = "../shared/scenes/MetalRoughSpheresNoTextures/glTF-Binary/MetalRoughSpheresNoTextures.glb";
  std::string env = "../shared/scenes/envmaps/chinese_garden_1k.hdr";
  int record_res = 512;  // the recording render: record_res^2 pixels at record_spp
  int record_spp = 64;
  size_t record_cap = 1000000;  // rays kept per kind
  float split_budget = BVHBuildOptions{}.split_budget;  // of prism's mesh builds (the library's default)
  bool spatial_splits = false;                          // prism's mesh builds with spatial splits (SBVH)
  // The cases to run (--cases, comma-separated): procedural, slivers, slivers_nosplit (prism without
  // pre-splitting), slivers_hq (Embree at its high build quality), slivers_sbvh (both with spatial splits), watertight, metalroughspheres. All by default; A/B comparisons of a
  // change usually need only one.
  std::string cases = "procedural,slivers,slivers_nosplit,slivers_hq,slivers_sbvh,watertight,metalroughspheres";
  // Appended to Embree's device configuration (--embree-config), e.g.
  // "isa=avx2" to hold Embree to the kernels prism has on this machine.
  std::string embree_config;
  // make_displaced_sphere's resolution for the procedural case (12 n^2
  // triangles; 289: about 1M). Smaller meshes show the ratio with the BVH in cache.
  int procedural_n = 289;
  // Which library runs first in each repetition's pair (--first): "alternate"
  // (prism in even repetitions, Embree in odd ones), "prism" or "embree".
  std::string first = "alternate";
  // --layout-csv: rows of this binary's BVH layout appended to this file
  // (scripts/bench.sh builds one binary per layout: bench/results/layouts.csv).
  std::string layout_csv;
  bool prism_first(int rep) const { return first == "prism" || (first == "alternate" && rep % 2 == 0); }
  bool runs(const char* name) const {
    for (size_t p = 0; p <= cases.size();) {
      size_t q = cases.find(',', p);
      if (q == std::string::npos) q = cases.size();
      if (cases.compare(p, q - p, name) == 0) return true;
      p = q + 1;
    }
    return false;
  }
};

struct InstanceRow {
  std::string name;
  double direct, identity, rotated;  // Mrays/s
};
std::vector<InstanceRow> g_instance_rows;

// This binary's BVH layout: node width, float or quantized child boxes, and
// the triangle packets' width (all chosen at compile time).
std::string layout_name() {
#if defined(PRISM_BVH_QUANTIZED) && PRISM_BVH_QUANTIZED
  constexpr bool quantized = true;
#else
  constexpr bool quantized = false;
#endif
  return "nodes" + std::to_string(detail::wide_width) + (quantized ? "_quantized" : "_float") + "_packets" +
         std::to_string(triangle_packet_width);
}

struct CsvRow {
  std::string name;
  size_t triangles;
  int threads;
  double prism, embree, ratio;
  // The smallest and largest ratio of one repetition's pair (prism and Embree
  // run back to back): how far the VM's drift moves the figure within a run.
  double ratio_min, ratio_max;
  // The case's BVH memory (wide nodes, leaf order, triangle packets) per input triangle.
  double bytes_per_triangle = 0;
};

// One row of traversal.csv (with the bytes per triangle appended for layouts.csv).
void write_row(FILE* f, const CsvRow& r, bool with_bytes = false) {
  std::fprintf(f, "%s,%zu,%d,%.3f,%.3f,%.3f,%.3f,%.3f", r.name.c_str(), r.triangles, r.threads, r.prism, r.embree,
               r.ratio, r.ratio_min, r.ratio_max);
  if (with_bytes) std::fprintf(f, ",%.1f", r.bytes_per_triangle);
  std::fputc('\n', f);
}

// The ratio of each repetition's pair, Embree's time over prism's, as
// {smallest, largest}.
std::pair<double, double> paired_ratio_range(const std::vector<double>& t_prism, const std::vector<double>& t_embree) {
  double lo = infinity, hi = 0;
  for (size_t r = 0; r < t_prism.size(); ++r) {
    double q = t_embree[r] / t_prism[r];
    lo = std::min(lo, q);
    hi = std::max(hi, q);
  }
  return {lo, hi};
}

struct Agreement {
  size_t rays = 0, hit_agree = 0, both_hit = 0, t_agree = 0, prim_agree = 0;
  double hit_frac() const { return rays ? double(hit_agree) / double(rays) : 1; }
  double t_frac() const { return both_hit ? double(t_agree) / double(both_hit) : 1; }
};

Agreement compare(const std::vector<HitRecord>& a, const std::vector<HitRecord>& b) {
  Agreement g;
  g.rays = a.size();
  for (size_t i = 0; i < a.size(); ++i) {
    bool ha = a[i].t != infinity, hb = b[i].t != infinity;
    if (ha == hb) ++g.hit_agree;
    if (ha && hb) {
      ++g.both_hit;
      if (std::abs(a[i].t - b[i].t) <= 1e-4f * std::max(a[i].t, b[i].t)) ++g.t_agree;
      if (a[i].prim == b[i].prim) ++g.prim_agree;
    }
  }
  return g;
}
Agreement compare(const std::vector<uint8_t>& a, const std::vector<uint8_t>& b) {
  Agreement g;
  g.rays = a.size();
  for (size_t i = 0; i < a.size(); ++i) g.hit_agree += a[i] == b[i];
  return g;
}

void report_agreement(const std::string& name, const Agreement& g, bool closest) {
  std::printf("  check %-28s hit/miss agree %.4f%%", name.c_str(), 100 * g.hit_frac());
  if (closest)
    std::printf(", t within 1e-4 %.4f%% of %zu common hits (same triangle %.3f%%)", 100 * g.t_frac(), g.both_hit,
                g.both_hit ? 100.0 * double(g.prim_agree) / double(g.both_hit) : 100.0);
  std::printf("\n");
  if (g.hit_frac() < 0.999 || (closest && g.t_frac() < 0.999))
    std::printf("  WARNING: prism and Embree disagree on more than 0.1%% of the %s rays\n", name.c_str());
}

// A ray set given from outside (the recorded rays), traced like the others.
struct ExtraRaySet {
  std::string kind;  // the CSV name is kind + "_" + case
  const std::vector<BenchRay>* rays;
  bool closest;      // closest hit; else any hit (occluded)
};

void run_case(const std::string& case_name, const TriangleMesh& mesh, Vector3f view_dir, const Options& opt,
              std::vector<CsvRow>& rows, const std::vector<ExtraRaySet>& external = {},
              RTCBuildQuality embree_quality = RTC_BUILD_QUALITY_MEDIUM) {
  size_t ntri = mesh.triangle_count();
  const size_t first_row = rows.size();
  std::printf("\n== %s: %zu triangles, %zu vertices\n", case_name.c_str(), ntri, mesh.positions.size());
  std::fflush(stdout);

  SceneAccel prism_scene;
  prism_scene.add_mesh_instance(prism_scene.add_mesh(mesh));

  struct PerThreads {
    int threads;
    std::unique_ptr<EmbreeScene> embree;
  };
  std::vector<PerThreads> per;

  // Build: median of reps, prism and Embree back to back, the first alternating.
  for (int th : opt.threads) {
    auto em = std::make_unique<EmbreeScene>(mesh, th, opt.embree_config, embree_quality);
    std::vector<double> tp, te;
    BVHBuildOptions bo;
    bo.threads = th;
    bo.split_budget = opt.split_budget;
    bo.spatial_splits = opt.spatial_splits ? spatial_split_builder : nullptr;
    for (int r = 0; r < std::max(3, opt.reps); ++r) {
      auto build_prism = [&] {
        double t0 = now_seconds();
        prism_scene.build(bo);
        tp.push_back(now_seconds() - t0);
      };
      if (opt.prism_first(r)) {
        build_prism();
        te.push_back(em->build());
      } else {
        te.push_back(em->build());
        build_prism();
      }
    }
    double mp = median(tp), me = median(te);
    auto [lo, hi] = paired_ratio_range(tp, te);
    std::printf("  build   threads=%d  prism %.3f s (%.2f Mtri/s)  embree %.3f s (%.2f Mtri/s)  embree/prism time %.3f"
                " (pairs %.3f..%.3f)\n",
                th, mp, double(ntri) / mp * 1e-6, me, double(ntri) / me * 1e-6, me / mp, lo, hi);
    std::fflush(stdout);
    rows.push_back(
        {"build_" + case_name, ntri, th, double(ntri) / mp * 1e-6, double(ntri) / me * 1e-6, me / mp, lo, hi});
    per.push_back({th, std::move(em)});
  }
  const MeshAccel& ma = prism_scene.mesh_accels()[0];
  size_t leaves = 0;
  for (const auto& n : ma.bvh().wide_nodes())
    for (uint32_t c : n.count) leaves += c != 0 && c != detail::BVHWideNode::interior;
  const double bytes_per_triangle = double(ma.memory_bytes()) / double(ntri);
  std::printf("  prism BVH: %zu wide nodes, %zu leaves, %.2f triangles per leaf, %.1f bytes per "
              "triangle (wide nodes, leaf order, triangle packets), %zu references (split budget %g)\n",
              ma.bvh().wide_node_count(), leaves, double(ma.reference_count()) / double(leaves), bytes_per_triangle,
              ma.reference_count(), double(opt.split_budget));

  // Ray sets, all derived from prism's primary hits (deterministic).
  Bounds3f bounds = prism_scene.bounds();
  Float radius = 0.5f * length(bounds.diagonal());
  Point3f center = bounds.centroid();
  std::vector<BenchRay> primary = primary_rays(mesh, bounds, view_dir, opt.res);
  std::vector<HitRecord> prim_hits;
  trace_prism(prism_scene, primary, 2, prim_hits);
  std::vector<BenchRay> incoherent, shadow;
  Float extra = 1e-5f * radius;  // "a little" beyond the conservative error offset
  for (size_t i = 0; i < primary.size(); ++i) {
    if (prim_hits[i].t == infinity) continue;
    auto h = prism_scene.intersect(Ray{primary[i].o, primary[i].d}, primary[i].t_max);
    Ray ray{primary[i].o, primary[i].d};
    SurfaceInteraction si = prism_scene.interaction(ray, *h);
    Normal3f n = dot(si.n, ray.d) > 0 ? -si.n : si.n;  // facing the camera
    PCG32 rng(i, 0x5eed);
    // Incoherent: cosine hemisphere about the facing geometric normal.
    Vector3f wl = sample_cosine_hemisphere({rng.next_float(), rng.next_float()});
    Vector3f w = normalize(Frame::from_z(Vector3f(n)).from_local(wl));
    Point3f o = offset_ray_origin(si.p, si.p_error, n, w) + Vector3f(n) * extra;
    incoherent.push_back({o, w, infinity});
    // Shadow: towards a random point on a sphere around the scene, on the
    // normal's side of the centre.
    Vector3f u = sample_uniform_sphere({rng.next_float(), rng.next_float()});
    if (dot(u, n) < 0) u = -u;
    Point3f target = center + u * (1.5f * radius);
    Vector3f to = target - si.p;
    Point3f os = offset_ray_origin(si.p, si.p_error, n, to) + (dot(to, n) < 0 ? -Vector3f(n) : Vector3f(n)) * extra;
    Vector3f ds = target - os;
    Float dist = length(ds);
    shadow.push_back({os, ds / dist, dist});
  }
  std::printf("  rays: %zu primary (%zu hit), %zu incoherent, %zu shadow\n", primary.size(), incoherent.size(),
              incoherent.size(), shadow.size());
  std::fflush(stdout);

  struct RaySet {
    std::string name;
    const std::vector<BenchRay>* rays;
    bool closest;
  };
  std::vector<RaySet> sets = {{"primary_" + case_name, &primary, true},
                              {"incoherent_" + case_name, &incoherent, true},
                              {"shadow_" + case_name, &shadow, false}};
  // The procedural mesh also gets its incoherent rays in a shuffled order
  // ("scattered"): consecutive rays then share no nodes, as a path tracer's
  // later bounces do not, so each query pays its own cache misses.
  std::vector<BenchRay> scattered;
  if (case_name == "procedural") {
    scattered = incoherent;
    PCG32 rng(11, 0xab);
    for (size_t i = scattered.size(); i > 1; --i) std::swap(scattered[i - 1], scattered[rng.next_u32() % i]);
    sets.push_back({"scattered_" + case_name, &scattered, true});
  }
  for (const ExtraRaySet& x : external)
    if (!x.rays->empty()) sets.push_back({x.kind + "_" + case_name, x.rays, x.closest});

  // Correctness: prism against Embree on every set.
  {
    RTCScene es = per.front().embree->scene;
    for (const auto& s : sets) {
      if (s.closest) {
        std::vector<HitRecord> a, b;
        trace_prism(prism_scene, *s.rays, 2, a);
        trace_embree(es, *s.rays, 2, b);
        report_agreement(s.name, compare(a, b), true);
      } else {
        std::vector<uint8_t> a, b;
        occluded_prism(prism_scene, *s.rays, 2, a);
        occluded_embree(es, *s.rays, 2, b);
        size_t occ = size_t(std::count(a.begin(), a.end(), uint8_t(1)));
        std::printf("  (%s occluded for prism: %.1f%%)\n", s.name.c_str(), 100.0 * double(occ) / double(a.size()));
        report_agreement(s.name, compare(a, b), false);
      }
    }
  }

  // Throughput.
  for (const auto& pt : per) {
    RTCScene es = pt.embree->scene;
    for (const auto& s : sets) {
      std::vector<double> tp, te;
      std::vector<HitRecord> hr;
      std::vector<uint8_t> oc;
      auto run_prism = [&] {
        double t0 = now_seconds();
        if (s.closest)
          trace_prism(prism_scene, *s.rays, pt.threads, hr);
        else
          occluded_prism(prism_scene, *s.rays, pt.threads, oc);
        tp.push_back(now_seconds() - t0);
      };
      auto run_embree = [&] {
        double t0 = now_seconds();
        if (s.closest)
          trace_embree(es, *s.rays, pt.threads, hr);
        else
          occluded_embree(es, *s.rays, pt.threads, oc);
        te.push_back(now_seconds() - t0);
      };
      for (int r = 0; r < opt.reps; ++r) {
        if (opt.prism_first(r)) {
          run_prism();
          run_embree();
        } else {
          run_embree();
          run_prism();
        }
      }
      double n = double(s.rays->size());
      double mp = n / median(tp) * 1e-6, me = n / median(te) * 1e-6;
      auto [lo, hi] = paired_ratio_range(tp, te);
      std::printf("  %-28s threads=%d  prism %7.2f Mrays/s  embree %7.2f Mrays/s  ratio %.3f (pairs %.3f..%.3f)\n",
                  s.name.c_str(), pt.threads, mp, me, mp / me, lo, hi);
      std::fflush(stdout);
      rows.push_back({s.name, ntri, pt.threads, mp, me, mp / me, lo, hi});
    }
  }

  // The two-level BVH's cost for one instance: incoherent rays, one thread,
  // through the mesh's own BVH (MeshAccel), through SceneAccel with the mesh
  // as its one identity instance, and with the mesh under a rotation (rays
  // rotated alike, so every set finds the same hits).
  {
    Transform xf = rotate(0.7f, {0.3f, 1, -0.2f});
    SceneAccel rotated;
    rotated.add_mesh_instance(rotated.add_mesh(mesh), xf);
    BVHBuildOptions bo;
    bo.split_budget = opt.split_budget;
    bo.spatial_splits = opt.spatial_splits ? spatial_split_builder : nullptr;
    rotated.build(bo);
    std::vector<BenchRay> world = incoherent;
    for (BenchRay& r : world) {
      r.o = xf(r.o);
      r.d = xf(r.d);
    }
    std::vector<double> td, ti, tr;
    std::vector<HitRecord> hr;
    for (int r = 0; r < opt.reps; ++r) {
      double t0 = now_seconds();
      hr.assign(incoherent.size(), {});
      parallel_for(incoherent.size(), 1, [&](size_t b, size_t e) {
        for (size_t i = b; i < e; ++i) {
          Float t = incoherent[i].t_max;
          TriangleHit h{};
          uint32_t tri = 0;
          if (ma.intersect(incoherent[i].o, incoherent[i].d, &t, &h, &tri)) hr[i] = {t, tri};
        }
      });
      double t1 = now_seconds();
      trace_prism(prism_scene, incoherent, 1, hr);
      double t2 = now_seconds();
      trace_prism(rotated, world, 1, hr);
      double t3 = now_seconds();
      td.push_back(t1 - t0);
      ti.push_back(t2 - t1);
      tr.push_back(t3 - t2);
    }
    double n = double(incoherent.size()) * 1e-6;
    double md = n / median(td), mi = n / median(ti), mr = n / median(tr);
    std::printf("  two-level, incoherent, threads=1: MeshAccel %.2f Mrays/s, one identity instance %.2f (%.3fx), "
                "one rotated instance %.2f (%.3fx)\n",
                md, mi, mi / md, mr, mr / md);
    g_instance_rows.push_back({case_name, md, mi, mr});
  }
  for (size_t i = first_row; i < rows.size(); ++i) rows[i].bytes_per_triangle = bytes_per_triangle;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--reps") {
      opt.reps = std::max(1, std::atoi(next().c_str()));
    } else if (a == "--res") {
      opt.res = std::max(16, std::atoi(next().c_str()));
    } else if (a == "--out") {
      opt.out = next();
    } else if (a == "--layout-csv") {
      opt.layout_csv = next();
    } else if (a == "--gltf") {
      opt.gltf = next();
    } else if (a == "--env") {
      opt.env = next();
    } else if (a == "--record-res") {
      opt.record_res = std::max(0, std::atoi(next().c_str()));
    } else if (a == "--record-spp") {
      opt.record_spp = std::max(1, std::atoi(next().c_str()));
    } else if (a == "--record-cap") {
      opt.record_cap = size_t(std::max(1, std::atoi(next().c_str())));
    } else if (a == "--split-budget") {
      opt.split_budget = std::strtof(next().c_str(), nullptr);
    } else if (a == "--cases") {
      opt.cases = next();
    } else if (a == "--embree-config") {
      opt.embree_config = next();
    } else if (a == "--first") {
      opt.first = next();
      if (opt.first != "alternate" && opt.first != "prism" && opt.first != "embree") {
        std::fprintf(stderr, "--first takes alternate, prism or embree, not %s\n", opt.first.c_str());
        return 2;
      }
    } else if (a == "--procedural-n") {
      opt.procedural_n = std::max(2, std::atoi(next().c_str()));
    } else if (a == "--threads") {
      opt.threads.clear();
      std::string s = next();
      for (size_t p = 0; p < s.size();) {
        size_t q = s.find(',', p);
        if (q == std::string::npos) q = s.size();
        opt.threads.push_back(std::max(1, std::atoi(s.substr(p, q - p).c_str())));
        p = q + 1;
      }
    } else {
      std::fprintf(stderr,
                   "usage: %s [--reps N] [--res N] [--threads 1,2] [--out FILE] [--gltf FILE] [--env FILE]\n"
                   "       [--record-res N (0: no recorded rays)] [--record-spp N] [--record-cap N]\n"
                   "       [--split-budget F (prism's BVHBuildOptions::split_budget; default: the library's, %g)]\n"
                   "       [--cases procedural,slivers,slivers_nosplit,slivers_hq,slivers_sbvh,watertight,metalroughspheres\n"
                   "        (default: all)]\n"
                   "       [--embree-config STR (appended to Embree's device configuration, e.g. isa=avx2)]\n"
                   "       [--procedural-n N (the procedural mesh's resolution: 12 N^2 triangles; default 289)]\n"
                   "       [--first alternate|prism|embree (which library runs first in a repetition's pair;\n"
                   "        default alternate)]\n"
                   "       [--layout-csv FILE (this binary's BVH layout: its rows appended to FILE)]\n",
                   argv[0], double(BVHBuildOptions{}.split_budget));
      return a == "--help" || a == "-h" ? 0 : 2;
    }
  }

  std::printf("prism vs Embree %d.%d.%d: %d repetitions (medians), %dx%d primary rays\n", RTC_VERSION_MAJOR,
              RTC_VERSION_MINOR, RTC_VERSION_PATCH, opt.reps, opt.res, opt.res);
  std::vector<CsvRow> rows;

  std::vector<WatertightRow> wt;
  if (opt.runs("procedural") || opt.runs("watertight")) {
    // The edge rays always go to the 1M-triangle mesh (watertight.csv's
    // "procedural" row), whatever size --procedural-n gives the traversal rows.
    constexpr int watertight_n = 289;
    TriangleMesh sphere = make_displaced_sphere(opt.runs("procedural") ? opt.procedural_n : watertight_n);
    if (opt.runs("procedural"))
      run_case("procedural", sphere, prism_bench::procedural_view, opt, rows);
    if (opt.runs("watertight")) {
      if (opt.runs("procedural") && opt.procedural_n != watertight_n) sphere = make_displaced_sphere(watertight_n);
      wt.push_back(run_watertight("procedural", sphere, 1000000));
    }
  }
  if (opt.runs("slivers")) run_case("slivers", make_sliver_scene(), {0.3f, 0.8f, 0.5f}, opt, rows);
  // Without pre-splitting: prism's fastest build of the scene, against
  // Embree's default build (how much of the build ratio the splits cost).
  if (opt.runs("slivers_nosplit")) {
    Options no_split = opt;
    no_split.split_budget = 0;
    run_case("slivers_nosplit", make_sliver_scene(), {0.3f, 0.8f, 0.5f}, no_split, rows);
  }
  // The same against Embree's spatial-split build (RTC_BUILD_QUALITY_HIGH):
  // each library's layout that traces slivers fastest.
  if (opt.runs("slivers_hq"))
    run_case("slivers_hq", make_sliver_scene(), {0.3f, 0.8f, 0.5f}, opt, rows, {}, RTC_BUILD_QUALITY_HIGH);
  // Both with spatial splits in the builder: prism's SBVH option
  // (BVHBuildOptions::spatial_splits) against Embree's high quality build.
  if (opt.runs("slivers_sbvh")) {
    Options sbvh = opt;
    sbvh.spatial_splits = spatial_split_builder;
    run_case("slivers_sbvh", make_sliver_scene(), {0.3f, 0.8f, 0.5f}, sbvh, rows, {}, RTC_BUILD_QUALITY_HIGH);
  }
  // Edge rays into the tube: towards a point at least 1 inside either end and
  // at most half as far from the axis as the target.
  if (opt.runs("watertight"))
    wt.push_back(run_watertight("sliver_tube", make_sliver_tube(65536), 1000000, [](const Point3f& p, PCG32& r) {
      Vector3f w = normalize(tube_c1 - tube_c0);
      Float len = length(tube_c1 - tube_c0);
      Float along = dot(p - tube_c0, w);
      Point3f axis = tube_c0 + w * along;
      Float a = std::clamp(along + (r.next_float() - 0.5f) * 10, 1.0f, len - 1);
      return tube_c0 + w * a + (p - axis) * (0.5f * r.next_float());
    }));

#ifdef PRISM_BENCH_HAS_GLTF
  if (!opt.runs("metalroughspheres")) {
  } else if (fs::exists(opt.gltf)) {
    TriangleMesh m;
    if (load_gltf_flat(opt.gltf, &m)) {
      // Rays recorded from prism's path tracer rendering the same model.
      RecordedRays rec;
      std::vector<ExtraRaySet> extra;
#ifdef PRISM_HAS_GLTF
      if (opt.record_res > 0) {
        std::printf("\n== recording prism's path tracer on %s\n", opt.gltf.c_str());
        if (record_rays(opt.gltf, opt.env, opt.record_res, opt.record_spp, opt.record_cap, &rec))
          extra = {{"recorded_camera", &rec.camera.rays, true},
                   {"recorded_bounce1", &rec.bounce[0].rays, true},
                   {"recorded_bounce2", &rec.bounce[1].rays, true},
                   {"recorded_bounce3", &rec.bounce[2].rays, true},
                   {"recorded_shadow", &rec.shadow.rays, false}};
      }
#else
      std::printf("\n(no recorded rays: built without prism::gltf)\n");
#endif
      // The spheres stand in a plane facing +z; look at them slightly from the side.
      run_case("metalroughspheres", m, {0.15f, 0.2f, 1.0f}, opt, rows, extra);
    }
  } else {
    std::printf("\n(skipping metalroughspheres: %s not found)\n", opt.gltf.c_str());
  }
#else
  if (opt.runs("metalroughspheres")) std::printf("\n(skipping metalroughspheres: built without tinygltf)\n");
#endif

  fs::path out(opt.out);
  if (out.has_parent_path()) fs::create_directories(out.parent_path());
  FILE* f = std::fopen(opt.out.c_str(), "w");
  if (!f) {
    std::fprintf(stderr, "cannot write %s\n", opt.out.c_str());
    return 1;
  }
  std::fprintf(f, "case,triangles,threads,prism_mrays,embree_mrays,ratio,ratio_min,ratio_max\n");
  for (const auto& r : rows) write_row(f, r);
  std::fclose(f);
  std::printf("\nwrote %s\n", opt.out.c_str());
  fs::path inst_out = (out.has_parent_path() ? out.parent_path() : fs::path(".")) / "instances.csv";
  if (FILE* w = g_instance_rows.empty() ? nullptr : std::fopen(inst_out.string().c_str(), "w")) {
    std::fprintf(w, "case,threads,meshaccel_mrays,identity_instance_mrays,rotated_instance_mrays\n");
    for (const auto& r : g_instance_rows)
      std::fprintf(w, "%s,1,%.3f,%.3f,%.3f\n", r.name.c_str(), r.direct, r.identity, r.rotated);
    std::fclose(w);
    std::printf("wrote %s\n", inst_out.string().c_str());
  }
  fs::path wt_out = (out.has_parent_path() ? out.parent_path() : fs::path(".")) / "watertight.csv";
  if (FILE* w = wt.empty() ? nullptr : std::fopen(wt_out.string().c_str(), "w")) {
    std::fprintf(w, "mesh,rays,prism_misses,embree_misses\n");
    for (const auto& r : wt) std::fprintf(w, "%s,%zu,%zu,%zu\n", r.mesh.c_str(), r.rays, r.prism_misses, r.embree_misses);
    std::fclose(w);
    std::printf("wrote %s\n", wt_out.string().c_str());
  }
  if (!opt.layout_csv.empty()) {
    // Appended, so that one file gathers the layouts' binaries (a header when
    // the file is new or empty).
    fs::path lp(opt.layout_csv);
    std::error_code ec;
    if (lp.has_parent_path()) fs::create_directories(lp.parent_path(), ec);
    const bool fresh = !fs::exists(lp, ec) || fs::file_size(lp, ec) == 0;
    FILE* l = std::fopen(opt.layout_csv.c_str(), "a");
    if (!l) {
      std::fprintf(stderr, "cannot write %s\n", opt.layout_csv.c_str());
      return 1;
    }
    // traversal.csv's columns, after the layout's and with the bytes per triangle last.
    if (fresh)
      std::fprintf(l, "layout,node_bytes,case,triangles,threads,prism_mrays,embree_mrays,ratio,ratio_min,ratio_max,"
                      "bytes_per_triangle\n");
    const std::string layout = layout_name();
    for (const auto& r : rows) {
      std::fprintf(l, "%s,%zu,", layout.c_str(), sizeof(detail::BVHWideNode));
      write_row(l, r, true);
    }
    std::fclose(l);
    std::printf("appended %s's rows to %s\n", layout.c_str(), opt.layout_csv.c_str());
  }
  return 0;
}
