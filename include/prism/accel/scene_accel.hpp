// prism/accel/scene_accel.hpp — two-level ray queries: one BVH per triangle mesh
// in its object space, one BVH over instances (a mesh under a transform, or a
// sphere). A mesh used by many instances is stored and built once.
//
// Motion blur: an instance may move between two transform keys
// (AnimatedTransform); a ray meets it where it is at the ray's time. The top
// level stores boxes that enclose each moving instance over a time interval.
// The motion's time range is cut into `motion_segments` equal intervals, each
// with its own top-level BVH over the instances' boxes during it, and a ray
// uses its interval's tree: one segment is the classic interval bounds, more
// segments trade memory and build time for tighter boxes when objects move
// far (docs/motion_blur.md gives the measurement behind the default).
//
// Deformation blur: a mesh added with vertex keys (add_deforming_mesh,
// accel/deforming_mesh.hpp) is met where its vertices are at the ray's time;
// its instances may be transformed and move too. The top level's boxes
// enclose it over each segment's time interval.
#pragma once
#include <limits>
#include <optional>
#include <string>
#include <vector>
#include "prism/accel/bvh.hpp"
#include "prism/accel/deforming_mesh.hpp"
#include "prism/accel/presplit.hpp"
#include "prism/accel/triangle_packet.hpp"
#include "prism/attributes.hpp"
#include "prism/error.hpp"
#include "prism/math/animated_transform.hpp"
#include "prism/geometry/sphere.hpp"
#include "prism/geometry/triangle.hpp"

namespace prism {

namespace detail {
// The bounds of triangle i of `mesh`, for BVH::build and BVH::refit.
inline auto triangle_bounds(const TriangleMesh& mesh) {
  return [p = mesh.positions.data(), idx = mesh.indices.data()](size_t i) {
    return triangle_box(p[idx[3 * i]], p[idx[3 * i + 1]], p[idx[3 * i + 2]]);
  };
}
}  // namespace detail

// A mesh's BVH with its triangles' vertices copied into leaf order, a packet
// of triangle_packet_width triangles at a time (accel/triangle_packet.hpp):
// each leaf starts a new packet, so a leaf's triangles are contiguous, need
// no index lookups and are tested together.
//
// Where pre-splitting (accel/presplit.hpp; on by default, for slivers only)
// cuts triangles, the BVH is built over its references: a triangle may then
// sit in several leaves, each packet lane holding the whole triangle, so hits are exact and
// the same as without splitting. Reference k < n is triangle k itself (its
// first piece); only the extra pieces, after them, need a map to their
// triangle (m_extra_tri), 4 bytes each.
class MeshAccel {
 public:
  MeshAccel() = default;
  MeshAccel(const TriangleMesh& mesh, const BVHBuildOptions& options) {
    size_t n = mesh.triangle_count();
    BVHBuildOptions opt = options;
    opt.leaf_block = triangle_packet_width;
    m_threads = detail::build_threads(opt.threads);
    detail::check_split_options(opt.split_budget, opt.split_threshold);
    const Point3f* p = mesh.positions.data();
    const uint32_t* idx = mesh.indices.data();
    auto vertices = detail::mesh_vertices(p, idx);
    const detail::SpatialBuildFn spatial = opt.spatial_splits;
    if (spatial) detail::check_spatial_alpha(opt.spatial_alpha);
    // Pre-splitting first; with spatial splits the builder then cuts where
    // the SAH asks for it (pre-splitting cuts the worst slivers everywhere,
    // which the builder's greedy choice of planes does not do).
    detail::SplitReferences refs;
    if (opt.split_budget != 0.0f)
      refs = detail::presplit_triangles(n, vertices, opt.split_budget, opt.split_threshold, m_threads);
    if (spatial) {
      detail::SpatialBVH sb = spatial(n, p, idx, opt, &refs);
      m_bvh = std::move(sb.bvh);
      m_extra_tri = std::move(sb.extra_tri);
    } else if (refs.size() != 0) {
      m_bvh = BVH::build(refs.size(), [&](size_t i) { return refs.bounds[i]; }, opt);
      m_extra_tri = std::move(refs.extra_tri);
    } else {
      m_bvh = BVH::build(n, detail::triangle_bounds(mesh), opt);
    }
    m_triangles = n;
    size_t packets = m_bvh.prims().size() / triangle_packet_width;
    detail::reserve_huge(m_packets, packets);
    m_packets.resize(packets);
    pack(mesh);
  }

