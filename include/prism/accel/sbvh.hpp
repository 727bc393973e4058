// prism/accel/sbvh.hpp — a triangle BVH built with spatial splits (the SBVH
// of Stich, Friedrich & Dietrich 2009, "Spatial Splits in Bounding Volume
// Hierarchies"), for MeshAccel with BVHBuildOptions::spatial_splits.
//
// Pre-splitting (accel/presplit.hpp, the default) cuts long thin triangles
// once, before the build, where a heuristic expects it to pay. Here the
// builder itself may cut: at each node it weighs the best object split
// (binned SAH over the references' centroids, as BVH::build) against the
// best spatial split (a plane across the node's box; references that
// straddle it go to both sides, each with the box of the triangle's part on
// its side), and takes the cheaper by the SAH. Spatial splits are looked at
// only where the object split's two boxes overlap by more than
// spatial_alpha of the root's surface area, and they spend the extra
// references of split_budget (times the triangle count), shared between a
// node's children in proportion to their references, so the tree does not
// depend on the thread count.
//
// Conservative: every reference box holds the part of its triangle that lies
// in the reference's region (the whole space at first; a spatial split
// replaces a straddling reference's region by its intersection with each
// closed half-space), and the regions of a triangle's references cover it.
// A straddling reference's halves are made as split_triangle's restart does
// (accel/presplit.hpp): the triangle is clipped to the half's box with its six
// planes moved out by 5 h (h = clip_rounding times the triangle's largest
// coordinate per axis), and the half's box is the clipped polygon's box grown
// by 6 h and kept inside the half's box. So a ray that hits a triangle enters
// a leaf holding one of its references, and the hit (found by the exact test
// on the whole triangle) is the one a tree without splits finds.
//
// The build is serial below a few top levels, whose subtrees run on their
// own threads; slower than BVH::build (it bins the boxes of triangles' parts
// in slabs, and clips straddling references at the plane it takes), it pays
// where a scene is traced long enough: docs/performance.md has the
// measurements.
//
// A program asks for it by name: BVHBuildOptions::spatial_splits =
// prism::spatial_split_builder, declared here. Neither scene_accel.hpp nor
// prism/prism.hpp includes this header: every translation unit that builds
// a scene would compile the builder, about 15% more compile time for a
// feature that is off by default.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <future>
#include <vector>

#include "prism/accel/bvh.hpp"
#include "prism/accel/presplit.hpp"

namespace prism {
namespace detail {

template <class Vertices>
class SpatialSplitBuilder {
 public:
  // vertices(i, v) writes triangle i's three vertices to v[0..2].
  SpatialSplitBuilder(Vertices& vertices, const BVHBuildOptions& opt)
      : m_vertices(vertices), m_opt(opt), m_block(uint32_t(std::max(1, opt.leaf_block))) {}

