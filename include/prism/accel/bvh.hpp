// prism/accel/bvh.hpp — a binary BVH built with the binned surface-area
// heuristic (Wald 2007, "On fast Construction of SAH-based Bounding Volume
// Hierarchies") and stored flat in depth-first order: 32-byte nodes, the first
// child right after its parent, so traversal walks memory forwards.
//
// The BVH knows only primitive bounds. Traversal takes a callback that
// intersects primitive i (in the BVH's leaf order) and shrinks t_max on a hit;
// the mesh and instance layers supply it. Ray–box tests are robust in the sense
// of Ize 2013 ("Robust BVH Ray Traversal"): the far distance is enlarged by
// 1 + 2 gamma(3), so rounding never culls a box the ray really enters.
//
// The build is deterministic: the same input gives the same tree at any
// thread count (subtrees are built in parallel, then laid out in a fixed order).
#pragma once
#include <atomic>
#include <cstdint>
#include <future>
#include <memory>
#include <span>
#include <thread>
#include <vector>
#include "prism/geometry/ray.hpp"

namespace prism {

struct alignas(32) BVHNode {
  Float bmin[3];
  uint32_t offset;  // leaf: first primitive; interior: index of the second child
  Float bmax[3];
  uint32_t count;   // primitives in a leaf; 0 for an interior node

  bool is_leaf() const { return count != 0; }
  Bounds3f bounds() const {
    Bounds3f b;
    b.min = {bmin[0], bmin[1], bmin[2]};
    b.max = {bmax[0], bmax[1], bmax[2]};
    return b;
  }
};
static_assert(sizeof(BVHNode) == 32);

struct BVHBuildOptions {
  int max_leaf_size = 8;
  // Relative cost of a node visit against one primitive test.
  Float traversal_cost = 1.0f;
  // Threads for the build; 0 = all hardware threads. The tree does not depend on it.
  int threads = 0;
};

// Per-ray data for box tests.
struct RayBoxPrecomp {
  Float o[3], inv_d[3];
  int sign[3];
  explicit RayBoxPrecomp(const Point3f& org, const Vector3f& d) {
    o[0] = org.x; o[1] = org.y; o[2] = org.z;
    inv_d[0] = 1 / d.x; inv_d[1] = 1 / d.y; inv_d[2] = 1 / d.z;
    for (int i = 0; i < 3; ++i) sign[i] = inv_d[i] < 0 ? 1 : 0;
  }
};

// Entry distance of the ray into the node's box, or +inf when it misses or the
// box lies beyond t_max.
inline Float intersect_node(const BVHNode& n, const RayBoxPrecomp& r, Float t_max) {
  const Float* lo = n.bmin;
  const Float* hi = n.bmax;
  Float tx0 = ((r.sign[0] ? hi : lo)[0] - r.o[0]) * r.inv_d[0];
  Float tx1 = ((r.sign[0] ? lo : hi)[0] - r.o[0]) * r.inv_d[0];
  Float ty0 = ((r.sign[1] ? hi : lo)[1] - r.o[1]) * r.inv_d[1];
  Float ty1 = ((r.sign[1] ? lo : hi)[1] - r.o[1]) * r.inv_d[1];
  Float tz0 = ((r.sign[2] ? hi : lo)[2] - r.o[2]) * r.inv_d[2];
  Float tz1 = ((r.sign[2] ? lo : hi)[2] - r.o[2]) * r.inv_d[2];
  // NaN (0 * inf on a slab boundary) loses every comparison and is ignored.
  Float t0 = tx0 > 0 ? tx0 : 0;
  t0 = ty0 > t0 ? ty0 : t0;
  t0 = tz0 > t0 ? tz0 : t0;
  Float t1 = tx1 < t_max ? tx1 : t_max;
  t1 = ty1 < t1 ? ty1 : t1;
  t1 = tz1 < t1 ? tz1 : t1;
  constexpr Float widen = 1 + 2 * gamma(3);
  return t0 <= t1 * widen ? t0 : infinity;
}

class BVH {
 public:
  // Depth is at most 48 SAH levels plus 32 halvings (see Builder::max_sah_depth).
  static constexpr int traversal_stack_size = 96;
  BVH() = default;

  // Builds over primitives with the given bounds. Empty input gives an empty BVH.
  static BVH build(std::span<const Bounds3f> prim_bounds, const BVHBuildOptions& opt = {}) {
    BVH bvh;
    size_t n = prim_bounds.size();
    if (n == 0) return bvh;
    Builder b{prim_bounds, opt, {}, {}, {}};
    b.centroids.resize(n);
    for (size_t i = 0; i < n; ++i) b.centroids[i] = prim_bounds[i].centroid();
    bvh.m_prims.resize(n);
    for (size_t i = 0; i < n; ++i) bvh.m_prims[i] = uint32_t(i);
    int threads = opt.threads > 0 ? opt.threads : int(std::max(1u, std::thread::hardware_concurrency()));
    b.spare_threads = threads - 1;
    auto root = b.build_range(bvh.m_prims.data(), 0, uint32_t(n), 0);
    bvh.m_nodes.reserve(b.node_count.load());
    flatten(*root, bvh.m_nodes);
    return bvh;
  }