  // After the mesh's vertices moved (same triangles, same indices): refits the
  // BVH (BVH::refit) and repacks the triangles. Hits are then those of a
  // rebuilt MeshAccel, at a fraction of the build's cost.
  void refit(const TriangleMesh& mesh) {
    if (mesh.triangle_count() != m_triangles)
      throw Error("MeshAccel::refit: the mesh has " + std::to_string(mesh.triangle_count()) +
                  " triangles, the BVH was built over " + std::to_string(m_triangles));
    // A split triangle's references each get its whole new box: conservative,
    // so hits stay exact (re-splitting needs a rebuild).
    m_bvh.refit([this, b = detail::triangle_bounds(mesh)](size_t i) { return b(triangle_of(uint32_t(i))); },
                m_threads);
    pack(mesh);
  }

  const BVH& bvh() const { return m_bvh; }
  // BVH references per triangle (> 1 with pre-splitting).
  size_t reference_count() const { return m_triangles + m_extra_tri.size(); }
  // The mesh's triangle index of leaf-order entry k (entries of bvh().prims()).
  uint32_t leaf_triangle(size_t k) const { return triangle_of(m_bvh.prims()[k]); }
  Bounds3f bounds() const { return m_bvh.bounds(); }
  // Bytes of the BVH (nodes and leaf order), the triangle packets and the split map.
  size_t memory_bytes() const {
    return m_bvh.memory_bytes() + m_packets.size() * sizeof(LeafPacket) +
           m_extra_tri.size() * sizeof(uint32_t);
  }

  // Closest hit before *t_max; on a hit lowers *t_max and fills *hit and *tri
  // (the triangle's index in the mesh).
  bool intersect(const Point3f& o, const Vector3f& d, Float* t_max, TriangleHit* hit, uint32_t* tri) const {
    return intersect(o, d, detail::WideRayPrecomp(o, d), t_max, hit, tri);
  }
  // The same with the ray's box-test data already computed (SceneAccel traces
  // a world-space ray through its top level and identity instances with one).
  bool intersect(const Point3f& o, const Vector3f& d, const detail::WideRayPrecomp& wr, Float* t_max,
                 TriangleHit* hit, uint32_t* tri) const {
    const RayTrianglePrecomp pc(d);
    switch (pc.kz) {
      case 0: return intersect_axis<0>(o, wr, pc.sx, pc.sy, pc.sz, t_max, hit, tri);
      case 1: return intersect_axis<1>(o, wr, pc.sx, pc.sy, pc.sz, t_max, hit, tri);
      default: return intersect_axis<2>(o, wr, pc.sx, pc.sy, pc.sz, t_max, hit, tri);
    }
  }
  // Any hit before t_max, ignoring triangle `skip` (mesh index) if given.
  bool occluded(const Point3f& o, const Vector3f& d, Float t_max, uint32_t skip = UINT32_MAX) const {
    return occluded(o, d, detail::WideRayPrecomp(o, d), t_max, skip);
  }
  bool occluded(const Point3f& o, const Vector3f& d, const detail::WideRayPrecomp& wr, Float t_max,
                uint32_t skip = UINT32_MAX) const {
    const RayTrianglePrecomp pc(d);
    switch (pc.kz) {
      case 0: return occluded_axis<0>(o, wr, pc.sx, pc.sy, pc.sz, t_max, skip);
      case 1: return occluded_axis<1>(o, wr, pc.sx, pc.sy, pc.sz, t_max, skip);
      default: return occluded_axis<2>(o, wr, pc.sx, pc.sy, pc.sz, t_max, skip);
    }
  }

