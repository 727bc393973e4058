// prism/accel/bvh/binned_sah_builder.hpp — BVH::build: the binary tree by
// the binned surface-area heuristic (Wald 2007), all three axes binned in
// one SIMD pass over 32-byte primitive references, large ranges binned and
// subtrees built in parallel, laid out in an order that does not depend on
// the thread count; then the leaf order (padded to leaf blocks) and the
// collapse to wide nodes (collapse.hpp). Also BVH::from_binary_tree, the
// same last steps for a binary tree built elsewhere (accel/sbvh.hpp), with
// its check of that tree.
#pragma once
#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <future>
#include <memory>
#include <span>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>
#include "prism/accel/bvh/build_support.hpp"
#include "prism/accel/bvh/collapse.hpp"
#include "prism/accel/bvh/node.hpp"
#include "prism/accel/bvh/simd.hpp"
#include "prism/accel/bvh/tree.hpp"
#include "prism/error.hpp"
#include "prism/math/bounds.hpp"

namespace prism {

// A primitive during the build: its bounds and its input index, laid out
// for two 16-byte loads.
struct alignas(16) BVH::PrimRef {
  Float lo[3];
  uint32_t index;
  Float hi[3];
  uint32_t pad;
  static PrimRef make(const Bounds3f& b, uint32_t i) {
    return {{b.min.x, b.min.y, b.min.z}, i, {b.max.x, b.max.y, b.max.z}, 0};
  }
  Bounds3f bounds() const {
    Bounds3f b;
    b.min = {lo[0], lo[1], lo[2]};
    b.max = {hi[0], hi[1], hi[2]};
    return b;
  }
};

// A running union of boxes, with union_bounds' semantics: per component
// std::min(acc, v) and std::max(acc, v), so the first of equal values (and
// a NaN already in acc) is kept. minps(v, acc) is v < acc ? v : acc, which
// is std::min(acc, v); likewise for max.
struct BVH::BoxAcc {
#ifdef PRISM_BVH_SSE
  __m128 lo = _mm_set1_ps(infinity), hi = _mm_set1_ps(-infinity);
  void grow(__m128 l, __m128 h) {
    lo = _mm_min_ps(l, lo);
    hi = _mm_max_ps(h, hi);
  }
  void grow(const BoxAcc& b) { grow(b.lo, b.hi); }
  // Bounds3f::surface_area of a box that is not empty, from the registers:
  // 2 ((dx dy + dz dx) + dy dz), the same value (products commute).
  Float area() const {
    __m128 d = _mm_sub_ps(hi, lo);
    __m128 p = _mm_mul_ps(d, _mm_shuffle_ps(d, d, _MM_SHUFFLE(3, 0, 2, 1)));  // dx dy, dy dz, dz dx
    Float xy = _mm_cvtss_f32(p), yz = _mm_cvtss_f32(_mm_shuffle_ps(p, p, 1)),
          zx = _mm_cvtss_f32(_mm_shuffle_ps(p, p, 2));
    return 2 * ((xy + zx) + yz);
  }
  Bounds3f bounds() const {
    alignas(16) Float l[4], h[4];
    _mm_store_ps(l, lo);
    _mm_store_ps(h, hi);
    Bounds3f b;
    b.min = {l[0], l[1], l[2]};
    b.max = {h[0], h[1], h[2]};
    return b;
  }
#else
  Bounds3f box;
  void grow(const Bounds3f& b) { box = union_bounds(box, b); }
  void grow(const BoxAcc& b) { grow(b.box); }
  Float area() const { return box.surface_area(); }
  Bounds3f bounds() const { return box; }
#endif
};

// Top-down binned SAH. Each call appends its subtree to `out` in depth-first
// order (interior offsets index `out`); subtrees built by other threads go to
// their own arrays and are appended in a fixed order, so the layout does not
// depend on the thread count or timing.
struct BVH::Builder {
  const BVHBuildOptions& opt;
  int threads;
  std::unique_ptr<PrimRef[]> refs;
  std::atomic<int> active{1};  // threads doing build work
  static constexpr int bin_count = 16;
  static constexpr uint32_t parallel_threshold = 16 * 1024;
  static constexpr uint32_t parallel_binning_threshold = 256 * 1024;

