// prism/accel/bvh/tree.hpp — class BVH and its build options: the data a
// BVH holds (the wide traversal layout, the leaf order, the binary tree if
// kept), its accessors, and the declarations of what the other headers of
// accel/bvh/ define: the build (binned_sah_builder.hpp), the collapse to wide
// nodes (collapse.hpp), traversal (traversal.hpp) and refit (refit.hpp).
// Include prism/accel/bvh.hpp, which holds them all, to use a BVH.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <type_traits>
#include <utility>
#include <vector>
#include "prism/accel/bvh/build_support.hpp"
#include "prism/accel/bvh/node.hpp"
#include "prism/accel/bvh/ray_box.hpp"
#include "prism/math/bounds.hpp"

namespace prism {

struct BVHBuildOptions;
namespace detail {
struct SplitReferences;  // accel/presplit.hpp
struct SpatialBVH;       // accel/presplit.hpp
// A mesh builder with spatial splits (BVHBuildOptions::spatial_splits): n
// triangles from positions and indices (three per triangle), the options,
// and the pre-split references to start from. The one there is,
// prism::spatial_split_builder, is in accel/sbvh.hpp.
using SpatialBuildFn = SpatialBVH (*)(size_t, const Point3f*, const uint32_t*, const BVHBuildOptions&,
                                      const SplitReferences*);
}  // namespace detail

struct BVHBuildOptions {
  // The most primitives in a leaf; 0 (the default) or less means one
  // leaf_block, and at least 8 (leaf_size_limit()): MeshAccel's leaves then
  // hold one packet of triangles, 8 or, with 16-wide packets (the default
  // with AVX-512), 16 (accel/triangle_packet.hpp), and 4-wide packets two.
  int max_leaf_size = 0;
  // Primitives a leaf tests together (triangle packets): the SAH counts a
  // leaf's cost in blocks of this many, and each leaf's range in prims()
  // starts at a multiple of it, padded by repeating the leaf's last primitive.
  int leaf_block = 1;
  // Relative cost of a node visit against one primitive test.
  Float traversal_cost = 1.0f;
  // Threads for the build; 0 = all hardware threads. The tree does not depend on it.
  int threads = 0;
  // Scenes with moving instances: top-level trees over the motion's time
  // range (scene_accel.hpp); 0 = SceneAccel::kDefaultMotionSegments.
  int motion_segments = 0;
  // Deforming meshes (accel/deforming_mesh.hpp): BVHs per interval between
  // two vertex keys, each over the triangles' boxes during its part of the
  // interval; 0 = chosen from how far the vertices move against the
  // triangles' sizes.
  int deformation_slices = 0;
  // Triangle meshes (MeshAccel): extra BVH references from pre-splitting
  // triangles whose box is much larger than they are (accel/presplit.hpp), as
  // a fraction of the triangle count; 0 = off. Only triangles whose box's
  // surface area is at least split_threshold times twice their area are cut:
  // long thin or large diagonal slivers. A mesh without them (a ratio of 2 to
  // about 6 is usual) is built exactly as with splitting off. Where it cuts,
  // it trades build time for tracing: on traversal_bench's sliver scene the
  // build takes 1.7x as long and rays trace 1.7-1.9x faster; 0 suits a mesh
  // rebuilt every frame and traced little.
  float split_budget = 0.3f;
  float split_threshold = 32;
  // Triangle meshes (MeshAccel): after pre-splitting, spatial splits inside
  // the builder too (SBVH; the program includes prism/accel/sbvh.hpp, which
  // holds the builder, or this is refused with prism::Error): at nodes where
  // the best object split's two boxes overlap by more than spatial_alpha
  // times the root's surface area, a plane across the node's box that cuts
  // the references it crosses, where the SAH prefers it. It may add up to split_budget times
  // the triangle count references on top of pre-splitting's. On
  // traversal_bench's sliver scene the build takes about 5 times as long and
  // rays trace 1.25 to 1.35 times as fast (docs/performance.md). Off by
  // default (null). To turn it on, name the builder, which lives in its own
  // header (prism/prism.hpp leaves it out: it would add about 15% to the
  // compile time of every program that builds a scene):
  //   #include <prism/accel/sbvh.hpp>
  //   opt.spatial_splits = prism::spatial_split_builder;
  // A program that asks for spatial splits without the header does not
  // compile.
  detail::SpatialBuildFn spatial_splits = nullptr;
  float spatial_alpha = 1e-3f;
  // Keep the binary tree that the wide traversal layout is derived from
  // (BVH::nodes(), for tests and inspection). Otherwise it is freed once the
  // layout is written: 32 bytes per binary node, about 9 per mesh triangle.
  bool keep_binary_tree = false;