 private:
  static constexpr int W = triangle_packet_width;
  // A packet of a leaf's triangles with their indices in the mesh, next to
  // them: a hit reads its triangle without a lookup elsewhere, and a shadow
  // ray's `skip` is compared the same way (with 8 lanes the indices fill the
  // fifth cache line, which the vertices use by half; with 16, a tenth line
  // of their own).
  struct alignas(W >= 8 ? 64 : 32) LeafPacket {
    TrianglePacket tris;
    uint32_t tri[W];
  };
  static_assert(sizeof(LeafPacket) == 40 * W);
  // The triangle of BVH reference r: itself, or for an extra piece from
  // pre-splitting (r >= the triangle count) the one it was cut from.
  uint32_t triangle_of(uint32_t r) const { return r < m_triangles ? r : m_extra_tri[r - m_triangles]; }
  // Copies the triangles into the packets, in leaf order.
  void pack(const TriangleMesh& mesh) {
    const Point3f* p = mesh.positions.data();
    const uint32_t* idx = mesh.indices.data();
    size_t packets = m_packets.size();
    const uint32_t* order = m_bvh.prims().data();
    detail::parallel_chunks(packets, detail::parallel_chunk_count(packets, m_threads),
                            [&](size_t begin, size_t end, int) {
                              for (size_t k = begin; k < end; ++k)
                                for (int l = 0; l < W; ++l) {
                                  size_t t = triangle_of(order[k * W + size_t(l)]);
                                  m_packets[k].tris.set(l, p[idx[3 * t]], p[idx[3 * t + 1]], p[idx[3 * t + 2]]);
                                  m_packets[k].tri[l] = uint32_t(t);
                                }
                            });
  }
  // Every lane of a leaf's packets is tested: the build pads a leaf to whole
  // packets by repeating its last triangle (BVHBuildOptions::leaf_block), and
  // a repeated triangle finds the same hit again, which changes nothing (the
  // first lane of equal t wins; a shadow ray's `skip` matches the copies too).
  static constexpr int all_lanes = (1 << W) - 1;

  // The lanes of a packet that hold triangle `skip`, compared at once
  // (shadow rays to an area light skip the light's triangle in every packet
  // they test).
  static int lanes_of_triangle(const LeafPacket& p, uint32_t skip) {
    int m = 0;
#if defined(PRISM_BVH_SSE)
    const __m128i s = _mm_set1_epi32(int(skip));
    for (int h = 0; h < W; h += 4) {
      __m128i e = _mm_load_si128(reinterpret_cast<const __m128i*>(p.tri + h));
      m |= _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(e, s))) << h;
    }
#else
    for (int l = 0; l < W; ++l) m |= int(p.tri[l] == skip) << l;
#endif
    return m;
  }

  // The queries for a ray whose largest direction component is KZ. The
  // watertight test's axis permutation is then a compile-time constant; the
  // arithmetic is unchanged. The shear arrives as three floats, in
  // registers. (A RayTrianglePrecomp passed by value went through the stack,
  // and GCC 12 copied it with a 16-byte load of fields just written one by
  // one: a store-forwarding stall on every ray, a third of the caller's perf
  // samples on primary rays. Passed by reference instead, the loop here lost
  // 5% as it reloaded the fields; ab, these three floats: primary 1.037 and
  // 1.058, the other sets 0.98-1.01.)
  template <int KZ>
  PRISM_FLATTEN bool intersect_axis(const Point3f& o, const detail::WideRayPrecomp& wr, Float sx, Float sy, Float sz,
                                    Float* t_max, TriangleHit* hit, uint32_t* tri) const {
    const RayTrianglePrecomp pc(KZ, sx, sy, sz);
    uint32_t best = 0;  // the triangle hit
    bool found = m_bvh.intersect_leaves(wr, *t_max, [&](uint32_t first, uint32_t count, Float& tm) {
      bool any = false;
      for (uint32_t j = 0; j * W < count; ++j) {
        uint32_t k = first / W + j;
        if (auto h = intersect_packet<KZ>(m_packets[k].tris, o, pc, tm, all_lanes)) {
          tm = h->hit.t;
          *hit = h->hit;
          best = m_packets[k].tri[h->lane];
          any = true;
        }
      }
      return any;
    });
    if (found) *tri = best;
    return found;
  }
  template <int KZ>
  PRISM_FLATTEN bool occluded_axis(const Point3f& o, const detail::WideRayPrecomp& wr, Float sx, Float sy, Float sz,
                                   Float t_max, uint32_t skip) const {
    const RayTrianglePrecomp pc(KZ, sx, sy, sz);
    const LeafPacket* packets = m_packets.data();
    return m_bvh.occluded_leaves(wr, t_max, [&](uint32_t first, uint32_t count, Float tm) {
      for (uint32_t j = 0; j * W < count; ++j) {
        uint32_t k = first / W + j;
        int lanes = all_lanes;
        if (skip != UINT32_MAX) lanes &= ~lanes_of_triangle(packets[k], skip);
        if (occluded_packet<KZ>(packets[k].tris, o, pc, tm, lanes)) return true;
      }
      return false;
    });
  }

  BVH m_bvh;
  detail::fill_later_vector<LeafPacket> m_packets;  // written whole by pack(), in parallel
  std::vector<uint32_t> m_extra_tri;  // pre-splitting only: extra reference n + j -> triangle
  size_t m_triangles = 0;
  int m_threads = 1;
};