  // From the n triangles, or from references already cut (pre-splitting:
  // `start`, whose boxes hold their triangles' parts in regions that cover
  // each triangle, as presplit_triangles makes them).
  SpatialBVH build(size_t n, const SplitReferences* start = nullptr, bool keep_reference_boxes = false) {
    SpatialBVH out;
    check_split_options(m_opt.split_budget, m_opt.split_threshold);
    check_spatial_alpha(m_opt.spatial_alpha);
    if (n == 0) return out;
    if (n > size_t(UINT32_MAX) / 2) throw Error("spatial splits: too many triangles (" + std::to_string(n) + ")");
    std::vector<Ref> refs;
    Bounds3f root;
    if (start && start->size() != 0) {
      refs.resize(start->size());
      for (size_t k = 0; k < refs.size(); ++k) {
        refs[k] = {start->bounds[k], start->triangle(k)};
        root = union_bounds(root, refs[k].box);
      }
    } else {
      refs.resize(n);
      for (size_t i = 0; i < n; ++i) {
        Point3f v[3];
        m_vertices(i, v);
        refs[i] = {triangle_box(v[0], v[1], v[2]), uint32_t(i)};
        root = union_bounds(root, refs[i].box);
      }
    }
    // References are numbered in 32 bits with room to spare (as BVH::build's
    // primitives): the start and the budget stay within 2^31 - 1. The budget
    // is capped in double, before its conversion (undefined past 2^64).
    constexpr size_t max_refs = size_t(UINT32_MAX) / 2;
    if (refs.size() > max_refs)
      throw Error("spatial splits: " + std::to_string(refs.size()) + " references to start from, more than " +
                  std::to_string(max_refs));
    const double asked = std::floor(double(m_opt.split_budget) * double(n));
    const double room = double(max_refs - refs.size());
    uint64_t budget = asked >= room ? uint64_t(room) : asked > 0 ? uint64_t(asked) : 0;
    m_root_area = root.surface_area();
    m_threads = build_threads(m_opt.threads);
    Subtree t;
    node(std::move(refs), 0, budget, t, m_threads > 1 ? 3 : 0);
    // Leaf entries to reference numbers: a triangle's first entry (in leaf
    // order) is the triangle itself, later ones extra references.
    std::vector<uint8_t> seen(n, 0);
    std::vector<uint32_t> ids(t.leaf_tri.size());
    for (size_t k = 0; k < ids.size(); ++k) {
      uint32_t tri = t.leaf_tri[k];
      if (!seen[tri]) {
        seen[tri] = 1;
        ids[k] = tri;
      } else {
        ids[k] = uint32_t(n + out.extra_tri.size());
        out.extra_tri.push_back(tri);
      }
    }
    if (keep_reference_boxes) {
      out.ref_box = std::move(t.leaf_box);
      out.ref_tri = std::move(t.leaf_tri);
    }
    t.leaf_tri = {};
    t.leaf_box = {};
    out.bvh = BVH::from_binary_tree(std::move(t.nodes), ids, m_opt);
    return out;
  }

 private:
  struct Ref {
    Bounds3f box;
    uint32_t tri;
  };
  struct Subtree {
    std::vector<BVHNode> nodes;
    std::vector<uint32_t> leaf_tri;
    std::vector<Bounds3f> leaf_box;
  };
  static constexpr int object_bins = 16;
  static constexpr int spatial_bins = 16;
  static constexpr int max_depth = 48;  // then median splits without duplicates (BVH::Builder's bound)

  Float blocks(size_t n) const { return Float((n + m_block - 1) / m_block); }

  // The triangle's part inside `box`, conservatively (see the file comment);
  // false if the triangle does not meet it.
  bool clipped_box(uint32_t tri, const Bounds3f& box, Bounds3f* out) const {
    Point3f v[3];
    m_vertices(size_t(tri), v);
    const Bounds3f tb = triangle_box(v[0], v[1], v[2]);
    Float h[3];
    Bounds3f grown = box;
    for (int a = 0; a < 3; ++a) {
      h[a] = clip_rounding * std::max(std::abs(tb.min[a]), std::abs(tb.max[a]));
      grown.min[a] -= 5 * h[a];
      grown.max[a] += 5 * h[a];
    }
    Point3f poly[16];
    int m = clip_triangle_to_box(v[0], v[1], v[2], grown, poly);
    if (m == 0) return false;
    Bounds3f r;
    for (int i = 0; i < m; ++i) r = union_bounds(r, poly[i]);
    for (int a = 0; a < 3; ++a) {
      r.min[a] = std::max(r.min[a] - 6 * h[a], box.min[a]);
      r.max[a] = std::min(r.max[a] + 6 * h[a], box.max[a]);
    }
    *out = r;
    return true;
  }

  struct Split {
    Float cost = infinity;  // sum of area times blocks of the two sides
    int axis = -1;
    int bin = 0;            // object: last bin on the left; spatial: the plane after this bin
    bool spatial = false;
    Float plane = 0;
    Bounds3f left, right;   // the two sides' boxes (object splits)
  };

