// The wide nodes' box test (detail::intersect_wide) against exact arithmetic:
// a lane whose box the exact ray meets before t_max is always entered, with
// an entry distance no later than the exact one allows, and a box the exact
// ray clearly misses is not. Run in every accel build: with AVX2 and FMA most
// rays take the directed-FMA path (WideRayPrecomp::fast), elsewhere (and for
// rays with a zero direction component everywhere) the exact form.
//
// The reference decides in binary128 (__float128, 113 significant bits,
// exponents down to 2^-16382, so float subnormals too are exact in it),
// where every quantity it forms is exact: a difference b - o of two floats
// whose exponents differ by at most 60 needs at most 85 bits, and its product
// with a float at most 109. Slab distances are compared as fractions, by
// cross-multiplying, so no division rounds.
#include "support/accel_variant.hpp"
#include <catch2/catch.hpp>

#include <algorithm>
#include <bit>
#include <cmath>
#include <sstream>
#include <string>
#include <type_traits>

#include "prism/accel/bvh.hpp"
#include "prism/sampling/pcg32.hpp"

#include "support/lanes.hpp"
#include "support/random.hpp"

namespace slab_test {

#if defined(__SIZEOF_FLOAT128__)  // GCC and Clang on x86-64

using namespace prism;
using test::uniform;

namespace {

constexpr int W = detail::wide_width;
using Q = __float128;

// A distance along the ray as the fraction num / den, den > 0 (den = |d_a|),
// or unbounded.
struct Frac {
  Q num, den;
};
bool frac_le(const Frac& a, const Frac& b) { return a.num * b.den <= b.num * a.den; }

// The exact entry and exit of the ray o + t d, t in [0, t_max], into box b:
// hit when entry <= exit. For an axis with d = 0 the ray is inside the slab
// or misses the box.
struct Exact {
  bool hit;
  Frac entry;          // max(0, near distances)
  Frac exit;           // min(t_max, far distances); den 0 when unbounded
  bool exit_bounded;
};
Exact exact_slab(const Point3f& o, const Vector3f& d, Float t_max, const Bounds3f& b) {
  Exact e{true, {0, 1}, {0, 0}, false};
  if (t_max < infinity) {
    e.exit = {Q(t_max), 1};
    e.exit_bounded = true;
  }
  for (int a = 0; a < 3; ++a) {
    if (d[a] == 0) {
      if (!(b.min[a] <= o[a] && o[a] <= b.max[a])) e.hit = false;
      continue;
    }
    Q den = d[a] > 0 ? Q(d[a]) : -Q(d[a]);
    Q lo = (Q(b.min[a]) - Q(o[a])) * (d[a] > 0 ? 1 : -1);
    Q hi = (Q(b.max[a]) - Q(o[a])) * (d[a] > 0 ? 1 : -1);
    Frac near{std::min(lo, hi), den}, far{std::max(lo, hi), den};
    if (frac_le(e.entry, near)) e.entry = near;
    if (!e.exit_bounded || frac_le(far, e.exit)) {
      e.exit = far;
      e.exit_bounded = true;
    }
  }
  if (e.exit_bounded && !frac_le(e.entry, e.exit)) e.hit = false;
  return e;
}
double to_double(const Frac& f) { return double(f.num / f.den); }

// A box of scale s around a random centre: ordinary, thin, flat on one or two
// axes (zero thickness), or a point.
Bounds3f random_box(PCG32& rng, Float s) {
  Point3f c{uniform(rng, -s, s), uniform(rng, -s, s), uniform(rng, -s, s)};
  int kind = int(rng.next_u32() % 5);
  Bounds3f b;
  for (int a = 0; a < 3; ++a) {
    Float h = s * uniform(rng, 0.05f, 0.5f);
    if (kind == 1 && a == 0) h *= 1e-4f;
    if ((kind == 2 && a == 1) || (kind == 3 && a != 2) || kind == 4) h = 0;
    b.min[a] = c[a] - h;
    b.max[a] = c[a] + h;
  }
  return b;
}

// A point on the boundary of b: each coordinate a bound or inside, at least
// one a bound (a face, edge or corner).
Point3f boundary_point(PCG32& rng, const Bounds3f& b) {
  Point3f p;
  int forced = int(rng.next_u32() % 3);
  for (int a = 0; a < 3; ++a) {
    uint32_t k = rng.next_u32() % 3;
    if (a == forced && k == 2) k = rng.next_u32() % 2;
    p[a] = k == 0 ? b.min[a] : k == 1 ? b.max[a] : b.min[a] + rng.next_float() * (b.max[a] - b.min[a]);
    p[a] = std::clamp(p[a], b.min[a], b.max[a]);
  }
  return p;
}

struct Tally {
  long rays = 0, fast_rays = 0, lanes_hit = 0, lanes_missed_clearly = 0;
  long culled = 0, late = 0, loose = 0, mismatched = 0;
  std::string first;
  void fail(long& counter, const std::string& what) {
    if (counter++ == 0 && first.empty()) first = what;
  }
};

std::string describe(const Point3f& o, const Vector3f& d, Float t_max, const Bounds3f& b) {
  std::ostringstream s;
  s.precision(9);
  s << "o (" << o.x << ", " << o.y << ", " << o.z << ") d (" << d.x << ", " << d.y << ", " << d.z
    << ") t_max " << t_max << " box (" << b.min.x << ", " << b.min.y << ", " << b.min.z << ")-(" << b.max.x
    << ", " << b.max.y << ", " << b.max.z << ")";
  return s.str();
}

void check_node(PCG32& rng, Float s, Tally& t) {
  Bounds3f box[W];
  int k = 1 + int(rng.next_u32() % uint32_t(W));
  for (int l = 0; l < k; ++l) box[l] = random_box(rng, s);
  detail::BVHFloatWideNode node;
  detail::set_boxes(node, box, k);
  for (int j = 0; j < 24; ++j) {
    const Bounds3f& target = box[rng.next_u32() % uint32_t(k)];
    Point3f p = boundary_point(rng, target);
    Point3f o{uniform(rng, -4 * s, 4 * s), uniform(rng, -4 * s, 4 * s), uniform(rng, -4 * s, 4 * s)};
    uint32_t kind = rng.next_u32() % 9;
    if (kind == 0) {  // grazing: the origin in a plane of the target, moving along it
      int a = int(rng.next_u32() % 3);
      o[a] = rng.next_float() < 0.5f ? target.min[a] : target.max[a];
      p[a] = o[a];
    }
    // From the coordinate origin: c = o inv is 0, so only the rounding of inv
    // and of the FMA separate entry from exit, and d = p exactly, so a ray at
    // an edge or corner enters and leaves at the same exact t.
    if (kind == 3) o = Point3f(0, 0, 0);
    Vector3f d = p - o;
    if (kind == 3) {  // scaled by a power of two (exactly) to |d| in [1, 2): normal even for subnormal p
      Float m = max_component(abs(d));
      if (m > 0) {
        int e = -std::ilogb(m);
        d = Vector3f(std::ldexp(d.x, e), std::ldexp(d.y, e), std::ldexp(d.z, e));
      }
    }
    if (kind == 1) d[int(rng.next_u32() % 3)] = 0;  // a zero component: the exact path
    if (kind == 2) d = d * uniform(rng, 1e-3f, 1e3f);
    if (kind == 8) d = d * (0x1p100f / max_component(abs(d)));  // |d| 2^100
    // Unit length for kinds 4-7, t_max then around the target's distance (in
    // double: at subnormal scales float squares would underflow).
    Float t_hit = 1;
    if (kind >= 4 && kind < 8) {
      double len = std::sqrt(double(d.x) * d.x + double(d.y) * d.y + double(d.z) * d.z);
      if (!(len > 0)) continue;
      t_hit = Float(len);
      d = Vector3f(Float(d.x / len), Float(d.y / len), Float(d.z / len));
    }
    if (d.x == 0 && d.y == 0 && d.z == 0) continue;
    // The box tests take 1 / d: each component must be 0 or have a normal
    // reciprocal (an axis with |d| < 2^-128 is tested as if d were 0 there).
    bool normal = true;
    for (int a = 0; a < 3; ++a)
      if (d[a] != 0 && !(std::abs(d[a]) >= 0x1p-126f && std::abs(d[a]) <= 0x1p126f)) normal = false;
    if (!normal) continue;
    // t_max around the target's distance, or unbounded, or zero (only boxes
    // around the origin count).
    Float t_max = rng.next_float() < 0.4f ? infinity : t_hit * uniform(rng, 0.8f, 1.25f);
    if (rng.next_u32() % 16 == 0) t_max = 0;
    detail::WideRayPrecomp r(o, d);
    const Float t_cull = detail::widen_exit(t_max);
    alignas(32) Float t_entry[W];
    int mask = detail::intersect_wide(node, r, t_cull, t_entry);
    // Built from RayBoxPrecomp (as SceneAccel did before), the same ray data:
    // the same lanes entered at the same distances.
    {
      detail::WideRayPrecomp r2{RayBoxPrecomp(o, d)};
      alignas(32) Float t_entry2[W];
      int mask2 = detail::intersect_wide(node, r2, t_cull, t_entry2);
      bool same = mask2 == mask && r2.fast == r.fast;
      for (int l = 0; l < W; ++l)
        if (mask >> l & 1 && std::bit_cast<uint32_t>(t_entry[l]) != std::bit_cast<uint32_t>(t_entry2[l])) same = false;
      if (!same) t.fail(t.mismatched, "the two ray set-ups differ: " + describe(o, d, t_max, box[0]));
    }
#if defined(PRISM_BVH_AVX_NODES) && defined(__AVX2__)
    // The lanes entered, as the vector push_by_distance takes: the mask's
    // bits, unused lanes clear, every lane all ones or all zeros (whole
    // lanes compared, not just their sign bits).
    {
      detail::LaneMaskV inside;
      alignas(32) Float t_entry3[W];
      int mask3 = detail::intersect_wide(node, r, t_cull, t_entry3, &inside);
      if (mask3 != mask || !test::same_lanes(inside, detail::lanes_inside(unsigned(mask))))
        t.fail(t.mismatched, "the vector of lanes entered is not the mask: " + describe(o, d, t_max, box[0]));
    }
#endif
    double o_over_d = 0;
    for (int a = 0; a < 3; ++a)
      if (d[a] != 0) o_over_d = std::max(o_over_d, std::abs(double(o[a]) / double(d[a])));
    ++t.rays;
    if (r.fast) ++t.fast_rays;
    for (int l = 0; l < k; ++l) {
      Exact e = exact_slab(o, d, t_max, box[l]);
      bool entered = mask >> l & 1;
      if (e.hit) {
        ++t.lanes_hit;
        if (!entered) {
          t.fail(t.culled, "culled: " + describe(o, d, t_max, box[l]));
        } else if (!(Q(t_entry[l]) * e.entry.den <=
                     e.entry.num * Q(detail::box_exit_widen) + Q(detail::box_exit_slack) * e.entry.den)) {
          // The entry reported may be early, never later than rounding allows
          // (deferred children are culled against widen_exit(t_max), at
          // least t_max (1 + 2 gamma(5)) + 2^-147).
          t.fail(t.late, "late entry: " + describe(o, d, t_max, box[l]));
        }
      } else if (e.exit_bounded) {
        // Clearly missed: by more than 1e-4 of the distances, 1e-5 of the
        // largest |o_a / d_a| (the directed-FMA path's slack is a few ulps of
        // o inv, absolute, besides its relative part) and 1e-43 (the
        // subnormal slack of widen_exit and of five ulps added).
        double en = to_double(e.entry), ex = to_double(e.exit);
        if (ex < en - 1e-4 * std::max(std::abs(en), std::abs(ex)) - 1e-5 * o_over_d - 1e-43) {
          ++t.lanes_missed_clearly;
          if (entered) t.fail(t.loose, "entered a clear miss: " + describe(o, d, t_max, box[l]));
        }
      }
    }
    if (mask & ~((1 << k) - 1)) t.fail(t.loose, "entered an empty lane");
  }
}

}  // namespace

TEST_CASE("the wide box test enters every box the exact ray meets", "[accel][bvh][slab]") {
  // Scales from 1e-43 (subnormal coordinates and distances) to 1e30:
  // coordinates, boxes and origins of one scale per node (so the reference
  // stays exact), rays aimed at faces, edges and corners (some exactly through
  // them, from the coordinate origin), grazing along faces, with zero
  // direction components or |d| = 2^100, and with t_max zero, just short of
  // or beyond the target.
  PCG32 rng(41, 0x51ab);
  const Float scales[] = {1, 1e-30f, 1e30f, 3e-6f, 7e5f, 1e12f, 1e-39f, 1e-43f, 2e-38f};
  Tally t;
  for (Float s : scales)
    for (int it = 0; it < test::variant_count(1500); ++it) check_node(rng, s, t);
  INFO(t.rays << " rays (" << t.fast_rays << " on the directed-FMA path), " << t.lanes_hit << " lanes met exactly, "
               << t.lanes_missed_clearly << " clearly missed; culled " << t.culled << ", late " << t.late
               << ", loose " << t.loose << ", set-ups differing " << t.mismatched << "; first: " << t.first);
  CHECK(t.culled == 0);
  CHECK(t.late == 0);
  CHECK(t.loose == 0);
  CHECK(t.mismatched == 0);
  CHECK(t.lanes_hit > t.rays / 4);
  CHECK(t.lanes_missed_clearly > t.rays / 4);
#if defined(PRISM_BVH_FMA_SLABS)
  // Most rays take the fast path; the ones with a zero component (1 in 8,
  // and some grazing ones) or huge o / d do not.
  CHECK(t.fast_rays > t.rays / 2);
  CHECK(t.fast_rays < t.rays);
#else
  CHECK(t.fast_rays == 0);
#endif
}

TEST_CASE("the wide box test enters boxes met at subnormal distances", "[accel][bvh][slab]") {
  // Rays from the coordinate origin with small integer directions d, at a box
  // that the exact ray touches at one corner (or edge) at t = m 2^-150, m odd:
  // entry and exit are the same exact distance, halfway between two subnormal
  // floats, and rounding each slab distance to the subnormal grid can invert
  // them (an error that is absolute there, not relative: a widening by a
  // factor alone culls such boxes).
  PCG32 rng(43, 0x5ab);
  int rays = 0, culled = 0;
  std::string first;
  for (int it = 0; it < 4000; ++it) {
    Vector3f d;
    Point3f corner;
    const uint32_t m = 2 * (rng.next_u32() % 500) + 1;
    for (int a = 0; a < 3; ++a) {
      // d_a = 2 j: the corner m j 2^-149 is a float (a subnormal multiple of 2^-149).
      int j = int(rng.next_u32() % 40) - (a == 2 ? 10 : 20);
      d[a] = Float(2 * j);
      corner[a] = std::ldexp(Float(int(m) * j), -149);
    }
    if (d.x == 0 && d.y == 0 && d.z == 0) continue;
    // The box lies beyond the corner along the axes the ray enters by and
    // before it along those it leaves by; an axis with d = 0 spans 0.
    Bounds3f b;
    int enter_axis = int(rng.next_u32() % 3);
    for (int a = 0; a < 3; ++a) {
      Float w = std::ldexp(Float(1 + rng.next_u32() % 200), -149);
      bool beyond = (a == enter_axis) == (d[a] > 0);
      if (d[a] == 0) {
        b.min[a] = -w;
        b.max[a] = w;
      } else if (beyond) {
        b.min[a] = corner[a];
        b.max[a] = corner[a] + w;
      } else {
        b.min[a] = corner[a] - w;
        b.max[a] = corner[a];
      }
    }
    Exact e = exact_slab(Point3f(0, 0, 0), d, infinity, b);
    if (!e.hit) continue;
    Bounds3f box[W];
    for (int l = 0; l < W; ++l) box[l] = b;
    detail::BVHFloatWideNode node;
    detail::set_boxes(node, box, 1);
    detail::WideRayPrecomp r(Point3f(0, 0, 0), d);
    for (Float t_max : {infinity, std::ldexp(Float(m + 1), -150)}) {
      alignas(32) Float t_entry[W];
      Exact et = exact_slab(Point3f(0, 0, 0), d, t_max, b);
      if (!et.hit) continue;
      ++rays;
      if (!(detail::intersect_wide(node, r, detail::widen_exit(t_max), t_entry) & 1) && culled++ == 0)
        first = describe(Point3f(0, 0, 0), d, t_max, b);
    }
  }
  INFO(rays << " rays touching a box at a subnormal distance; culled " << culled << "; first: " << first);
  CHECK(rays > 2000);
  CHECK(culled == 0);
}

TEST_CASE("the wide box test's slack is the one it documents, no more", "[accel][bvh][slab]") {
  // From o = 0 along d = (1, 1, 1) every slab distance is exact (inv = 1,
  // c = o inv = 0 up to its subnormal slack), so a box's computed entry E and
  // exit X are its planes. The box spans [0, X] on x and starts at E on y:
  // the exact ray misses it for E > X, and the test enters it exactly when E
  // is within the slack the comment on WideRayPrecomp proves enough. The
  // directed-FMA path raises X by five ulps; the exact form enters up to
  // widen_exit(X). Here that boundary is hit on both sides, so a slack cut
  // below the proof's (culling met boxes elsewhere) or widened past it fails.
  int cases = 0;
  for (Float x : {1.0f, 3.7f, 1e-20f, 6.5e12f, 0x1p-100f}) {
    detail::WideRayPrecomp r(Point3f(0, 0, 0), Vector3f(1, 1, 1));
#if defined(PRISM_BVH_FMA_SLABS)
    REQUIRE(r.fast);
    const Float last = std::bit_cast<Float>(std::bit_cast<uint32_t>(x) + 5);
#else
    REQUIRE(!r.fast);
    const Float last = detail::widen_exit(x);
#endif
    const Float first_out = std::nextafter(last, infinity);
    for (int lane = 0; lane < W; ++lane)
      for (Float e : {last, first_out}) {
        Bounds3f box[W];
        for (int l = 0; l < W; ++l) box[l] = Bounds3f(Point3f(0, 0, 0), Point3f(1e30f, 1e30f, 1e30f));
        box[lane].min = Point3f(0, e, 0);
        box[lane].max = Point3f(x, 2 * e, 2 * e);
        detail::BVHFloatWideNode node;
        detail::set_boxes(node, box, W);
        alignas(32) Float t_entry[W];
        const int mask = detail::intersect_wide(node, r, infinity, t_entry);
        INFO("exit " << x << ", entry " << e << " (" << (e == last ? "last entered" : "first culled") << "), lane "
                     << lane);
        CHECK(bool(mask >> lane & 1) == (e == last));
        CHECK((mask | (1 << lane)) == (1 << W) - 1);  // the other lanes, boxes around the ray, entered
        ++cases;
      }
  }
  CHECK(cases == 10 * W);
}

#endif

// The traversal layout and its width are the ones the build's flags select.
TEST_CASE("the traversal layout is the one the build selects", "[accel][bvh][slab]") {
  constexpr int W = detail::wide_width;
#if defined(PRISM_BVH_QUANTIZED) && PRISM_BVH_QUANTIZED
  CHECK(std::is_same_v<detail::BVHWideNode, detail::BVHQuantWideNode>);
  CHECK(sizeof(detail::BVHWideNode) == (W == 8 ? 128u : 72u));
#else
  CHECK(std::is_same_v<detail::BVHWideNode, detail::BVHFloatWideNode>);
  CHECK(sizeof(detail::BVHWideNode) == 32u * W);
#endif
#if defined(PRISM_BVH_WIDTH)
  CHECK(W == PRISM_BVH_WIDTH);
#elif defined(PRISM_BVH_ZMM) && !(defined(PRISM_BVH_QUANTIZED) && PRISM_BVH_QUANTIZED)
  CHECK(W == 16);
#else
  CHECK(W == 8);
#endif
#if defined(PRISM_BVH_ZMM_NODES)
  CHECK(sizeof(detail::bx::V) == 64);  // one AVX-512 register per axis and side
#endif
}

// The ordering of closest-hit traversal for three or more entered lanes
// (detail::push_by_distance: with AVX2 branch-free, built on detail::sort8;
// otherwise an insertion sort): for random sets of entered lanes and entry
// distances (many of them equal, or within a few ulps), the nearest lane is
// returned and the others are written farthest first, each with its own
// child, count and distance. Keys compare a distance's bits with the lane in
// the low three (four with 16-wide nodes, whose SIMD form sorts up to eight
// entered lanes with sort8 and more by insertion), so lanes whose distances
// differ only there may swap; the check allows exactly that (the insertion
// sort's exact order passes too).
// The any-hit form (push_by_distance<false>, without distances) must push
// the same children and counts.
TEST_CASE("closest-hit traversal orders entered lanes by distance", "[accel][bvh][slab]") {
  constexpr int W = detail::wide_width;
  PCG32 rng(91, 3);
  // Distances within 8 ulps (16 with 16-wide nodes) may go in lane order:
  // the SIMD orderings' keys hold the lane in those low bits.
  constexpr uint32_t low_bits = uint32_t(std::max(W, 8) - 1);
  auto key = [](Float t) { return std::bit_cast<uint32_t>(t) & ~low_bits; };
  long wrong = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    detail::BVHWideNode node{};
    alignas(32) Float t_entry[W];
    const Float base = std::ldexp(1.0f + rng.next_float(), int(rng.next_u32() % 40) - 20);
    for (int l = 0; l < W; ++l) {
      node.child[l] = rng.next_u32();
      node.count[l] = rng.next_u32() % 3 == 0 ? detail::BVHWideNode::interior : rng.next_u32() % 9;
      uint32_t kind = rng.next_u32() % 4;
      t_entry[l] = kind == 0 ? base  // ties
                   : kind == 1 ? std::bit_cast<Float>(std::bit_cast<uint32_t>(base) + rng.next_u32() % 16)
                   : kind == 2 ? 0.0f
                               : base * 4 * rng.next_float();
    }
    unsigned mask = rng.next_u32() & ((1u << W) - 1);
    if (std::popcount(mask) < 2) mask |= 3u << (rng.next_u32() % (W - 1));
    alignas(32) uint32_t child[2 * W], count[2 * W];
    alignas(32) Float t[2 * W];
    int nearest = detail::push_by_distance(node, mask, t_entry, child, count, t);
    const int n = std::popcount(mask);
    // Reconstruct the lanes pushed (children are random 32-bit values: unique
    // with overwhelming probability; a collision only makes the check skip).
    bool ok = (mask >> nearest & 1) != 0;
    unsigned seen = 1u << nearest;
    for (int l = 0; l < W; ++l)
      if ((mask >> l & 1) && key(t_entry[l]) < key(t_entry[nearest])) ok = false;
    for (int j = 0; j + 1 < n && ok; ++j) {
      int lane = -1;
      for (int l = 0; l < W; ++l)
        if ((mask >> l & 1) && !(seen >> l & 1) && node.child[l] == child[j]) lane = l;
      if (lane < 0) {
        ok = false;
        break;
      }
      seen |= 1u << lane;
      if (count[j] != node.count[lane] || std::bit_cast<uint32_t>(t[j]) != std::bit_cast<uint32_t>(t_entry[lane]))
        ok = false;
      // Farthest first: every later slot (and the nearest) is no farther.
      if (j > 0 && key(t[j]) > key(t[j - 1])) ok = false;
    }
    if (n >= 2 && key(t[n - 2]) < key(t_entry[nearest])) ok = false;
    if (seen != mask) ok = false;
    // The any-hit form (no distances) pushes the same children and counts in the same order.
    alignas(32) uint32_t child2[2 * W], count2[2 * W];
    if (detail::push_by_distance<false>(node, mask, t_entry, child2, count2, nullptr) != nearest ||
        !std::equal(child, child + n - 1, child2) || !std::equal(count, count + n - 1, count2))
      ok = false;
    if (!ok) ++wrong;
  }
  CHECK(wrong == 0);
}