struct Instance {
  // deforming_mesh: a mesh added with vertex keys (SceneAccel::add_deforming_mesh).
  enum class Kind : uint8_t { mesh, sphere, deforming_mesh };
  Kind kind = Kind::mesh;
  uint32_t geometry = 0;      // mesh or sphere index
  Transform object_to_world;  // meshes only; spheres live in world space
  bool identity = true;
  bool mirror = false;  // object_to_world swaps handedness (cached: asked per hit)
  int32_t motion = -1;  // index of its AnimatedTransform if it moves, else -1
};

struct Hit {
  Float t = infinity;
  Float b0 = 0, b1 = 0, b2 = 0;  // triangle barycentrics (unused for spheres)
  uint32_t instance = 0, primitive = 0;
};

class SceneAccel {
 public:
  uint32_t add_mesh(TriangleMesh mesh) {
    m_meshes.push_back(std::move(mesh));
    return uint32_t(m_meshes.size() - 1);
  }
  // A mesh whose vertices move during the shutter: `motion` holds its
  // vertex keys (the mesh's own positions are replaced by the first key).
  // Its instances meet rays where the vertices are at the ray's time.
  // Throws prism::Error if the keys do not fit the mesh.
  uint32_t add_deforming_mesh(TriangleMesh mesh, VertexMotion motion) {
    motion.validate(mesh.positions.size());
    mesh.positions = motion.positions[0];
    m_meshes.push_back(std::move(mesh));
    m_deform_of.resize(m_meshes.size(), -1);
    m_deform_of.back() = int32_t(m_vertex_motions.size());
    m_vertex_motions.push_back(std::move(motion));
    return uint32_t(m_meshes.size() - 1);
  }
  // True if mesh `mesh` was added with vertex keys.
  bool is_deforming(uint32_t mesh) const { return mesh < m_deform_of.size() && m_deform_of[mesh] >= 0; }
  // Its vertex keys (for a mesh with is_deforming(mesh)).
  const VertexMotion& vertex_motion(uint32_t mesh) const { return m_vertex_motions[size_t(m_deform_of[mesh])]; }

  uint32_t add_mesh_instance(uint32_t mesh, const Transform& object_to_world = {}) {
    m_instances.push_back({kind_of(mesh), mesh, object_to_world, object_to_world.is_identity(),
                           object_to_world.swaps_handedness()});
    return uint32_t(m_instances.size() - 1);
  }
  // An instance that moves: object_to_world is motion.at(ray time). One that
  // does not move is stored as a plain transformed instance.
  uint32_t add_mesh_instance(uint32_t mesh, const AnimatedTransform& motion) {
    if (!motion.is_moving()) return add_mesh_instance(mesh, motion.at(motion.start_time()));
    m_motions.push_back(motion);
    Transform t0 = motion.at(motion.start_time());
    m_instances.push_back({kind_of(mesh), mesh, t0, false, motion.swaps_handedness(),
                           int32_t(m_motions.size() - 1)});
    return uint32_t(m_instances.size() - 1);
  }
  uint32_t add_sphere(const Sphere& s) {
    m_spheres.push_back(s);
    m_instances.push_back({Instance::Kind::sphere, uint32_t(m_spheres.size() - 1), {}, true, false});
    return uint32_t(m_instances.size() - 1);
  }