  // Builds the subtree of `refs` into t. `parallel_levels` > 0: the right
  // child is built on another thread.
  void node(std::vector<Ref> refs, int depth, uint64_t budget, Subtree& t, int parallel_levels) {
    const uint32_t idx = uint32_t(t.nodes.size());
    t.nodes.emplace_back();
    Bounds3f bb, cb;
    {
      const size_t chunks = chunk_count(refs.size());
      std::vector<Bounds3f> cbb(chunks), ccb(chunks);
      parallel_items(chunks, m_threads, [&](size_t c) {
        for (size_t i = refs.size() * c / chunks, e = refs.size() * (c + 1) / chunks; i < e; ++i) {
          cbb[c] = union_bounds(cbb[c], refs[i].box);
          ccb[c] = union_bounds(ccb[c], refs[i].box.centroid());
        }
      });
      for (size_t c = 0; c < chunks; ++c) {
        bb = union_bounds(bb, cbb[c]);
        cb = union_bounds(cb, ccb[c]);
      }
    }
    for (int a = 0; a < 3; ++a) {
      t.nodes[idx].bmin[a] = bb.min[a];
      t.nodes[idx].bmax[a] = bb.max[a];
    }
    const size_t n = refs.size();
    auto make_leaf = [&] {
      t.nodes[idx].offset = uint32_t(t.leaf_tri.size());
      t.nodes[idx].count = uint32_t(n);
      for (const Ref& r : refs) {
        t.leaf_tri.push_back(r.tri);
        t.leaf_box.push_back(r.box);
      }
    };
    const size_t max_leaf = size_t(std::max(1, m_opt.leaf_size_limit()));
    if (n == 1 || (n <= m_block && n <= max_leaf && m_opt.traversal_cost >= 1)) return make_leaf();

    std::vector<Ref> left, right;
    Split best;
    if (depth < max_depth) best = object_split(refs, cb);
    const Split object = best;
    const Float area = bb.surface_area();
    if (depth < max_depth && budget > 0 && best.axis >= 0 && all_finite(bb)) {
      // The overlap of the object split's two boxes.
      const Bounds3f &lb = best.left, &rb = best.right;
      Bounds3f ov;
      for (int a = 0; a < 3; ++a) {
        ov.min[a] = std::max(lb.min[a], rb.min[a]);
        ov.max[a] = std::min(lb.max[a], rb.max[a]);
      }
      bool overlap = ov.min.x <= ov.max.x && ov.min.y <= ov.max.y && ov.min.z <= ov.max.z;
      if (overlap && ov.surface_area() > m_opt.spatial_alpha * m_root_area) {
        Split s = spatial_split(refs, bb, budget);
        if (s.cost < best.cost) best = s;
      }
    }
    const Float leaf_cost = blocks(n);
    const Float split_cost = m_opt.traversal_cost + (area > 0 ? best.cost / area : blocks(n));
    if (best.axis < 0 || !(best.cost < infinity)) {
      if (n <= max_leaf) return make_leaf();
      median_split(refs, cb, left, right);
    } else {
      if (n <= max_leaf && leaf_cost <= split_cost) return make_leaf();
      if (best.spatial) {
        spatial_partition(refs, best, left, right);  // (both sides non-empty)
        // The binned counts can differ from the cut's by references whose box
        // ends within rounding of the plane: past the budget, the object split.
        if (left.size() + right.size() - n > budget) {
          left.clear();
          right.clear();
        }
      }
      if (left.empty()) object_partition(refs, cb, object, left, right);
    }
    refs = {};
    // The budget left, shared in proportion to the children's references.
    const uint64_t used = left.size() + right.size() - n;
    const uint64_t rest = budget - std::min(budget, used);
    const uint64_t lbud = uint64_t(double(rest) * double(left.size()) / double(left.size() + right.size()));
    const uint64_t rbud = rest - lbud;
    if (parallel_levels > 0 && left.size() + right.size() > 4096) {
      Subtree rt;
      auto task = std::async(std::launch::async, [&, r = std::move(right)]() mutable {
        node(std::move(r), depth + 1, rbud, rt, parallel_levels - 1);
      });
      node(std::move(left), depth + 1, lbud, t, parallel_levels - 1);
      task.get();
      t.nodes[idx].offset = uint32_t(t.nodes.size());
      append(rt, t);
    } else {
      node(std::move(left), depth + 1, lbud, t, 0);
      t.nodes[idx].offset = uint32_t(t.nodes.size());
      node(std::move(right), depth + 1, rbud, t, 0);
    }
  }