  // max_leaf_size, with 0 resolved.
  int leaf_size_limit() const { return max_leaf_size > 0 ? max_leaf_size : std::max(8, leaf_block); }
};

class BVH {
 public:
  // Depth is at most 48 SAH levels plus 32 halvings (see Builder::max_sah_depth).
  static constexpr int traversal_stack_size = 96;
  // The wide layout is no deeper than the binary tree; a visit defers at most wide_width - 1 children.
  static constexpr int wide_stack_size = (detail::wide_width - 1) * traversal_stack_size + detail::wide_width;
  BVH() = default;

  // Builds over primitives with the given bounds. Empty input gives an empty BVH.
  static BVH build(std::span<const Bounds3f> prim_bounds, const BVHBuildOptions& opt = {});
  // The same, with the bounds of primitive i given by bounds_of(i) (called once
  // per primitive, possibly from several threads), so that callers need not
  // store them.
  template <class BoundsOf>
    requires std::is_invocable_r_v<Bounds3f, BoundsOf&, size_t>
  static BVH build(size_t n, BoundsOf&& bounds_of, const BVHBuildOptions& opt = {});

  // A BVH from a binary tree built elsewhere (accel/sbvh.hpp, whose spatial
  // splits make references that a build over boxes cannot): `nodes` as
  // nodes() holds them, in depth-first pre-order (an interior node's first
  // child follows it and `offset` is its second child; a leaf covers entries
  // [offset, offset + count) of leaf_prims), leaf_prims the primitive numbers
  // in leaf order. opt.leaf_block and keep_binary_tree apply as in build().
  // Throws prism::Error if the tree is not one: an index out of range, a
  // node reached twice or never, an entry in two leaves or in none, a depth
  // beyond what traversal's stack holds (Builder::max_sah_depth + 32), or
  // leaves that padded to blocks hold more than 2^32 - 1 entries.
  static BVH from_binary_tree(std::vector<BVHNode> nodes, std::span<const uint32_t> leaf_prims,
                              const BVHBuildOptions& opt = {});

  // Refit after the primitives moved (a deforming mesh): the same tree over
  // the new bounds, bounds_of(i) giving input primitive i's (called from
  // several threads). Every wide node's boxes are recomputed bottom-up: leaf
  // lanes from their primitives, inner lanes from the child node's box, so
  // queries are exact; the SAH quality of the old topology may degrade if the
  // motion reshuffles primitives (rebuild then). A kept binary tree
  // (BVHBuildOptions::keep_binary_tree) is refitted too.
  template <class BoundsOf>
    requires std::is_invocable_r_v<Bounds3f, BoundsOf&, size_t>
  void refit(BoundsOf&& bounds_of, int threads = 0);

  bool empty() const { return m_wide.empty(); }
  // The binary tree the traversal layout was derived from; empty unless the
  // build kept it (BVHBuildOptions::keep_binary_tree).
  const std::vector<BVHNode>& nodes() const { return m_nodes; }
  // Leaf order: primitive k of a leaf range is the input primitive prims()[k].
  const std::vector<uint32_t>& prims() const { return m_prims; }
  Bounds3f bounds() const { return m_bounds; }
  // Bytes held: the wide traversal layout, the leaf order and the binary tree if kept.
  size_t memory_bytes() const {
    return m_nodes.size() * sizeof(BVHNode) + m_wide.size() * sizeof(detail::BVHWideNode) +
           m_prims.size() * sizeof(uint32_t);
  }
  size_t wide_node_count() const { return m_wide.size(); }
  // The traversal layout (detail::BVHWideNode), for inspection and tests.
  std::span<const detail::BVHWideNode> wide_nodes() const { return m_wide; }

