// prism/lights/bvh_sampler.hpp — chooses a light for a receiving point from a
// binary tree over the lights' LightBounds (Conty Estevez & Kulla 2018; the
// pbrt-v4 book, section 12.6.3, builds the same kind of tree).
//
// sample(ctx, u) descends from the root, at each node choosing a child with
// probability proportional to its importance for ctx (LightBounds::
// importance), and returns the leaf's light with the product of the choices.
// pmf(ctx, i) retraces light i's path, kept as a bit trail per light (bit k:
// the child taken at depth k), and multiplies the same probabilities, so that
// pmf(ctx, sample(ctx, u).index) equals the returned pmf to the last bit.
//
// Lights without bounds (environments, sun, distant lights) sit outside the
// tree: with k of them, each is chosen with probability 1 / (k + 1) and the
// tree with the remaining 1 / (k + 1), as pbrt-v4 does (all k / k when there
// is no tree). Bounded lights of zero power are never chosen.
//
// The tree is built top-down, one light per leaf; each split is the one of 12
// buckets per axis of the centroids that minimises the summed cost of the two
// sides, a surface-area heuristic weighted by power and by the solid angle of
// the orientation cone (pbrt-v4's cost, with its penalty on thin boxes).
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>
#include "prism/error.hpp"
#include "prism/lights/light.hpp"
#include "prism/lights/light_bounds.hpp"
#include "prism/lights/light_sampler.hpp"

namespace prism {

class BVHLightSampler {
 public:
  BVHLightSampler() = default;
  // bounds[i]: light i's bounds, nullopt for a light without (an infinite one).
  explicit BVHLightSampler(std::span<const std::optional<LightBounds>> bounds) : m_count(uint32_t(bounds.size())) {
    m_trail.assign(bounds.size(), 0);
    m_in_tree.assign(bounds.size(), 0);
    std::vector<Item> items;
    for (size_t i = 0; i < bounds.size(); ++i) {
      if (!bounds[i]) {
        m_in_tree[i] = 2;
        m_infinite.push_back(uint32_t(i));
        continue;
      }
      const LightBounds& b = *bounds[i];
      if (!(b.phi > 0) || !std::isfinite(b.phi) || b.bounds.empty() || b.bounds.min.has_nan() ||
          b.bounds.max.has_nan())
        continue;
      items.push_back({b, uint32_t(i)});
    }
    if (!items.empty()) {
      m_nodes.reserve(2 * items.size());
      build(items, 0, items.size(), 0, 0);
    }
    size_t k = m_infinite.size();
    m_p_infinite = k == 0 ? 0 : Float(k) / Float(k + (m_nodes.empty() ? 0 : 1));
  }

  size_t size() const { return m_count; }
  size_t node_count() const { return m_nodes.size(); }
  // The probability of choosing among the unbounded lights.
  Float infinite_probability() const { return m_p_infinite; }

  std::optional<SampledLight> sample(const LightSampleContext& ctx, Float u) const {
    const Point3f& p = ctx.p;
    const Normal3f& n = ctx.ns;
    if (u < m_p_infinite) {
      size_t k = m_infinite.size();
      size_t i = std::min(size_t(u / m_p_infinite * Float(k)), k - 1);
      return SampledLight{m_infinite[i], m_p_infinite / Float(k)};
    }
    if (m_nodes.empty()) return std::nullopt;
    u = std::min((u - m_p_infinite) / (1 - m_p_infinite), one_minus_epsilon);
    Float pmf = 1 - m_p_infinite;
    uint32_t node = 0;
    if (m_nodes[0].leaf) {
      if (!(m_nodes[0].bounds.importance(p, n) > 0)) return std::nullopt;
      return SampledLight{m_nodes[0].index, pmf};
    }
    for (;;) {
      const Node& nd = m_nodes[node];
      if (nd.leaf) return SampledLight{nd.index, pmf};
      Float p0;
      if (!child_probability(nd, node, p, n, &p0)) return std::nullopt;
      if (u < p0) {
        u = std::min(u / p0, one_minus_epsilon);
        pmf *= p0;
        node = node + 1;
      } else {
        u = std::min((u - p0) / (1 - p0), one_minus_epsilon);
        pmf *= 1 - p0;
        node = nd.index;
      }
    }
  }