  const std::vector<TriangleMesh>& meshes() const { return m_meshes; }
  const std::vector<Sphere>& spheres() const { return m_spheres; }
  const std::vector<Instance>& instances() const { return m_instances; }
  const std::vector<MeshAccel>& mesh_accels() const { return m_mesh_accels; }
  const std::vector<AnimatedTransform>& motions() const { return m_motions; }
  // The deforming meshes' structures, after build(); deforming_accel(mesh)
  // for a mesh with is_deforming(mesh).
  const std::vector<DeformingMeshAccel>& deforming_mesh_accels() const { return m_deform_accels; }
  const DeformingMeshAccel& deforming_accel(uint32_t mesh) const { return m_deform_accels[size_t(m_deform_of[mesh])]; }
  // Everything the scene covers at any time.
  Bounds3f bounds() const { return m_bounds; }
  // Something moves or deforms during the shutter.
  bool has_motion() const { return !m_motions.empty() || !m_vertex_motions.empty(); }
  int motion_segments() const { return int(m_tops.size()); }

  // The world transform of an instance at a time (its fixed one if it does not move).
  Transform instance_transform(const Instance& in, Float time) const {
    return in.motion >= 0 ? m_motions[size_t(in.motion)].at(time) : in.object_to_world;
  }

  // opt.motion_segments: top-level trees over the motion's time range (0: the
  // default, kDefaultMotionSegments: 4, within 11% of the best segment count
  // for motions from 1/4 to 4 object sizes in bench/motion_bench.cpp, where
  // one segment loses up to 2x; docs/motion_blur.md); ignored when nothing
  // moves.
  static constexpr int kDefaultMotionSegments = 4;
  void build(const BVHBuildOptions& opt = {}) {
    m_mesh_accels.clear();
    m_mesh_accels.reserve(m_meshes.size());
    m_deform_of.resize(m_meshes.size(), -1);
    m_deform_accels.clear();
    m_deform_accels.reserve(m_vertex_motions.size());
    for (size_t i = 0; i < m_meshes.size(); ++i) {
      if (m_deform_of[i] >= 0) {
        // A deforming mesh's still MeshAccel stays empty: rays use its keys.
        m_mesh_accels.emplace_back();
        m_deform_accels.emplace_back(m_meshes[i], m_vertex_motions[size_t(m_deform_of[i])], opt);
      } else {
        m_mesh_accels.emplace_back(m_meshes[i], opt);
      }
    }
    build_top(opt);
  }

  // A deforming mesh: new vertex positions for mesh `mesh` (same count, same
  // triangles), after build(). Refits its BVH (MeshAccel::refit) and rebuilds
  // the top level over the instances' new bounds.
  void refit_mesh(uint32_t mesh, std::vector<Point3f> positions) {
    if (mesh >= m_meshes.size() || m_mesh_accels.size() != m_meshes.size())
      throw Error("SceneAccel::refit_mesh: mesh " + std::to_string(mesh) + " does not exist or build() has not run");
    if (is_deforming(mesh))
      throw Error("SceneAccel::refit_mesh: mesh " + std::to_string(mesh) + " deforms by vertex keys: add it anew");
    if (positions.size() != m_meshes[mesh].positions.size())
      throw Error("SceneAccel::refit_mesh: mesh " + std::to_string(mesh) + " has " +
                  std::to_string(m_meshes[mesh].positions.size()) + " vertices, got " +
                  std::to_string(positions.size()));
    m_meshes[mesh].positions = std::move(positions);
    m_mesh_accels[mesh].refit(m_meshes[mesh]);
    build_top(m_build_options);
  }

