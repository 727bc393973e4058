// prism/accel/presplit.hpp — triangle pre-splitting before a BVH build
// (BVHBuildOptions::split_budget). A long thin or diagonal triangle has a box
// far larger than itself; rays that enter the box mostly miss the triangle.
// Before the build, such triangles are cut into several references, each with
// the tight box of the triangle's part inside a sub-box, so that the BVH is
// built over smaller boxes (the idea of Ernst & Greiner 2007, "early split
// clipping", with the budgeted, prioritised allocation of Karras & Aila 2013).
//
// Which triangles: those whose box's surface area is at least `threshold`
// times twice the triangle's area (its two sides; BVHBuildOptions::
// split_threshold, 32 by default). A well-shaped triangle's box is 2 (flat in
// an axis plane) to about 6 times that; on prism's 1M-triangle displaced
// sphere no triangle reaches 32, while long thin or large diagonal slivers
// are in the hundreds or thousands. So a mesh of well-shaped triangles is not
// split at all and builds exactly as without splitting.
//
// Allocation: a candidate's priority is the surface area by which its box
// exceeds the triangle (box area minus twice the triangle's area; both sides
// of the triangle count, as they do for a flat box). Candidate i gets
// min(floor(s * priority_i), cap_i) extra references, cap_i = floor(ratio_i
// / 4) for the ratio above (about the number of pieces whose boxes would be
// as tight as a well-shaped triangle's: cutting a sliver k times divides its
// ratio by about k), the scale s the largest (by bisection) that keeps the
// total within the budget. The cap keeps a few slivers in a large mesh from
// taking the whole budget. A triangle with k extra
// references is cut recursively: the current reference box is halved at the
// midpoint of its longest axis, the polygon it was made from (at first the
// triangle) is clipped by the split plane moved outwards by a bound on the
// rounding so far (Sutherland-Hodgman, one plane per half), each half's
// reference box is the box of its polygon grown by that bound and kept
// inside the half, and the remaining k - 1 references are shared between the
// halves in proportion to their boxes' areas.
//
// Conservative: the union of a triangle's reference boxes contains the whole
// triangle (every point of the triangle inside a half is in that half's
// box, split_triangle gives the argument; a half whose clip comes out empty
// leaves its parent box unsplit). The
// result does not depend on the thread count: per-triangle work is
// independent, counts are summed as integers, and chunks are concatenated in
// triangle order.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "prism/accel/bvh.hpp"
#include "prism/error.hpp"
#include "prism/geometry/triangle.hpp"

