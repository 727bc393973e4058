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
// gathers is chosen for the least SAH cost of the whole layout (BVH::Collapse). Each lane's box test is exactly
// intersect_node's, so a ray reaches the same primitives as through the
// binary tree. -DPRISM_BVH_QUANTIZED=1 stores the children's
// boxes quantized to bytes, rounded outward (half the node size; see
// BVHQuantWideNode): a ray then reaches a superset of those primitives.
#pragma once
#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <future>
#include <iterator>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <thread>
#include <type_traits>
#include <vector>
#include "prism/error.hpp"
#include "prism/geometry/ray.hpp"

#if defined(__linux__)
#include <sys/mman.h>
#endif

// SIMD paths: SSE2 for the build and (without AVX) traversal, AVX for
// traversal; plain C++ otherwise, or with PRISM_BVH_NO_SIMD defined. All
// paths compute the same values.
#if defined(PRISM_BVH_NO_SIMD)
#elif defined(__AVX__)
#include <immintrin.h>
#define PRISM_BVH_AVX 1
#define PRISM_BVH_SSE 1
#elif defined(__SSE2__) || defined(_M_X64) || (defined(_M_IX86_FP) && _M_IX86_FP >= 2)
#include <emmintrin.h>
#define PRISM_BVH_SSE 1
#endif
// With AVX2 and FMA, box tests take the directed-FMA path (see WideRayPrecomp).
#if defined(PRISM_BVH_AVX) && defined(__AVX2__) && defined(__FMA__)
#define PRISM_BVH_FMA_SLABS 1
#endif

namespace prism {

struct alignas(32) BVHNode {
  Float bmin[3];
  uint32_t offset;  // leaf: first primitive; interior: index of the second child
  Float bmax[3];
  uint32_t count;   // primitives in a leaf; 0 for an interior node

  bool is_leaf() const { return count != 0; }
  Bounds3f bounds() const {
    Bounds3f b;
    b.min = {bmin[0], bmin[1], bmin[2]};
    b.max = {bmax[0], bmax[1], bmax[2]};
    return b;
  }
};
static_assert(sizeof(BVHNode) == 32);

struct BVHBuildOptions {
  // The most primitives in a leaf; 0 (the default) or less means one
  // leaf_block, and at least 8 (leaf_size_limit()): MeshAccel's leaves then
  // hold one packet of triangles, 8 or, with 16-wide packets (the default
  // with AVX-512), 16 (accel/triangle_packet.hpp), and 4-wide packets two.
  int max_leaf_size = 0;
  // Primitives a leaf tests together (triangle packets): the SAH counts a
  // leaf's cost in blocks of this many, and each leaf's range in prims()
  // starts at a multiple of it, padded by repeating the leaf's last primitive.
  int leaf_block = 1;
  // Relative cost of a node visit against one primitive test.
  Float traversal_cost = 1.0f;
  // Threads for the build; 0 = all hardware threads. The tree does not depend on it.
  int threads = 0;
  // Scenes with moving instances: top-level trees over the motion's time
  // range (scene_accel.hpp); 0 = SceneAccel::kDefaultMotionSegments.
  int motion_segments = 0;
  // Triangle meshes (MeshAccel): extra BVH references from pre-splitting
  // triangles whose box is much larger than they are (accel/presplit.hpp), as
  // a fraction of the triangle count; 0 = off. Only triangles whose box's
  // surface area is at least split_threshold times twice their area are cut:
  // long thin or large diagonal slivers. A mesh without them (a ratio of 2 to
  // about 6 is usual) is built exactly as with splitting off. Where it cuts,
  // it trades build time for tracing: on traversal_bench's sliver scene the
  // build takes 1.7x as long and rays trace 1.7-1.9x faster; 0 suits a mesh
  // rebuilt every frame and traced little.
  float split_budget = 0.3f;
  float split_threshold = 32;
  // Triangle meshes (MeshAccel): after pre-splitting, spatial splits inside
  // the builder too (SBVH; the program includes prism/accel/sbvh.hpp, which
  // holds the builder, or this is refused with prism::Error): at nodes where
  // the best object split's two boxes overlap by more than spatial_alpha
  // times the root's surface area, a plane across the node's box that cuts
  // the references it crosses, where the SAH prefers it. It may add up to split_budget times
  // the triangle count references on top of pre-splitting's. On
  // traversal_bench's sliver scene the build takes about 5 times as long and
  // rays trace 1.25 to 1.35 times as fast (docs/performance.md). Off by
  // default.
  bool spatial_splits = false;
  float spatial_alpha = 1e-3f;
  // Keep the binary tree that the wide traversal layout is derived from
  // (BVH::nodes(), for tests and inspection). Otherwise it is freed once the
  // layout is written: 32 bytes per binary node, about 9 per mesh triangle.
  bool keep_binary_tree = false;