 private:
  void build_top(const BVHBuildOptions& opt) {
    m_build_options = opt;
    const int motion_segments = opt.motion_segments;
    int segments = 1;
    m_time0 = 0;
    m_time1 = 0;
    if (!m_motions.empty()) {
      segments = std::clamp(motion_segments > 0 ? motion_segments : kDefaultMotionSegments, 1, 1024);
      m_time0 = infinity;
      m_time1 = -infinity;
      for (const auto& m : m_motions) {
        m_time0 = std::min(m_time0, m.start_time());
        m_time1 = std::max(m_time1, m.end_time());
      }
    }
    // Deforming meshes: the time range covers their keys too.
    bool deforms = false;
    for (const Instance& in : m_instances)
      if (in.kind == Instance::Kind::deforming_mesh) {
        const VertexMotion& vm = m_vertex_motions[size_t(m_deform_of[in.geometry])];
        if (!deforms && m_motions.empty()) {
          segments = std::clamp(motion_segments > 0 ? motion_segments : kDefaultMotionSegments, 1, 1024);
          m_time0 = infinity;
          m_time1 = -infinity;
        }
        deforms = true;
        m_time0 = std::min(m_time0, vm.time0);
        m_time1 = std::max(m_time1, vm.time1);
      }
    // top_for() finds a ray's segment with other roundings than the
    // segments' ends below: each segment's boxes cover a few ulps more
    // time on either side, so a ray at a time on a boundary is inside them.
    const Float time_pad = 8 * std::numeric_limits<Float>::epsilon() *
                           std::max({std::abs(m_time0), std::abs(m_time1), m_time1 - m_time0});
    BVHBuildOptions top = opt;
    top.max_leaf_size = 1;
    m_tops.clear();
    m_bounds = Bounds3f{};
    std::vector<Bounds3f> b(m_instances.size());
    for (int k = 0; k < segments; ++k) {
      Float ta = m_time0 + (m_time1 - m_time0) * Float(k) / Float(segments) - time_pad;
      Float tb = (k + 1 == segments ? m_time1 : m_time0 + (m_time1 - m_time0) * Float(k + 1) / Float(segments)) +
                 time_pad;
      for (size_t i = 0; i < m_instances.size(); ++i) {
        const Instance& in = m_instances[i];
        if (in.kind == Instance::Kind::sphere) {
          b[i] = m_spheres[in.geometry].bounds();
          continue;
        }
        // The object-space box over [ta, tb] (a segment's end time belongs
        // to both segments, so each tree covers its closed interval).
        Bounds3f object = in.kind == Instance::Kind::deforming_mesh ? deforming_accel(in.geometry).bounds(ta, tb)
                                                                   : m_mesh_accels[in.geometry].bounds();
        if (in.motion >= 0)
          b[i] = m_motions[size_t(in.motion)].motion_bounds(object, ta, tb);
        else
          b[i] = in.identity ? object : in.object_to_world(object);
      }
      m_tops.push_back(BVH::build(b, top));
      m_bounds = union_bounds(m_bounds, m_tops.back().bounds());
    }
    m_time_scale = m_time1 > m_time0 ? Float(segments) / (m_time1 - m_time0) : 0;
    m_lone_instance = m_instances.size() == 1;
    m_lone_mesh = -1;
    if (m_lone_instance && m_instances[0].kind == Instance::Kind::mesh && m_instances[0].identity &&
        m_instances[0].motion < 0)
      m_lone_mesh = int32_t(m_instances[0].geometry);
  }

 public:

  std::optional<Hit> intersect(const Ray& ray, Float t_max = infinity) const {
    if (m_lone_mesh >= 0) {
      // A scene of one mesh, untransformed and still: its own BVH answers,
      // with no top level and no dispatch on the instance's kind.
      TriangleHit th;
      uint32_t tri;
      Float t = t_max;
      if (!m_mesh_accels[size_t(m_lone_mesh)].intersect(ray.o, ray.d, &t, &th, &tri)) return std::nullopt;
      return Hit{t, th.b0, th.b1, th.b2, 0, tri};
    }
    return intersect_instances(ray, t_max);
  }

  // True if anything lies along the ray before t_max. A hit on (skip_instance,
  // skip_primitive) is ignored: shadow rays pass their target's own surface.
  bool occluded(const Ray& ray, Float t_max, uint32_t skip_instance = UINT32_MAX,
                uint32_t skip_primitive = UINT32_MAX) const {
    if (m_lone_mesh >= 0)
      return m_mesh_accels[size_t(m_lone_mesh)].occluded(ray.o, ray.d, t_max,
                                                         skip_instance == 0 ? skip_primitive : UINT32_MAX);
    return occluded_instances(ray, t_max, skip_instance, skip_primitive);
  }