  static bool all_finite(const Bounds3f& b) {
    for (int a = 0; a < 3; ++a)
      if (!std::isfinite(b.min[a]) || !std::isfinite(b.max[a])) return false;
    return true;
  }

  // Appends a subtree built on its own, rebasing interior and leaf offsets.
  static void append(Subtree& from, Subtree& to) {
    const uint32_t nb = uint32_t(to.nodes.size()), lb = uint32_t(to.leaf_tri.size());
    for (BVHNode nd : from.nodes) {
      nd.offset += nd.is_leaf() ? lb : nb;
      to.nodes.push_back(nd);
    }
    to.leaf_tri.insert(to.leaf_tri.end(), from.leaf_tri.begin(), from.leaf_tri.end());
    to.leaf_box.insert(to.leaf_box.end(), from.leaf_box.begin(), from.leaf_box.end());
    from = {};
  }

  // The centroid bin of c on an axis: bins of [lo, lo + object_bins / k); NaN in bin 0.
  static int bin_of(Float c, Float lo, Float k) {
    Float x = (c - lo) * k;
    return x >= 0 ? std::min(object_bins - 1, int(std::min(x, Float(object_bins)))) : 0;
  }
  static Float bin_scale(const Bounds3f& cb, int a) {
    Float ext = cb.max[a] - cb.min[a];
    if (!(ext > 0)) return 0;
    Float k = Float(object_bins) * (1 - 1e-6f) / ext;
    return std::isfinite(k) ? k : 0;
  }

  // Bins of a pass over references, summed over chunks in chunk order.
  template <int Bins>
  struct BinSet {
    Bounds3f box[3][Bins];
    size_t enter[3][Bins] = {}, exit[3][Bins] = {};
    void add(const BinSet& o) {
      for (int a = 0; a < 3; ++a)
        for (int b = 0; b < Bins; ++b) {
          box[a][b] = union_bounds(box[a][b], o.box[a][b]);
          enter[a][b] += o.enter[a][b];
          exit[a][b] += o.exit[a][b];
        }
    }
  };
  // fill(begin, end, bins) over refs: in one pass, or for a large node in a
  // fixed number of chunks on the build's threads (the same result whatever
  // their count: the chunks are merged in order).
  // The chunks a pass over n references is cut into: a number that does
  // not depend on the thread count, so that neither does the result.
  size_t chunk_count(size_t n) const {
    constexpr size_t chunk_min = 32 * 1024;
    return m_threads > 1 && n >= 2 * chunk_min ? std::min<size_t>(8, n / chunk_min) : 1;
  }
  // route(r, left, right) appends reference r to one side or both, over
  // chunks of refs, the sides concatenated in chunk order.
  template <class Route>
  void partition(const std::vector<Ref>& refs, Route&& route, std::vector<Ref>& left, std::vector<Ref>& right) const {
    const size_t n = refs.size(), chunks = chunk_count(n);
    if (chunks == 1) {
      for (const Ref& r : refs) route(r, left, right);
      return;
    }
    std::vector<std::vector<Ref>> l(chunks), r(chunks);
    parallel_items(chunks, m_threads, [&](size_t c) {
      for (size_t i = n * c / chunks, e = n * (c + 1) / chunks; i < e; ++i) route(refs[i], l[c], r[c]);
    });
    size_t nl = 0, nr = 0;
    for (size_t c = 0; c < chunks; ++c) {
      nl += l[c].size();
      nr += r[c].size();
    }
    left.reserve(nl);
    right.reserve(nr);
    for (size_t c = 0; c < chunks; ++c) {
      left.insert(left.end(), l[c].begin(), l[c].end());
      right.insert(right.end(), r[c].begin(), r[c].end());
    }
  }
  template <int Bins, class Fill>
  BinSet<Bins> binned(size_t n, Fill&& fill) const {
    const size_t chunks = chunk_count(n);
    std::vector<BinSet<Bins>> part(chunks);
    parallel_items(chunks, m_threads, [&](size_t c) { fill(n * c / chunks, n * (c + 1) / chunks, part[c]); });
    for (size_t c = 1; c < chunks; ++c) part[0].add(part[c]);
    return part[0];
  }

