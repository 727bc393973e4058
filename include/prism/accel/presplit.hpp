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
// midpoint of its longest axis, the triangle is clipped against each half
// grown by a bound on the clipping's rounding (Sutherland-Hodgman), each
// half's reference box is the box of its clipped polygon, grown by the same
// bound and kept inside the half (clipped_reference), and the remaining
// k - 1 references are shared between the halves in proportion to their
// boxes' areas.
//
// Conservative: the union of a triangle's reference boxes contains the whole
// triangle (every point of the triangle inside a half is in that half's
// box, clipped_reference gives the argument; a half whose clip comes out
// empty leaves its parent box unsplit). The
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

// The convex polygon of triangle (a, b, c) clipped to box `box` (closed); its
// vertices, at most 9, in *out; returns their count (0: empty). Vertices
// created on a plane get that plane's coordinate exactly.
inline int clip_triangle_to_box(const Point3f& a, const Point3f& b, const Point3f& c, const Bounds3f& box,
                                Point3f* out) {
  Point3f buf[2][10];
  int n = 3;
  buf[0][0] = a;
  buf[0][1] = b;
  buf[0][2] = c;
  int cur = 0;
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const Float plane = side == 0 ? box.min[axis] : box.max[axis];
      auto inside = [&](const Point3f& p) { return side == 0 ? p[axis] >= plane : p[axis] <= plane; };
      const Point3f* in = buf[cur];
      bool all_in = true;
      for (int i = 0; i < n; ++i) all_in = all_in && inside(in[i]);
      if (all_in) continue;
      Point3f* o = buf[1 - cur];
      int m = 0;
      for (int i = 0; i < n; ++i) {
        const Point3f& p = in[i];
        const Point3f& q = in[(i + 1) % n];
        bool pi = inside(p), qi = inside(q);
        if (pi) o[m++] = p;
        if (pi != qi) {
          Float t = (plane - p[axis]) / (q[axis] - p[axis]);
          Point3f x;
          for (int k = 0; k < 3; ++k) {
            Float v = p[k] + t * (q[k] - p[k]);
            // Keep the vertex on its edge's extent despite rounding.
            x[k] = std::clamp(v, std::min(p[k], q[k]), std::max(p[k], q[k]));
          }
          x[axis] = plane;
          o[m++] = x;
        }
      }
      n = m;
      cur = 1 - cur;
      if (n == 0) return 0;
    }
  for (int i = 0; i < n; ++i) out[i] = buf[cur][i];
  return n;
}

// The reference box of triangle (a, b, c) inside `half`: the triangle is
// clipped to `half` grown by a margin m per axis, the clipped polygon's box is
// grown by m too and then intersected with `half`. Empty if the clip is.
//
// Why it contains the part of the triangle inside `half`, whatever the
// rounding. Per axis, let m = 128 epsilon * M, M the largest coordinate
// magnitude of the triangle's box (which holds every clipped vertex: a new
// vertex is clamped to its edge's extent). A new vertex p + t (q - p) is
// within h = 11 epsilon M of the exact crossing of the computed edge pq
// (first order: the sum, the product and the difference each round once,
// and t, a quotient of two rounded differences, is within 3 epsilon of its
// value); kept vertices are exact. So after each clip, every point of the
// exact clip of the previous computed polygon is within h of the new one
// (the same convex combination of the rounded vertices). By induction, after
// k clips every point x of the triangle inside `half` is within k h of a point
// x' of the computed polygon; as long as k h <= m, x' lies inside the next
// grown plane (x lies inside the plane itself), so x' survives that clip's
// exact version and the induction goes on. After the six planes x is within
// 6 h = 66 epsilon M < m of the polygon, hence in its box grown by m. Without
// the grown planes this fails where a polygon edge grazes a clipping plane: a
// point of the triangle just inside the plane may have its computed
// neighbour just outside it, and the part of the polygon lost with it can be
// far longer than the rounding.
inline Bounds3f clipped_reference(const Point3f& a, const Point3f& b, const Point3f& c, const Bounds3f& tri_box,
                                  const Bounds3f& half) {
  constexpr Float k = 128 * std::numeric_limits<Float>::epsilon();
  Float margin[3];
  Bounds3f grown = half;
  for (int ax = 0; ax < 3; ++ax) {
    margin[ax] = k * std::max(std::abs(tri_box.min[ax]), std::abs(tri_box.max[ax]));
    grown.min[ax] = half.min[ax] - margin[ax];
    grown.max[ax] = half.max[ax] + margin[ax];
  }
  Point3f poly[10];
  int n = clip_triangle_to_box(a, b, c, grown, poly);
  Bounds3f r;
  if (n == 0) return r;
  for (int i = 0; i < n; ++i) r = union_bounds(r, poly[i]);
  for (int ax = 0; ax < 3; ++ax) {
    r.min[ax] = std::max(r.min[ax] - margin[ax], half.min[ax]);
    r.max[ax] = std::min(r.max[ax] + margin[ax], half.max[ax]);
  }
  return r;
}