 private:
  // The queries through the top level, out of line: intersect() and
  // occluded() stay small enough to inline, so a lone mesh's rays pay no
  // call more than MeshAccel's own queries (measured: 0.94-0.95 of
  // MeshAccel's speed on primary rays through the lone-instance path, about
  // 1.00 now).
  PRISM_NOINLINE std::optional<Hit> intersect_instances(const Ray& ray, Float t_max) const {
    const BVH& top = top_for(ray.time);
    if (top.empty()) return std::nullopt;
    detail::WideRayPrecomp wr(ray.o, ray.d);
    Hit best;
    auto visit = [&](uint32_t k, Float& tm) {
      uint32_t inst_id = top.prims()[k];
      const Instance& in = m_instances[inst_id];
      if (in.kind == Instance::Kind::sphere) {
        auto h = intersect_sphere(m_spheres[in.geometry], ray, tm);
        if (!h) return false;
        tm = h->t;
        best = {h->t, 0, 0, 0, inst_id, 0};
        return true;
      }
      TriangleHit th;
      uint32_t tri;
      Float t_local = tm;
      bool h;
      if (in.kind == Instance::Kind::deforming_mesh) {
        const DeformingMeshAccel& dm = deforming_accel(in.geometry);
        if (in.identity) {
          h = dm.intersect(ray.o, ray.d, ray.time, &t_local, &th, &tri);
        } else {
          Float dt;
          Ray r = transform_ray(inverse(instance_transform(in, ray.time)), ray, &dt);
          Float t_obj = tm - dt;
          h = dm.intersect(r.o, r.d, ray.time, &t_obj, &th, &tri);
          t_local = t_obj + dt;
        }
      } else if (in.identity) {
        h = m_mesh_accels[in.geometry].intersect(ray.o, ray.d, wr, &t_local, &th, &tri);
      } else {
        Float dt;
        Ray r = transform_ray(inverse(in.motion < 0 ? in.object_to_world : m_motions[size_t(in.motion)].at(ray.time)),
                              ray, &dt);
        Float t_obj = tm - dt;
        h = m_mesh_accels[in.geometry].intersect(r.o, r.d, &t_obj, &th, &tri);
        t_local = t_obj + dt;
      }
      if (!h) return false;
      tm = t_local;
      best = {t_local, th.b0, th.b1, th.b2, inst_id, tri};
      return true;
    };
    // A lone instance needs no top level: the top-level box only encloses the
    // instance, whose own test (its BVH's boxes, in its own space, or its
    // sphere) culls at least as much, so the answer is the same.
    bool found = m_lone_instance ? visit(0, t_max) : top.intersect(wr, t_max, visit);
    if (!found) return std::nullopt;
    return best;
  }

  PRISM_NOINLINE bool occluded_instances(const Ray& ray, Float t_max, uint32_t skip_instance,
                                         uint32_t skip_primitive) const {
    const BVH& top = top_for(ray.time);
    if (top.empty()) return false;
    detail::WideRayPrecomp wr(ray.o, ray.d);
    auto visit = [&](uint32_t k, Float tm) {
      uint32_t inst_id = top.prims()[k];
      const Instance& in = m_instances[inst_id];
      if (in.kind == Instance::Kind::sphere) {
        if (inst_id == skip_instance) return false;
        return intersect_sphere(m_spheres[in.geometry], ray, tm).has_value();
      }
      uint32_t skip = inst_id == skip_instance ? skip_primitive : UINT32_MAX;
      if (in.kind == Instance::Kind::deforming_mesh) {
        const DeformingMeshAccel& dm = deforming_accel(in.geometry);
        if (in.identity) return dm.occluded(ray.o, ray.d, ray.time, tm, skip);
        Float dt;
        Ray r = transform_ray(inverse(instance_transform(in, ray.time)), ray, &dt);
        return dm.occluded(r.o, r.d, ray.time, tm - dt, skip);
      }
      if (in.identity) return m_mesh_accels[in.geometry].occluded(ray.o, ray.d, wr, tm, skip);
      Float dt;
      Ray r = transform_ray(inverse(in.motion < 0 ? in.object_to_world : m_motions[size_t(in.motion)].at(ray.time)),
                            ray, &dt);
      return m_mesh_accels[in.geometry].occluded(r.o, r.d, tm - dt, skip);
    };
    return m_lone_instance ? visit(0, t_max) : top.occluded(wr, t_max, visit);
  }