  Split object_split(const std::vector<Ref>& refs, const Bounds3f& cb) const {
    Split best;
    Float k[3];
    bool any = false;
    for (int a = 0; a < 3; ++a) any |= (k[a] = bin_scale(cb, a)) != 0;
    if (!any) return best;
    BinSet<object_bins> bins = binned<object_bins>(refs.size(), [&](size_t begin, size_t end, auto& out) {
      for (size_t i = begin; i < end; ++i) {
        const Ref& r = refs[i];
        const Point3f c = r.box.centroid();
        for (int a = 0; a < 3; ++a) {
          int b = bin_of(c[a], cb.min[a], k[a]);
          out.box[a][b] = union_bounds(out.box[a][b], r.box);
          ++out.enter[a][b];
        }
      }
    });
    for (int a = 0; a < 3; ++a)
      if (k[a] != 0) sweep(bins.box[a], bins.enter[a], object_bins, a, false, &best);
    if (best.axis >= 0)
      for (int b = 0; b < object_bins; ++b) {
        Bounds3f& side = b <= best.bin ? best.left : best.right;
        side = union_bounds(side, bins.box[best.axis][b]);
      }
    return best;
  }

  // Evaluates the SAH at every boundary between bins (left: bins 0..i).
  void sweep(const Bounds3f* box, const size_t* enter, int bins, int axis, bool spatial, Split* best,
             const size_t* exit = nullptr, uint64_t budget = 0, size_t n = 0) const {
    Float right_cost[spatial_bins];
    size_t right_n[spatial_bins];
    Bounds3f acc;
    size_t acc_n = 0;
    for (int i = bins - 1; i > 0; --i) {
      acc = union_bounds(acc, box[i]);
      acc_n += exit ? exit[i] : enter[i];
      right_n[i] = acc_n;
      right_cost[i] = acc_n ? blocks(acc_n) * acc.surface_area() : 0;
    }
    acc = Bounds3f();
    acc_n = 0;
    for (int i = 0; i < bins - 1; ++i) {
      acc = union_bounds(acc, box[i]);
      acc_n += enter[i];
      if (acc_n == 0 || right_n[i + 1] == 0) continue;
      if (spatial && (acc_n >= n || right_n[i + 1] >= n || acc_n + right_n[i + 1] - n > budget)) continue;
      Float cost = blocks(acc_n) * acc.surface_area() + right_cost[i + 1];
      if (cost < best->cost) {
        best->cost = cost;
        best->axis = axis;
        best->bin = i;
        best->spatial = spatial;
      }
    }
  }

  void object_partition(const std::vector<Ref>& refs, const Bounds3f& cb, const Split& s, std::vector<Ref>& left,
                        std::vector<Ref>& right) const {
    const Float k = bin_scale(cb, s.axis);
    partition(refs, [&](const Ref& r, std::vector<Ref>& l, std::vector<Ref>& rr) {
      (bin_of(r.box.centroid()[s.axis], cb.min[s.axis], k) <= s.bin ? l : rr).push_back(r);
    }, left, right);
  }

