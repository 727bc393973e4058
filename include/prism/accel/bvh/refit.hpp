// prism/accel/bvh/refit.hpp — BVH::refit: after the primitives moved, the
// same tree over their new bounds. The wide nodes' boxes are recomputed
// bottom-up (leaf lanes in parallel, then inner lanes in one reverse sweep
// of the pre-order layout), and a kept binary tree's likewise.
#pragma once
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <type_traits>
#include <vector>
#include "prism/accel/bvh/build_support.hpp"
#include "prism/accel/bvh/node.hpp"
#include "prism/accel/bvh/tree.hpp"
#include "prism/math/bounds.hpp"

namespace prism {

template <class BoundsOf>
  requires std::is_invocable_r_v<Bounds3f, BoundsOf&, size_t>
inline void BVH::refit(BoundsOf&& bounds_of, int threads) {
  if (m_wide.empty()) return;
  threads = detail::build_threads(threads);
  if (!m_nodes.empty()) {
    // A kept binary tree needs the same primitive boxes as the wide
    // layout: ask for each once, then refit both from the copies.
    std::vector<Bounds3f> prim_box(m_prims.empty() ? 0 : size_t(*std::max_element(m_prims.begin(), m_prims.end())) + 1);
    detail::parallel_chunks(prim_box.size(), detail::parallel_chunk_count(prim_box.size(), threads),
                            [&](size_t b, size_t e, int) {
                              for (size_t i = b; i < e; ++i) prim_box[i] = bounds_of(i);
                            });
    refit_layouts([&](size_t i) { return prim_box[i]; }, threads);
    return;
  }
  refit_layouts(bounds_of, threads);
}

template <class BoundsOf>
inline void BVH::refit_layouts(BoundsOf&& bounds_of, int threads) {
  constexpr int W = detail::wide_width;
  // The leaf lanes' boxes, in parallel (the bulk of the work: one call of
  // bounds_of per primitive); then the inner lanes and the nodes' own
  // boxes in one reverse sweep (pre-order puts a child after its parent).
  // (About 64 primitives under a wide node: split into chunks from 1024 nodes on.)
  std::vector<std::array<Bounds3f, W>> lane(m_wide.size());
  size_t nw = m_wide.size();
  detail::parallel_chunks(nw, detail::parallel_chunk_count(nw * 64, threads), [&](size_t b, size_t e, int) {
    for (size_t w = b; w < e; ++w) {
      const detail::BVHWideNode& n = m_wide[w];
      for (int l = 0; l < W; ++l) {
        if (n.count[l] == 0 || n.count[l] == detail::BVHWideNode::interior) continue;
        Bounds3f box;
        for (uint32_t k = n.child[l], end = n.child[l] + n.count[l]; k < end; ++k)
          box = union_bounds(box, bounds_of(size_t(m_prims[k])));
        lane[w][size_t(l)] = box;
      }
    }
  });
  std::vector<Bounds3f> node_box(nw);
  for (size_t w = nw; w-- > 0;) {
    detail::BVHWideNode& n = m_wide[w];
    int k = 0;
    Bounds3f all;
    for (; k < W && n.count[k] != 0; ++k) {
      if (n.count[k] == detail::BVHWideNode::interior) lane[w][size_t(k)] = node_box[n.child[k]];
      all = union_bounds(all, lane[w][size_t(k)]);
    }
    detail::set_boxes(n, lane[w].data(), k);  // keeps the links
    node_box[w] = all;
  }
  m_bounds = node_box[0];
  // The binary tree, if kept: the same reverse sweep.
  for (size_t i = m_nodes.size(); i-- > 0;) {
    BVHNode& nd = m_nodes[i];
    Bounds3f b;
    if (nd.is_leaf()) {
      for (uint32_t k = nd.offset, e = nd.offset + nd.count; k < e; ++k) b = union_bounds(b, bounds_of(m_prims[k]));
    } else {
      b = union_bounds(m_nodes[i + 1].bounds(), m_nodes[nd.offset].bounds());
    }
    for (int a = 0; a < 3; ++a) {
      nd.bmin[a] = b.min[a];
      nd.bmax[a] = b.max[a];
    }
  }
}

}  // namespace prism