namespace prism {
namespace detail {

// The references of a mesh's n triangles: reference k < n is (the first
// piece of) triangle k; the extra pieces follow, reference n + j being a
// piece of triangle extra_tri[j]. So only the extra pieces need a map.
struct SplitReferences {
  std::vector<Bounds3f> bounds;     // reference boxes
  std::vector<uint32_t> extra_tri;  // extra reference -> triangle index in the mesh
  size_t size() const { return bounds.size(); }
  size_t triangles() const { return bounds.size() - extra_tri.size(); }
  uint32_t triangle(size_t k) const { return k < triangles() ? uint32_t(k) : extra_tri[k - triangles()]; }
};

// The point where edge pq crosses the plane `plane` on `axis` (p and q on
// opposite sides of it): the plane's coordinate exactly, the others within
// the edge's extent.
inline Point3f plane_crossing(const Point3f& p, const Point3f& q, int axis, Float plane) {
  Float t = (plane - p[axis]) / (q[axis] - p[axis]);
  Point3f x;
  for (int k = 0; k < 3; ++k) {
    Float v = p[k] + t * (q[k] - p[k]);
    x[k] = std::clamp(v, std::min(p[k], q[k]), std::max(p[k], q[k]));
  }
  x[axis] = plane;
  return x;
}

// Clips the convex polygon in[0..n) to the closed half-space of the plane
// `plane` on `axis` (side 0: coordinates <= plane, side 1: >= plane); writes
// the result, at most n + 1 vertices, to out and returns their count (0:
// empty). A vertex created on the plane gets the plane's coordinate exactly
// and stays within its edge's extent on the other axes.
//
// "At most n + 1" holds for the rounded polygons too, which need not be
// convex. What it needs is that along the polygon each coordinate rises and
// falls once at most (cyclically), so that the vertices inside form one run
// and the boundary is crossed twice at most. A triangle has that property,
// and clipping keeps it: a new vertex lies between its edge's ends on every
// axis (the clamp in plane_crossing), and dropping vertices cannot add a
// turn. So clip_triangle_to_box returns at most 9 vertices.
inline int clip_polygon(const Point3f* in, int n, int axis, int side, Float plane, Point3f* out) {
  auto inside = [&](const Point3f& p) { return side == 0 ? p[axis] <= plane : p[axis] >= plane; };
  int m = 0;
  for (int i = 0; i < n; ++i) {
    const Point3f& p = in[i];
    const Point3f& q = in[i + 1 == n ? 0 : i + 1];
    bool pi = inside(p), qi = inside(q);
    if (pi) out[m++] = p;
    if (pi != qi) out[m++] = plane_crossing(p, q, axis, plane);
  }
  return m;
}

// The convex polygon of triangle (a, b, c) clipped to box `box` (closed); its
// vertices, at most 9, in *out; returns their count (0: empty).
inline int clip_triangle_to_box(const Point3f& a, const Point3f& b, const Point3f& c, const Bounds3f& box,
                                Point3f* out) {
  Point3f buf[2][10] = {{a, b, c}, {}};
  int n = 3, cur = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      n = clip_polygon(buf[cur], n, axis, side, side == 0 ? box.max[axis] : box.min[axis], buf[1 - cur]);
      cur = 1 - cur;
      if (n == 0) return 0;
    }
  for (int i = 0; i < n; ++i) out[i] = buf[cur][i];
  return n;
}

// The rounding of one clip (clip_polygon), per axis, in units of epsilon
// times the largest coordinate magnitude M of the triangle's box (which
// holds every clipped vertex: a new vertex is clamped to its edge's extent):
// a new vertex p + t (q - p) is within 11 of them of the exact crossing of
// the computed edge pq (first order: the sum, the product and the difference
// each round once, and t, a quotient of two rounded differences, is within 3
// epsilon of its value); kept vertices are exact. 16 leaves room for the
// second-order terms.
inline constexpr Float clip_rounding = 16 * std::numeric_limits<Float>::epsilon();

// A reference of a triangle being split: its box, its share of the extra
// references, and the clipped polygon it was made from (see split_triangle).
struct SplitPiece {
  static constexpr int max_vertices = 16;
  Bounds3f box;
  uint32_t extra = 0;
  int n = 0, clips = 0;
  Point3f poly[max_vertices];
};

// Appends the references of triangle `t` with `extra` extra references (or
// fewer, where a box cannot be halved or a clip comes out empty).
//
// Why they contain the triangle, whatever the rounding. A reference is a box
// B, inside the half H of its parent's box that it was made for, and a
// computed convex polygon P, the result of k clips, with the invariant: every
// point x of the triangle inside H lies within e_k = k h of P per axis (h =
// clip_rounding M). The first reference is the triangle's box and the
// triangle itself, k = 0. B is P's box grown by e_k and kept inside H, so it
// holds every such x.
//
// A reference is split at the midpoint of B's longest axis into halves H'
// (each inside H). P is clipped by the split plane moved outwards by
// g = (k + 1) h >= e_k. For x of the triangle inside H', the invariant gives
// x' in P within e_k of x; x lies inside the plane, so x' lies inside the
// moved one and survives that clip's exact version; the computed clip moves
// the polygon by at most h (the same convex combination of the rounded
// vertices), so x is within e_k + h = e_(k+1) of the new polygon P'. The
// half's box is P''s box grown by e_(k+1), kept inside H'. Without the moved
// plane this fails where an edge of P grazes the plane: a point of the
// triangle just inside it may have its computed neighbour just outside, and
// the part of the polygon lost with it can be far longer than the rounding.
//
// Each clip can add a vertex. A polygon with no room left (`max_vertices`,
// at most SplitPiece::max_vertices; tests lower it) is computed anew from
// the triangle and B (its six planes moved out by 5 h; every x is then
// within 6 h of it by the same induction).
inline void split_triangle(const Point3f& a, const Point3f& b, const Point3f& c, uint32_t t, uint32_t extra,
                           std::vector<Bounds3f>& out_bounds, std::vector<uint32_t>& out_tri,
                           std::vector<SplitPiece>& stack, int max_vertices = SplitPiece::max_vertices) {
  max_vertices = std::clamp(max_vertices, 4, SplitPiece::max_vertices);
  const Bounds3f tri_box = triangle_box(a, b, c);
  Float unit[3];  // h per axis
  for (int ax = 0; ax < 3; ++ax)
    unit[ax] = clip_rounding * std::max(std::abs(tri_box.min[ax]), std::abs(tri_box.max[ax]));
  auto emit = [&](const Bounds3f& box) {
    out_bounds.push_back(box);
    out_tri.push_back(t);
  };
  // A piece's polygon is copied only as far as it is used.
  auto assign = [](SplitPiece& to, const SplitPiece& from) {
    to.box = from.box;
    to.extra = from.extra;
    to.n = from.n;
    to.clips = from.clips;
    std::copy(from.poly, from.poly + from.n, to.poly);
  };
  stack.resize(1);
  stack[0].box = tri_box;
  stack[0].extra = extra;
  stack[0].n = 3;
  stack[0].clips = 0;
  stack[0].poly[0] = a;
  stack[0].poly[1] = b;
  stack[0].poly[2] = c;
  SplitPiece upper;  // the half above the split plane; the lower half is made in a new slot
  while (!stack.empty()) {
    // Room for the lower half first, so that `it` stays valid below.
    if (stack.size() == stack.capacity()) stack.reserve(2 * stack.size());
    SplitPiece& it = stack.back();
    const Bounds3f box = it.box;
    int axis = box.max_extent();
    Float lo = box.min[axis], hi = box.max[axis];
    Float mid = 0.5f * (lo + hi);
    if (it.extra == 0 || !(mid > lo && mid < hi)) {
      emit(box);
      stack.pop_back();
      continue;
    }
    if (it.n >= max_vertices) {  // no room for a new vertex: start again from the triangle
      Bounds3f grown = box;
      for (int ax = 0; ax < 3; ++ax) {
        grown.min[ax] -= 5 * unit[ax];
        grown.max[ax] += 5 * unit[ax];
      }
      it.n = clip_triangle_to_box(a, b, c, grown, it.poly);
      it.clips = 6;
    }
    const Float g = Float(it.clips + 1) * unit[axis];
    SplitPiece& lower = stack.emplace_back();  // no reallocation: reserved above
    bool ok = it.n > 0;
    for (int side = 0; side < 2 && ok; ++side) {
      SplitPiece& h = side == 0 ? lower : upper;
      h.clips = it.clips + 1;
      h.n = clip_polygon(it.poly, it.n, axis, side, side == 0 ? mid + g : mid - g, h.poly);
      ok = h.n > 0;
      Bounds3f hb = box;
      (side == 0 ? hb.max : hb.min)[axis] = mid;
      Bounds3f r;
      for (int i = 0; i < h.n; ++i) r = union_bounds(r, h.poly[i]);
      for (int ax = 0; ax < 3; ++ax) {
        Float e = Float(h.clips) * unit[ax];
        r.min[ax] = std::max(r.min[ax] - e, hb.min[ax]);
        r.max[ax] = std::min(r.max[ax] + e, hb.max[ax]);
      }
      h.box = r;
    }
    if (!ok) {  // cannot split: keep the box whole
      emit(box);
      stack.pop_back();
      stack.pop_back();
      continue;
    }
    uint32_t rest = it.extra - 1;
    double la = double(lower.box.surface_area()), ra = double(upper.box.surface_area());
    uint32_t nl = la + ra > 0 ? uint32_t(std::min(double(rest), std::floor(double(rest) * la / (la + ra) + 0.5))) : rest / 2;
    lower.extra = nl;
    upper.extra = rest - nl;
    // The upper half below the lower one on the stack (in the parent's
    // slot): the lower half's references come out first.
    assign(it, upper);
  }
}

// The same with a stack of its own.
inline void split_triangle(const Point3f& a, const Point3f& b, const Point3f& c, uint32_t t, uint32_t extra,
                           std::vector<Bounds3f>& out_bounds, std::vector<uint32_t>& out_tri,
                           int max_vertices = SplitPiece::max_vertices) {
  std::vector<SplitPiece> stack;
  split_triangle(a, b, c, t, extra, out_bounds, out_tri, stack, max_vertices);
}

// The vertex fetch that presplit_triangles and the spatial-split builder
// take, for a mesh's positions p and indices idx (three per triangle):
// writes triangle i's vertices to v[0..2].
inline auto mesh_vertices(const Point3f* p, const uint32_t* idx) {
  return [p, idx](size_t i, Point3f* v) {
    v[0] = p[idx[3 * i]];
    v[1] = p[idx[3 * i + 1]];
    v[2] = p[idx[3 * i + 2]];
  };
}

// A mesh BVH built with spatial splits (accel/sbvh.hpp): the BVH over
// references, and for reference n + j (n the triangle count) its triangle
// extra_tri[j]; reference k < n is triangle k.
struct SpatialBVH {
  BVH bvh;
  std::vector<uint32_t> extra_tri;
  // With keep_reference_boxes: each reference's box and triangle, in leaf
  // order (for tests: they must cover the triangles).
  std::vector<Bounds3f> ref_box;
  std::vector<uint32_t> ref_tri;
};

// Throws prism::Error unless the budget is finite and >= 0 and the threshold
// finite and >= 1 (checked whether or not splitting is on).
inline void check_split_options(float budget, float threshold) {
  if (!(budget >= 0) || !std::isfinite(budget))
    throw Error("BVHBuildOptions::split_budget must be a finite number >= 0, got " + std::to_string(budget));
  if (!(threshold >= 1) || !std::isfinite(threshold))
    throw Error("BVHBuildOptions::split_threshold must be a finite number >= 1, got " + std::to_string(threshold));
}

// Throws prism::Error unless spatial_alpha (BVHBuildOptions) is finite and >= 0.
inline void check_spatial_alpha(float alpha) {
  if (!(alpha >= 0) || !std::isfinite(alpha))
    throw Error("BVHBuildOptions::spatial_alpha must be a finite number >= 0, got " + std::to_string(alpha));
}

template <class Vertices>
SplitReferences presplit_triangles(size_t n, Vertices&& vertices, float budget, float threshold, int threads) {
  check_split_options(budget, threshold);
  // Compared in double before any conversion: a budget times n beyond 2^64
  // would make the conversion undefined.
  const double asked = std::floor(double(budget) * double(n));
  if (double(n) + asked > double(UINT32_MAX))
    throw Error("BVHBuildOptions::split_budget " + std::to_string(budget) + " asks for " +
                std::to_string(double(n) + asked) + " references, more than 2^32 - 1");
  const uint64_t total = uint64_t(asked);
  if (total == 0) return {};
  // The candidates (triangle, priority, cap), chunk by chunk in triangle order.
  struct Candidate {
    uint32_t tri;
    uint32_t cap;
    double prio;
  };
  const int chunks = parallel_chunk_count(n, threads);
  std::vector<std::vector<Candidate>> found(static_cast<size_t>(chunks));
  parallel_chunks(n, chunks, [&](size_t begin, size_t end, int ch) {
    for (size_t i = begin; i < end; ++i) {
      Point3f v[3];
      vertices(i, v);
      Bounds3f box = triangle_box(v[0], v[1], v[2]);
      double area2 = double(length(cross(v[1] - v[0], v[2] - v[0])));  // twice the area
      double sa = double(box.surface_area());
      // Zero-area triangles are never hit: no reason to cut them.
      if (!(area2 > 0) || !std::isfinite(sa) || !(sa >= double(threshold) * area2)) continue;
      double cap = std::min(std::floor(sa / (4 * area2)), double(total));
      double prio = sa - area2;
      if (!(prio > 0) || cap < 1) continue;
      found[size_t(ch)].push_back({uint32_t(i), uint32_t(cap), prio});
    }
  });
  std::vector<Candidate> cand;
  for (auto& f : found) {
    cand.insert(cand.end(), f.begin(), f.end());
    f = {};
  }
  if (cand.empty()) return {};
  // Counts and sums below run over the candidates in triangle order, so
  // that the scale, hence the references, do not depend on the thread count.
  auto extra_at = [](const Candidate& c, double s) {
    return uint64_t(std::min(std::floor(c.prio * s), double(c.cap)));
  };
  auto count_at = [&](double s) {
    uint64_t k = 0;
    for (const Candidate& c : cand) k += extra_at(c, s);
    return k;
  };
  // The scale: count_at is non-decreasing in s; at lo = total / (sum of the
  // priorities) it is at most the total, and at hi every candidate reaches its cap.
  double hi = 0, psum = 0;
  for (const Candidate& c : cand) {
    hi = std::max(hi, (double(c.cap) + 1) / c.prio);
    psum += c.prio;
  }
  double scale = hi;
  if (count_at(hi) > total) {
    double lo = std::min(double(total) / psum, hi);
    for (int it = 0; it < 64 && hi > lo * (1 + 1e-7); ++it) {
      double m = 0.5 * (lo + hi);
      if (count_at(m) <= total)
        lo = m;
      else
        hi = m;
    }
    scale = lo;
  }
  std::vector<uint32_t> extra(n, 0);
  uint64_t any = 0;
  for (const Candidate& c : cand) any += (extra[c.tri] = uint32_t(extra_at(c, scale)));
  if (any == 0) return {};
  // The references: each triangle's first piece at its own index, the extra
  // pieces chunk by chunk after them, in triangle order.
  struct Part {
    std::vector<Bounds3f> bounds;
    std::vector<uint32_t> tri;
  };
  SplitReferences refs;
  // Room for every extra piece from the start (any bounds them): the
  // references are appended below without moving the first n.
  reserve_huge(refs.bounds, n + size_t(any));
  refs.bounds.resize(n);
  // The pieces' chunks are balanced by work, not by triangle count: the
  // candidates may all sit in one stretch of the mesh (a sliver costs about a
  // hundred times what an unsplit triangle does). Which chunk a triangle falls
  // in changes nothing in the result (chunks are concatenated in order).
  const int piece_chunks = any >= 256 ? std::max(chunks, std::max(1, threads)) : chunks;
  std::vector<size_t> cut(static_cast<size_t>(piece_chunks) + 1, n);
  cut[0] = 0;
  if (piece_chunks > 1) {
    constexpr uint64_t piece_weight = 128;  // one extra piece against one unsplit triangle
    const uint64_t work = uint64_t(n) + piece_weight * any;
    uint64_t acc = 0;
    size_t c = 1;
    for (size_t i = 0; i < n && c < cut.size() - 1; ++i) {
      acc += 1 + piece_weight * extra[i];
      while (c < cut.size() - 1 && acc * uint64_t(piece_chunks) >= work * c) cut[c++] = i + 1;
    }
  }
  std::vector<Part> parts(static_cast<size_t>(piece_chunks));
  parallel_chunks(size_t(piece_chunks), piece_chunks, [&](size_t first_chunk, size_t, int ch) {
    const size_t begin = cut[first_chunk], end = cut[first_chunk + 1];
    Part& part = parts[size_t(ch)];
    size_t extras = 0;
    for (size_t i = begin; i < end; ++i) extras += extra[i];
    part.bounds.reserve(extras);
    part.tri.reserve(extras);
    std::vector<Bounds3f> pieces;
    std::vector<uint32_t> piece_tri;
    std::vector<SplitPiece> stack;
    for (size_t i = begin; i < end; ++i) {
      Point3f v[3];
      vertices(i, v);
      if (extra[i] == 0) {
        refs.bounds[i] = triangle_box(v[0], v[1], v[2]);
        continue;
      }
      pieces.clear();
      piece_tri.clear();
      split_triangle(v[0], v[1], v[2], uint32_t(i), extra[i], pieces, piece_tri, stack);
      refs.bounds[i] = pieces[0];
      part.bounds.insert(part.bounds.end(), pieces.begin() + 1, pieces.end());
      part.tri.insert(part.tri.end(), piece_tri.begin() + 1, piece_tri.end());
    }
  });
  size_t count = 0;
  for (const auto& p : parts) count += p.tri.size();
  refs.extra_tri.reserve(count);
  for (auto& p : parts) {
    refs.bounds.insert(refs.bounds.end(), p.bounds.begin(), p.bounds.end());
    refs.extra_tri.insert(refs.extra_tri.end(), p.tri.begin(), p.tri.end());
    p = {};
  }
  return refs;
}

}  // namespace detail
}  // namespace prism