  // Halves by centroid order on the widest centroid axis (no duplicates).
  static void median_split(std::vector<Ref>& refs, const Bounds3f& cb, std::vector<Ref>& left,
                           std::vector<Ref>& right) {
    int a = cb.max_extent();
    auto mid = refs.begin() + std::ptrdiff_t(refs.size() / 2);
    // A strict weak order also with NaN centroids (after every number), as
    // nth_element needs.
    std::nth_element(refs.begin(), mid, refs.end(), [a](const Ref& x, const Ref& y) {
      const Float cx = x.box.centroid()[a], cy = y.box.centroid()[a];
      const bool nx = std::isnan(cx), ny = std::isnan(cy);
      if (nx != ny) return ny;
      if (!nx && cx != cy) return cx < cy;
      return x.tri < y.tri;
    });
    left.assign(refs.begin(), mid);
    right.assign(mid, refs.end());
  }

  // The best plane across the node's box `bb` (finite) on each axis, from the
  // boxes of the references' parts in each of spatial_bins slabs (for the
  // cost only: these parts need not be conservative).
  Split spatial_split(const std::vector<Ref>& refs, const Bounds3f& bb, uint64_t budget) const {
    const size_t n = refs.size();
    Float lo[3], w[3];
    bool active[3];
    for (int a = 0; a < 3; ++a) {
      lo[a] = bb.min[a];
      w[a] = (bb.max[a] - lo[a]) / Float(spatial_bins);
      active[a] = w[a] > 0 && std::isfinite(w[a]);
    }
    auto plane = [&](int a, int i) { return i == spatial_bins ? bb.max[a] : lo[a] + Float(i) * w[a]; };
    // (A NaN coordinate, which the node's finite box can hide, in bin 0.)
    auto bin = [&](int a, Float x) {
      Float f = (x - lo[a]) / w[a];
      return f >= 1 ? int(std::min(f, Float(spatial_bins - 1))) : 0;
    };
    BinSet<spatial_bins> bins = binned<spatial_bins>(n, [&](size_t begin, size_t end, auto& out) {
    auto& box = out.box;
    auto& enter = out.enter;
    auto& exit = out.exit;
    Point3f v[3];
    for (size_t ri = begin; ri < end; ++ri) {
      const Ref& r = refs[ri];
      int b0[3] = {}, b1[3] = {};
      bool spans = false;
      for (int a = 0; a < 3; ++a) {
        if (!active[a]) continue;
        b0[a] = bin(a, r.box.min[a]);
        b1[a] = bin(a, r.box.max[a]);
        ++enter[a][b0[a]];
        ++exit[a][b1[a]];
        if (b0[a] == b1[a])
          box[a][b0[a]] = union_bounds(box[a][b0[a]], r.box);
        else
          spans = true;
      }
      if (!spans) continue;
      // The triangle's part in each slab, from its vertices there and its
      // edges' crossings of the slab's two planes, kept inside the
      // reference's box (as Embree's spatial binning: looser than clipping
      // the triangle to the reference's box first, for a cut reference, and
      // several times cheaper).
      m_vertices(size_t(r.tri), v);
      for (int a = 0; a < 3; ++a) {
        if (!active[a] || b0[a] == b1[a]) continue;
        // The crossings of the plane at `at` (at most two: a plane meets two edges of a triangle).
        auto crossings = [&](Float at, Bounds3f* into) {
          for (int e = 0; e < 3; ++e) {
            const Point3f &p = v[e], &q = v[e == 2 ? 0 : e + 1];
            if ((p[a] < at && q[a] > at) || (p[a] > at && q[a] < at)) *into = union_bounds(*into, plane_crossing(p, q, a, at));
          }
        };
        Bounds3f low;  // the crossings of the slab's lower plane
        Float s0 = r.box.min[a];
        crossings(s0, &low);
        for (int b = b0[a]; b <= b1[a]; ++b) {
          const Float s1 = b == b1[a] ? r.box.max[a] : plane(a, b + 1);
          Bounds3f high;
          crossings(s1, &high);
          Bounds3f part = union_bounds(low, high);
          for (int e = 0; e < 3; ++e)
            if (v[e][a] >= s0 && v[e][a] <= s1) part = union_bounds(part, v[e]);
          for (int k = 0; k < 3; ++k) {
            part.min[k] = std::max(part.min[k], r.box.min[k]);
            part.max[k] = std::min(part.max[k], r.box.max[k]);
          }
          part.min[a] = std::max(part.min[a], s0);
          part.max[a] = std::min(part.max[a], s1);
          if (part.min.x <= part.max.x && part.min.y <= part.max.y && part.min.z <= part.max.z)
            box[a][b] = union_bounds(box[a][b], part);
          low = high;
          s0 = s1;
        }
      }
    }
    });
    Split best;
    for (int a = 0; a < 3; ++a) {
      if (!active[a]) continue;
      Split s;
      sweep(bins.box[a], bins.enter[a], spatial_bins, a, true, &s, bins.exit[a], budget, n);
      if (s.axis >= 0 && s.cost < best.cost) {
        best = s;
        best.plane = plane(a, s.bin + 1);
      }
    }
    return best;
  }

