// The wide layout's collapse of the binary tree: its SAH cost (a wide node
// costs wide_node_cost times its box's area, a leaf its area times its blocks)
// is the least of all collapses, found here by enumerating every cover of
// every wide node's subtree; and every binary leaf appears under exactly one
// wide lane. Runs in every build (and with 4-wide nodes in the w4 variant).
#include "support/accel_variant.hpp"
#include <catch2/catch.hpp>

#include <algorithm>
#include <map>
#include <type_traits>
#include <vector>

#include "prism/accel/bvh.hpp"
#include "prism/sampling/pcg32.hpp"

#include "support/random.hpp"

namespace collapse_test {

using namespace prism;
using test::uniform;

namespace {

constexpr int W = detail::wide_width;

// Random boxes: clusters of small boxes and a few long ones, so that the
// binary tree is uneven and the best collapse is not the obvious one.
std::vector<Bounds3f> random_boxes(PCG32& rng, int n) {
  std::vector<Bounds3f> boxes;
  Point3f centre;
  for (int i = 0; i < n; ++i) {
    if (i % 7 == 0) centre = {uniform(rng, -10, 10), uniform(rng, -10, 10), uniform(rng, -10, 10)};
    Float s = rng.next_float() < 0.1f ? 5 : Float(0.3);
    Point3f a{centre.x + uniform(rng, -1, 1), centre.y + uniform(rng, -1, 1), centre.z + uniform(rng, -1, 1)};
    Point3f b{a.x + uniform(rng, 0, s), a.y + uniform(rng, 0, s), a.z + uniform(rng, 0, s)};
    boxes.push_back(union_bounds(Bounds3f(a), b));
  }
  return boxes;
}

// The least sum of wide-node areas of any collapse, by enumeration: a wide
// node for binary node n takes as its slots any cover of n's subtree below n
// (disjoint subtrees holding all of n's leaves) with at most W members; a slot
// that is an inner binary node is a wide node of its own.
struct BruteForce {
  const std::vector<BVHNode>& nodes;
  std::map<uint32_t, Float> memo;

