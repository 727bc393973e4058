// prism/accel/bvh/collapse.hpp — the wide traversal layout derived from the
// binary tree: BVH::Collapse chooses which binary nodes each wide node
// gathers, for the least SAH cost of the whole layout (Ylitie, Karras and
// Laine 2017), and BVH::collapse_all writes the wide nodes in depth-first
// pre-order, the subtrees below the top levels in parallel.
#pragma once
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>
#include "prism/accel/bvh/build_support.hpp"
#include "prism/accel/bvh/node.hpp"
#include "prism/accel/bvh/tree.hpp"
#include "prism/math/bounds.hpp"

namespace prism {

// Which binary nodes become the slots of each wide node: the collapse with
// the least SAH cost (after Ylitie, Karras and Laine 2017, "Efficient
// incoherent ray traversal on GPUs through compressed wide BVHs"), found by
// dynamic programming over the binary tree. The binary leaves are kept
// whole, so every collapse has the same leaves and the SAH cost differs only
// in its wide nodes: the collapse minimises the sum of the wide nodes' box
// areas (the expected visits of a ray), whatever a visit costs. Of covers
// with equal cost, the one with fewer wide nodes wins: all costs tie when
// the boxes have no area, and the wide nodes should still be full then.
class BVH::Collapse {
 public:
  // The costs of every binary node: subtrees below binary depth 8 in
  // parallel, then the top. (m_cost, 84 bytes per binary node with 8-wide
  // nodes and 164 with 16-wide ones, is written only there: a zeroed vector
  // in 4 KiB pages cost 3-38 ms of faults alone, slivers scene, 167k nodes,
  // on a VM.)
  Collapse(const std::vector<BVHNode>& nodes, int threads)
      : m_nodes(nodes), m_cost(detail::make_huge_array<Cost>(nodes.size())) {
    constexpr int cost_levels = 8;
    std::vector<uint32_t> roots;
    fill(0, 0, cost_levels, &roots);
    detail::parallel_items(roots.size(), threads, [&](size_t i) { fill(roots[i], 0, -1, nullptr); });
    fill(0, 0, cost_levels, nullptr);
  }
  // The slots of the wide node for binary node `bin`, in lane order.
  int children(uint32_t bin, uint32_t* kids) const {
    if (m_nodes[bin].is_leaf()) {
      kids[0] = bin;  // only for a tree that is a single leaf
      return 1;
    }
    int first = m_cost[bin].own_first;
    int k = 0;
    cover(bin + 1, first, kids, k);
    cover(m_nodes[bin].offset, detail::wide_width - first, kids, k);
    return k;
  }

 private:
  // For binary node n and j = 1..W, cost[j - 1] is the least sum of the
  // wide nodes' areas in a cover of n's subtree by at most j slots of a
  // wide node, with nodes[j - 1] wide nodes; the cover gives first[j - 1]
  // slots to n's first child and second[j - 1] to its second (first[j - 1]
  // == 0: n itself is one slot, a leaf or a wide node of its own). When n
  // is a wide node of its own, own_first of its W slots go to its first child.
  struct Cost {
    Float cost[detail::wide_width];
    uint32_t nodes[detail::wide_width];
    uint8_t first[detail::wide_width], second[detail::wide_width];
    uint8_t own_first;
  };
  struct Cover {
    Float cost;
    uint32_t nodes;
    bool operator<(const Cover& o) const { return cost < o.cost || (cost == o.cost && nodes < o.nodes); }
  };

  // The best split of `slots` slots between the two children of interior
  // node n (each child gets at least one; the first of equal covers wins).
  std::pair<int, Cover> best_split(uint32_t n, int slots) const {
    const Cost& a = m_cost[n + 1];
    const Cost& b = m_cost[m_nodes[n].offset];
    int best = 1;
    Cover best_cover{infinity, UINT32_MAX};
    for (int k = 1; k < slots; ++k) {
      Cover c{a.cost[k - 1] + b.cost[slots - k - 1], a.nodes[k - 1] + b.nodes[slots - k - 1]};
      if (c < best_cover) {
        best_cover = c;
        best = k;
      }
    }
    return {best, best_cover};
  }
  // Fills m_cost[n] from its children's entries.
  void cost_of(uint32_t n) {
    constexpr int W = detail::wide_width;
    const BVHNode& nd = m_nodes[n];
    Cost& cc = m_cost[n];
    if (nd.is_leaf()) {
      for (int j = 0; j < W; ++j) {
        cc.cost[j] = 0;
        cc.nodes[j] = 0;
        cc.first[j] = cc.second[j] = 0;
      }
      cc.own_first = 0;
      return;
    }
    // One slot: n as a wide node, whose own W slots are split between its children.
    auto [own_first, own] = best_split(n, W);
    cc.own_first = uint8_t(own_first);
    cc.cost[0] = nd.bounds().surface_area() + own.cost;
    cc.nodes[0] = own.nodes + 1;
    cc.first[0] = cc.second[0] = 0;
    for (int j = 2; j <= W; ++j) {
      auto [k, c] = j == W ? std::pair<int, Cover>{own_first, own} : best_split(n, j);
      if (c < Cover{cc.cost[j - 2], cc.nodes[j - 2]}) {
        cc.cost[j - 1] = c.cost;
        cc.nodes[j - 1] = c.nodes;
        cc.first[j - 1] = uint8_t(k);
        cc.second[j - 1] = uint8_t(j - k);
      } else {  // fewer slots do as well
        cc.cost[j - 1] = cc.cost[j - 2];
        cc.nodes[j - 1] = cc.nodes[j - 2];
        cc.first[j - 1] = cc.first[j - 2];
        cc.second[j - 1] = cc.second[j - 2];
      }
    }
  }
  // Fills m_cost for the subtree of n, children first, down to binary depth
  // `stop`, where a frontier node goes to `frontier` (if given) or is taken
  // as filled already.
  void fill(uint32_t n, int depth, int stop, std::vector<uint32_t>* frontier) {
    if (depth == stop) {
      if (frontier) frontier->push_back(n);
      return;
    }
    if (!m_nodes[n].is_leaf()) {
      fill(n + 1, depth + 1, stop, frontier);
      fill(m_nodes[n].offset, depth + 1, stop, frontier);
    }
    if (!frontier) cost_of(n);
  }
  // Appends the slots of the best cover of n's subtree by at most j slots.
  void cover(uint32_t n, int j, uint32_t* kids, int& k) const {
    const Cost& cc = m_cost[n];
    if (cc.first[j - 1] == 0) {
      kids[k++] = n;
      return;
    }
    cover(n + 1, cc.first[j - 1], kids, k);
    cover(m_nodes[n].offset, cc.second[j - 1], kids, k);
  }

