// prism/accel/deforming_mesh.hpp — deformation motion blur: a triangle mesh
// whose vertices move during the shutter (a skinned or morphing character,
// cloth, a simulation), given as vertex keys at evenly spaced times, and the
// acceleration structure that finds a ray's hit at the ray's time.
//
// Between two keys every vertex moves along a straight line:
//     p(t) = p_k + f (p_{k+1} - p_k),   f = the time's fraction of the segment.
// A triangle whose vertices move linearly stays inside the box that encloses
// its two end positions, so each segment [t_k, t_{k+1}] gets its own BVH over
// those boxes, built once (Embree's and Cycles' "motion steps" do the same,
// with one tree over time slices). A ray uses its segment's tree and, in
// each leaf it reaches, blends the two keys' triangle packets to the ray's
// time and runs the same watertight packet test as a still mesh. More keys
// follow a curved motion (a turning limb) more closely and keep each
// segment's boxes tight; a motion that is linear over the shutter needs two.
// docs/motion_blur.md measures the cost against a still mesh.
//
// The blend is one rounding formula, a + f (b - a), in the traversal and in
// the hit's interaction. A build that lets the compiler fuse multiplies and
// adds (-ffp-contract=fast, GCC's default with -march=native) may fuse one
// and not the other: the hit point then differs from the traversal's by an
// ulp or so, well inside its error bound.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include <vector>
#include "prism/accel/bvh.hpp"
#include "prism/accel/triangle_packet.hpp"
#include "prism/attributes.hpp"
#include "prism/error.hpp"
#include "prism/geometry/triangle.hpp"

namespace prism {

// The vertex keys of a deforming mesh: key k holds every vertex at time
// time0 + k (time1 - time0) / (keys - 1). Normals and tangents are optional,
// keyed the same way (empty: the mesh's own, still ones; a tangent's
// handedness w is taken from key 0). The mesh's indices, uvs and colours do
// not change.
struct VertexMotion {
  Float time0 = 0, time1 = 1;
  std::vector<std::vector<Point3f>> positions;
  std::vector<std::vector<Normal3f>> normals;
  std::vector<std::vector<std::array<Float, 4>>> tangents;

  size_t keys() const { return positions.size(); }

  // Throws prism::Error naming what is wrong for a mesh of `vertices` vertices.
  void validate(size_t vertices) const {
    auto fail = [](const std::string& what) { throw Error("VertexMotion: " + what); };
    if (!(std::isfinite(time0) && std::isfinite(time1) && time1 > time0))
      fail("the keys' times [" + std::to_string(time0) + ", " + std::to_string(time1) +
           "] are not a finite interval with time1 > time0");
    if (positions.size() < 2) fail("needs at least 2 position keys, got " + std::to_string(positions.size()));
    if (!normals.empty() && normals.size() != positions.size())
      fail(std::to_string(normals.size()) + " normal keys for " + std::to_string(positions.size()) + " position keys");
    if (!tangents.empty() && tangents.size() != positions.size())
      fail(std::to_string(tangents.size()) + " tangent keys for " + std::to_string(positions.size()) +
           " position keys");
    for (size_t k = 0; k < positions.size(); ++k) {
      auto check = [&](size_t n, const char* what) {
        if (n != vertices)
          fail(std::string(what) + " key " + std::to_string(k) + " has " + std::to_string(n) +
               " vertices, the mesh has " + std::to_string(vertices));
      };
      check(positions[k].size(), "position");
      if (!normals.empty()) check(normals[k].size(), "normal");
      if (!tangents.empty()) check(tangents[k].size(), "tangent");
      for (size_t v = 0; v < positions[k].size(); ++v)
        if (!(std::isfinite(positions[k][v].x) && std::isfinite(positions[k][v].y) &&
              std::isfinite(positions[k][v].z)))
          fail("position key " + std::to_string(k) + ", vertex " + std::to_string(v) + " is not finite");
    }
  }