  // Every cover of n's subtree (n itself included) with at most `limit` members.
  std::vector<std::vector<uint32_t>> covers(uint32_t n, int limit) const {
    std::vector<std::vector<uint32_t>> out{{n}};
    if (nodes[n].is_leaf() || limit < 2) return out;
    for (const auto& a : covers(n + 1, limit - 1))
      for (const auto& b : covers(nodes[n].offset, limit - int(a.size()))) {
        std::vector<uint32_t> c = a;
        c.insert(c.end(), b.begin(), b.end());
        out.push_back(std::move(c));
      }
    return out;
  }
  Float slot_cost(uint32_t n) { return nodes[n].is_leaf() ? 0 : wide_cost(n); }
  // The least sum of areas of n as a wide node and the wide nodes below it.
  Float wide_cost(uint32_t n) {
    if (auto it = memo.find(n); it != memo.end()) return it->second;
    Float best = infinity;
    for (const auto& a : covers(n + 1, W - 1))
      for (const auto& b : covers(nodes[n].offset, W - int(a.size()))) {
        Float c = 0;
        for (uint32_t s : a) c += slot_cost(s);
        for (uint32_t s : b) c += slot_cost(s);
        best = std::min(best, c);
      }
    best += nodes[n].bounds().surface_area();
    memo[n] = best;
    return best;
  }
};

using detail::lane_box;

// The sum of the built layout's wide-node areas, from its own nodes: the
// root's box (the binary root's) and every inner lane's box. Also counts the
// leaf lanes and the primitives they hold.
Float layout_cost(const BVH& bvh, size_t* leaf_lanes, size_t* leaf_prims) {
  Float cost = bvh.nodes()[0].bounds().surface_area();
  *leaf_lanes = *leaf_prims = 0;
  for (const auto& n : bvh.wide_nodes())
    for (int l = 0; l < W; ++l) {
      if (n.count[l] == 0) continue;  // an unused lane
      if (n.count[l] == detail::BVHWideNode::interior) {
        cost += lane_box(n, l).surface_area();
      } else {
        ++*leaf_lanes;
        *leaf_prims += n.count[l];
      }
    }
  return cost;
}

// The binary tree's leaves, inner nodes and the primitives in its leaves.
struct TreeCounts {
  size_t leaves = 0, inner = 0, prims = 0;
};
TreeCounts count_nodes(const std::vector<BVHNode>& nodes) {
  TreeCounts c;
  for (const auto& nd : nodes) {
    if (nd.is_leaf()) {
      ++c.leaves;
      c.prims += nd.count;
    } else {
      ++c.inner;
    }
  }
  return c;
}

}  // namespace

TEST_CASE("The wide layout is the collapse with the least SAH cost", "[accel][bvh][collapse]") {
  if constexpr (!std::is_same_v<detail::BVHWideNode, detail::BVHFloatWideNode>) {
    SUCCEED("quantized boxes are looser than the binary ones: the cost is checked on float nodes");
  } else {
    PCG32 rng(0x5eed, 17);
    int checked = 0;
    const int trials = test::accel_variant ? 5 : 12;  // n up to 120 or 260 boxes
    for (int trial = 0; trial < trials; ++trial) {
      int n = 40 + 20 * trial;
      std::vector<Bounds3f> boxes = random_boxes(rng, n);
      BVHBuildOptions opt;
      opt.max_leaf_size = 1 + trial % 4;
      opt.leaf_block = trial % 3 == 0 ? 4 : 1;
      opt.keep_binary_tree = true;
      BVH bvh = BVH::build(boxes, opt);
      const auto& nodes = bvh.nodes();
      if (nodes[0].is_leaf()) continue;
      BruteForce bf{nodes, {}};
      Float best = bf.wide_cost(0);
      size_t leaf_lanes = 0, leaf_prims = 0;
      Float got = layout_cost(bvh, &leaf_lanes, &leaf_prims);
      INFO("trial " << trial << ", " << n << " boxes, " << nodes.size() << " binary nodes, "
                    << bvh.wide_node_count() << " wide nodes");
      // Sums of the same terms in another order: a few ulps apart.
      CHECK(got == Approx(best).epsilon(1e-5));
      // Every binary leaf is one wide lane, holding all its primitives once.
      TreeCounts bin = count_nodes(nodes);
      CHECK(leaf_lanes == bin.leaves);
      CHECK(leaf_prims == bin.prims);
      ++checked;
    }
    CHECK(checked >= trials - 2);
  }
}

TEST_CASE("The collapse beats gathering the largest child first", "[accel][bvh][collapse]") {
  // The earlier collapse: a wide node's slots start as its binary children,
  // and the inner slot with the largest area is replaced by its children
  // until there are W. On an uneven tree the least-cost collapse is strictly
  // cheaper.
  PCG32 rng(0xc0ffee, 3);
  std::vector<Bounds3f> boxes = random_boxes(rng, 5000);
  BVHBuildOptions keep;
  keep.keep_binary_tree = true;
  BVH bvh = BVH::build(boxes, keep);
  const auto& nodes = bvh.nodes();
  std::vector<Float> greedy(nodes.size(), 0);
  // Reverse depth-first order meets children before parents.
  for (size_t i = nodes.size(); i-- > 0;) {
    if (nodes[i].is_leaf()) continue;
    std::vector<uint32_t> slots{uint32_t(i + 1), nodes[i].offset};
    for (;;) {
      int best = -1;
      Float best_area = -1;
      for (size_t s = 0; s < slots.size(); ++s)
        if (!nodes[slots[s]].is_leaf() && nodes[slots[s]].bounds().surface_area() > best_area) {
          best_area = nodes[slots[s]].bounds().surface_area();
          best = int(s);
        }
      if (best < 0 || int(slots.size()) == W) break;
      uint32_t c = slots[size_t(best)];
      slots[size_t(best)] = c + 1;
      slots.push_back(nodes[c].offset);
    }
    Float cost = nodes[i].bounds().surface_area();
    for (uint32_t s : slots) cost += greedy[s];
    greedy[i] = cost;
  }
  if constexpr (std::is_same_v<detail::BVHWideNode, detail::BVHFloatWideNode>) {
    size_t lanes = 0, prims = 0;
    Float got = layout_cost(bvh, &lanes, &prims);
    INFO("least-cost " << got << ", largest-first " << greedy[0]);
    CHECK(got < greedy[0] * (1 - 1e-4));
  } else {
    SUCCEED("quantized boxes are looser than the binary ones: the cost is checked on float nodes");
  }
}

TEST_CASE("Boxes without area still fill the wide nodes", "[accel][bvh][collapse]") {
  // Every collapse of point boxes costs 0; ties go to the cover with fewer
  // wide nodes, so the wide nodes are not left with two children each (about
  // half as many wide nodes as inner binary nodes).
  std::vector<Bounds3f> boxes(4000, Bounds3f(Point3f{1, 2, 3}));
  BVHBuildOptions keep;
  keep.keep_binary_tree = true;
  BVH bvh = BVH::build(boxes, keep);
  size_t inner = count_nodes(bvh.nodes()).inner;
  INFO(inner << " inner binary nodes, " << bvh.wide_node_count() << " wide nodes");
  REQUIRE(inner > 100);
  // A wide node takes in at most W - 1 inner binary nodes: the least count
  // is inner / (W - 1) rounded up; allow 5% over it.
  size_t least = (inner + W - 2) / (W - 1);
  CHECK(bvh.wide_node_count() <= least + inner / 20);
}

}  // namespace collapse_test