  // max_leaf_size, with 0 resolved.
  int leaf_size_limit() const { return max_leaf_size > 0 ? max_leaf_size : std::max(8, leaf_block); }
};

// Per-ray data for box tests.
struct RayBoxPrecomp {
  Float o[3], inv_d[3];
  int sign[3];
  explicit RayBoxPrecomp(const Point3f& org, const Vector3f& d) {
    o[0] = org.x; o[1] = org.y; o[2] = org.z;
    inv_d[0] = 1 / d.x; inv_d[1] = 1 / d.y; inv_d[2] = 1 / d.z;
    for (int i = 0; i < 3; ++i) sign[i] = inv_d[i] < 0 ? 1 : 0;
  }
};

namespace detail {

// How the box tests enlarge an exit distance t before comparing it with an
// entry distance: widen_exit(t) = (t + 2^-147) (1 + 2 gamma(5)), rounded
// twice, as Ize 2013's 1 + 2 gamma(3) but also covering distances in the
// subnormal range and the rounding of the widening itself.
// Why it suffices. With u = 2^-24, a computed slab distance
// fl(fl(b - o) fl(1 / d)) is within three roundings of the exact (b - o) / d:
// for a result x >= 0 a rounding gives at most x (1 + u) + 2^-150 and at
// least x (1 - u) - 2^-150, the absolute term for results that underflow (a
// product's error is not relative there; a difference that underflows is
// exact). So the computed entry t0 (the largest near distance and 0) is at
// most E (1 + u)^3 + 2^-150, and if the exact ray meets the box (0 <= E <= X)
// the computed exit t1 (the least far distance and t_max) is at least
// X (1 - u)^3 - 2^-150, so t1 >= -0 and
//   t0 <= (t1 + 2^-150) r + 2^-150,  r = (1 + u)^3 / (1 - u)^3 < 1 + 6u + 19u^2.
// The constant 1 + 2 gamma(5) rounds to w = 1 + 10u, and
// widen_exit(t1) >= (t1 + 2^-147) (1 - u)^2 w - 2^-150, where
// (1 - u)^2 w > 1 + 8u - 19u^2 > r and 2^-147 (1 - u)^2 w exceeds
// 2^-150 (r + 2): so widen_exit(t1) >= t0. (1 / d must be a normal float:
// |d| <= 2^126.) An addition followed by a product cannot be contracted to
// an FMA, so every path computes it bit for bit alike.
inline constexpr Float box_exit_slack = 0x1p-147f;
inline constexpr Float box_exit_widen = 1 + 2 * gamma(5);
inline Float widen_exit(Float t) { return (t + box_exit_slack) * box_exit_widen; }

}  // namespace detail

// Entry distance of the ray into the node's box, or +inf when it misses or the
// box lies beyond t_max.
inline Float intersect_node(const BVHNode& n, const RayBoxPrecomp& r, Float t_max) {
  const Float* lo = n.bmin;
  const Float* hi = n.bmax;
  Float tx0 = ((r.sign[0] ? hi : lo)[0] - r.o[0]) * r.inv_d[0];
  Float tx1 = ((r.sign[0] ? lo : hi)[0] - r.o[0]) * r.inv_d[0];
  Float ty0 = ((r.sign[1] ? hi : lo)[1] - r.o[1]) * r.inv_d[1];
  Float ty1 = ((r.sign[1] ? lo : hi)[1] - r.o[1]) * r.inv_d[1];
  Float tz0 = ((r.sign[2] ? hi : lo)[2] - r.o[2]) * r.inv_d[2];
  Float tz1 = ((r.sign[2] ? lo : hi)[2] - r.o[2]) * r.inv_d[2];
  // NaN (0 * inf on a slab boundary) loses every comparison and is ignored.
  Float t0 = tx0 > 0 ? tx0 : 0;
  t0 = ty0 > t0 ? ty0 : t0;
  t0 = tz0 > t0 ? tz0 : t0;
  Float t1 = tx1 < t_max ? tx1 : t_max;
  t1 = ty1 < t1 ? ty1 : t1;
  t1 = tz1 < t1 ? tz1 : t1;
  return t0 <= detail::widen_exit(t1) ? t0 : infinity;
}

namespace detail {

// Asks the OS to back a large buffer about to be written with huge pages
// (Linux transparent huge pages in "madvise" mode): building a BVH writes some
// hundred megabytes, and faulting them in 4 KiB at a time is a large share of
// the build time. A hint only; elsewhere, or for small buffers, nothing.
inline void advise_huge_pages([[maybe_unused]] const void* p, [[maybe_unused]] size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr uintptr_t huge = uintptr_t(2) << 20;
  uintptr_t begin = (reinterpret_cast<uintptr_t>(p) + huge - 1) & ~(huge - 1);
  uintptr_t end = (reinterpret_cast<uintptr_t>(p) + bytes) & ~(huge - 1);
  if (end > begin) madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
#endif
}
// std::allocator, except that a vector's resize() default-initialises the
// elements it adds instead of value-initialising them: for a trivial T they
// are left unwritten, so that their pages are first touched (and zeroed by
// the kernel) by the threads that fill them, not zeroed once more by the
// calling thread first. For arrays that the build writes whole in parallel
// (wide nodes, triangle packets): zeroing the 1M-triangle mesh's 40 MB of
// packets on one thread took 2-80 ms of a 2-thread build of about 0.2 s.
// (Construction with arguments falls through std::allocator_traits to
// std::construct_at, and rebinding to the template's first argument.)
template <class T>
struct fill_later_allocator : std::allocator<T> {
  fill_later_allocator() = default;
  template <class U>
  fill_later_allocator(const fill_later_allocator<U>&) noexcept {}
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
};
template <class T>
using fill_later_vector = std::vector<T, fill_later_allocator<T>>;

template <class T, class A>
void reserve_huge(std::vector<T, A>& v, size_t n) {
  v.reserve(n);
  advise_huge_pages(v.data(), v.capacity() * sizeof(T));
}
// An array of n default-initialised T (trivial T: not written, so the pages
// are first touched by the threads that fill them), huge pages advised.
template <class T>
std::unique_ptr<T[]> make_huge_array(size_t n) {
  static_assert(std::is_trivially_default_constructible_v<T>);
  std::unique_ptr<T[]> a(new T[n]);
  advise_huge_pages(a.get(), n * sizeof(T));
  return a;
}

// Threads for a build: 0 means all hardware threads.
inline int build_threads(int requested) {
  return requested > 0 ? requested : int(std::max(1u, std::thread::hardware_concurrency()));
}
// Runs fn(i) for every i in [0, n) on up to `threads` threads (the calling
// thread among them), handing out items one at a time so that uneven items
// keep every thread busy.
template <class F>
void parallel_items(size_t n, int threads, F&& fn) {
  size_t t = std::min(n, size_t(std::max(1, threads)));
  if (t <= 1) {
    for (size_t i = 0; i < n; ++i) fn(i);
    return;
  }
  std::atomic<size_t> next{0};
  auto worker = [&] {
    for (size_t i = next.fetch_add(1); i < n; i = next.fetch_add(1)) fn(i);
  };
  std::vector<std::thread> pool;
  for (size_t c = 1; c < t; ++c) pool.emplace_back(worker);
  worker();
  for (auto& th : pool) th.join();
}
// How many contiguous chunks parallel_chunks should split n items into.
inline int parallel_chunk_count(size_t n, int threads) { return n < 64 * 1024 ? 1 : std::max(1, threads); }
// Runs fn(begin, end, chunk) on `chunks` contiguous ranges of [0, n), one
// thread per chunk (the calling thread takes the first).
template <class F>
void parallel_chunks(size_t n, int chunks, F&& fn) {
  if (chunks <= 1) {
    fn(size_t(0), n, 0);
    return;
  }
  std::vector<std::thread> pool;
  for (int c = 1; c < chunks; ++c)
    pool.emplace_back([&, c] { fn(n * size_t(c) / size_t(chunks), n * size_t(c + 1) / size_t(chunks), c); });
  fn(size_t(0), n / size_t(chunks), 0);
  for (auto& t : pool) t.join();
}

// Up to wide_width children of the binary tree, gathered under one node for
// traversal. Boxes are stored as structure of arrays: b[2W * axis + W * side +
// lane] (W = wide_width), side 0 = min, 1 = max. Unused lanes hold an empty
// box (+inf, -inf) and an empty leaf, so they are never entered by a ray
// without NaNs and are harmless for one with them.
//
// The width: PRISM_BVH_WIDTH if the user sets it (4, 8 or 16), otherwise 16
// where the compiler may use 512-bit AVX-512 registers (512-byte nodes, one
// AVX-512 pass per visit) and 8 elsewhere (256-byte nodes, one AVX pass or
// two SSE passes per visit; also the width of quantized nodes, which are at
// most 8 wide). 4-wide nodes are 128 bytes, one SSE pass. 16-wide nodes
// without AVX-512 are tested four lanes at a time (SSE). The layout depends
// on the compiler's instruction-set flags: every translation unit of a
// program must be compiled with the same ones (or set PRISM_BVH_WIDTH).
// docs/performance.md has the measurements behind the default (16 lanes
// were measured on AMD Zen 5, whose vector units are 512 bits wide).
#if defined(PRISM_BVH_FMA_SLABS) && defined(PRISM_AVX512_ZMM)
#define PRISM_BVH_ZMM 1  // a 16-lane box test is available
#endif
#if defined(PRISM_BVH_WIDTH)
#define PRISM_BVH_W PRISM_BVH_WIDTH
#elif defined(PRISM_BVH_ZMM) && !(defined(PRISM_BVH_QUANTIZED) && PRISM_BVH_QUANTIZED)
#define PRISM_BVH_W 16
#else
#define PRISM_BVH_W 8
#endif
inline constexpr int wide_width = PRISM_BVH_W;
static_assert(wide_width == 4 || wide_width == 8 || wide_width == 16, "PRISM_BVH_WIDTH must be 4, 8 or 16");
#if defined(PRISM_BVH_QUANTIZED) && PRISM_BVH_QUANTIZED && PRISM_BVH_W > 8
#error "quantized BVH nodes are 4 or 8 wide (PRISM_BVH_WIDTH)"
#endif
// The box test's registers: 8 lanes of AVX for 8-wide nodes, 16 of AVX-512
// (with the directed-FMA path) for 16-wide ones; SSE otherwise.
#if defined(PRISM_BVH_AVX) && PRISM_BVH_W == 8
#define PRISM_BVH_AVX_NODES 1
#elif defined(PRISM_BVH_ZMM) && PRISM_BVH_W == 16
#define PRISM_BVH_ZMM_NODES 1
#endif
struct alignas(64) BVHFloatWideNode {
  static constexpr uint32_t interior = UINT32_MAX;
  Float b[6 * wide_width];
  uint32_t child[wide_width];  // interior: index of a wide node; leaf: first primitive (leaf order)
  uint32_t count[wide_width];  // leaf: primitive count; interior: `interior`
};
static_assert(sizeof(BVHFloatWideNode) == 32 * wide_width);

#if PRISM_BVH_W <= 8  // (quantized nodes are at most 8 wide: `lanes` is a byte)
// The compact layout (-DPRISM_BVH_QUANTIZED=1), after Ylitie et al. 2017
// ("Efficient Incoherent Ray Traversal on GPUs Through Compressed Wide BVHs")
// and Embree's compressed nodes: per node and axis an origin and a power-of-
// two scale 2^(e - 127) (e a byte: the bits of a float's exponent field; e = 0
// means scale 0), per child and axis two bytes q, the planes being
//   plane(q) = origin + q * scale.
// 128 bytes for 8 children (the boxes in the first cache line, the links in
// the second), 72 for 4.
//
// Why the box test stays conservative. (1) For 1 <= e <= 246 the product
// q * 2^(e - 127) (q < 256) is exact: 8 significant bits scaled by a power of
// two between 2^-126 and 2^119, so neither underflow nor overflow; for e = 0
// it is +0. So origin + q * scale has one rounding whether or not it is
// contracted to an FMA, and traversal (any SIMD path) computes bit for bit the
// plane that the builder computes with dequantize() below. (2) The builder
// checks those computed planes, not real-number ones: it picks for each child
// the largest q whose plane is <= the child's float min and the smallest whose
// plane is >= its float max (plane(q) is non-decreasing in q, rounding being
// monotonic; plane(0) = origin = the node's min and plane(255) >= the node's
// max by the choice of scale). So the box traversal tests contains the child's
// box. (3) On that float box the slab test is slab_lanes', robust in the
// sense of Ize 2013 (exact path: far distance widened by widen_exit;
// directed-FMA path: see WideRayPrecomp): no box the ray really enters is
// culled, and the entry distance it reports is at most the exact box's
// (within the rounding that the culling of deferred children allows for),
// so sorting and that culling stay conservative. An axis that cannot be quantized (non-finite or
// inverted child bounds, or an extent beyond 255 * 2^119) gets origin NaN:
// its planes are NaN, which the slab test ignores (every comparison with NaN
// keeps the running value), so that axis culls nothing. Unused lanes are not
// in `lanes` and are never entered.
struct alignas(wide_width == 8 ? 64 : 8) BVHQuantWideNode {
  static constexpr uint32_t interior = UINT32_MAX;
  Float origin[3];
  uint8_t exp[3];
  uint8_t lanes;                // bit l: lane l holds a child
  uint8_t q[6 * wide_width];    // q[2W * axis + W * side + lane], side 0 = min, 1 = max
  uint32_t child[wide_width];
  uint32_t count[wide_width];
};
static_assert(sizeof(BVHQuantWideNode) == 16 + 14 * wide_width);

// The plane q of an axis with the given origin and scale exponent byte.
inline Float quant_scale(uint8_t e) { return std::bit_cast<Float>(uint32_t(e) << 23); }
inline Float dequantize(Float origin, uint8_t e, int q) { return origin + Float(q) * quant_scale(e); }

// Fills the boxes of a quantized node from the k children's float boxes (see
// BVHQuantWideNode for why the result contains them); the links (child,
// count) are left as they are.
inline void set_boxes(BVHQuantWideNode& n, const Bounds3f* box, int k) {
  constexpr int W = wide_width;
  constexpr int max_e = 246;  // scale 2^119: 255 * scale stays below 2^127
  std::fill(std::begin(n.q), std::end(n.q), uint8_t(0));
  n.lanes = uint8_t((1u << k) - 1);
  for (int a = 0; a < 3; ++a) {
    uint8_t* qlo = n.q + 2 * W * a;
    uint8_t* qhi = qlo + W;
    Float lo = infinity, hi = -infinity;
    bool ok = k > 0;
    for (int l = 0; l < k; ++l) {
      Float bl = box[l].min[a], bh = box[l].max[a];
      if (!(std::isfinite(bl) && std::isfinite(bh) && bl <= bh)) ok = false;
      lo = std::min(lo, bl);
      hi = std::max(hi, bh);
    }
    int e = 0;
    if (ok && hi > lo) {
      // The smallest scale 2^s with 255 * 2^s >= hi - lo (in double: exact).
      int p;
      double m = std::frexp((double(hi) - double(lo)) / 255.0, &p);
      int s = std::max(m == 0.5 ? p - 1 : p, -126);
      e = s + 127;
      while (e <= max_e && dequantize(lo, uint8_t(e), 255) < hi) ++e;  // rounding (not expected)
      if (e > max_e) ok = false;
    }
    if (!ok) {
      n.origin[a] = std::numeric_limits<Float>::quiet_NaN();
      n.exp[a] = 0;
      continue;
    }
    n.origin[a] = lo;
    n.exp[a] = uint8_t(e);
    double scale = double(quant_scale(uint8_t(e)));
    auto plane = [&](int q) { return dequantize(lo, uint8_t(e), q); };
    for (int l = 0; l < k; ++l) {
      Float bl = box[l].min[a], bh = box[l].max[a];
      int ql = 0, qh = 0;
      if (scale > 0) {
        ql = int(std::clamp(std::floor((double(bl) - double(lo)) / scale), 0.0, 255.0));
        qh = int(std::clamp(std::ceil((double(bh) - double(lo)) / scale), 0.0, 255.0));
      }
      // The largest plane <= bl and the smallest >= bh (plane(0) = lo <= bl,
      // plane(255) >= hi >= bh).
      while (ql > 0 && plane(ql) > bl) --ql;
      while (ql < 255 && plane(ql + 1) <= bl) ++ql;
      while (qh < 255 && plane(qh) < bh) ++qh;
      while (qh > 0 && plane(qh - 1) >= bh) --qh;
      qlo[l] = uint8_t(ql);
      qhi[l] = uint8_t(qh);
    }
  }
}
// The box traversal tests for lane l (NaN planes on an unquantized axis).
inline Bounds3f dequantized_box(const BVHQuantWideNode& n, int l) {
  constexpr int W = wide_width;
  Bounds3f b;
  for (int a = 0; a < 3; ++a) {
    b.min[a] = dequantize(n.origin[a], n.exp[a], n.q[2 * W * a + l]);
    b.max[a] = dequantize(n.origin[a], n.exp[a], n.q[2 * W * a + W + l]);
  }
  return b;
}
// The box traversal tests for lane l of a node of either layout.
inline Bounds3f lane_box(const BVHQuantWideNode& n, int l) { return dequantized_box(n, l); }
#endif
inline Bounds3f lane_box(const BVHFloatWideNode& n, int l) {
  constexpr int W = wide_width;
  Bounds3f b;
  for (int a = 0; a < 3; ++a) {
    b.min[a] = n.b[2 * W * a + l];
    b.max[a] = n.b[2 * W * a + W + l];
  }
  return b;
}
// The same for a float node: lanes from k on get the empty box (+inf, -inf).
// A NaN bound (which the builder's unions never produce) is stored as an
// unbounded one, -inf or +inf: the exact slab test ignores NaN planes, the
// directed-FMA one needs them not to be NaN, and both then agree.
inline void set_boxes(BVHFloatWideNode& n, const Bounds3f* box, int k) {
  constexpr int W = wide_width;
  for (int l = 0; l < W; ++l)
    for (int a = 0; a < 3; ++a) {
      Float lo = l < k ? box[l].min[a] : infinity, hi = l < k ? box[l].max[a] : -infinity;
      n.b[2 * W * a + l] = std::isnan(lo) ? -infinity : lo;
      n.b[2 * W * a + W + l] = std::isnan(hi) ? infinity : hi;
    }
}

#if defined(PRISM_BVH_QUANTIZED) && PRISM_BVH_QUANTIZED
using BVHWideNode = BVHQuantWideNode;
#else
using BVHWideNode = BVHFloatWideNode;
#endif

#if defined(PRISM_BVH_SSE)
// The lanes of one box-test register: sixteen with AVX-512 nodes, eight with
// AVX nodes, four otherwise.
namespace bx {
#if defined(PRISM_BVH_ZMM_NODES)
using V = __m512;
using I = __m512i;
inline V set1(Float x) { return _mm512_set1_ps(x); }
inline V zero() { return _mm512_setzero_ps(); }
inline V sub(V a, V b) { return _mm512_sub_ps(a, b); }
inline V add(V a, V b) { return _mm512_add_ps(a, b); }
inline V mul(V a, V b) { return _mm512_mul_ps(a, b); }
inline V vmax(V a, V b) { return _mm512_maskz_max_ps(__mmask16(0xffff), a, b); }
inline V vmin(V a, V b) { return _mm512_maskz_min_ps(__mmask16(0xffff), a, b); }
inline void store(Float* p, V a) { _mm512_storeu_ps(p, a); }  // (unaligned: tests pass 32-byte arrays)
inline V load(const Float* p) { return _mm512_load_ps(p); }
inline I fmsub_bits(V a, V b, V c) { return _mm512_castps_si512(_mm512_fmsub_ps(a, b, c)); }
inline I bits(V a) { return _mm512_castps_si512(a); }
inline V as_v(I a) { return _mm512_castsi512_ps(a); }
inline I izero() { return _mm512_setzero_si512(); }
inline I imax(I a, I b) { return _mm512_maskz_max_epi32(__mmask16(0xffff), a, b); }
inline I imin(I a, I b) { return _mm512_maskz_min_epi32(__mmask16(0xffff), a, b); }
inline I iadd(I a, int k) { return _mm512_add_epi32(a, _mm512_set1_epi32(k)); }
inline I iadd(I a, I b) { return _mm512_add_epi32(a, b); }
inline void store_bits(Float* p, I a) { _mm512_storeu_ps(p, _mm512_castsi512_ps(a)); }
// Comparisons give mask registers, which are the lane masks themselves; no
// traversal reads a vector of the lanes entered (`inside`) here.
using M = __mmask16;
inline M le(V a, V b) { return _mm512_cmp_ps_mask(a, b, _CMP_LE_OQ); }
inline M igt(I a, I b) { return _mm512_cmpgt_epi32_mask(a, b); }
inline int movemask(M m) { return int(m); }
inline int sign_mask(M m) { return int(m); }
inline void keep_inside(V*, M) {}
#elif defined(PRISM_BVH_AVX_NODES)
using V = __m256;
inline V set1(Float x) { return _mm256_set1_ps(x); }
inline V zero() { return _mm256_setzero_ps(); }
inline V sub(V a, V b) { return _mm256_sub_ps(a, b); }
inline V add(V a, V b) { return _mm256_add_ps(a, b); }
inline V mul(V a, V b) { return _mm256_mul_ps(a, b); }
inline V vmax(V a, V b) { return _mm256_max_ps(a, b); }
inline V vmin(V a, V b) { return _mm256_min_ps(a, b); }
inline V le(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }  // a <= b (NaN: false)
inline int movemask(V a) { return _mm256_movemask_ps(a); }
inline void store(Float* p, V a) { _mm256_store_ps(p, a); }
inline V load(const Float* p) { return _mm256_load_ps(p); }
// Eight bytes as eight floats.
inline V load_u8(const uint8_t* p) {
#if defined(__AVX2__)
  return _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p))));