  // Closest hit. isect(k, t_max) tests leaf-order primitive k and, on a hit
  // closer than t_max, lowers t_max and returns true. Children are visited
  // nearest entry first; a deferred child is skipped once a closer hit makes it
  // unreachable.
  template <class F>
  bool intersect(const Point3f& o, const Vector3f& d, Float& t_max, F&& isect) const;
  // The same with the ray's box-test data computed once by the caller, which
  // may trace the ray through several BVHs.
  template <class F>
  bool intersect(const detail::WideRayPrecomp& r, Float& t_max, F&& isect) const;
  // Closest hit, a leaf at a time: leaf(first, count, t_max) tests leaf-order
  // primitives [first, first + count) and, on a hit closer than t_max, lowers
  // t_max and returns true. With BVHBuildOptions::leaf_block > 1, first is a
  // multiple of it and the range may be read up to the next multiple.
  template <class F>
  bool intersect_leaves(const detail::WideRayPrecomp& r, Float& t_max, F&& leaf) const;

  // Any hit before t_max: stops at the first primitive for which isect returns true.
  template <class F>
  bool occluded(const Point3f& o, const Vector3f& d, Float t_max, F&& isect) const;
  template <class F>
  bool occluded(const detail::WideRayPrecomp& r, Float t_max, F&& isect) const;
  // Any hit, a leaf at a time: leaf(first, count, t_max) returns whether one of
  // the leaf's primitives is hit before t_max (see intersect_leaves).
  template <class F>
  bool occluded_leaves(const detail::WideRayPrecomp& r, Float t_max, F&& leaf) const;

 private:
  // The build's types (binned_sah_builder.hpp): a primitive reference, a
  // running union of boxes, the binned-SAH builder.
  struct PrimRef;
  struct BoxAcc;
  struct Builder;
  // Which binary nodes each wide node gathers (collapse.hpp).
  class Collapse;

  // binned_sah_builder.hpp: from_binary_tree's check; the leaf order padded to blocks.
  static void check_tree(const std::vector<BVHNode>& nodes, size_t prims, uint32_t block);
  template <class IndexOf>
  void pad_leaves(IndexOf&& index_of, uint32_t block, int threads);
  // collapse.hpp: the wide layout from the binary tree.
  void collapse_all(int threads);
  uint32_t wide_size(const Collapse& plan, uint32_t bin, int depth, int stop,
                     detail::fill_later_vector<uint32_t>& size, std::vector<uint32_t>* frontier) const;
  void write_wide(const Collapse& plan, uint32_t bin, uint32_t w, int depth, int stop,
                  const detail::fill_later_vector<uint32_t>& size,
                  std::vector<std::pair<uint32_t, uint32_t>>* jobs);
  // traversal.hpp: prefetching deferred children; any hit's ordering of a node's lanes.
  void prefetch_children(const detail::BVHWideNode& node, unsigned lanes) const;
  int visit_nearest(const detail::BVHWideNode& node, unsigned mask, detail::LaneMaskV inside,
                    const Float* t_entry, uint32_t* stack_child, uint32_t* stack_count, int& sp) const;
  // refit.hpp: both layouts' boxes from the primitives'.
  template <class BoundsOf>
  void refit_layouts(BoundsOf&& bounds_of, int threads);

  std::vector<BVHNode> m_nodes;  // the binary tree: during the build, after it only if kept
  std::vector<uint32_t> m_prims;
  detail::fill_later_vector<detail::BVHWideNode> m_wide;  // traversal layout, derived from m_nodes
  Bounds3f m_bounds;
};

}  // namespace prism
