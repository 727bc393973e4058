// Watertightness through the whole query pipeline (SceneAccel: instance BVH,
// object-space transform, mesh BVH, watertight triangle test): rays aimed
// exactly at the shared edges and vertices of closed meshes never slip through.
//
// Two closed meshes, each instanced twice (once untransformed, once under a
// rotation, non-uniform scale and translation): a subdivided icosahedron
// (1280 triangles) and a cube of 12 triangles, whose face diagonals are edges
// shared by coplanar triangles. Targets are mesh vertices and points on edges
// (lerp between the edge's two vertices in float). Origins are random points
// outside the mesh from which the target's neighbourhood faces the ray.
//
// A third closed mesh, a tube of long slivers along a diagonal, is pre-split
// by MeshAccel (accel/presplit.hpp): its triangles reach the BVH as several
// clipped references each, which must still leave no crack.
//
// Misses alone would be a weak check: a ray leaking through a crack in the near
// side of a closed mesh is caught by the far side. So each hit must also be on
// one of the faces around the target (a Möller-Trumbore intersector, or this
// one with strict edge tests, fails that part), and, the meshes being convex
// and wound outwards, on the front of its face (reference boxes shrunk by
// 10^-5 of the coordinates' magnitude fail that part for the tube).
//
// Why "faces the ray": the ray's direction is the float difference of target
// and origin, so the exact ray passes within a few float roundings of the target
// (delta below). On a silhouette edge such a perturbation can make it miss the
// mesh legitimately. From an origin in front of every face around the target
// (cosine >= kMinCos) the faces' projections cover a disk of radius >> delta
// around the target, so a correct, watertight pipeline must report a hit, and
// that hit must be on a face around the target.
#include <catch2/catch.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <vector>

#include "prism/accel/scene_accel.hpp"
#include "prism/sampling/pcg32.hpp"
#include "prism/sampling/warps.hpp"
#include "support/meshes.hpp"