#else
  __m128i b = _mm_loadl_epi64(reinterpret_cast<const __m128i*>(p));
  __m128i lo = _mm_cvtepu8_epi32(b), hi = _mm_cvtepu8_epi32(_mm_srli_si128(b, 4));
  return _mm256_cvtepi32_ps(_mm256_insertf128_si256(_mm256_castsi128_si256(lo), hi, 1));
#endif
}
// org + q * scale (q * scale exact for quantized planes: fused or not, one rounding).
inline V plane(V q, V scale, V org) {
#if defined(__FMA__)
  return _mm256_fmadd_ps(q, scale, org);
#else
  return _mm256_add_ps(org, _mm256_mul_ps(q, scale));
#endif
}
#if defined(PRISM_BVH_FMA_SLABS)
using I = __m256i;
inline I fmsub_bits(V a, V b, V c) { return _mm256_castps_si256(_mm256_fmsub_ps(a, b, c)); }
inline I bits(V a) { return _mm256_castps_si256(a); }
inline V as_v(I a) { return _mm256_castsi256_ps(a); }
inline I izero() { return _mm256_setzero_si256(); }
inline I imax(I a, I b) { return _mm256_max_epi32(a, b); }
inline I imin(I a, I b) { return _mm256_min_epi32(a, b); }
inline I iadd(I a, int k) { return _mm256_add_epi32(a, _mm256_set1_epi32(k)); }
inline I iadd(I a, I b) { return _mm256_add_epi32(a, b); }
inline I igt(I a, I b) { return _mm256_cmpgt_epi32(a, b); }
inline int sign_mask(I a) { return _mm256_movemask_ps(_mm256_castsi256_ps(a)); }
inline void store_bits(Float* p, I a) { _mm256_store_ps(p, _mm256_castsi256_ps(a)); }
#endif
#else
using V = __m128;
inline V set1(Float x) { return _mm_set1_ps(x); }
inline V zero() { return _mm_setzero_ps(); }
inline V sub(V a, V b) { return _mm_sub_ps(a, b); }
inline V add(V a, V b) { return _mm_add_ps(a, b); }
inline V mul(V a, V b) { return _mm_mul_ps(a, b); }
inline V vmax(V a, V b) { return _mm_max_ps(a, b); }
inline V vmin(V a, V b) { return _mm_min_ps(a, b); }
inline V le(V a, V b) { return _mm_cmple_ps(a, b); }  // a <= b (NaN: false)
inline int movemask(V a) { return _mm_movemask_ps(a); }
inline void store(Float* p, V a) { _mm_store_ps(p, a); }
inline V load(const Float* p) { return _mm_load_ps(p); }
// Four bytes as four floats (SSE2 unpacking).
inline V load_u8(const uint8_t* p) {
  int32_t v;
  std::memcpy(&v, p, 4);
  __m128i z = _mm_setzero_si128();
  return _mm_cvtepi32_ps(_mm_unpacklo_epi16(_mm_unpacklo_epi8(_mm_cvtsi32_si128(v), z), z));
}
inline V plane(V q, V scale, V org) { return _mm_add_ps(org, _mm_mul_ps(q, scale)); }
#if defined(PRISM_BVH_FMA_SLABS)
using I = __m128i;
inline I fmsub_bits(V a, V b, V c) { return _mm_castps_si128(_mm_fmsub_ps(a, b, c)); }
inline I bits(V a) { return _mm_castps_si128(a); }
inline V as_v(I a) { return _mm_castsi128_ps(a); }
inline I izero() { return _mm_setzero_si128(); }
inline I imax(I a, I b) { return _mm_max_epi32(a, b); }
inline I imin(I a, I b) { return _mm_min_epi32(a, b); }
inline I iadd(I a, int k) { return _mm_add_epi32(a, _mm_set1_epi32(k)); }
inline I iadd(I a, I b) { return _mm_add_epi32(a, b); }
inline I igt(I a, I b) { return _mm_cmpgt_epi32(a, b); }
inline int sign_mask(I a) { return _mm_movemask_ps(_mm_castsi128_ps(a)); }
inline void store_bits(Float* p, I a) { _mm_store_ps(p, _mm_castsi128_ps(a)); }
#endif
#endif
#if !defined(PRISM_BVH_ZMM_NODES)
// Hands the vector of the lanes entered to a caller that asks for it.
inline void keep_inside(V* inside, V in) {
  if (inside) *inside = in;
}
#if defined(PRISM_BVH_FMA_SLABS)
inline void keep_inside(V* inside, I in) { keep_inside(inside, as_v(in)); }
#endif
#endif
}  // namespace bx
#endif