 public:
  // The full surface description of a hit, in world space.
  SurfaceInteraction interaction(const Ray& ray, const Hit& h) const {
    SurfaceInteraction si;
    const Instance& in = m_instances[h.instance];
    si.instance = h.instance;
    si.primitive = h.primitive;
    si.time = ray.time;
    si.wo = normalize(-ray.d);
    si.wo_free = 0.5f * h.t * length(ray.d);  // the ray met nothing before the hit
    if (in.kind == Instance::Kind::sphere) {
      sphere_interaction(m_spheres[in.geometry], ray, SphereHit{h.t}, &si);
      return si;
    }
    if (in.kind == Instance::Kind::deforming_mesh)
      deforming_interaction(in.geometry, h, ray.time, &si);
    else
      triangle_interaction(m_meshes[in.geometry], h.primitive, TriangleHit{h.t, h.b0, h.b1, h.b2}, &si);
    if (!in.identity) {
      Transform moved;
      if (in.motion >= 0) moved = m_motions[size_t(in.motion)].at(ray.time);
      const Transform& t = in.motion >= 0 ? moved : in.object_to_world;
      Vector3f err;
      si.p = t.apply(si.p, si.p_error, &err);
      si.p_error = err;
      si.n = normalize(t(si.n));
      si.ns = normalize(t(si.ns));
      si.dpdu = t(si.dpdu);
      si.dpdv = t(si.dpdv);
      si.tangent = t(si.tangent);
      // A mirroring transform flips the bitangent's handedness.
      if (in.mirror) si.tangent_w = -si.tangent_w;
    }
    return si;
  }

 private:
  Instance::Kind kind_of(uint32_t mesh) const {
    return is_deforming(mesh) ? Instance::Kind::deforming_mesh : Instance::Kind::mesh;
  }
  // A deforming mesh's hit: its vertices, normals and tangents blended to the
  // ray's time as the traversal blended the positions.
  void deforming_interaction(uint32_t mesh, const Hit& h, Float time, SurfaceInteraction* si) const {
    const TriangleMesh& m = m_meshes[mesh];
    const VertexMotion& vm = m_vertex_motions[size_t(m_deform_of[mesh])];
    auto [k, f] = vm.segment(time);
    Point3f p[3];
    Normal3f n[3];
    std::array<Float, 4> tg[3];
    for (int j = 0; j < 3; ++j) {
      uint32_t v = m.indices[3 * h.primitive + uint32_t(j)];
      p[j] = lerp_key(vm.positions[k][v], vm.positions[k + 1][v], f);
      if (!vm.normals.empty()) {
        const Normal3f &a = vm.normals[k][v], &b = vm.normals[k + 1][v];
        n[j] = Normal3f(lerp_key(a.x, b.x, f), lerp_key(a.y, b.y, f), lerp_key(a.z, b.z, f));
      }
      if (!vm.tangents.empty()) {
        const auto &a = vm.tangents[k][v], &b = vm.tangents[k + 1][v];
        tg[j] = {lerp_key(a[0], b[0], f), lerp_key(a[1], b[1], f), lerp_key(a[2], b[2], f), vm.tangents[0][v][3]};
      }
    }
    triangle_interaction(m, h.primitive, TriangleHit{h.t, h.b0, h.b1, h.b2}, si, p,
                         vm.normals.empty() ? nullptr : n, vm.tangents.empty() ? nullptr : tg);
  }

  // The top-level tree of the motion segment holding `time` (times outside
  // the motion's range use the end segments: every instance is clamped too).
  const BVH& top_for(Float time) const {
    if (m_tops.size() == 1) return m_tops[0];
    Float f = (time - m_time0) * m_time_scale;
    size_t k = f > 0 ? std::min(size_t(f), m_tops.size() - 1) : 0;  // NaN time: segment 0
    return m_tops[k];
  }

  std::vector<TriangleMesh> m_meshes;
  std::vector<MeshAccel> m_mesh_accels;
  std::vector<Sphere> m_spheres;
  std::vector<Instance> m_instances;
  std::vector<AnimatedTransform> m_motions;
  std::vector<VertexMotion> m_vertex_motions;       // the deforming meshes' keys
  std::vector<int32_t> m_deform_of;                 // per mesh: its index in the two below, or -1
  std::vector<DeformingMeshAccel> m_deform_accels;  // built by build()
  std::vector<BVH> m_tops{1};  // one per motion segment
  Bounds3f m_bounds;
  Float m_time0 = 0, m_time1 = 0, m_time_scale = 0;
  bool m_lone_instance = false;
  // The mesh of the one instance when that instance is a mesh with no
  // transform and no motion, else -1: intersect() and occluded() then call
  // its MeshAccel directly. (Through the general lone-instance path, in
  // intersect_instances, primary rays ran 5-6% slower than MeshAccel's own
  // queries and incoherent rays 2%: the per-instance callback was not
  // inlined.)
  int32_t m_lone_mesh = -1;
  BVHBuildOptions m_build_options;
};

}  // namespace prism