  const std::vector<BVHNode>& m_nodes;
  std::unique_ptr<Cost[]> m_cost;
};

// Derives the wide layout from the binary tree. The wide node of binary
// node `bin` is followed by the wide subtrees of its inner children, in lane
// order (depth-first pre-order). The subtrees below the top `top_levels`
// wide levels are sized, and later written into their own index ranges, in
// parallel; the top is sized and written by this thread. The layout does not
// depend on the thread count.
inline void BVH::collapse_all(int threads) {
  m_wide.clear();
  if (m_nodes.empty()) return;
  const Collapse plan(m_nodes, threads);
  constexpr int top_levels = 3;
  // Wide nodes in the subtree of a wide root, by binary index (written by
  // wide_size before it is read, so not zeroed first).
  detail::fill_later_vector<uint32_t> size(m_nodes.size());
  std::vector<uint32_t> frontier;
  wide_size(plan, 0, 0, top_levels, size, &frontier);  // only gathers the frontier
  detail::parallel_items(frontier.size(), threads,
                         [&](size_t i) { wide_size(plan, frontier[i], 0, -1, size, nullptr); });
  uint32_t total = wide_size(plan, 0, 0, top_levels, size, nullptr);
  detail::reserve_huge(m_wide, total);
  m_wide.resize(total);
  std::vector<std::pair<uint32_t, uint32_t>> jobs;  // (binary node, wide index) at the frontier
  write_wide(plan, 0, 0, 0, top_levels, size, &jobs);
  detail::parallel_items(jobs.size(), threads, [&](size_t i) {
    write_wide(plan, jobs[i].first, jobs[i].second, 0, -1, size, nullptr);
  });
}
// The number of wide nodes under wide root `bin`, stored in size[bin]. At
// wide depth `stop` it stops: a frontier root is appended to `frontier`
// when given, and its stored size is used.
inline uint32_t BVH::wide_size(const Collapse& plan, uint32_t bin, int depth, int stop,
                               detail::fill_later_vector<uint32_t>& size, std::vector<uint32_t>* frontier) const {
  if (depth == stop) {
    if (!frontier) return size[bin];
    frontier->push_back(bin);  // (not sized yet: the sizes above it are discarded)
    return 0;
  }
  uint32_t kids[detail::wide_width];
  int k = plan.children(bin, kids);
  uint32_t total = 1;
  for (int l = 0; l < k; ++l)
    if (!m_nodes[kids[l]].is_leaf()) total += wide_size(plan, kids[l], depth + 1, stop, size, frontier);
  size[bin] = total;
  return total;
}
// Writes the wide node of `bin` at index w and its subtree after it, down to
// wide depth `stop`, where the frontier's (root, index) pairs go to `jobs`.
inline void BVH::write_wide(const Collapse& plan, uint32_t bin, uint32_t w, int depth, int stop,
                            const detail::fill_later_vector<uint32_t>& size,
                            std::vector<std::pair<uint32_t, uint32_t>>* jobs) {
  if (depth == stop) {
    jobs->emplace_back(bin, w);
    return;
  }
  constexpr int W = detail::wide_width;
  uint32_t kids[W];
  int k = plan.children(bin, kids);
  Bounds3f boxes[W];
  for (int l = 0; l < k; ++l) boxes[l] = m_nodes[kids[l]].bounds();
  detail::BVHWideNode node{};  // unused lanes: child 0, count 0
  detail::set_boxes(node, boxes, k);
  uint32_t next = w + 1;
  for (int l = 0; l < k; ++l) {
    const BVHNode& c = m_nodes[kids[l]];
    if (c.is_leaf()) {
      node.child[l] = c.offset;
      node.count[l] = c.count;
    } else {
      node.child[l] = next;
      node.count[l] = detail::BVHWideNode::interior;
      write_wide(plan, kids[l], next, depth + 1, stop, size, jobs);
      next += size[kids[l]];
    }
  }
  m_wide[w] = node;
}

}  // namespace prism