// Per-ray data for the lane-parallel box tests: the offsets in BVHWideNode::b
// of the near and far slab planes per axis, chosen by the direction's sign as
// in intersect_node.
//
// With AVX2 and FMA (PRISM_BVH_FMA_SLABS) a ray normally takes a shorter
// path: the distance to a plane b is one FMA, b * inv - c, and the entry and
// exit distances are combined with integer max and min (for floats that are
// not NaN, the signed-integer order of their bits is their order as numbers,
// with every negative value below +0). It stays conservative (Ize 2013's
// concern) as follows. Let T = (b - o) / d be the exact distance, u = 2^-24,
// and inv = fl(1 / d), so inv d is in [1 - u, 1 + u].
// - c_near is fl(o inv) moved up by two ulps, so c_near >= o inv plus at
//   least half an ulp; the FMA's exact value b inv - c_near is then at most
//   (b - o) inv = T (inv d), and after its one rounding the near distance is
//   at most T (1 + u)^2 for T >= 0 (half a subnormal ulp is covered by the
//   slack of c_near) and at most 0 for T <= 0.
// - c_far is fl(o inv) moved down by two ulps: the far distance is at least
//   T (1 - u)^2 for T >= 0, and negative only when T is.
// So the computed entry is at most E (1 + u)^2 and the computed exit at least
// X (1 - u)^2, E and X the exact entry and exit; the test compares the entry
// with the exit raised by five ulps (five added to its bits: at least a
// factor 1 + 5u > (1 + u)^2 / (1 - u)^2), and a box that the exact ray meets
// before t_max is entered. For rays with a zero (or nearly zero) direction
// component, an origin so far out that o inv nears overflow (|inv| or |c|
// beyond 2^100), or NaNs, `fast` is false and the exact form of
// intersect_node is used instead. The argument assumes the IEEE default
// mode (round to nearest, no flush-to-zero or denormals-are-zero: the slack
// of c is subnormal near zero) and t_max >= +0.

struct WideRayPrecomp {
#if defined(PRISM_BVH_SSE)
  bx::V o[3], inv_d[3];
#if defined(PRISM_BVH_FMA_SLABS)
  bx::V c_near[3], c_far[3];
  bx::V six;  // integer 6 in every lane (a memory operand in the loop, not rebuilt per visit)
#endif
#else
  Float o[3], inv_d[3];
#endif
  std::ptrdiff_t near_off[3], far_off[3];  // pointer-sized: no sign extension per load
  bool fast = false;  // the directed-FMA path (PRISM_BVH_FMA_SLABS only)
  // From a ray: the same values as from RayBoxPrecomp(org, d), in fewer steps
  // (one division for the three axes where SSE is available).
  WideRayPrecomp(const Point3f& org, const Vector3f& d) {
#if defined(PRISM_BVH_SSE)
    init(_mm_setr_ps(org.x, org.y, org.z, 0), _mm_div_ps(_mm_set1_ps(1), _mm_setr_ps(d.x, d.y, d.z, 1)));
#else
    init(RayBoxPrecomp(org, d));
#endif
  }
  explicit WideRayPrecomp(const RayBoxPrecomp& r) {
#if defined(PRISM_BVH_SSE)
    init(_mm_setr_ps(r.o[0], r.o[1], r.o[2], 0), _mm_setr_ps(r.inv_d[0], r.inv_d[1], r.inv_d[2], 1));
#else
    init(r);
#endif
  }

 private:
  void set_offsets(int neg) {  // bit a of neg: the direction's axis a is negative (RayBoxPrecomp::sign)
    for (int a = 0; a < 3; ++a) {
      near_off[a] = 2 * wide_width * a + wide_width * ((neg >> a) & 1);
      far_off[a] = near_off[a] ^ wide_width;  // the other half of the axis's 2 wide_width planes
    }
  }
#if defined(PRISM_BVH_SSE)
  // org and inv: the origin and 1 / d in lanes 0-2, lane 3 = 0 and 1.
  void init(__m128 org, __m128 inv) {
    alignas(16) Float ov[4], iv[4];
    _mm_store_ps(ov, org);
    _mm_store_ps(iv, inv);
    for (int a = 0; a < 3; ++a) {
      o[a] = bx::set1(ov[a]);
      inv_d[a] = bx::set1(iv[a]);
    }
    set_offsets(_mm_movemask_ps(_mm_cmplt_ps(inv, _mm_setzero_ps())));
#if defined(PRISM_BVH_FMA_SLABS)
    // The next float above x (x finite; -0 is taken as +0 first): the
    // magnitude is in the low bits.
    auto up = [](__m128 x) {
      __m128i b = _mm_castps_si128(_mm_add_ps(x, _mm_setzero_ps()));
      __m128i step = _mm_or_si128(_mm_srai_epi32(b, 31), _mm_set1_epi32(1));  // -1 if negative, else +1
      return _mm_castsi128_ps(_mm_add_epi32(b, step));
    };
    const __m128 neg = _mm_set1_ps(-0.0f);
    const __m128 p = _mm_mul_ps(org, inv);
    const __m128 cn = up(up(p));
    const __m128 cf = _mm_xor_ps(up(up(_mm_xor_ps(p, neg))), neg);
    // All finite and in range: |inv| in [2^-100, 2^100), |c| < 2^100.
    const __m128 lim = _mm_set1_ps(0x1p100f);
    auto mag = [&](__m128 x) { return _mm_andnot_ps(neg, x); };
    __m128 ok = _mm_and_ps(_mm_cmplt_ps(mag(inv), lim), _mm_cmpge_ps(mag(inv), _mm_set1_ps(0x1p-100f)));
    ok = _mm_and_ps(ok, _mm_and_ps(_mm_cmplt_ps(mag(cn), lim), _mm_cmplt_ps(mag(cf), lim)));
    fast = (_mm_movemask_ps(ok) & 7) == 7;
    six = bx::as_v(bx::iadd(bx::izero(), 6));
    alignas(16) Float v[2][4];
    _mm_store_ps(v[0], cn);
    _mm_store_ps(v[1], cf);
    for (int a = 0; a < 3; ++a) {
      c_near[a] = bx::set1(v[0][a]);
      c_far[a] = bx::set1(v[1][a]);
    }
#endif
  }
#else
  void init(const RayBoxPrecomp& r) {
    for (int a = 0; a < 3; ++a) {
      o[a] = r.o[a];
      inv_d[a] = r.inv_d[a];
    }
    set_offsets(r.sign[0] | r.sign[1] << 1 | r.sign[2] << 2);
  }
#endif
};