  Float pmf(const LightSampleContext& ctx, uint32_t light) const {
    if (light >= m_count) return 0;
    if (m_in_tree[light] == 2) return m_p_infinite / Float(m_infinite.size());
    if (m_in_tree[light] == 0) return 0;
    const Point3f& p = ctx.p;
    const Normal3f& n = ctx.ns;
    Float pmf = 1 - m_p_infinite;
    if (m_nodes[0].leaf) return m_nodes[0].bounds.importance(p, n) > 0 ? pmf : 0;
    uint64_t trail = m_trail[light];
    uint32_t node = 0;
    for (;;) {
      const Node& nd = m_nodes[node];
      if (nd.leaf) return pmf;
      Float p0;
      if (!child_probability(nd, node, p, n, &p0)) return 0;
      if ((trail & 1) == 0) {
        pmf *= p0;
        node = node + 1;
      } else {
        pmf *= 1 - p0;
        node = nd.index;
      }
      trail >>= 1;
    }
  }

 private:
  static constexpr Float one_minus_epsilon = Float(0x1.fffffep-1);
  static constexpr int buckets = 12;
  // Past this depth, splits halve the lights by count so that bit trails fit 64 bits.
  static constexpr int max_sah_depth = 48;

  struct Item {
    LightBounds b;
    uint32_t light;
  };
  // An interior node's first child follows it; `index` is its second child.
  // A leaf's `index` is its light.
  struct Node {
    LightBounds bounds;
    uint32_t index = 0;
    bool leaf = false;
  };

  // The probability of the first child of interior node `node`; false when
  // neither child can light p.
  bool child_probability(const Node& nd, uint32_t node, const Point3f& p, const Normal3f& n, Float* p0) const {
    Float c0 = m_nodes[node + 1].bounds.importance(p, n);
    Float c1 = m_nodes[nd.index].bounds.importance(p, n);
    if (!std::isfinite(c0 + c1)) {  // an overflow: favour the infinite side(s) evenly
      c0 = std::isfinite(c0) ? 0 : 1;
      c1 = std::isfinite(c1) ? 0 : 1;
    }
    if (!(c0 + c1 > 0)) return false;
    *p0 = c0 / (c0 + c1);
    return true;
  }

  // The solid-angle measure of an orientation cone widened by theta_e, the
  // term of the split cost that favours grouping lights facing alike.
  static Float orientation_measure(const LightBounds& b) {
    Float theta_o = safe_acos(b.cos_theta_o), theta_e = safe_acos(b.cos_theta_e);
    Float theta_w = std::min(theta_o + theta_e, pi);
    Float sin_o = std::sin(theta_o);
    return 2 * pi * (1 - b.cos_theta_o) +
           pi / 2 * (2 * theta_w * sin_o - std::cos(theta_o - 2 * theta_w) - 2 * theta_o * sin_o + b.cos_theta_o);
  }
  static Float split_cost(const LightBounds& b, const Bounds3f& parent, int axis) {
    Vector3f d = parent.diagonal();
    Float extent = d[axis];
    Float max_extent = std::max({d.x, d.y, d.z});
    Float thinness = extent > 0 ? max_extent / extent : 1;
    return b.phi * orientation_measure(b) * thinness * b.bounds.surface_area();
  }