  // Past this depth the builder halves ranges instead of using the SAH, so
  // traversal stacks (max_sah_depth + 32 entries) never overflow.
  static constexpr int max_sah_depth = 48;

  Builder(const BVHBuildOptions& o, int t)
      : opt(o), threads(t), block(uint32_t(std::max(1, o.leaf_block))), max_leaf(uint32_t(o.leaf_size_limit())) {
    if (std::has_single_bit(block)) block_shift = std::countr_zero(block);
  }
  uint32_t block;
  uint32_t max_leaf;  // opt.leaf_size_limit(), resolved once
  int block_shift = -1;  // log2(block) when block is a power of two
  // The cost of testing n primitives: the blocks they fill. (A division per
  // SAH candidate otherwise; leaf blocks are powers of two in practice.)
  Float blocks(uint32_t n) const {
    return Float(block_shift >= 0 ? (n + block - 1) >> block_shift : (n + block - 1) / block);
  }

  // The bin of centroid coordinate c: std::min(bin_count - 1, int((c - lo) * k)),
  // with NaN (from infinite bounds) in bin 0 rather than undefined.
  static int bin_of(Float c, Float lo, Float k) {
    Float x = (c - lo) * k;
    return x >= 0 ? std::min(bin_count - 1, int(std::min(x, Float(bin_count)))) : 0;
  }

  static Bounds3f centroid_bounds(const PrimRef* r, uint32_t begin, uint32_t end, Bounds3f* bb) {
    Bounds3f b, cb;
    for (uint32_t i = begin; i < end; ++i) {
      Bounds3f pb = r[i].bounds();
      b = union_bounds(b, pb);
      cb = union_bounds(cb, pb.centroid());
    }
    *bb = b;
    return cb;
  }

  // A side of a partition: the bounds of its references and of their centroids.
  struct Side {
    BoxAcc box, cen;
  };
  // Moves the references whose centroid falls in bins 0..split of axis a
  // (the bin bins_of / bin_of computes from lo and k) before the others,
  // with the swap sequence of libstdc++'s std::partition, and gathers each
  // side's bounds from the references it ends up with (so that they bound
  // them whatever the bins held: the bins' arithmetic may be contracted
  // differently); returns the first reference of the right side. A function
  // of its own with every constant in a local: as a lambda that captured
  // them by reference it was called per reference, reloading them (16% of
  // a 2-thread build's samples).
  static PrimRef* partition_by_bin(PrimRef* first, PrimRef* last, int a, Float lo, Float k, int split, Side& ls,
                                   Side& rs) {
#ifdef PRISM_BVH_SSE
    // Lane a of bins_of's arithmetic, in scalar: the same sum, product and
    // truncation (cvttss2si, like cvttps2dq, gives INT_MIN for NaN and out
    // of range values, which go to bin 0).
    auto left = [a, lo, k, split](const PrimRef& p) {
      int bi = _mm_cvttss_si32(_mm_set_ss(((p.lo[a] + p.hi[a]) * 0.5f - lo) * k));
      bi = bi > -1 ? bi : 0;
      return std::min(bi, bin_count - 1) <= split;
    };
    const __m128 half = _mm_set1_ps(0.5f), xyz = _mm_castsi128_ps(_mm_setr_epi32(-1, -1, -1, 0));
    // (Each side's four accumulators in registers, not in the Side.)
    __m128 lbl = ls.box.lo, lbh = ls.box.hi, lcl = ls.cen.lo, lch = ls.cen.hi;
    __m128 rbl = rs.box.lo, rbh = rs.box.hi, rcl = rs.cen.lo, rch = rs.cen.hi;
    auto grow = [half, xyz](const PrimRef& p, __m128& bl, __m128& bh, __m128& cl, __m128& ch) {
      __m128 l = _mm_and_ps(_mm_load_ps(p.lo), xyz), h = _mm_and_ps(_mm_load_ps(p.hi), xyz);
      __m128 c = _mm_mul_ps(_mm_add_ps(l, h), half);
      bl = _mm_min_ps(l, bl);
      bh = _mm_max_ps(h, bh);
      cl = _mm_min_ps(c, cl);
      ch = _mm_max_ps(c, ch);
    };
    auto grow_left = [&](const PrimRef& p) { grow(p, lbl, lbh, lcl, lch); };
    auto grow_right = [&](const PrimRef& p) { grow(p, rbl, rbh, rcl, rch); };
#else
    // (The centroid's coordinate a as Bounds3f::centroid computes it.)
    auto left = [a, lo, k, split](const PrimRef& p) { return bin_of((p.lo[a] + p.hi[a]) * 0.5f, lo, k) <= split; };
    auto grow = [](const PrimRef& p, Side& s) {
      Bounds3f b = p.bounds();
      s.box.grow(b);
      s.cen.grow(Bounds3f(b.centroid()));
    };
    auto grow_left = [&](const PrimRef& p) { grow(p, ls); };
    auto grow_right = [&](const PrimRef& p) { grow(p, rs); };
#endif
    for (;;) {
      for (;;) {
        if (first == last) goto partitioned;
        if (!left(*first)) break;
        grow_left(*first);
        ++first;
      }
      grow_right(*first);
      --last;
      for (;;) {
        if (first == last) goto partitioned;
        if (left(*last)) break;
        grow_right(*last);
        --last;
      }
      grow_left(*last);
      std::swap(*first, *last);
      ++first;
    }
  partitioned:
#ifdef PRISM_BVH_SSE
    ls.box = {lbl, lbh};
    ls.cen = {lcl, lch};
    rs.box = {rbl, rbh};
    rs.cen = {rcl, rch};
#endif
    return first;
  }