// Appends the references of triangle `t` with `extra` extra references (or
// fewer, where a box cannot be halved or a clip comes out empty).
inline void split_triangle(const Point3f& a, const Point3f& b, const Point3f& c, uint32_t t, uint32_t extra,
                           std::vector<Bounds3f>& out_bounds, std::vector<uint32_t>& out_tri) {
  const Bounds3f tri_box = triangle_box(a, b, c);
  struct Item {
    Bounds3f box;
    uint32_t extra;
  };
  std::vector<Item> stack{{tri_box, extra}};
  while (!stack.empty()) {
    Item it = stack.back();
    stack.pop_back();
    if (it.extra == 0) {
      out_bounds.push_back(it.box);
      out_tri.push_back(t);
      continue;
    }
    int axis = it.box.max_extent();
    Float lo = it.box.min[axis], hi = it.box.max[axis];
    Float mid = 0.5f * (lo + hi);
    Bounds3f lh = it.box, rh = it.box;
    lh.max[axis] = mid;
    rh.min[axis] = mid;
    Bounds3f l, r;
    if (mid > lo && mid < hi) {
      l = clipped_reference(a, b, c, tri_box, lh);
      r = clipped_reference(a, b, c, tri_box, rh);
    }
    if (l.empty() || r.empty()) {  // cannot split: keep the box whole
      out_bounds.push_back(it.box);
      out_tri.push_back(t);
      continue;
    }
    uint32_t rest = it.extra - 1;
    double la = double(l.surface_area()), ra = double(r.surface_area());
    uint32_t nl = la + ra > 0 ? uint32_t(std::min(double(rest), std::floor(double(rest) * la / (la + ra) + 0.5))) : rest / 2;
    // Right first on the stack: the left half's references come out first.
    stack.push_back({r, rest - nl});
    stack.push_back({l, nl});
  }
}

// The references of mesh triangles for a budget of `budget` extra references
// per triangle (a fraction: 0.3 = up to 30% more references than triangles)
// among the triangles whose box-to-area ratio reaches `threshold`. Empty when
// no triangle is split (the caller then builds over the triangles as they are).
// Throws prism::Error unless the budget is finite and >= 0 and the threshold
// finite and >= 1 (checked whether or not splitting is on).
inline void check_split_options(float budget, float threshold) {
  if (!(budget >= 0) || !std::isfinite(budget))
    throw Error("BVHBuildOptions::split_budget must be a finite number >= 0, got " + std::to_string(budget));
  if (!(threshold >= 1) || !std::isfinite(threshold))
    throw Error("BVHBuildOptions::split_threshold must be a finite number >= 1, got " + std::to_string(threshold));
}

template <class Vertices>
SplitReferences presplit_triangles(size_t n, Vertices&& vertices, float budget, float threshold, int threads) {
  check_split_options(budget, threshold);
  const uint64_t total = uint64_t(double(budget) * double(n));
  if (double(n) + double(total) > double(UINT32_MAX))
    throw Error("BVHBuildOptions::split_budget " + std::to_string(budget) + " asks for " +
                std::to_string(double(n) + double(total)) + " references, more than 2^32 - 1");
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
    for (size_t i = begin; i < end; ++i) {
      Point3f v[3];
      vertices(i, v);
      if (extra[i] == 0) {
        refs.bounds[i] = triangle_box(v[0], v[1], v[2]);
        continue;
      }
      pieces.clear();
      piece_tri.clear();
      split_triangle(v[0], v[1], v[2], uint32_t(i), extra[i], pieces, piece_tri);
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