  // The segment holding `time` (times outside [time0, time1] are clamped to
  // its ends) and the time's fraction f of it, in [0, 1].
  struct Segment {
    uint32_t k;
    Float f;
  };
  static Segment segment(Float time, Float time0, Float time1, size_t keys) {
    const Float last = Float(keys - 1);
    Float u = (time - time0) / (time1 - time0) * last;
    if (!(u > 0)) return {0, 0};  // also a NaN time
    if (u >= last) return {uint32_t(keys - 2), 1};
    uint32_t k = std::min(uint32_t(u), uint32_t(keys - 2));
    return {k, std::min(u - Float(k), Float(1))};
  }
  Segment segment(Float time) const { return segment(time, time0, time1, keys()); }
};

// The blend of two keys at fraction f: one formula, used by the traversal and
// by the hit's interaction alike.
inline Float lerp_key(Float a, Float b, Float f) { return a + f * (b - a); }
inline Point3f lerp_key(const Point3f& a, const Point3f& b, Float f) {
  return {lerp_key(a.x, b.x, f), lerp_key(a.y, b.y, f), lerp_key(a.z, b.z, f)};
}

// One BVH per segment over the triangles' boxes through it, with the
// triangles of each leaf packed at both of the segment's keys (the keys
// themselves are not kept: the caller has them, for the hits' interactions).
class DeformingMeshAccel {
 public:
  DeformingMeshAccel() = default;
  DeformingMeshAccel(const TriangleMesh& mesh, const VertexMotion& motion, const BVHBuildOptions& options)
      : m_time0(motion.time0), m_time1(motion.time1), m_keys(motion.keys()) {
    motion.validate(mesh.positions.size());
    BVHBuildOptions opt = options;
    opt.leaf_block = W;
    opt.spatial_splits = nullptr;
    const size_t n = mesh.triangle_count();
    const uint32_t* idx = mesh.indices.data();
    m_slices = opt.deformation_slices > 0 ? std::min(opt.deformation_slices, 64) : auto_slices(mesh, motion);
    m_segments.resize(m_keys - 1);
    for (size_t s = 0; s + 1 < m_keys; ++s) {
      const Point3f* a = motion.positions[s].data();
      const Point3f* b = motion.positions[s + 1].data();
      // A triangle's box from fraction f0 to f1 of the interval: a vertex
      // lies between where it is at both ends.
      auto box_of = [&](size_t i, Float f0, Float f1) {
        uint32_t v0 = idx[3 * i], v1 = idx[3 * i + 1], v2 = idx[3 * i + 2];
        Bounds3f box = union_bounds(
            triangle_box(lerp_key(a[v0], b[v0], f0), lerp_key(a[v1], b[v1], f0), lerp_key(a[v2], b[v2], f0)),
            triangle_box(lerp_key(a[v0], b[v0], f1), lerp_key(a[v1], b[v1], f1), lerp_key(a[v2], b[v2], f1)));
        // The blend a + f (b - a) is rounded: it may step an ulp past the
        // end points, so the box grows by a few ulps.
        Vector3f pad = max(abs(Vector3f(box.min)), abs(Vector3f(box.max))) * gamma(3);
        return Bounds3f(box.min - pad, box.max + pad);
      };
      // One tree shape per interval, built over the triangles' boxes
      // through all of it; each slice refits a copy to its own part of the
      // interval (the leaves keep their order, so the packets are shared).
      Segment& seg = m_segments[s];
      BVH shape = BVH::build(n, [&](size_t i) { return box_of(i, 0, 1); }, opt);
      const uint32_t* order = shape.prims().data();
      seg.packets.resize(shape.prims().size() / W);
      for (size_t k = 0; k < seg.packets.size(); ++k)
        for (int l = 0; l < W; ++l) {
          uint32_t t = order[k * W + size_t(l)];
          seg.packets[k].a.set(l, a[idx[3 * t]], a[idx[3 * t + 1]], a[idx[3 * t + 2]]);
          seg.packets[k].d.set(l, b[idx[3 * t]], b[idx[3 * t + 1]], b[idx[3 * t + 2]]);
          for (int r = 0; r < 9; ++r) seg.packets[k].d.v[r][l] -= seg.packets[k].a.v[r][l];
          seg.packets[k].tri[l] = t;
        }
      m_bounds = union_bounds(m_bounds, shape.bounds());
      seg.slices.resize(size_t(m_slices));
      for (int j = 0; j < m_slices; ++j) {
        const Float f0 = Float(j) / Float(m_slices), f1 = j + 1 == m_slices ? Float(1) : Float(j + 1) / Float(m_slices);
        seg.slices[size_t(j)] = shape;
        if (m_slices > 1) seg.slices[size_t(j)].refit([&](size_t i) { return box_of(i, f0, f1); }, opt.threads);
      }
    }
  }