  // bb and cb bound the primitives of [begin, end) and their centroids.
  void build_range(uint32_t begin, uint32_t end, int depth, const Bounds3f& bb, const Bounds3f& cb,
                   std::vector<BVHNode>& out) {
    uint32_t idx = uint32_t(out.size());
    out.emplace_back();
    for (int i = 0; i < 3; ++i) {
      out[idx].bmin[i] = bb.min[i];
      out[idx].bmax[i] = bb.max[i];
    }
    uint32_t n = end - begin;
    auto make_leaf = [&] {
      out[idx].offset = begin;
      out[idx].count = n;
    };
    if (n == 1) return make_leaf();
    // A range that fits one block is a leaf whatever the bins say: a leaf
    // costs blocks(n) = 1 and a split at least traversal_cost + (A_l + A_r)
    // / A >= 1 (and the ties, NaN costs and centroids that coincide all
    // end in a leaf below too). Half of all nodes are such leaves, so
    // binning them was a large part of the build.
    if (n <= block && n <= max_leaf && opt.traversal_cost >= 1) return make_leaf();
    PrimRef* r = refs.get();
    Bounds3f lb, lc, rb, rc;  // children's bounds and centroid bounds
    uint32_t mid;
    if (depth >= max_sah_depth) {
      if (n <= max_leaf) return make_leaf();
      mid = begin + n / 2;
      lc = centroid_bounds(r, begin, mid, &lb);
      rc = centroid_bounds(r, mid, end, &rb);
    } else {
      // Bin centroids along each axis and evaluate the SAH at every bin
      // boundary, all axes in one pass over the primitives.
      Float lo[3] = {}, k[3] = {};
      bool active_axis[3] = {};
      for (int a = 0; a < 3; ++a) {
        lo[a] = cb.min[a];
        active_axis[a] = cb.max[a] > lo[a];
        k[a] = active_axis[a] ? Float(bin_count) * (1 - 1e-6f) / (cb.max[a] - lo[a]) : 0;
        // A spread below 16 / FLT_MAX overflows the bin scale: skip the axis.
        if (!std::isfinite(k[a])) {
          active_axis[a] = false;
          k[a] = 0;
        }
      }
      BoxAcc bin_b[3][bin_count];
      uint32_t bin_n[3][bin_count] = {};
#ifdef PRISM_BVH_SSE
      const __m128 lo4 = _mm_setr_ps(lo[0], lo[1], lo[2], 0), k4 = _mm_setr_ps(k[0], k[1], k[2], 0);
      const __m128 half = _mm_set1_ps(0.5f);
      const __m128i last_bin = _mm_set1_epi32(bin_count - 1);
      // A primitive's bounds l, h (lane 3, which holds the index and padding,
      // cleared so that no arithmetic sees their bits as slow denormals), its
      // centroid c and its bins in lanes 0-2, bin_of's values.
      const __m128 xyz = _mm_castsi128_ps(_mm_setr_epi32(-1, -1, -1, 0));
      auto bins_of = [&](const PrimRef& p, __m128& l, __m128& h, __m128& c) {
        l = _mm_and_ps(_mm_load_ps(p.lo), xyz);
        h = _mm_and_ps(_mm_load_ps(p.hi), xyz);
        c = _mm_mul_ps(_mm_add_ps(l, h), half);
        // (c - lo) * k >= 0 for finite bounds; NaN (from infinite bounds)
        // converts to INT_MIN, which is clamped to bin 0.
        __m128i bi = _mm_cvttps_epi32(_mm_mul_ps(_mm_sub_ps(c, lo4), k4));
        bi = _mm_and_si128(bi, _mm_cmpgt_epi32(bi, _mm_set1_epi32(-1)));
        __m128i lt = _mm_cmplt_epi32(bi, last_bin);
        return _mm_or_si128(_mm_and_si128(lt, bi), _mm_andnot_si128(lt, last_bin));
      };
#endif
      // Adds the primitives of [b0, e0) to the bins bb, bn.
      auto bin_range = [&](uint32_t b0, uint32_t e0, BoxAcc (*bb)[bin_count], uint32_t (*bn)[bin_count]) {
#ifdef PRISM_BVH_SSE
        // Adds reference p to the bins bb, bn of the active axes (of all
        // three when all_axes: the usual case, without the test).
        auto add = [&]<bool all_axes>(std::bool_constant<all_axes>, const PrimRef& p, BoxAcc(*to_b)[bin_count],
                                      uint32_t(*to_n)[bin_count]) {
          __m128 l, h, c;
          alignas(16) int bi[4];
          _mm_store_si128(reinterpret_cast<__m128i*>(bi), bins_of(p, l, h, c));
          for (int a = 0; a < 3; ++a) {
            if (!all_axes && !active_axis[a]) continue;
            ++to_n[a][bi[a]];
            to_b[a][bi[a]].grow(l, h);
          }
        };
        constexpr std::true_type all3{};
        if (!(active_axis[0] && active_axis[1] && active_axis[2])) {
          for (uint32_t i = b0; i < e0; ++i) add(std::false_type{}, r[i], bb, bn);
        } else if (e0 - b0 < 256) {
          for (uint32_t i = b0; i < e0; ++i) add(all3, r[i], bb, bn);
        } else {
          // Consecutive references mostly fall in the same bins, so each
          // bin's update waits on the one before through memory: two sets
          // of bins, for the even and odd references, halve that chain.
          BoxAcc ob[3][bin_count];
          uint32_t on[3][bin_count] = {};
          uint32_t i = b0;
          for (; i + 1 < e0; i += 2) {
            add(all3, r[i], bb, bn);
            add(all3, r[i + 1], ob, on);
          }
          if (i < e0) add(all3, r[i], bb, bn);
          for (int a = 0; a < 3; ++a)
            for (int j = 0; j < bin_count; ++j) {
              bn[a][j] += on[a][j];
              bb[a][j].grow(ob[a][j]);
            }
        }
#else
        for (uint32_t i = b0; i < e0; ++i) {
          Bounds3f b = r[i].bounds();
          Point3f c = b.centroid();
          for (int a = 0; a < 3; ++a) {
            if (!active_axis[a]) continue;
            int bi = bin_of(c[a], lo[a], k[a]);
            ++bn[a][bi];
            bb[a][bi].grow(b);
          }
        }
#endif
      };
      if (n >= parallel_binning_threshold) {
        // Large ranges (the top levels) are binned in a fixed number of
        // chunks on the threads that are idle, and the chunks' bins merged in
        // order: the bins do not depend on the thread count.
        constexpr int chunks = 8;
        struct Bins {
          BoxAcc b[3][bin_count];
          uint32_t n[3][bin_count] = {};
        };
        std::vector<Bins> part(chunks);
        int idle = std::max(1, threads - active.load() + 1);
        detail::parallel_items(chunks, idle, [&](size_t c) {
          bin_range(begin + uint32_t(uint64_t(n) * c / chunks), begin + uint32_t(uint64_t(n) * (c + 1) / chunks),
                    part[c].b, part[c].n);
        });
        for (int c = 0; c < chunks; ++c)
          for (int a = 0; a < 3; ++a)
            for (int i = 0; i < bin_count; ++i) {
              bin_n[a][i] += part[size_t(c)].n[a][i];
              bin_b[a][i].grow(part[size_t(c)].b[a][i]);
            }
      } else {
        bin_range(begin, end, bin_b, bin_n);
      }
      // The SAH at every bin boundary with primitives on both sides, without
      // branches on the bins' contents (which bins are empty is data, and
      // mispredicting it cost more than the sweep): an empty bin's box
      // (+inf, -inf) leaves a running union as it is, and a boundary after
      // an empty bin costs exactly what the one before it does, so the
      // first of equal costs still wins.
      int best_axis = -1, best_split = 0;
      Float best_cost = infinity;
      for (int a = 0; a < 3; ++a) {
        if (!active_axis[a]) continue;
        Float right_cost[bin_count];
        uint32_t right_n[bin_count];
        BoxAcc acc;
        uint32_t acc_n = 0;
        for (int i = bin_count - 1; i > 0; --i) {
          acc.grow(bin_b[a][i]);
          acc_n += bin_n[a][i];
          right_cost[i] = blocks(acc_n) * acc.area();  // used only where acc_n != 0
          right_n[i] = acc_n;
        }
        acc = BoxAcc{};
        acc_n = 0;
        for (int i = 0; i < bin_count - 1; ++i) {
          acc.grow(bin_b[a][i]);
          acc_n += bin_n[a][i];
          Float cost = blocks(acc_n) * acc.area() + right_cost[i + 1];
          bool better = acc_n != 0 && right_n[i + 1] != 0 && cost < best_cost;
          best_cost = better ? cost : best_cost;
          best_axis = better ? a : best_axis;
          best_split = better ? i : best_split;
        }
      }

      Float area = bb.surface_area();
      Float leaf_cost = blocks(n);
      Float split_cost = opt.traversal_cost + (area > 0 ? best_cost / area : blocks(n));
      if (best_axis < 0) {
        // All centroids coincide: split in the middle if the leaf would be too big.
        if (n <= max_leaf) return make_leaf();
        mid = begin + n / 2;
        lc = centroid_bounds(r, begin, mid, &lb);
        rc = centroid_bounds(r, mid, end, &rb);
      } else {
        if (n <= max_leaf && leaf_cost <= split_cost) return make_leaf();
        int a = best_axis;
        Side ls, rs;
        PrimRef* first = partition_by_bin(r + begin, r + end, a, lo[a], k[a], best_split, ls, rs);
        mid = uint32_t(first - r);
        lb = ls.box.bounds();
        rb = rs.box.bounds();
        lc = ls.cen.bounds();
        rc = rs.cen.bounds();
        if (mid == begin || mid == end) {
          mid = begin + n / 2;
          lc = centroid_bounds(r, begin, mid, &lb);
          rc = centroid_bounds(r, mid, end, &rb);
        }
      }
    }

    if (n >= parallel_threshold && active.fetch_add(1) < threads) {
      // The right subtree on a new thread, into its own array; the left one
      // here, in place.
      std::vector<BVHNode> right;
      auto task = std::async(std::launch::async, [&, mid, end, depth] {
        detail::reserve_huge(right, 2 * size_t(end - mid));
        build_range(mid, end, depth + 1, rb, rc, right);
        --active;
      });
      build_range(begin, mid, depth + 1, lb, lc, out);
      --active;  // idle while waiting
      task.get();
      ++active;
      out[idx].offset = uint32_t(out.size());
      append(right, out);
    } else {
      if (n >= parallel_threshold) --active;
      build_range(begin, mid, depth + 1, lb, lc, out);
      out[idx].offset = uint32_t(out.size());
      build_range(mid, end, depth + 1, rb, rc, out);
    }
  }