// The slab test of a wide node's lanes, given their near and far planes per
// axis: returns the mask of lanes entered before t_cull = widen_exit(t_max)
// and writes their entry distances to t_entry.
//
// On the exact path, the operations and their order (including which operand
// wins a comparison with a NaN) are intersect_node's, so every lane's mask bit
// and entry distance are bit for bit intersect_node's with t_max: max(a, b)
// below is a > b ? a : b and min(a, b) is a < b ? a : b, lane by lane, and
// min(widen_exit(A), widen_exit(t_max)) = widen_exit(min(A, t_max)) because
// rounding is monotonic.
// On the directed-FMA path (WideRayPrecomp::fast) the entry distance is at
// most the exact one times (1 + u)^2 and no box the exact ray meets is culled;
// t_cull also keeps its widening there, which covers the rounding of the
// triangle test's t (a hit computed before t_max is never culled).
#if defined(PRISM_BVH_SSE)
// `inside`, if given, gets the lanes entered as a vector, each lane all ones
// or all zeros (the mask's bits). It is written when given, and
// slab_lane_groups gives it only when a node's lanes fill one register; only
// the AVX2 ordering of 8-wide nodes reads it (push_by_distance), which then
// need not rebuild it from the mask.
// Every lane's entry distance, entered or not, is >= +0 (sign bit clear):
// t0 starts at +0 and a NaN plane distance never wins the max.
inline int slab_lanes(const bx::V* pn, const bx::V* pf, const WideRayPrecomp& r, Float t_cull, Float* t_entry,
                      bx::V* inside = nullptr) {
  using namespace bx;
#if defined(PRISM_BVH_FMA_SLABS)
  if (r.fast) {
    I tn[3], tf[3];
    for (int a = 0; a < 3; ++a) {
      tn[a] = fmsub_bits(pn[a], r.inv_d[a], r.c_near[a]);
      tf[a] = fmsub_bits(pf[a], r.inv_d[a], r.c_far[a]);
    }
    // No NaN can arise (b finite or infinite, inv and c finite and nonzero).
    I t0 = imax(imax(tn[0], tn[1]), imax(tn[2], izero()));
    I t1 = imin(imin(tf[0], tf[1]), imin(tf[2], bits(set1(t_cull))));
    store_bits(t_entry, t0);
    // Entered: t0 <= t1 raised by five ulps (see WideRayPrecomp), i.e.
    // t1 + 6 > t0 as integers (t1 is at most +inf, so no overflow). t0 >=
    // +0, so t0 <= t1 as numbers exactly when it is as integers. A negative
    // t1 culls, rightly: a far distance is negative (never -0) only when the
    // exact exit is, and t_cull only for a t_max below -2^-147 (a t_max of
    // +-0 gives a small positive t_cull); +inf + 5 ulps is a positive NaN
    // pattern, above every t0. (One comparison whose result is the mask: its
    // complement cost two more operations per visit; ab 1.01-1.02.)
    const auto in = igt(iadd(t1, bits(r.six)), t0);
    keep_inside(inside, in);
    return sign_mask(in);
  }
#endif
  V t0 = zero();
  V t1 = set1(infinity);
  for (int a = 0; a < 3; ++a) {
    V tn = mul(sub(pn[a], r.o[a]), r.inv_d[a]);
    V tf = mul(sub(pf[a], r.o[a]), r.inv_d[a]);
    t0 = vmax(tn, t0);
    t1 = vmin(tf, t1);
  }
  // widen_exit, lane by lane, then min with t_cull.
  t1 = vmin(mul(add(t1, set1(box_exit_slack)), set1(box_exit_widen)), set1(t_cull));
  store(t_entry, t0);
  const auto in = le(t0, t1);
  keep_inside(inside, in);
  return movemask(in);
}
#else
// One lane from its planes (the portable build: the exact path only).
inline bool slab_lane(const Float* pn, const Float* pf, const WideRayPrecomp& r, Float t_cull, Float* t_entry) {
  Float t0 = 0, t1 = infinity;
  for (int a = 0; a < 3; ++a) {
    Float tn = (pn[a] - r.o[a]) * r.inv_d[a];
    Float tf = (pf[a] - r.o[a]) * r.inv_d[a];
    t0 = tn > t0 ? tn : t0;
    t1 = tf < t1 ? tf : t1;
  }
  t1 = widen_exit(t1);
  t1 = t1 < t_cull ? t1 : t_cull;
  *t_entry = t0;
  return t0 <= t1;
}
#endif

// The slab test of every lane of a wide node, a register of lanes at a time
// (sixteen with AVX-512 nodes, eight with AVX nodes, four with SSE, one in the
// portable build):
// planes(h, pn, pf) writes the near and far planes per axis of the lanes
// from h on.
//
// `inside` gets the lanes entered as a vector (see slab_lanes) when a node's
// lanes fill one AVX or SSE register (8-wide nodes on AVX, 4-wide on SSE);
// it is left as it was otherwise (16-wide nodes on AVX-512 too, whose
// verdicts are a mask register). Whether a quantized node's unused lanes
// are cleared in it depends on the build: see intersect_wide. Traversal
// reads it only under PRISM_BVH_SORT_AVX2.
#if defined(PRISM_BVH_SSE)
using LaneMaskV = bx::V;
#else
using LaneMaskV = Float;  // (not used: the portable build has no lane vectors)
#endif
template <class Planes>
inline int slab_lane_groups(const WideRayPrecomp& r, Float t_cull, Float* t_entry, Planes&& planes,
                            [[maybe_unused]] LaneMaskV* inside) {
  int mask = 0;
#if defined(PRISM_BVH_SSE)
  constexpr int G = int(sizeof(bx::V) / sizeof(Float));
  if constexpr (G == wide_width) {
    bx::V pn[3], pf[3];
    planes(0, pn, pf);
    return slab_lanes(pn, pf, r, t_cull, t_entry, inside);
  }
  for (int h = 0; h < wide_width; h += G) {
    bx::V pn[3], pf[3];
    planes(h, pn, pf);
    mask |= slab_lanes(pn, pf, r, t_cull, t_entry + h) << h;
  }
#else
  for (int l = 0; l < wide_width; ++l) {
    Float pn[3], pf[3];
    planes(l, pn, pf);
    if (slab_lane(pn, pf, r, t_cull, t_entry + l)) mask |= 1 << l;
  }
#endif
  return mask;
}

// The slab test of every lane of a float node (see slab_lanes).
inline int intersect_wide(const BVHFloatWideNode& n, const WideRayPrecomp& r, Float t_cull, Float* t_entry,
                          LaneMaskV* inside = nullptr) {
  return slab_lane_groups(r, t_cull, t_entry, [&](int h, auto* pn, auto* pf) {
    for (int a = 0; a < 3; ++a) {
#if defined(PRISM_BVH_SSE)
      pn[a] = bx::load(n.b + r.near_off[a] + h);
      pf[a] = bx::load(n.b + r.far_off[a] + h);
#else
      pn[a] = n.b[r.near_off[a] + h];
      pf[a] = n.b[r.far_off[a] + h];
#endif
    }
  }, inside);
}

#if defined(PRISM_BVH_AVX_NODES) && defined(__AVX2__)
// The vector of the lanes in `mask`: all ones in lane l when bit l is set.
inline __m256 lanes_inside(unsigned mask) {
  const __m256i bit = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
  return _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(int(mask)), bit), bit));
}
#endif