  bool empty() const { return m_nodes.empty(); }
  const std::vector<BVHNode>& nodes() const { return m_nodes; }
  // Leaf order: primitive k of a leaf range is the input primitive prims()[k].
  const std::vector<uint32_t>& prims() const { return m_prims; }
  Bounds3f bounds() const { return m_nodes.empty() ? Bounds3f{} : m_nodes[0].bounds(); }

  // Closest hit. isect(k, t_max) tests leaf-order primitive k and, on a hit
  // closer than t_max, lowers t_max and returns true.
  template <class F>
  bool intersect(const Point3f& o, const Vector3f& d, Float& t_max, F&& isect) const {
    if (m_nodes.empty()) return false;
    RayBoxPrecomp r(o, d);
    if (intersect_node(m_nodes[0], r, t_max) == infinity) return false;
    uint32_t stack[traversal_stack_size];
    int sp = 0;
    uint32_t idx = 0;
    bool hit = false;
    for (;;) {
      const BVHNode& node = m_nodes[idx];
      if (node.is_leaf()) {
        for (uint32_t k = node.offset, e = node.offset + node.count; k < e; ++k)
          if (isect(k, t_max)) hit = true;
      } else {
        uint32_t l = idx + 1, rr = node.offset;
        Float tl = intersect_node(m_nodes[l], r, t_max);
        Float tr = intersect_node(m_nodes[rr], r, t_max);
        if (tl != infinity) {
          if (tr != infinity) {
            if (tr < tl) std::swap(l, rr);
            stack[sp++] = rr;
          }
          idx = l;
          continue;
        }
        if (tr != infinity) {
          idx = rr;
          continue;
        }
      }
      // Pop, skipping nodes that a closer hit has since made unreachable.
      for (;;) {
        if (sp == 0) return hit;
        idx = stack[--sp];
        if (!hit || intersect_node(m_nodes[idx], r, t_max) != infinity) break;
      }
    }
  }

  // Any hit before t_max: stops at the first primitive for which isect returns true.
  template <class F>
  bool occluded(const Point3f& o, const Vector3f& d, Float t_max, F&& isect) const {
    if (m_nodes.empty()) return false;
    RayBoxPrecomp r(o, d);
    if (intersect_node(m_nodes[0], r, t_max) == infinity) return false;
    uint32_t stack[traversal_stack_size];
    int sp = 0;
    uint32_t idx = 0;
    for (;;) {
      const BVHNode& node = m_nodes[idx];
      if (node.is_leaf()) {
        for (uint32_t k = node.offset, e = node.offset + node.count; k < e; ++k)
          if (isect(k, t_max)) return true;
      } else {
        uint32_t l = idx + 1, rr = node.offset;
        bool hl = intersect_node(m_nodes[l], r, t_max) != infinity;
        bool hr = intersect_node(m_nodes[rr], r, t_max) != infinity;
        if (hl) {
          if (hr) stack[sp++] = rr;
          idx = l;
          continue;
        }
        if (hr) {
          idx = rr;
          continue;
        }
      }
      if (sp == 0) return false;
      idx = stack[--sp];
    }
  }

 private:
  struct BuildNode {
    Bounds3f bounds;
    uint32_t first = 0, count = 0;
    std::unique_ptr<BuildNode> child[2];
  };

  struct Builder {
    std::span<const Bounds3f> bounds;
    const BVHBuildOptions& opt;
    std::vector<Point3f> centroids;
    std::atomic<int> spare_threads{0};
    std::atomic<size_t> node_count{0};
    static constexpr int bin_count = 16;
    static constexpr uint32_t parallel_threshold = 32 * 1024;

    // Past this depth the builder halves ranges instead of using the SAH, so
    // traversal stacks (max_sah_depth + 32 entries) never overflow.
    static constexpr int max_sah_depth = 48;