  // Builds the subtree of items[begin, end) at depth `depth`, whose lights'
  // bit trails start with `trail`; returns its node index.
  uint32_t build(std::vector<Item>& items, size_t begin, size_t end, int depth, uint64_t trail) {
    if (depth > 63) throw Error("light BVH: the tree is deeper than 64 levels");
    uint32_t index = uint32_t(m_nodes.size());
    if (end - begin == 1) {
      Node leaf;
      leaf.bounds = items[begin].b;
      leaf.index = items[begin].light;
      leaf.leaf = true;
      m_nodes.push_back(leaf);
      m_trail[items[begin].light] = trail;
      m_in_tree[items[begin].light] = 1;
      return index;
    }
    LightBounds all;
    Bounds3f centroids;
    for (size_t i = begin; i < end; ++i) {
      all = union_light_bounds(all, items[i].b);
      centroids = union_bounds(centroids, items[i].b.centroid());
    }
    size_t mid = begin + (end - begin) / 2;
    bool split_found = false;
    if (depth < max_sah_depth) {
      Float best = infinity;
      int best_axis = -1, best_bucket = -1;
      for (int axis = 0; axis < 3; ++axis) {
        Float lo = centroids.min[axis], hi = centroids.max[axis];
        if (!(hi > lo)) continue;
        std::array<LightBounds, buckets> bucket{};
        auto bucket_of = [&](const Item& it) {
          int b = int(Float(buckets) * (it.b.centroid()[axis] - lo) / (hi - lo));
          return std::clamp(b, 0, buckets - 1);
        };
        for (size_t i = begin; i < end; ++i) {
          int b = bucket_of(items[i]);
          bucket[size_t(b)] = union_light_bounds(bucket[size_t(b)], items[i].b);
        }
        // Costs of splitting after bucket k: prefix and suffix unions.
        std::array<LightBounds, buckets> below{}, above{};
        LightBounds acc;
        for (int k = 0; k < buckets; ++k) below[size_t(k)] = acc = union_light_bounds(acc, bucket[size_t(k)]);
        acc = LightBounds{};
        for (int k = buckets - 1; k >= 0; --k) above[size_t(k)] = acc = union_light_bounds(acc, bucket[size_t(k)]);
        for (int k = 0; k < buckets - 1; ++k) {
          if (!(below[size_t(k)].phi > 0) || !(above[size_t(k + 1)].phi > 0)) continue;
          Float cost = split_cost(below[size_t(k)], all.bounds, axis) + split_cost(above[size_t(k + 1)], all.bounds, axis);
          if (cost < best) {
            best = cost;
            best_axis = axis;
            best_bucket = k;
          }
        }
      }
      if (best_axis >= 0) {
        Float lo = centroids.min[best_axis], hi = centroids.max[best_axis];
        auto it = std::partition(items.begin() + std::ptrdiff_t(begin), items.begin() + std::ptrdiff_t(end),
                                 [&](const Item& item) {
                                   int b = int(Float(buckets) * (item.b.centroid()[best_axis] - lo) / (hi - lo));
                                   return std::clamp(b, 0, buckets - 1) <= best_bucket;
                                 });
        size_t m = size_t(it - items.begin());
        if (m > begin && m < end) {
          mid = m;
          split_found = true;
        }
      }
    }
    if (!split_found) {
      // Halve by count along the widest axis of the centroids.
      int axis = centroids.max_extent();
      std::nth_element(items.begin() + std::ptrdiff_t(begin), items.begin() + std::ptrdiff_t(mid),
                       items.begin() + std::ptrdiff_t(end), [axis](const Item& a, const Item& b) {
                         return a.b.centroid()[axis] < b.b.centroid()[axis];
                       });
    }
    Node node;
    node.bounds = all;
    m_nodes.push_back(node);
    build(items, begin, mid, depth + 1, trail);
    uint32_t second = build(items, mid, end, depth + 1, trail | (uint64_t(1) << depth));
    m_nodes[index].index = second;
    return index;
  }

  uint32_t m_count = 0;
  std::vector<Node> m_nodes;
  std::vector<uint64_t> m_trail;
  std::vector<uint8_t> m_in_tree;  // per light: 0 never chosen, 1 in the tree, 2 unbounded
  std::vector<uint32_t> m_infinite;
  Float m_p_infinite = 0;
};

}  // namespace prism