#if PRISM_BVH_W <= 8  // (quantized nodes)
// The same for a quantized node: each lane's planes are dequantized (exactly
// as dequantize() computes them) and then tested as above, so every lane's
// result is the float node's on the box dequantized_box() gives. An axis that
// could not be quantized (origin NaN) is unbounded: NaN planes in the portable
// build (ignored by the exact test), infinite ones in the SIMD builds (the
// directed-FMA path needs planes that are not NaN).
inline int intersect_wide(const BVHQuantWideNode& n, const WideRayPrecomp& r, Float t_cull, Float* t_entry,
                          LaneMaskV* inside = nullptr) {
  int mask = slab_lane_groups(r, t_cull, t_entry, [&](int h, auto* pn, auto* pf) {
    for (int a = 0; a < 3; ++a) {
#if defined(PRISM_BVH_SSE)
      if (std::isnan(n.origin[a])) {
        bool lo_near = r.near_off[a] % (2 * wide_width) == 0;
        pn[a] = bx::set1(lo_near ? -infinity : infinity);
        pf[a] = bx::set1(lo_near ? infinity : -infinity);
        continue;
      }
      const bx::V org = bx::set1(n.origin[a]), scale = bx::set1(quant_scale(n.exp[a]));
      pn[a] = bx::plane(bx::load_u8(n.q + r.near_off[a] + h), scale, org);
      pf[a] = bx::plane(bx::load_u8(n.q + r.far_off[a] + h), scale, org);
#else
      pn[a] = dequantize(n.origin[a], n.exp[a], n.q[r.near_off[a] + h]);
      pf[a] = dequantize(n.origin[a], n.exp[a], n.q[r.far_off[a] + h]);
#endif
    }
  }, inside);
#if defined(PRISM_BVH_AVX_NODES) && defined(__AVX2__)
  // Without the unused lanes, in the one build that reads `inside`
  // (PRISM_BVH_SORT_AVX2); elsewhere it holds only the box test's result.
  if (inside) {
    *inside = _mm256_and_ps(*inside, lanes_inside(n.lanes));
  }
#endif
  return mask & n.lanes;
}
#endif

// Starts loading a wide node that traversal has deferred, so that it is in
// cache by the time the stack hands it back.
inline void prefetch(const BVHWideNode* n) {
  // Every cache line the node touches. A node aligned to whole lines covers
  // a fixed number of them (a loop the compiler unrolls: this runs per
  // deferred child); a 72-byte node may straddle three.
  constexpr bool whole_lines = alignof(BVHWideNode) % 64 == 0 && sizeof(BVHWideNode) % 64 == 0;
  uintptr_t first = reinterpret_cast<uintptr_t>(n) & ~uintptr_t(63);
  uintptr_t end = whole_lines ? first + sizeof(BVHWideNode)
                              : ((reinterpret_cast<uintptr_t>(n) + sizeof(BVHWideNode) - 1) & ~uintptr_t(63)) + 64;
  for (uintptr_t at = first; at < end; at += 64) {
    const char* line = reinterpret_cast<const char*>(at);
#if defined(PRISM_BVH_SSE)
    _mm_prefetch(line, _MM_HINT_T0);
#elif defined(__GNUC__) || defined(__clang__)
    __builtin_prefetch(line);
#endif
  }
}

// Asks for the cache line of a node's child[0]: with 8 lanes the line of all
// its links (child, count), the last of a float node's four lines and the
// second of a quantized node's two; with 16 lanes the children's line
// (asking for the counts' too measured nothing).
inline void prefetch_links(const BVHWideNode* n) {
  const char* line = reinterpret_cast<const char*>(n->child);
#if defined(PRISM_BVH_SSE)
  _mm_prefetch(line, _MM_HINT_T0);
#elif defined(__GNUC__) || defined(__clang__)
  __builtin_prefetch(line);
#endif
}

// Two entered lanes a < b in order of entry distance, nearer first (equal
// distances keep lane order), without a branch: GCC 12 compiles a selection
// on a float comparison into one, a coin toss for incoherent rays. Entry
// distances are >= +0, so their bits order like them. Any hit uses it (ab:
// shadow rays 1.028); closest hit keeps the branch, which primary rays
// predict well (this form there: primary 0.969, incoherent 0.999).
inline void nearer_first(const Float* t_entry, int& a, int& b) {
  const uint32_t ta = std::bit_cast<uint32_t>(t_entry[a]), tb = std::bit_cast<uint32_t>(t_entry[b]);
  const int x = (a ^ b) & -int(tb < ta);
  a ^= x;
  b ^= x;
}

// Closest-hit ordering (see the AVX2 form below) without SIMD, for builds
// without AVX2 and for 16-wide nodes with more than eight lanes entered:
// (distance, lane) keys sorted by insertion (distances are >= +0, so their
// bit patterns order like their values; ties keep lane order), then written
// farthest first. The vector of lanes not entered is not needed here.
template <bool with_t = true>
inline int push_by_distance_scalar(const BVHWideNode& node, unsigned mask, const Float* t_entry, uint32_t* child,
                                   uint32_t* count, Float* t) {
  uint64_t key[wide_width] = {};  // (initialised: mask is never 0, but GCC cannot tell)
  int n = 0;
  for (; mask != 0; mask &= mask - 1) {
    int c = std::countr_zero(mask);
    uint64_t kc = uint64_t(std::bit_cast<uint32_t>(t_entry[c])) << 32 | uint64_t(c);
    int j = n++;
    for (; j > 0 && kc < key[j - 1]; --j) key[j] = key[j - 1];
    key[j] = kc;
  }
  for (int j = n - 1, s = 0; j > 0; --j, ++s) {
    int c = int(key[j] & 0xff);
    child[s] = node.child[c];
    count[s] = node.count[c];
    if constexpr (with_t) t[s] = t_entry[c];
  }
  return int(key[0] & 0xff);
}

#if defined(__AVX2__) && (defined(PRISM_BVH_AVX_NODES) || defined(PRISM_BVH_ZMM_NODES))
// Eight int32 keys in ascending order: Batcher's odd-even merge sort, 19
// comparators in 6 layers, each layer a permutation to the partner lane, a
// min, a max and a blend keeping the max in the upper lane of each pair.
inline __m256i sort8(__m256i x) {
  auto layer = [](__m256i v, __m256i partner, auto hi_lanes) {
    __m256i y = _mm256_permutevar8x32_epi32(v, partner);
    return _mm256_blend_epi32(_mm256_min_epi32(v, y), _mm256_max_epi32(v, y), decltype(hi_lanes)::value);
  };
  using std::integral_constant;
  x = layer(x, _mm256_setr_epi32(2, 3, 0, 1, 6, 7, 4, 5), integral_constant<int, 0xCC>{});
  x = layer(x, _mm256_setr_epi32(4, 5, 6, 7, 0, 1, 2, 3), integral_constant<int, 0xF0>{});
  x = layer(x, _mm256_setr_epi32(1, 0, 3, 2, 5, 4, 7, 6), integral_constant<int, 0xAA>{});
  x = layer(x, _mm256_setr_epi32(0, 1, 4, 5, 2, 3, 6, 7), integral_constant<int, 0x30>{});
  x = layer(x, _mm256_setr_epi32(0, 4, 2, 6, 1, 5, 3, 7), integral_constant<int, 0x50>{});
  x = layer(x, _mm256_setr_epi32(0, 2, 1, 4, 3, 6, 5, 7), integral_constant<int, 0x54>{});
  return x;
}
// The smallest of eight int32 keys, in three steps (the sort takes six).
inline int min_key8(__m256i k) {
  __m256i m = _mm256_min_epi32(k, _mm256_permute2x128_si256(k, k, 0x01));
  m = _mm256_min_epi32(m, _mm256_shuffle_epi32(m, 0x4E));
  m = _mm256_min_epi32(m, _mm256_shuffle_epi32(m, 0xB1));
  return _mm256_cvtsi256_si32(m);
}
#endif

#if defined(PRISM_BVH_AVX_NODES) && defined(__AVX2__)
#define PRISM_BVH_SORT_AVX2 1

// Closest-hit ordering of a node's entered lanes (`mask`, two or more) without
// branches: the lanes sorted by entry distance (ties, and distances within 8
// ulps, by lane: the key is the distance's bits with the lane in the low
// three), all but the nearest written farthest first to child/count/t (eight
// entries are stored; those past the entered ones are scratch). Returns the
// nearest lane. Entry distances are >= +0, so their bits order like them.
// Precondition: every lane of t_entry, entered or not, has its sign bit clear
// (slab_lanes guarantees it): a lane not entered gets its key by OR with
// INT32_MAX, which leaves a set sign bit set and would sort it first.
// Without `with_t` (any hit, which culls nothing it has pushed), t is neither
// written nor needed. `inside` is intersect_wide's vector of the lanes
// entered (mask's bits), each lane all ones or all zeros.
template <bool with_t = true>
inline int push_by_distance(const BVHWideNode& node, unsigned mask, __m256 inside, const Float* t_entry,
                            uint32_t* child, uint32_t* count, Float* t) {
  const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i tv = _mm256_load_si256(reinterpret_cast<const __m256i*>(t_entry));
  // Lanes not entered get INT32_MAX (every bit but the sign bit set).
  __m256i key = _mm256_or_si256(_mm256_andnot_si256(_mm256_set1_epi32(7), tv), lane);
  key = _mm256_or_si256(key, _mm256_andnot_si256(_mm256_castps_si256(inside), _mm256_set1_epi32(INT32_MAX)));
  const __m256i by_distance = _mm256_and_si256(sort8(key), _mm256_set1_epi32(7));
  // Slot j of the push holds the (n - 1 - j)-th nearest (n entered lanes).
  const int n = std::popcount(mask);
  const __m256i slot = _mm256_permutevar8x32_epi32(by_distance, _mm256_sub_epi32(_mm256_set1_epi32(n - 1), lane));
  auto gather = [&](const void* p) {
    return _mm256_permutevar8x32_epi32(_mm256_loadu_si256(static_cast<const __m256i*>(p)), slot);
  };
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(child), gather(node.child));
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(count), gather(node.count));
  if constexpr (with_t) _mm256_storeu_si256(reinterpret_cast<__m256i*>(t), _mm256_permutevar8x32_epi32(tv, slot));
  // The nearest lane, the sort's first, by a horizontal minimum of the keys
  // (unique: the lane is in them): three steps instead of the sort's six, so
  // that traversal can go on to the nearest child before the sort is done.
  return min_key8(key) & 7;
}

