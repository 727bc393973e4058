// prism/accel/bvh.hpp — a binary BVH built with the binned surface-area
// heuristic (Wald 2007, "On fast Construction of SAH-based Bounding Volume
// Hierarchies") and stored flat in depth-first order: 32-byte nodes, the first
// child right after its parent.
//
// The BVH knows only primitive bounds. Traversal takes a callback that
// intersects primitive i (in the BVH's leaf order) and shrinks t_max on a hit;
// the mesh and instance layers supply it. Ray–box tests are robust in the sense
// of Ize 2013 ("Robust BVH Ray Traversal"): the far distance is enlarged
// (detail::widen_exit), so rounding never culls a box the ray really enters.
//
// The build is deterministic: the same input gives the same tree at any
// thread count (subtrees are built in parallel, then laid out in a fixed order).
// It bins all three axes in one SIMD pass over 32-byte primitive references
// and derives the children's bounds from the bins and the partition pass.
//
// Traversal runs on a second layout derived from the binary tree: nodes with
// up to sixteen children (with AVX-512; eight otherwise, as in Embree's BVH8)
// whose boxes sit side by side, so one visit tests them all in one SIMD pass
// (AVX-512 or AVX; SSE2 in passes of four) and a ray makes a fraction of the
// binary tree's visits and cache misses. Which binary nodes a wide node
// gathers is chosen for the least SAH cost of the whole layout (BVH::Collapse).
// Each lane's box test is exactly intersect_node's, so a ray reaches the same
// primitives as through the binary tree. -DPRISM_BVH_QUANTIZED=1 stores the
// children's boxes quantized to bytes, rounded outward (half the node size;
// see BVHQuantWideNode): a ray then reaches a superset of those primitives.
//
// One concept per header, in accel/bvh/ (this header includes them all):
//   simd.hpp                the instruction sets, the node width they select
//                           (PRISM_BVH_W) and the box test's SIMD wrappers
//   build_support.hpp       the builds' memory (huge pages) and threads
//   node.hpp                BVHNode; the float and quantized wide nodes
//   ray_box.hpp             ray–box tests for binary and wide nodes
//   tree.hpp                class BVH and BVHBuildOptions
//   binned_sah_builder.hpp  BVH::build (and from_binary_tree)
//   collapse.hpp            the binary tree collapsed to wide nodes
//   traversal.hpp           closest and any hit; the lane orderings
//   refit.hpp               BVH::refit
#pragma once
#include "prism/accel/bvh/binned_sah_builder.hpp"
#include "prism/accel/bvh/build_support.hpp"
#include "prism/accel/bvh/collapse.hpp"
#include "prism/accel/bvh/node.hpp"
#include "prism/accel/bvh/ray_box.hpp"
#include "prism/accel/bvh/refit.hpp"
#include "prism/accel/bvh/simd.hpp"
#include "prism/accel/bvh/traversal.hpp"
#include "prism/accel/bvh/tree.hpp"
#include "prism/geometry/ray.hpp"  // (for the programs that have always had Ray from here)