namespace watertight_test {

using namespace prism;

namespace {

constexpr double kU = 0x1p-24;
constexpr double kMinCos = 0.05;

struct ClosedMesh {
  TriangleMesh mesh;
  std::vector<std::array<uint32_t, 2>> edges;     // every undirected edge once
  std::vector<std::vector<uint32_t>> edge_faces;  // the two faces of each edge
  std::vector<std::vector<uint32_t>> vertex_faces;
};

// Fills the adjacency of a triangle list; every edge must have two faces.
ClosedMesh with_adjacency(TriangleMesh m) {
  ClosedMesh c;
  std::map<std::pair<uint32_t, uint32_t>, std::vector<uint32_t>> edge_map;
  c.vertex_faces.resize(m.positions.size());
  for (uint32_t f = 0; f < m.triangle_count(); ++f)
    for (int k = 0; k < 3; ++k) {
      uint32_t a = m.indices[3 * f + uint32_t(k)], b = m.indices[3 * f + uint32_t((k + 1) % 3)];
      edge_map[{std::min(a, b), std::max(a, b)}].push_back(f);
      c.vertex_faces[a].push_back(f);
    }
  for (auto& [e, faces] : edge_map) {
    c.edges.push_back({e.first, e.second});
    c.edge_faces.push_back(faces);
  }
  c.mesh = std::move(m);
  return c;
}

// A unit icosahedron subdivided `levels` times, vertices projected to the unit
// sphere; midpoints are shared through a cache, so neighbouring triangles use
// the very same float vertices. Faces wind counter-clockwise seen from outside.
TriangleMesh icosphere(int levels) {
  const double t = (1 + std::sqrt(5.0)) / 2;
  std::vector<std::array<double, 3>> v = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
                                          {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  std::vector<uint32_t> f = {0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4, 11, 10, 2, 10, 7, 6,
                             7, 1, 8, 3, 9, 4, 3, 4, 2, 3, 2, 6, 3, 6, 8, 3, 8, 9, 4, 9, 5, 2, 4, 11, 6, 2, 10, 8, 6, 7,
                             9, 8, 1};
  auto unit = [](std::array<double, 3> p) {
    double l = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    return std::array<double, 3>{p[0] / l, p[1] / l, p[2] / l};
  };
  for (auto& p : v) p = unit(p);
  for (int l = 0; l < levels; ++l) {
    std::map<std::pair<uint32_t, uint32_t>, uint32_t> mid;
    auto midpoint = [&](uint32_t a, uint32_t b) {
      auto key = std::make_pair(std::min(a, b), std::max(a, b));
      auto it = mid.find(key);
      if (it != mid.end()) return it->second;
      v.push_back(unit({v[a][0] + v[b][0], v[a][1] + v[b][1], v[a][2] + v[b][2]}));
      uint32_t idx = uint32_t(v.size() - 1);
      mid[key] = idx;
      return idx;
    };
    std::vector<uint32_t> nf;
    for (size_t i = 0; i < f.size(); i += 3) {
      uint32_t a = f[i], b = f[i + 1], c = f[i + 2];
      uint32_t ab = midpoint(a, b), bc = midpoint(b, c), ca = midpoint(c, a);
      nf.insert(nf.end(), {a, ab, ca, b, bc, ab, c, ca, bc, ab, bc, ca});
    }
    f = std::move(nf);
  }
  TriangleMesh m;
  for (auto& p : v) m.positions.push_back({Float(p[0]), Float(p[1]), Float(p[2])});
  m.indices = f;
  return m;
}

// A cube [c - 1, c + 1]^3 as 12 triangles, counter-clockwise from outside.
TriangleMesh cube(const Point3f& c) {
  TriangleMesh m;
  for (int i = 0; i < 8; ++i)
    m.positions.push_back({c.x + (i & 1 ? 1.f : -1.f), c.y + (i & 2 ? 1.f : -1.f), c.z + (i & 4 ? 1.f : -1.f)});
  // Each face as a quad (a, b, c, d) counter-clockwise from outside, split along a-c.
  const uint32_t quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& q : quads) m.indices.insert(m.indices.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
  return m;
}

using test::sliver_tube;

Vector3f random_unit(PCG32& rng) {
  Float a = rng.next_float();
  return sample_uniform_sphere({a, rng.next_float()});
}

struct InstanceInfo {
  const ClosedMesh* mesh;
  Transform to_world;
  std::vector<Point3f> world_positions;  // vertices transformed to world space (rounded)
  std::vector<Vector3f> world_normals;   // unit outward face normals in world space
  double size;                           // rough radius in world space
};

InstanceInfo make_info(const ClosedMesh& m, const Transform& t, double size) {
  InstanceInfo in{&m, t, {}, {}, size};
  for (const Point3f& p : m.mesh.positions) in.world_positions.push_back(t(p));
  for (uint32_t f = 0; f < m.mesh.triangle_count(); ++f) {
    const Point3f& p0 = m.mesh.positions[m.mesh.indices[3 * f]];
    const Point3f& p1 = m.mesh.positions[m.mesh.indices[3 * f + 1]];
    const Point3f& p2 = m.mesh.positions[m.mesh.indices[3 * f + 2]];
    Normal3f n(cross(p1 - p0, p2 - p0));
    in.world_normals.push_back(normalize(Vector3f(t(n))));
  }
  return in;
}

struct Stats {
  size_t rays = 0, misses = 0, wrong_instance = 0, wrong_face = 0, back_facing = 0, resampled = 0;
};

// Shoots n rays at edges (and vertices) of instance `id` and counts failures.
void shoot(const SceneAccel& accel, uint32_t id, const InstanceInfo& in, size_t n, uint64_t seed, Stats* st) {
  PCG32 rng(id, seed);
  const ClosedMesh& cm = *in.mesh;
  std::vector<uint32_t> faces;
  for (size_t r = 0; r < n; ++r) {
    // Target: a vertex (40%) or a point on an edge.
    Point3f p;
    faces.clear();
    uint32_t va, vb;
    bool at_vertex = rng.next_bounded(5) < 2;
    Float t = 0;
    if (at_vertex) {
      va = vb = rng.next_bounded(uint32_t(cm.mesh.positions.size()));
      p = in.world_positions[va];
    } else {
      uint32_t e = rng.next_bounded(uint32_t(cm.edges.size()));
      va = cm.edges[e][0];
      vb = cm.edges[e][1];
      t = rng.next_float();
      p = lerp(t, in.world_positions[va], in.world_positions[vb]);
    }
    // Faces around the target: the edge's two faces, or the vertex's fan. An
    // edge point close to an endpoint (within the ray's perturbation, magnified
    // by up to 1 / kMinCos by foreshortening) also needs that endpoint's fan.
    const double max_dist = 16 * in.size;
    double pmag = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
    double delta = 8 * kU * (max_dist + in.size + 4 * pmag) / kMinCos;
    auto add = [&](const std::vector<uint32_t>& fs) { faces.insert(faces.end(), fs.begin(), fs.end()); };
    if (at_vertex) {
      add(cm.vertex_faces[va]);
    } else {
      uint32_t e_idx = 0;
      for (; e_idx < cm.edges.size(); ++e_idx)
        if (cm.edges[e_idx][0] == va && cm.edges[e_idx][1] == vb) break;
      add(cm.edge_faces[e_idx]);
      double len = distance(in.world_positions[va], in.world_positions[vb]);
      if (double(t) * len <= delta) add(cm.vertex_faces[va]);
      if ((1 - double(t)) * len <= delta) add(cm.vertex_faces[vb]);
    }
    // Origin: a random direction in front of all those faces (rejection), at a
    // log-uniform distance from 1/16 to 16 times the mesh size. Now and then
    // (cube instances) exactly along the summed face normals, which gives
    // directions with zero components.
    Vector3f dir;
    bool along_normal = in.size < 2 && rng.next_bounded(10) == 0 && cm.mesh.triangle_count() == 12;
    for (int attempt = 0;; ++attempt) {
      if (along_normal && attempt == 0) {
        Vector3f s;
        for (uint32_t f : faces) s += in.world_normals[f];
        dir = normalize(s);
      } else {
        dir = random_unit(rng);
      }
      bool ok = true;
      for (uint32_t f : faces) ok = ok && dot(dir, in.world_normals[f]) >= kMinCos;
      if (ok) break;
      ++st->resampled;
    }
    Float dist = Float(in.size * std::exp2(-4 + 8 * double(rng.next_float())));
    Point3f o = p + dir * dist;
    Vector3f d = p - o;
    if (rng.next_bounded(2)) d = normalize(d);
    Ray ray{o, d, 0};

    ++st->rays;
    std::optional<Hit> h = accel.intersect(ray);
    if (!h) {
      ++st->misses;
      if (st->misses <= 5)
        UNSCOPED_INFO("miss: instance " << id << (at_vertex ? " vertex " : " edge ") << va << "-" << vb
                                        << " t=" << t << " o=(" << o.x << "," << o.y << "," << o.z << ") d=("
                                        << d.x << "," << d.y << "," << d.z << ")");
      continue;
    }
    if (h->instance != id) {
      ++st->wrong_instance;
      continue;
    }
    // The closest hit lies within delta of the target, hence on a face whose
    // closure comes that close: one of the faces around the target.
    if (std::find(faces.begin(), faces.end(), h->primitive) == faces.end()) ++st->wrong_face;
    // The meshes are convex and wound outwards: a ray from outside meets a
    // face from its front first. One that leaked through a crack meets the
    // far side from behind.
    if (dot(d, in.world_normals[h->primitive]) >= 0) ++st->back_facing;
  }
}

}  // namespace

TEST_CASE("rays aimed at shared edges and vertices of closed meshes never miss", "[geometry][watertight]") {
  ClosedMesh ico = with_adjacency(icosphere(3));
  ClosedMesh box = with_adjacency(cube({0, 0, 1000}));
  REQUIRE(ico.mesh.triangle_count() == 1280);
  // Closed 2-manifolds: every edge has exactly two faces, V - E + F = 2.
  for (const ClosedMesh* m : {&ico, &box}) {
    for (const auto& ef : m->edge_faces) REQUIRE(ef.size() == 2);
    REQUIRE(long(m->mesh.positions.size()) - long(m->edges.size()) + long(m->mesh.triangle_count()) == 2);
  }

  SceneAccel accel;
  uint32_t ico_id = accel.add_mesh(ico.mesh);
  uint32_t box_id = accel.add_mesh(box.mesh);
  // Instances are 1000 apart, so no ray (origins within 16 sizes of their
  // target) can reach another instance.
  Transform t_ico = translate({1000, 0, 0}) * rotate(0.7f, {1, 2, 3}) * scale(3, 2, 2.5f);
  Transform t_box = translate({0, 1000, -1000}) * rotate(2.1f, {-1, 0.5f, 0.2f}) * scale(1.5f, 1.5f, 4);
  std::vector<InstanceInfo> infos;
  std::vector<uint32_t> ids;
  ids.push_back(accel.add_mesh_instance(ico_id));
  infos.push_back(make_info(ico, Transform{}, 1));
  ids.push_back(accel.add_mesh_instance(ico_id, t_ico));
  infos.push_back(make_info(ico, t_ico, 3));
  ids.push_back(accel.add_mesh_instance(box_id));
  infos.push_back(make_info(box, Transform{}, std::sqrt(3.0)));
  ids.push_back(accel.add_mesh_instance(box_id, t_box));
  infos.push_back(make_info(box, t_box, 4 * std::sqrt(3.0)));
  accel.build();

  constexpr size_t kRaysPerInstance = 250000;  // 10^6 in total
  Stats total;
  for (size_t i = 0; i < ids.size(); ++i) {
    Stats st;
    shoot(accel, ids[i], infos[i], kRaysPerInstance, 0xed6e, &st);
    INFO("instance " << ids[i] << ": rays " << st.rays << ", misses " << st.misses << ", wrong instance "
                     << st.wrong_instance << ", hit off the target's faces " << st.wrong_face
                     << ", hit from behind " << st.back_facing << ", origins resampled " << st.resampled);
    CHECK(st.misses == 0);
    CHECK(st.wrong_instance == 0);
    CHECK(st.wrong_face == 0);
    CHECK(st.back_facing == 0);
    total.rays += st.rays;
  }
  CHECK(total.rays == 1000000);
}

TEST_CASE("rays through the diagonal of a cube face hit one of its two triangles", "[geometry][watertight]") {
  // The classic crack: rays through points of the shared diagonal of two
  // coplanar triangles, perpendicular and oblique, with exact float targets.
  ClosedMesh box = with_adjacency(cube({0, 0, 0}));
  SceneAccel accel;
  accel.add_mesh_instance(accel.add_mesh(box.mesh));
  accel.build();
  PCG32 rng(7, 7);
  size_t misses = 0, wrong_face = 0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    // Face z = -1 has vertices 0 (-1,-1,-1) and 3 (1,1,-1) on its diagonal;
    // points (s, s, -1) are exactly on it for every float s in [-1, 1].
    // Perpendicular rays pass exactly through the diagonal anywhere on it;
    // oblique ones (through it up to rounding) stay away from the face's
    // corners, where a perturbed ray could pass outside the cube legitimately.
    bool perpendicular = i % 2;
    Float s = perpendicular ? 2 * rng.next_float() - 1 : rng.next_float() - 0.5f;
    Point3f p{s, s, -1};
    Vector3f d = perpendicular ? Vector3f{0, 0, 1} : normalize(Vector3f{rng.next_float() - 0.5f, rng.next_float() - 0.5f, 1});
    Float back = Float(std::exp2(-10 + 20 * double(rng.next_float())));
    Ray ray{p - d * back, d, 0};
    std::optional<Hit> h = accel.intersect(ray);
    if (!h)
      ++misses;
    else if (h->primitive > 1)  // the face z = -1 is triangles 0 and 1
      ++wrong_face;
  }
  CHECK(misses == 0);
  CHECK(wrong_face == 0);
}

TEST_CASE("rays aimed at shared edges and vertices of a pre-split sliver tube never miss", "[geometry][watertight]") {
  // Pre-splitting (on by default) gives a sliver several BVH references, each
  // boxing only the part of it inside a sub-box; a reference box that lost a
  // sliver of its triangle's part to the clipping's rounding would open a
  // crack along the cut. The same rays as above, at a closed convex mesh of
  // slivers. Near the centre of an end's fan its triangles are narrower than
  // the bound on the rays' perturbation (delta in shoot), so a hit on a
  // neighbour of the target's faces is legitimate there and only counted; a
  // leak is caught as a miss or as a hit on the far side from behind.
  ClosedMesh tube = with_adjacency(sliver_tube(256, 1, {-12, -9, -7}, {12, 10, 8}));
  for (const auto& ef : tube.edge_faces) REQUIRE(ef.size() == 2);
  REQUIRE(long(tube.mesh.positions.size()) - long(tube.edges.size()) + long(tube.mesh.triangle_count()) == 2);
  MeshAccel direct(tube.mesh, BVHBuildOptions{});
  INFO(tube.mesh.triangle_count() << " triangles, " << direct.reference_count() << " references");
  REQUIRE(direct.reference_count() > tube.mesh.triangle_count() + tube.mesh.triangle_count() / 5);

  SceneAccel accel;
  uint32_t mesh_id = accel.add_mesh(tube.mesh);
  Transform t_moved = translate({60, -40, 10}) * rotate(1.3f, {0.3f, -1, 0.4f});
  uint32_t ids[2] = {accel.add_mesh_instance(mesh_id), accel.add_mesh_instance(mesh_id, t_moved)};
  InstanceInfo infos[2] = {make_info(tube, Transform{}, 2), make_info(tube, t_moved, 2)};
  accel.build();
  for (int i = 0; i < 2; ++i) {
    Stats st;
    shoot(accel, ids[i], infos[i], 250000, 0x5e11, &st);
    INFO("instance " << ids[i] << ": rays " << st.rays << ", misses " << st.misses << ", wrong instance "
                     << st.wrong_instance << ", hit from behind " << st.back_facing
                     << ", hit off the target's faces " << st.wrong_face << " (not checked)");
    CHECK(st.rays == 250000);
    CHECK(st.misses == 0);
    CHECK(st.wrong_instance == 0);
    CHECK(st.back_facing == 0);
  }
}

}  // namespace watertight_test