// The lanes of a node that hold inner nodes (bit l for lane l).
inline unsigned inner_lanes(const BVHWideNode& node) {
  __m256i c = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(node.count));
  return unsigned(_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(c, _mm256_set1_epi32(-1)))));
}
#elif defined(PRISM_BVH_ZMM_NODES)
// 16-wide nodes: the same ordering, the keys with the lane in their low four
// bits. The entered lanes' keys are packed into the low eight lanes and
// sorted by the 8-key network when at most eight are entered (the usual
// case: the mask-register compress leaves the others INT32_MAX), by
// insertion otherwise. Eight entries are stored, as above. (The all-lanes
// masked forms of the intrinsics are the plain instructions; GCC 12 takes
// the plain forms' undefined pass-through register for an uninitialised
// read, -Wmaybe-uninitialized.)
template <bool with_t = true>
inline int push_by_distance(const BVHWideNode& node, unsigned mask, LaneMaskV /*inside*/, const Float* t_entry,
                            uint32_t* child, uint32_t* count, Float* t) {
  const int n = std::popcount(mask);
  if (n > 8) return push_by_distance_scalar<with_t>(node, mask, t_entry, child, count, t);
  const __mmask16 all = 0xffff;
  auto low8 = [](__m512i v) { return _mm512_maskz_extracti64x4_epi64(__mmask8(0xff), v, 0); };
  const __m512i lane = _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15);
  const __m512i tv = _mm512_loadu_si512(t_entry);
  const __m512i key = _mm512_or_si512(_mm512_maskz_andnot_epi32(all, _mm512_set1_epi32(15), tv), lane);
  const __m256i packed = low8(_mm512_mask_compress_epi32(_mm512_set1_epi32(INT32_MAX), __mmask16(mask), key));
  const __m256i by_distance = _mm256_and_si256(sort8(packed), _mm256_set1_epi32(15));
  // Slot j of the push holds the (n - 1 - j)-th nearest; lanes 8-15 of the
  // index vector are undefined and their results unused.
  const __m512i slot = _mm512_castsi256_si512(_mm256_permutevar8x32_epi32(
      by_distance, _mm256_sub_epi32(_mm256_set1_epi32(n - 1), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7))));
  auto gather = [&](const void* p) { return low8(_mm512_maskz_permutexvar_epi32(all, slot, _mm512_loadu_si512(p))); };
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(child), gather(node.child));
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(count), gather(node.count));
  if constexpr (with_t) _mm256_storeu_si256(reinterpret_cast<__m256i*>(t), gather(t_entry));
  return min_key8(packed) & 15;  // the nearest lane
}
// The lanes of a node that hold inner nodes (bit l for lane l).
inline unsigned inner_lanes(const BVHWideNode& node) {
  return unsigned(_mm512_cmpeq_epi32_mask(_mm512_loadu_si512(node.count), _mm512_set1_epi32(-1)));
}
#else
template <bool with_t = true>
inline int push_by_distance(const BVHWideNode& node, unsigned mask, LaneMaskV /*inside*/, const Float* t_entry,
                            uint32_t* child, uint32_t* count, Float* t) {
  return push_by_distance_scalar<with_t>(node, mask, t_entry, child, count, t);
}
inline unsigned inner_lanes(const BVHWideNode& node) {
  unsigned m = 0;
  for (int l = 0; l < wide_width; ++l) m |= unsigned(node.count[l] == BVHWideNode::interior) << l;
  return m;
}
#endif

// push_by_distance with the vector of lanes entered built from the mask,
// for callers without intersect_wide's vector.
template <bool with_t = true>
inline int push_by_distance(const BVHWideNode& node, unsigned mask, const Float* t_entry, uint32_t* child,
                            uint32_t* count, Float* t) {
#if defined(PRISM_BVH_SORT_AVX2)
  return push_by_distance<with_t>(node, mask, lanes_inside(mask), t_entry, child, count, t);
#else
  return push_by_distance<with_t>(node, mask, LaneMaskV{}, t_entry, child, count, t);
#endif
}

}  // namespace detail

class BVH {
 public:
  // Depth is at most 48 SAH levels plus 32 halvings (see Builder::max_sah_depth).
  static constexpr int traversal_stack_size = 96;
  // The wide layout is no deeper than the binary tree; a visit defers at most wide_width - 1 children.
  static constexpr int wide_stack_size = (detail::wide_width - 1) * traversal_stack_size + detail::wide_width;
  BVH() = default;