    std::unique_ptr<BuildNode> build_range(uint32_t* prims, uint32_t begin, uint32_t end, int depth) {
      auto node = std::make_unique<BuildNode>();
      ++node_count;
      Bounds3f bb, cb;
      for (uint32_t i = begin; i < end; ++i) {
        bb = union_bounds(bb, bounds[prims[i]]);
        cb = union_bounds(cb, centroids[prims[i]]);
      }
      node->bounds = bb;
      uint32_t n = end - begin;
      auto make_leaf = [&] {
        node->first = begin;
        node->count = n;
        return std::move(node);
      };
      if (n == 1) return make_leaf();
      if (depth >= max_sah_depth) {
        if (n <= uint32_t(opt.max_leaf_size)) return make_leaf();
        uint32_t half = begin + n / 2;
        node->child[0] = build_range(prims, begin, half, depth + 1);
        node->child[1] = build_range(prims, half, end, depth + 1);
        return node;
      }

      // Bin centroids along each axis and evaluate the SAH at every bin boundary.
      int best_axis = -1, best_split = 0;
      Float best_cost = infinity;
      for (int axis = 0; axis < 3; ++axis) {
        Float lo = cb.min[axis], hi = cb.max[axis];
        if (!(hi > lo)) continue;
        Float k = Float(bin_count) * (1 - 1e-6f) / (hi - lo);
        // A spread below 16 / FLT_MAX overflows the bin scale: skip the axis.
        if (!std::isfinite(k)) continue;
        Bounds3f bin_b[bin_count];
        uint32_t bin_n[bin_count] = {};
        for (uint32_t i = begin; i < end; ++i) {
          int bi = std::min(bin_count - 1, int((centroids[prims[i]][axis] - lo) * k));
          ++bin_n[bi];
          bin_b[bi] = union_bounds(bin_b[bi], bounds[prims[i]]);
        }
        Float right_area[bin_count];
        uint32_t right_n[bin_count];
        Bounds3f acc;
        uint32_t acc_n = 0;
        for (int i = bin_count - 1; i > 0; --i) {
          acc = union_bounds(acc, bin_b[i]);
          acc_n += bin_n[i];
          right_area[i] = acc.surface_area();
          right_n[i] = acc_n;
        }
        acc = Bounds3f{};
        acc_n = 0;
        for (int i = 0; i < bin_count - 1; ++i) {
          acc = union_bounds(acc, bin_b[i]);
          acc_n += bin_n[i];
          if (acc_n == 0 || right_n[i + 1] == 0) continue;
          Float cost = Float(acc_n) * acc.surface_area() + Float(right_n[i + 1]) * right_area[i + 1];
          if (cost < best_cost) {
            best_cost = cost;
            best_axis = axis;
            best_split = i;
          }
        }
      }

      Float area = bb.surface_area();
      Float leaf_cost = Float(n);
      Float split_cost = opt.traversal_cost + (area > 0 ? best_cost / area : Float(n));
      uint32_t mid;
      if (best_axis < 0) {
        // All centroids coincide: split in the middle if the leaf would be too big.
        if (n <= uint32_t(opt.max_leaf_size)) return make_leaf();
        mid = begin + n / 2;
      } else {
        if (n <= uint32_t(opt.max_leaf_size) && leaf_cost <= split_cost) return make_leaf();
        Float lo = cb.min[best_axis];
        Float k = Float(bin_count) * (1 - 1e-6f) / (cb.max[best_axis] - lo);
        uint32_t* m = std::partition(prims + begin, prims + end, [&](uint32_t p) {
          return std::min(bin_count - 1, int((centroids[p][best_axis] - lo) * k)) <= best_split;
        });
        mid = uint32_t(m - prims);
        if (mid == begin || mid == end) mid = begin + n / 2;
      }

      if (n >= parallel_threshold && spare_threads.fetch_sub(1) > 0) {
        auto left = std::async(std::launch::async, [&, prims, begin, mid] { return build_range(prims, begin, mid, depth + 1); });
        node->child[1] = build_range(prims, mid, end, depth + 1);
        node->child[0] = left.get();
        ++spare_threads;
      } else {
        if (n >= parallel_threshold) ++spare_threads;
        node->child[0] = build_range(prims, begin, mid, depth + 1);
        node->child[1] = build_range(prims, mid, end, depth + 1);
      }
      return node;
    }
  };

  static void flatten(const BuildNode& b, std::vector<BVHNode>& out) {
    size_t idx = out.size();
    out.push_back({});
    BVHNode& n = out[idx];
    for (int i = 0; i < 3; ++i) {
      n.bmin[i] = b.bounds.min[i];
      n.bmax[i] = b.bounds.max[i];
    }
    if (!b.child[0]) {
      out[idx].offset = b.first;
      out[idx].count = b.count;
      return;
    }
    flatten(*b.child[0], out);
    out[idx].offset = uint32_t(out.size());
    out[idx].count = 0;
    flatten(*b.child[1], out);
  }

  std::vector<BVHNode> m_nodes;
  std::vector<uint32_t> m_prims;
};

}  // namespace prism
