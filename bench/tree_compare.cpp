// bench/tree_compare.cpp — prism's BVH against a tree from Embree's own SAH
// builder, by what a ray set crosses: node boxes, leaf boxes and the
// triangles in those leaves, per ray. Not a timing: it tells whether a
// traversal gap lies in the tree (more boxes crossed) or in the cost of each
// visit (docs/performance.md, issue 11, fourteenth step).
//
// Embree's tree comes from its public builder API (rtcBuildBVH, 8-wide,
// RTC_BUILD_QUALITY_MEDIUM, SAH blocks and smallest leaf as given), the
// setting its scene builder uses for BVH8 with Triangle4 leaves when the
// block is 4; the traversal structure of rtcIntersect1 itself is not
// reachable through the API. prism's tree is MeshAccel's with default options.
//
// Rays: the procedural mesh of traversal_bench (12 N^2 triangles), a pinhole
// raster, and from each hit an incoherent ray (cosine about the facing
// normal). Only the incoherent rays that escape are counted: with no hit,
// every box they cross is visited whatever the traversal order, so the
// counts depend on the tree alone. The primary rays and the incoherent rays
// that hit are counted too, under a closest-hit traversal of each tree in
// the same order (nearest entry first, culled by the hit so far).
//
// Usage: tree_compare [--n N (30)] [--res R (400)] [--block B (4)] [--min-leaf M (4)]
#include <embree3/rtcore.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "procedural_mesh.hpp"
#include "prism/accel/scene_accel.hpp"
#include "prism/math/frame.hpp"
#include "prism/sampling/warps.hpp"