  // The slices per interval between keys that `BVHBuildOptions::
  // deformation_slices = 0` picks: one per kSliceMotion triangle sizes that
  // a typical vertex travels in the interval (the median triangle's, over
  // every interval), at most 8 (bench/deformation_bench.cpp,
  // docs/motion_blur.md).
  static constexpr Float kSliceMotion = 2.0f;
  static int auto_slices(const TriangleMesh& mesh, const VertexMotion& motion) {
    const size_t n = mesh.triangle_count();
    const uint32_t* idx = mesh.indices.data();
    std::vector<Float> ratio;
    ratio.reserve(n);
    Float worst = 0;
    for (size_t s = 0; s + 1 < motion.keys(); ++s) {
      const Point3f* a = motion.positions[s].data();
      const Point3f* b = motion.positions[s + 1].data();
      ratio.clear();
      for (size_t i = 0; i < n; ++i) {
        Float travel = 0;
        for (int j = 0; j < 3; ++j) travel = std::max(travel, length(b[idx[3 * i + size_t(j)]] - a[idx[3 * i + size_t(j)]]));
        Float size = length(triangle_box(a[idx[3 * i]], a[idx[3 * i + 1]], a[idx[3 * i + 2]]).diagonal());
        ratio.push_back(size > 0 ? travel / size : (travel > 0 ? infinity : 0));
      }
      if (ratio.empty()) continue;
      std::nth_element(ratio.begin(), ratio.begin() + std::ptrdiff_t(ratio.size() / 2), ratio.end());
      worst = std::max(worst, ratio[ratio.size() / 2]);
    }
    return int(std::clamp(std::ceil(worst / kSliceMotion), Float(1), Float(8)));
  }

  Float time0() const { return m_time0; }
  Float time1() const { return m_time1; }
  size_t segment_count() const { return m_keys - 1; }
  // BVHs per interval between keys (BVHBuildOptions::deformation_slices).
  int slices() const { return m_slices; }
  // Everything the mesh covers at any time.
  Bounds3f bounds() const { return m_bounds; }
  // What it covers during [ta, tb]: the boxes of the segments that overlap it.
  Bounds3f bounds(Float ta, Float tb) const {
    size_t s0 = tree_index(ta), s1 = tree_index(tb);
    Bounds3f b;
    for (size_t s = s0; s <= s1; ++s) b = union_bounds(b, tree(s).bounds());
    return b;
  }
  size_t memory_bytes() const {
    size_t bytes = 0;
    for (const auto& s : m_segments) {
      bytes += s.packets.size() * sizeof(LeafPackets);
      for (const auto& t : s.slices) bytes += t.memory_bytes();
    }
    return bytes;
  }

  // Closest hit before *t_max at the ray's time; on a hit lowers *t_max and
  // fills *hit and *tri (the triangle's index in the mesh).
  bool intersect(const Point3f& o, const Vector3f& d, Float time, Float* t_max, TriangleHit* hit,
                 uint32_t* tri) const {
    const RayTrianglePrecomp pc(d);
    const detail::WideRayPrecomp wr(o, d);
    auto [k, f] = segment(time);
    const Segment& seg = m_segments[k];
    const BVH& bvh = seg.slices[slice_of(f)];
    switch (pc.kz) {
      case 0: return intersect_axis<0>(seg, bvh, f, o, wr, pc, t_max, hit, tri);
      case 1: return intersect_axis<1>(seg, bvh, f, o, wr, pc, t_max, hit, tri);
      default: return intersect_axis<2>(seg, bvh, f, o, wr, pc, t_max, hit, tri);
    }
  }
  // Any hit before t_max at the ray's time, ignoring triangle `skip`.
  bool occluded(const Point3f& o, const Vector3f& d, Float time, Float t_max, uint32_t skip = UINT32_MAX) const {
    const RayTrianglePrecomp pc(d);
    const detail::WideRayPrecomp wr(o, d);
    auto [k, f] = segment(time);
    const Segment& seg = m_segments[k];
    const BVH& bvh = seg.slices[slice_of(f)];
    switch (pc.kz) {
      case 0: return occluded_axis<0>(seg, bvh, f, o, wr, pc, t_max, skip);
      case 1: return occluded_axis<1>(seg, bvh, f, o, wr, pc, t_max, skip);
      default: return occluded_axis<2>(seg, bvh, f, o, wr, pc, t_max, skip);
    }
  }