  // Builds over primitives with the given bounds. Empty input gives an empty BVH.
  static BVH build(std::span<const Bounds3f> prim_bounds, const BVHBuildOptions& opt = {}) {
    return build(prim_bounds.size(), [prim_bounds](size_t i) { return prim_bounds[i]; }, opt);
  }
  // The same, with the bounds of primitive i given by bounds_of(i) (called once
  // per primitive, possibly from several threads), so that callers need not
  // store them.
  template <class BoundsOf>
    requires std::is_invocable_r_v<Bounds3f, BoundsOf&, size_t>
  static BVH build(size_t n, BoundsOf&& bounds_of, const BVHBuildOptions& opt = {}) {
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

  // A BVH from a binary tree built elsewhere (accel/sbvh.hpp, whose spatial
  // splits make references that a build over boxes cannot): `nodes` as
  // nodes() holds them, in depth-first pre-order (an interior node's first
  // child follows it and `offset` is its second child; a leaf covers entries
  // [offset, offset + count) of leaf_prims), leaf_prims the primitive numbers
  // in leaf order. opt.leaf_block and keep_binary_tree apply as in build().
  // Throws prism::Error if the tree is not one: an index out of range, a
  // node reached twice or never, an entry in two leaves or in none, a depth
  // beyond what traversal's stack holds (Builder::max_sah_depth + 32), or
  // leaves that padded to blocks hold more than 2^32 - 1 entries.
  static BVH from_binary_tree(std::vector<BVHNode> nodes, std::span<const uint32_t> leaf_prims,
                              const BVHBuildOptions& opt = {}) {
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

  // Refit after the primitives moved (a deforming mesh): the same tree over
  // the new bounds, bounds_of(i) giving input primitive i's (called from
  // several threads). Every wide node's boxes are recomputed bottom-up: leaf
  // lanes from their primitives, inner lanes from the child node's box, so
  // queries are exact; the SAH quality of the old topology may degrade if the
  // motion reshuffles primitives (rebuild then). A kept binary tree
  // (BVHBuildOptions::keep_binary_tree) is refitted too.
  template <class BoundsOf>
    requires std::is_invocable_r_v<Bounds3f, BoundsOf&, size_t>
  void refit(BoundsOf&& bounds_of, int threads = 0) {
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

 private:
  template <class BoundsOf>
  void refit_layouts(BoundsOf&& bounds_of, int threads) {
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

 public:

  bool empty() const { return m_wide.empty(); }
  // The binary tree the traversal layout was derived from; empty unless the
  // build kept it (BVHBuildOptions::keep_binary_tree).
  const std::vector<BVHNode>& nodes() const { return m_nodes; }
  // Leaf order: primitive k of a leaf range is the input primitive prims()[k].
  const std::vector<uint32_t>& prims() const { return m_prims; }
  Bounds3f bounds() const { return m_bounds; }
  // Bytes held: the wide traversal layout, the leaf order and the binary tree if kept.
  size_t memory_bytes() const {
    return m_nodes.size() * sizeof(BVHNode) + m_wide.size() * sizeof(detail::BVHWideNode) +
           m_prims.size() * sizeof(uint32_t);
  }
  size_t wide_node_count() const { return m_wide.size(); }
  // The traversal layout (detail::BVHWideNode), for inspection and tests.
  std::span<const detail::BVHWideNode> wide_nodes() const { return m_wide; }

  // Closest hit. isect(k, t_max) tests leaf-order primitive k and, on a hit
  // closer than t_max, lowers t_max and returns true. Children are visited
  // nearest entry first; a deferred child is skipped once a closer hit makes it
  // unreachable.
  template <class F>
  bool intersect(const Point3f& o, const Vector3f& d, Float& t_max, F&& isect) const {
    if (m_wide.empty()) return false;
    return intersect(detail::WideRayPrecomp(o, d), t_max, isect);
  }
  // The same with the ray's box-test data computed once by the caller, which
  // may trace the ray through several BVHs.
  template <class F>
  bool intersect(const detail::WideRayPrecomp& r, Float& t_max, F&& isect) const {
    return intersect_leaves(r, t_max, [&](uint32_t first, uint32_t count, Float& tm) {
      bool hit = false;
      for (uint32_t k = first, e = first + count; k < e; ++k)
        if (isect(k, tm)) hit = true;
      return hit;
    });
  }
  // Closest hit, a leaf at a time: leaf(first, count, t_max) tests leaf-order
  // primitives [first, first + count) and, on a hit closer than t_max, lowers
  // t_max and returns true. With BVHBuildOptions::leaf_block > 1, first is a
  // multiple of it and the range may be read up to the next multiple.
  template <class F>
  bool intersect_leaves(const detail::WideRayPrecomp& r, Float& t_max, F&& leaf) const {
    if (m_wide.empty()) return false;
    // No separate test of the root box: a ray that misses it misses every
    // child box inside it too (the slab distances are monotonic in the planes).
    // The stack, a field per array (the AVX2 ordering stores eight entries at
    // once: wide_width entries of slack).
    constexpr int stack_slots = wide_stack_size + detail::wide_width;
    alignas(32) uint32_t stack_child[stack_slots], stack_count[stack_slots];
    alignas(32) Float stack_t[stack_slots];
    int sp = 0;
    uint32_t idx = 0;
    bool hit = false;
    Float t_cull = detail::widen_exit(t_max);  // deferred entries beyond it are skipped
    for (;;) {
      const detail::BVHWideNode& node = m_wide[idx];
      // The links' cache line is needed once the box test has chosen a lane;
      // asked for now, it arrives with the planes instead of after them (one
      // cache miss instead of two in a row when the node is not in cache).
      detail::prefetch_links(&node);
      alignas(64) Float t_entry[detail::wide_width];
      detail::LaneMaskV inside{};  // the lanes entered, for push_by_distance (AVX nodes only)
      unsigned mask = unsigned(detail::intersect_wide(node, r, t_cull, t_entry, &inside));
      if (mask != 0) {
        // Visit the nearest child next and defer the others, farthest deepest.
        // Deferred inner nodes start loading now (for rays whose nodes are not
        // in cache). (Any hit does the same through visit_nearest, without
        // the distances; through such a helper GCC 12 compiled this loop 4-6%
        // slower on every closest-hit ray set, so it stays written out.)
        int l = std::countr_zero(mask);
        if ((mask & (mask - 1)) != 0) {
          unsigned rest = mask & (mask - 1);
          if ((rest & (rest - 1)) == 0) {
            // Two: equal entry distances keep lane order. (GCC compiles the
            // selection into a branch, which primary rays predict; the
            // branch-free nearer_first cost them 3%.)
            int l1 = std::countr_zero(rest);
            bool swap = t_entry[l1] < t_entry[l];
            int near = swap ? l1 : l;
            l1 = swap ? l : l1;
            l = near;
            stack_child[sp] = node.child[l1];
            stack_count[sp] = node.count[l1];
            stack_t[sp++] = t_entry[l1];
            if (node.count[l1] == detail::BVHWideNode::interior) detail::prefetch(&m_wide[node.child[l1]]);
          } else {
            // Three or more.
            l = detail::push_by_distance(node, mask, inside, t_entry, stack_child + sp, stack_count + sp,
                                         stack_t + sp);
            sp += std::popcount(mask) - 1;
            prefetch_children(node, detail::inner_lanes(node) & mask & ~(1u << l));
          }
        }
        if (node.count[l] == detail::BVHWideNode::interior) {
          idx = node.child[l];
          continue;
        }
        if (leaf(node.child[l], node.count[l], t_max)) {
          hit = true;
          t_cull = detail::widen_exit(t_max);
        }
      }
      // Pop, skipping entries that a closer hit has since made unreachable
      // (slab_lanes' test with the lowered t_max).
      for (;;) {
        if (sp == 0) return hit;
        --sp;
        if (!(stack_t[sp] <= t_cull)) continue;
        if (stack_count[sp] == detail::BVHWideNode::interior) {
          idx = stack_child[sp];
          break;
        }
        if (leaf(stack_child[sp], stack_count[sp], t_max)) {
          hit = true;
          t_cull = detail::widen_exit(t_max);
        }
      }
    }
  }

  // Any hit before t_max: stops at the first primitive for which isect returns true.
  template <class F>
  bool occluded(const Point3f& o, const Vector3f& d, Float t_max, F&& isect) const {
    if (m_wide.empty()) return false;
    return occluded(detail::WideRayPrecomp(o, d), t_max, isect);
  }
  template <class F>
  bool occluded(const detail::WideRayPrecomp& r, Float t_max, F&& isect) const {
    return occluded_leaves(r, t_max, [&](uint32_t first, uint32_t count, Float tm) {
      for (uint32_t k = first, e = first + count; k < e; ++k)
        if (isect(k, tm)) return true;
      return false;
    });
  }
  // Any hit, a leaf at a time: leaf(first, count, t_max) returns whether one of
  // the leaf's primitives is hit before t_max (see intersect_leaves).
  template <class F>
  bool occluded_leaves(const detail::WideRayPrecomp& r, Float t_max, F&& leaf) const {
    if (m_wide.empty()) return false;
    // Children in the closest-hit order, nearest first, leaves and inner
    // nodes alike: a shadow ray starts on a surface, where an occluder is
    // likeliest, and the near side of the scene is searched first. Nothing
    // pushed is ever culled (t_max does not move), so the stack holds no
    // distances.
    constexpr int stack_slots = wide_stack_size + detail::wide_width;
    alignas(32) uint32_t stack_child[stack_slots], stack_count[stack_slots];
    int sp = 0;
    uint32_t idx = 0;
    const Float t_cull = detail::widen_exit(t_max);
    for (;;) {
      const detail::BVHWideNode& node = m_wide[idx];
      detail::prefetch_links(&node);
      alignas(64) Float t_entry[detail::wide_width];
      detail::LaneMaskV inside{};
      unsigned mask = unsigned(detail::intersect_wide(node, r, t_cull, t_entry, &inside));
      if (mask != 0) {
        int l = visit_nearest(node, mask, inside, t_entry, stack_child, stack_count, sp);
        if (node.count[l] == detail::BVHWideNode::interior) {
          idx = node.child[l];
          continue;
        }
        if (leaf(node.child[l], node.count[l], t_max)) return true;
      }
      for (;;) {
        if (sp == 0) return false;
        --sp;
        if (stack_count[sp] == detail::BVHWideNode::interior) {
          idx = stack_child[sp];
          break;
        }
        if (leaf(stack_child[sp], stack_count[sp], t_max)) return true;
      }
    }
  }

 private:
  // Starts loading the wide nodes of `lanes` (inner children that traversal defers).
  void prefetch_children(const detail::BVHWideNode& node, unsigned lanes) const {
    for (; lanes != 0; lanes &= lanes - 1) detail::prefetch(&m_wide[node.child[std::countr_zero(lanes)]]);
  }
  // Any hit's ordering of a node's entered lanes `mask` (not 0), nearest
  // first: pushes all but the nearest onto the stack at sp, farthest deepest
  // (children and counts; no distances, as any hit culls nothing it has
  // pushed), starts loading the deferred inner nodes, and returns the nearest
  // lane. Closest hit has the same code written out, with distances (see
  // intersect_leaves).
  int visit_nearest(const detail::BVHWideNode& node, unsigned mask, detail::LaneMaskV inside,
                    const Float* t_entry, uint32_t* stack_child, uint32_t* stack_count, int& sp) const {
    int l = std::countr_zero(mask);
    unsigned rest = mask & (mask - 1);
    if (rest == 0) return l;
    if ((rest & (rest - 1)) == 0) {  // two: equal distances in lane order
      int l1 = std::countr_zero(rest);
      detail::nearer_first(t_entry, l, l1);
      stack_child[sp] = node.child[l1];
      stack_count[sp++] = node.count[l1];
      if (node.count[l1] == detail::BVHWideNode::interior) detail::prefetch(&m_wide[node.child[l1]]);
      return l;
    }
    l = detail::push_by_distance<false>(node, mask, inside, t_entry, stack_child + sp, stack_count + sp, nullptr);
    sp += std::popcount(mask) - 1;
    prefetch_children(node, detail::inner_lanes(node) & mask & ~(1u << l));
    return l;
  }

  // A primitive during the build: its bounds and its input index, laid out
  // for two 16-byte loads.
  struct alignas(16) PrimRef {
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
  struct BoxAcc {
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
  struct Builder {
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

  // from_binary_tree's check (see there).
  static void check_tree(const std::vector<BVHNode>& nodes, size_t prims, uint32_t block) {
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
  void pad_leaves(IndexOf&& index_of, uint32_t block, int threads) {
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

  // Which binary nodes become the slots of each wide node: the collapse with
  // the least SAH cost (after Ylitie, Karras and Laine 2017, "Efficient
  // incoherent ray traversal on GPUs through compressed wide BVHs"), found by
  // dynamic programming over the binary tree. The binary leaves are kept
  // whole, so every collapse has the same leaves and the SAH cost differs only
  // in its wide nodes: the collapse minimises the sum of the wide nodes' box
  // areas (the expected visits of a ray), whatever a visit costs. Of covers
  // with equal cost, the one with fewer wide nodes wins: all costs tie when
  // the boxes have no area, and the wide nodes should still be full then.
  class Collapse {
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
  void collapse_all(int threads) {
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
  uint32_t wide_size(const Collapse& plan, uint32_t bin, int depth, int stop,
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
  void write_wide(const Collapse& plan, uint32_t bin, uint32_t w, int depth, int stop,
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

  std::vector<BVHNode> m_nodes;  // the binary tree: during the build, after it only if kept
  std::vector<uint32_t> m_prims;
  detail::fill_later_vector<detail::BVHWideNode> m_wide;  // traversal layout, derived from m_nodes
  Bounds3f m_bounds;
};

}  // namespace prism