  // Appends a subtree built in its own array, rebasing its interior offsets.
  static void append(const std::vector<BVHNode>& sub, std::vector<BVHNode>& out) {
    uint32_t base = uint32_t(out.size());
    out.insert(out.end(), sub.begin(), sub.end());
    for (size_t i = base; i < out.size(); ++i)
      if (!out[i].is_leaf()) out[i].offset += base;
  }
};

inline BVH BVH::build(std::span<const Bounds3f> prim_bounds, const BVHBuildOptions& opt) {
  return build(prim_bounds.size(), [prim_bounds](size_t i) { return prim_bounds[i]; }, opt);
}

template <class BoundsOf>
  requires std::is_invocable_r_v<Bounds3f, BoundsOf&, size_t>
inline BVH BVH::build(size_t n, BoundsOf&& bounds_of, const BVHBuildOptions& opt) {
  BVH bvh;
  if (n == 0) return bvh;
  int threads = detail::build_threads(opt.threads);
  Builder b(opt, threads);
  b.refs = detail::make_huge_array<PrimRef>(n);  // written once, below
  // Primitive references and the root's bounds, in chunks merged in order
  // (min and max keep the first of equal values, as a sequential loop does).
  int chunks = detail::parallel_chunk_count(n, threads);
  std::vector<Bounds3f> chunk_bb(static_cast<size_t>(chunks)), chunk_cb(static_cast<size_t>(chunks));
  detail::parallel_chunks(n, chunks, [&](size_t begin, size_t end, int c) {
    Bounds3f bb, cb;
    for (size_t i = begin; i < end; ++i) {
      Bounds3f pb = bounds_of(i);
      b.refs[i] = PrimRef::make(pb, uint32_t(i));
      bb = union_bounds(bb, pb);
      cb = union_bounds(cb, pb.centroid());
    }
    chunk_bb[size_t(c)] = bb;
    chunk_cb[size_t(c)] = cb;
  });
  Bounds3f bb, cb;
  for (int c = 0; c < chunks; ++c) {
    bb = union_bounds(bb, chunk_bb[size_t(c)]);
    cb = union_bounds(cb, chunk_cb[size_t(c)]);
  }
  detail::reserve_huge(bvh.m_nodes, 2 * n - 1);
  b.build_range(0, uint32_t(n), 0, bb, cb, bvh.m_nodes);
  if (opt.leaf_block > 1) {
    bvh.pad_leaves([r = b.refs.get()](uint32_t k) { return r[k].index; }, uint32_t(opt.leaf_block), threads);
  } else {
    detail::reserve_huge(bvh.m_prims, n);
    bvh.m_prims.resize(n);
    detail::parallel_chunks(n, chunks, [&](size_t begin, size_t end, int) {
      for (size_t i = begin; i < end; ++i) bvh.m_prims[i] = b.refs[i].index;
    });
  }
  bvh.collapse_all(threads);
  bvh.m_bounds = bvh.m_nodes[0].bounds();
  if (!opt.keep_binary_tree) bvh.m_nodes = {};
  return bvh;
}

inline BVH BVH::from_binary_tree(std::vector<BVHNode> nodes, std::span<const uint32_t> leaf_prims,
                                 const BVHBuildOptions& opt) {
  BVH bvh;
  if (nodes.empty()) return bvh;
  check_tree(nodes, leaf_prims.size(), uint32_t(std::max(1, opt.leaf_block)));
  int threads = detail::build_threads(opt.threads);
  bvh.m_nodes = std::move(nodes);
  if (opt.leaf_block > 1) {
    bvh.pad_leaves([leaf_prims](uint32_t k) { return leaf_prims[k]; }, uint32_t(opt.leaf_block), threads);
  } else {
    bvh.m_prims.assign(leaf_prims.begin(), leaf_prims.end());
  }
  bvh.collapse_all(threads);
  bvh.m_bounds = bvh.m_nodes[0].bounds();
  if (!opt.keep_binary_tree) bvh.m_nodes = {};
  return bvh;
}

// from_binary_tree's check (see there).
inline void BVH::check_tree(const std::vector<BVHNode>& nodes, size_t prims, uint32_t block) {
  constexpr int max_depth = Builder::max_sah_depth + 32;
  auto fail = [](const std::string& what) { throw Error("BVH::from_binary_tree: " + what); };
  std::vector<uint8_t> seen(nodes.size(), 0), used(prims, 0);
  uint64_t padded = 0;  // the entries after pad_leaves, numbered in 32 bits
  std::vector<std::pair<uint32_t, int>> stack{{0u, 0}};
  size_t reached = 0;
  while (!stack.empty()) {
    auto [i, depth] = stack.back();
    stack.pop_back();
    if (i >= nodes.size()) fail("node index " + std::to_string(i) + " beyond " + std::to_string(nodes.size()) + " nodes");
    if (seen[i]) fail("node " + std::to_string(i) + " is reached twice");
    if (depth > max_depth) fail("deeper than " + std::to_string(max_depth) + " levels at node " + std::to_string(i));
    seen[i] = 1;
    ++reached;
    const BVHNode& nd = nodes[i];
    if (nd.is_leaf()) {
      if (uint64_t(nd.offset) + nd.count > prims)
        fail("leaf " + std::to_string(i) + " covers entries past the " + std::to_string(prims) + " given");
      for (uint64_t k = nd.offset; k < uint64_t(nd.offset) + nd.count; ++k) {
        if (used[k]) fail("entry " + std::to_string(k) + " is in two leaves (the second: node " + std::to_string(i) + ")");
        used[k] = 1;
      }
      padded += (uint64_t(nd.count) + block - 1) / block * block;
      if (padded > UINT32_MAX) fail("the leaves padded to blocks of " + std::to_string(block) + " hold more than 2^32 - 1 entries");
      continue;
    }
    stack.push_back({nd.offset, depth + 1});
    stack.push_back({i + 1, depth + 1});
  }
  if (reached != nodes.size()) fail(std::to_string(nodes.size() - reached) + " nodes are not in the tree");
  const size_t unused = size_t(std::count(used.begin(), used.end(), uint8_t(0)));
  if (unused != 0) fail(std::to_string(unused) + " of the " + std::to_string(prims) + " entries are in no leaf");
}

// Lays out prims() with every leaf starting at a multiple of `block` and
// padded to one by repeating its last primitive; rewrites the leaves'
// offsets. Done in fixed chunks of the node array: each chunk's leaves are
// sized, the sizes summed in order, then each chunk written at its offset.
template <class IndexOf>
inline void BVH::pad_leaves(IndexOf&& index_of, uint32_t block, int threads) {
  size_t nn = m_nodes.size();
  size_t chunks = nn < 64 * 1024 ? 1 : 16;
  auto range = [&](size_t c) { return std::pair(nn * c / chunks, nn * (c + 1) / chunks); };
  auto padded = [block](uint32_t count) { return (count + block - 1) / block * block; };
  std::vector<size_t> start(chunks + 1, 0);
  detail::parallel_items(chunks, threads, [&](size_t c) {
    auto [b, e] = range(c);
    size_t total = 0;
    for (size_t i = b; i < e; ++i)
      if (m_nodes[i].is_leaf()) total += padded(m_nodes[i].count);
    start[c + 1] = total;
  });
  for (size_t c = 0; c < chunks; ++c) start[c + 1] += start[c];
  detail::reserve_huge(m_prims, start[chunks]);
  m_prims.resize(start[chunks]);
  detail::parallel_items(chunks, threads, [&](size_t c) {
    auto [b, e] = range(c);
    uint32_t at = uint32_t(start[c]);
    for (size_t i = b; i < e; ++i) {
      BVHNode& nd = m_nodes[i];
      if (!nd.is_leaf()) continue;
      uint32_t n = padded(nd.count);
      for (uint32_t k = 0; k < n; ++k) m_prims[at + k] = index_of(nd.offset + std::min(k, nd.count - 1));
      nd.offset = at;
      at += n;
    }
  });
}

}  // namespace prism