 private:
  static constexpr int W = triangle_packet_width;
  struct LeafPackets {
    TrianglePacket a, d;  // the triangles at the interval's first key, and b - a to its last
    uint32_t tri[W];
  };
  // An interval between two keys: its leaves' triangles, packed at both
  // keys, and one tree per slice, all of one shape.
  struct Segment {
    std::vector<LeafPackets> packets;
    std::vector<BVH> slices;
  };
  static constexpr int all_lanes = (1 << W) - 1;

  // The packet at fraction f between its keys: a + f (b - a), as lerp_key
  // (b - a was rounded once, when packed, exactly as lerp_key rounds it).
  static void blend(const LeafPackets& p, Float f, TrianglePacket* out) {
    for (int r = 0; r < 9; ++r)
      for (int l = 0; l < W; ++l) out->v[r][l] = p.a.v[r][l] + f * p.d.v[r][l];
  }
  template <int KZ>
  static bool intersect_axis(const Segment& seg, const BVH& bvh, Float f, const Point3f& o, const detail::WideRayPrecomp& wr,
                             const RayTrianglePrecomp& pc, Float* t_max, TriangleHit* hit, uint32_t* tri) {
    uint32_t best = 0;
    TrianglePacket now;
    bool found = bvh.intersect_leaves(wr, *t_max, [&](uint32_t first, uint32_t count, Float& tm) {
      bool any = false;
      for (uint32_t j = 0; j * W < count; ++j) {
        const LeafPackets& p = seg.packets[first / W + j];
        blend(p, f, &now);
        if (auto h = intersect_packet<KZ>(now, o, pc, tm, all_lanes)) {
          tm = h->hit.t;
          *hit = h->hit;
          best = p.tri[h->lane];
          any = true;
        }
      }
      return any;
    });
    if (found) *tri = best;
    return found;
  }
  template <int KZ>
  static bool occluded_axis(const Segment& seg, const BVH& bvh, Float f, const Point3f& o, const detail::WideRayPrecomp& wr,
                            const RayTrianglePrecomp& pc, Float t_max, uint32_t skip) {
    TrianglePacket now;
    return bvh.occluded_leaves(wr, t_max, [&](uint32_t first, uint32_t count, Float tm) {
      for (uint32_t j = 0; j * W < count; ++j) {
        const LeafPackets& p = seg.packets[first / W + j];
        int lanes = all_lanes;
        for (int l = 0; l < W; ++l)
          if (p.tri[l] == skip) lanes &= ~(1 << l);
        blend(p, f, &now);
        if (occluded_packet<KZ>(now, o, pc, tm, lanes)) return true;
      }
      return false;
    });
  }

  VertexMotion::Segment segment(Float time) const { return VertexMotion::segment(time, m_time0, m_time1, m_keys); }
  // The slice holding fraction f of an interval: the one whose ends, as the
  // build computed them, enclose f (f * slices may round across an end).
  size_t slice_of(Float f) const {
    const size_t m = size_t(m_slices);
    size_t j = std::min(size_t(f * Float(m_slices)), m - 1);
    if (j > 0 && f < Float(j) / Float(m_slices)) --j;
    if (j + 1 < m && f >= Float(j + 1) / Float(m_slices)) ++j;
    return j;
  }
  // Every slice in time order: index k * slices + slice.
  size_t tree_index(Float time) const {
    auto [k, f] = segment(time);
    return size_t(k) * size_t(m_slices) + slice_of(f);
  }
  const BVH& tree(size_t i) const { return m_segments[i / size_t(m_slices)].slices[i % size_t(m_slices)]; }

  Float m_time0 = 0, m_time1 = 1;
  size_t m_keys = 2;
  int m_slices = 1;
  std::vector<Segment> m_segments;  // keys - 1
  Bounds3f m_bounds;
};

}  // namespace prism