namespace {

using namespace prism;

struct Counts {
  long nodes = 0, leaves = 0, triangles = 0, blocks = 0;  // blocks: SIMD groups of a leaf's triangles
};

// The distance at which the ray's half-line [0, inf) enters the box, or -1
// if it misses it (in double: the counts should not depend on either
// library's rounding).
double entry(const Bounds3f& b, const Point3f& o, const Vector3f& d) {
  double t0 = 0, t1 = 1e300;
  for (int a = 0; a < 3; ++a) {
    double inv = 1.0 / double(d[a]);
    double tn = (double(b.min[a]) - o[a]) * inv, tf = (double(b.max[a]) - o[a]) * inv;
    if (tn > tf) std::swap(tn, tf);
    t0 = std::max(t0, tn);
    t1 = std::min(t1, tf);
  }
  return t0 <= t1 ? t0 : -1;
}
bool crosses(const Bounds3f& b, const Point3f& o, const Vector3f& d) { return entry(b, o, d) >= 0; }

// A closest-hit traversal of either tree, as prism's and Embree's run it:
// children nearest entry first, a child skipped once the hit so far is
// nearer than its entry. Leaves test their triangles with prism's watertight
// test.
struct ClosestHit {
  const TriangleMesh& mesh;
  Point3f o;
  Vector3f d;
  RayTrianglePrecomp pc;
  Counts& c;
  int block;
  Float t = infinity;
  void leaf(const uint32_t* tri, size_t n) {
    ++c.leaves;
    c.triangles += long(n);
    c.blocks += long((n + size_t(block) - 1) / size_t(block));
    for (size_t k = 0; k < n; ++k) {
      const uint32_t* v = &mesh.indices[3 * size_t(tri[k])];
      if (auto h = intersect_triangle(o, pc, t, mesh.positions[v[0]], mesh.positions[v[1]], mesh.positions[v[2]]))
        t = h->t;
    }
  }
  // Visits the children (entry, index) in order; visit(i) handles child i.
  template <class Visit>
  void ordered(std::vector<std::pair<double, int>>& ch, Visit&& visit) {
    std::sort(ch.begin(), ch.end());
    for (const auto& [e, i] : ch)
      if (e <= double(t)) visit(i);
  }
};

// Embree's tree, in nodes the callbacks allocate.
struct ENode {
  bool leaf = false;
  unsigned n = 0;  // children, or primitives of a leaf
  ENode* child[8] = {};
  Bounds3f box[8];
  uint32_t* prim = nullptr;  // a leaf's triangles
};
void* create_node(RTCThreadLocalAllocator a, unsigned k, void*) {
  return new (rtcThreadLocalAlloc(a, sizeof(ENode), 16)) ENode{false, k, {}, {}};
}
void set_children(void* p, void** c, unsigned k, void*) {
  for (unsigned i = 0; i < k; ++i) static_cast<ENode*>(p)->child[i] = static_cast<ENode*>(c[i]);
}
void set_bounds(void* p, const RTCBounds** b, unsigned k, void*) {
  for (unsigned i = 0; i < k; ++i) {
    Bounds3f& box = static_cast<ENode*>(p)->box[i];
    box.min = {b[i]->lower_x, b[i]->lower_y, b[i]->lower_z};
    box.max = {b[i]->upper_x, b[i]->upper_y, b[i]->upper_z};
  }
}
void* create_leaf(RTCThreadLocalAllocator a, const RTCBuildPrimitive* p, size_t n, void*) {
  auto* leaf = new (rtcThreadLocalAlloc(a, sizeof(ENode), 16)) ENode{true, unsigned(n), {}, {}};
  leaf->prim = static_cast<uint32_t*>(rtcThreadLocalAlloc(a, n * sizeof(uint32_t), 4));
  for (size_t i = 0; i < n; ++i) leaf->prim[i] = p[i].primID;
  return leaf;
}
void closest(const ENode& n, ClosestHit& q) {
  ++q.c.nodes;
  std::vector<std::pair<double, int>> ch;
  for (unsigned i = 0; i < n.n; ++i)
    if (double e = entry(n.box[i], q.o, q.d); e >= 0) ch.push_back({e, int(i)});
  q.ordered(ch, [&](int i) {
    const ENode& k = *n.child[i];
    if (k.leaf)
      q.leaf(k.prim, k.n);
    else
      closest(k, q);
  });
}
void walk(const ENode& n, const Point3f& o, const Vector3f& d, Counts& c) {
  ++c.nodes;
  for (unsigned i = 0; i < n.n; ++i) {
    if (!crosses(n.box[i], o, d)) continue;
    if (n.child[i]->leaf) {
      ++c.leaves;
      c.triangles += n.child[i]->n;
      c.blocks += long((n.child[i]->n + 3) / 4);
    } else {
      walk(*n.child[i], o, d, c);
    }
  }
}

void walk(std::span<const detail::BVHWideNode> w, uint32_t i, const Point3f& o, const Vector3f& d, Counts& c) {
  ++c.nodes;
  for (int l = 0; l < detail::wide_width; ++l) {
    uint32_t count = w[i].count[l];
    if (count == 0 || !crosses(detail::lane_box(w[i], l), o, d)) continue;
    if (count == detail::BVHWideNode::interior) {
      walk(w, w[i].child[l], o, d, c);
    } else {
      ++c.leaves;
      c.triangles += count;
      c.blocks += long((count + triangle_packet_width - 1) / triangle_packet_width);
    }
  }
}

void closest(std::span<const detail::BVHWideNode> w, const MeshAccel& m, uint32_t i, ClosestHit& q) {
  ++q.c.nodes;
  std::vector<std::pair<double, int>> ch;
  for (int l = 0; l < detail::wide_width; ++l)
    if (w[i].count[l] != 0)
      if (double e = entry(detail::lane_box(w[i], l), q.o, q.d); e >= 0) ch.push_back({e, l});
  q.ordered(ch, [&](int l) {
    uint32_t count = w[i].count[l], first = w[i].child[l];
    if (count == detail::BVHWideNode::interior) {
      closest(w, m, first, q);
      return;
    }
    std::vector<uint32_t> tri(count);
    for (uint32_t k = 0; k < count; ++k) tri[k] = m.leaf_triangle(first + k);
    q.leaf(tri.data(), count);
  });
}

}  // namespace