// The ordering of two entered lanes in any-hit traversal
// (detail::nearer_first, branch-free on the distances' bits): the nearer lane
// first, equal distances in lane order, exactly as comparing the distances as
// numbers. Distances from +0 to +inf, many equal or a few ulps apart.
TEST_CASE("two entered lanes are ordered nearer first", "[accel][bvh][slab]") {
  constexpr int W = detail::wide_width;
  PCG32 rng(92, 5);
  long wrong = 0, swapped = 0, ties = 0;
  for (int trial = 0; trial < 200000; ++trial) {
    alignas(32) Float t_entry[W];
    Float base = rng.next_float() < 0.05f ? infinity : uniform(rng, 0, 100);
    for (int l = 0; l < W; ++l) {
      uint32_t ulps = rng.next_u32() % 4;
      if (base == infinity) ulps = 0;  // (entry distances are never NaN)
      t_entry[l] = rng.next_float() < 0.1f ? Float(0) : std::bit_cast<Float>(std::bit_cast<uint32_t>(base) + ulps);
      if (rng.next_float() < 0.3f) t_entry[l] = uniform(rng, 0, 1000);
    }
    int a = int(rng.next_u32() % (W - 1));
    int b = a + 1 + int(rng.next_u32() % uint32_t(W - 1 - a));
    int na = a, nb = b;
    detail::nearer_first(t_entry, na, nb);
    bool expect_swap = t_entry[b] < t_entry[a];
    if (expect_swap ? (na != b || nb != a) : (na != a || nb != b)) ++wrong;
    swapped += expect_swap;
    ties += t_entry[a] == t_entry[b];
  }
  INFO(swapped << " swapped, " << ties << " ties");
  CHECK(swapped > 20000);
  CHECK(ties > 1000);
  CHECK(wrong == 0);
}

}  // namespace slab_test