  // References wholly on one side of the plane go there; the others are cut
  // into their parts on each side (clipped_box), either of which may be empty.
  void spatial_partition(const std::vector<Ref>& refs, const Split& s, std::vector<Ref>& left,
                         std::vector<Ref>& right) const {
    const int a = s.axis;
    partition(refs, [&](const Ref& r, std::vector<Ref>& left_side, std::vector<Ref>& right_side) {
      if (!(r.box.min[a] < s.plane && r.box.max[a] > s.plane)) {  // one side (a NaN box: the left)
        (r.box.max[a] <= s.plane || !(r.box.min[a] >= s.plane) ? left_side : right_side).push_back(r);
      } else {
        Bounds3f lh = r.box, rh = r.box, lbox, rbox;
        lh.max[a] = s.plane;
        rh.min[a] = s.plane;
        bool l = clipped_box(r.tri, lh, &lbox), rr = clipped_box(r.tri, rh, &rbox);
        if (l) left_side.push_back({lbox, r.tri});
        if (rr) right_side.push_back({rbox, r.tri});
        if (!l && !rr) left_side.push_back(r);  // (cannot happen: the box holds part of the triangle)
      }
    }, left, right);
    // A side left empty (every part on one side): fall back to halving.
    if (left.empty() || right.empty()) {
      std::vector<Ref> all = left.empty() ? std::move(right) : std::move(left);
      left.clear();
      right.clear();
      Bounds3f cb;
      for (const Ref& r : all) cb = union_bounds(cb, r.box.centroid());
      median_split(all, cb, left, right);
    }
  }

  Vertices& m_vertices;
  const BVHBuildOptions& m_opt;
  uint32_t m_block;
  Float m_root_area = 0;
  int m_threads = 1;
};

// Builds a mesh's BVH with spatial splits (see SpatialSplitBuilder).
template <class Vertices>
SpatialBVH build_spatial_bvh(size_t n, Vertices&& vertices, const BVHBuildOptions& opt,
                             const SplitReferences* start = nullptr, bool keep_reference_boxes = false) {
  SpatialSplitBuilder<std::remove_reference_t<Vertices>> b(vertices, opt);
  return b.build(n, start, keep_reference_boxes);
}

// MeshAccel's entry: a mesh's positions and indices.
inline SpatialBVH build_spatial_mesh_bvh(size_t n, const Point3f* p, const uint32_t* idx, const BVHBuildOptions& opt,
                                         const SplitReferences* start) {
  return build_spatial_bvh(n, mesh_vertices(p, idx), opt, start);
}

}  // namespace detail

// The spatial-split builder, for BVHBuildOptions::spatial_splits.
inline constexpr detail::SpatialBuildFn spatial_split_builder = &detail::build_spatial_mesh_bvh;

}  // namespace prism