int main(int argc, char** argv) {
  int n = 30, res = 400, block = 4, min_leaf = 4;
  for (int i = 1; i < argc; ++i) {
    std::string a = argv[i];
    int* v = a == "--n" ? &n : a == "--res" ? &res : a == "--block" ? &block : a == "--min-leaf" ? &min_leaf : nullptr;
    if (v == nullptr || i + 1 >= argc || (*v = std::atoi(argv[++i])) < 1) {
      std::fprintf(stderr, "usage: tree_compare [--n N (30)] [--res R (400)] [--block B (4)] [--min-leaf M (4)]\n");
      return 2;
    }
  }
  TriangleMesh mesh = prism_bench::make_displaced_sphere(n);
  SceneAccel scene;
  scene.add_mesh_instance(scene.add_mesh(mesh));
  BVHBuildOptions opt;
  scene.build(opt);
  std::span<const detail::BVHWideNode> wide = scene.mesh_accels()[0].bvh().wide_nodes();

  RTCDevice device = rtcNewDevice("threads=1");
  size_t nt = mesh.triangle_count();
  std::vector<RTCBuildPrimitive> prims(nt);
  for (size_t t = 0; t < nt; ++t) {
    Bounds3f b;
    for (int v = 0; v < 3; ++v) b = union_bounds(b, Bounds3f(mesh.positions[mesh.indices[3 * t + size_t(v)]]));
    prims[t] = {b.min.x, b.min.y, b.min.z, 0, b.max.x, b.max.y, b.max.z, unsigned(t)};
  }
  RTCBuildArguments args = rtcDefaultBuildArguments();
  args.maxBranchingFactor = 8;
  args.maxDepth = 64;
  args.sahBlockSize = unsigned(block);
  args.minLeafSize = unsigned(min_leaf);
  args.maxLeafSize = RTC_BUILD_MAX_PRIMITIVES_PER_LEAF;
  args.bvh = rtcNewBVH(device);
  args.primitives = prims.data();
  args.primitiveCount = nt;
  args.primitiveArrayCapacity = nt;
  args.createNode = create_node;
  args.setNodeChildren = set_children;
  args.setNodeBounds = set_bounds;
  args.createLeaf = create_leaf;
  const ENode* root = static_cast<const ENode*>(rtcBuildBVH(&args));
  if (root == nullptr) {
    std::fprintf(stderr, "tree_compare: rtcBuildBVH failed\n");
    return 1;
  }

  Bounds3f bb = scene.bounds();
  Point3f c = bb.centroid();
  Float radius = 0.5f * length(bb.diagonal());
  const Point3f eye = c + Vector3f{0.3f, 0.4f, 4.0f} * (radius / 2);
  const MeshAccel& accel = scene.mesh_accels()[0];
  Counts pc, ec;                   // escaping incoherent rays
  Counts ph[2], eh[2];             // closest hit: primary rays, hitting incoherent rays
  long rays = 0, hits[2] = {0, 0};
  long differ = 0;
  auto closest_both = [&](const Point3f& o, const Vector3f& d, int set, Float t_expected) {
    ClosestHit qp{mesh, o, d, RayTrianglePrecomp(d), ph[set], triangle_packet_width};
    closest(wide, accel, 0, qp);
    ClosestHit qe{mesh, o, d, RayTrianglePrecomp(d), eh[set], 4};  // Triangle4 blocks
    closest(*root, qe);
    // (Within 1e-5: with the bench's -O3 -march=native the compiler contracts
    // the scalar test's multiply-adds into FMAs differently from the packet
    // test's, so t may differ in its last bits; the tests build with
    // -ffp-contract=off, where the two agree bit for bit.)
    auto off = [&](Float t) { return !(std::abs(t - t_expected) <= 1e-5f * t_expected); };
    differ += off(qp.t) || off(qe.t);
    ++hits[set];
  };
  for (int y = 0; y < res; ++y)
    for (int x = 0; x < res; ++x) {
      Vector3f d = prism_bench::raster_direction(x, y, res);
      auto h = scene.intersect(Ray{eye, d});
      if (!h) continue;
      closest_both(eye, d, 0, h->t);
      PCG32 rng = prism_bench::pixel_rng(x, y, res);
      const uint32_t* tri = &mesh.indices[3 * size_t(h->primitive)];
      auto [o, w] = prism_bench::incoherent_ray(eye + d * h->t, mesh.positions[tri[0]], mesh.positions[tri[1]],
                                                mesh.positions[tri[2]], d, rng);
      if (auto hw = scene.intersect(Ray{o, w})) {
        closest_both(o, w, 1, hw->t);
        continue;
      }
      ++rays;
      walk(wide, 0, o, w, pc);
      walk(*root, o, w, ec);
    }
  if (rays == 0) {
    std::fprintf(stderr, "tree_compare: no escaping rays\n");
    return 1;
  }
  auto row = [&](const char* name, const Counts& k, long n) {
    std::printf("%-34s nodes %6.2f  leaves %6.2f  triangles %6.2f  blocks %6.2f per ray\n", name,
                double(k.nodes) / double(n), double(k.leaves) / double(n), double(k.triangles) / double(n),
                double(k.blocks) / double(n));
  };
  std::string e = "Embree rtcBuildBVH (block " + std::to_string(block) + ", min leaf " + std::to_string(min_leaf) + ")";
  std::printf("%zu triangles, %ld escaping incoherent rays\n", nt, rays);
  row("prism (MeshAccel defaults)", pc, rays);
  row(e.c_str(), ec, rays);
  const char* set_name[2] = {"primary rays", "hitting incoherent rays"};
  for (int k = 0; k < 2; ++k) {
    std::printf("closest hit, %ld %s (blocks: %d-wide packets for prism, Triangle4 for Embree)\n", hits[k],
                set_name[k], triangle_packet_width);
    row("prism (MeshAccel defaults)", ph[k], std::max(1L, hits[k]));
    row(e.c_str(), eh[k], std::max(1L, hits[k]));
  }
  if (differ != 0) std::printf("(%ld rays found a different hit than MeshAccel)\n", differ);
  rtcReleaseBVH(args.bvh);
  rtcReleaseDevice(device);
}
