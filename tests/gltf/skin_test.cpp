// Skins and morph targets evaluated at GltfOptions::time (io/gltf/deform.hpp):
// - a two-bone strip whose second bone turns about z, against positions and
//   normals worked out by hand below;
// - morph targets with default and animated weights, by hand;
// - zero morph weights leave a mesh bit-identical to one without targets;
// - the shared CesiumMan (19 joints) at three times against a skinning
//   written here from the glTF 2.0 specification (sections 3.7.3 skins,
//   3.11 animations: LINEAR, slerp for rotations), reading the file with
//   tinygltf and its own accessor code, none of prism's;
// - the Draco twins and the quantized twin, deformed, against their plain
//   files. The shared models are skipped when ../shared is absent.
#include <catch2/catch.hpp>
#include "support/gltf_deform.hpp"
#include "support/gltf_json.hpp"
#include "support/mesh_compare.hpp"
#include "support/skip.hpp"
#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <prism/io/gltf.hpp>
#include <tiny_gltf.h>

namespace skin_test {

using namespace prism;
using gltf_json::json;
using gltf_deform::two_bone_strip;
using gltf_deform::morph_triangle;
using mesh_compare::Tri;

const std::string scenes_dir = std::string(PRISM_SHARED_DIR) + "/scenes/";
bool have_scenes() { return std::filesystem::exists(scenes_dir + "CesiumMan/glTF-Binary/CesiumMan.glb"); }

const TriangleMesh& only_mesh(const GltfScene<RGB>& g) {
  REQUIRE(g.scene.accel().meshes().size() == 1);
  REQUIRE(g.scene.accel().instances().size() == 1);
  return g.scene.accel().meshes()[0];
}

TEST_CASE("skins: a two-bone strip at three times against positions worked out by hand", "[gltf][skin]") {
  const std::string path = gltf_json::write_temp_gltf("skin", "two_bone.gltf", two_bone_strip());
  // Bone 1's joint matrix at angle a: T(1,0,0) Rz(a) T(-1,0,0), so a point
  // (x, y) of joint 1 goes to (1 + c (x-1) - s y, s (x-1) + c y). v1 blends
  // it half and half with joint 0 (identity); its normal takes the inverse
  // transpose of the blend 0.5 (I + Rz(a)) = cos(a/2) Rz(a/2): turned by a/2.
  const double s45 = std::sqrt(0.5);
  struct Case {
    double time;
    std::array<std::array<double, 3>, 5> p;
    std::array<double, 3> n1, n2;
  };
  // At 45 degrees, c = s = sqrt(1/2); v1 = ((1.5 + 1 + c 0.5) / 2, s 0.5 / 2).
  const Case cases[] = {
      {0.0, {{{0, 0, 0}, {1.5, 0, 0}, {2, 0, 0}, {2, 1, 0}, {0, 1, 0}}}, {1, 0, 0}, {1, 0, 0}},
      {0.5,
       {{{0, 0, 0}, {(2.5 + 0.5 * s45) / 2, 0.25 * s45, 0}, {1 + s45, s45, 0}, {1 + s45 - s45, s45 + s45, 0}, {0, 1, 0}}},
       {std::cos(M_PI / 8), std::sin(M_PI / 8), 0},
       {s45, s45, 0}},
      {1.0, {{{0, 0, 0}, {1.25, 0.25, 0}, {1, 1, 0}, {0, 1, 0}, {0, 1, 0}}}, {s45, s45, 0}, {0, 1, 0}},
  };
  for (const Case& c : cases) {
    INFO("time " << c.time);
    GltfOptions opt;
    opt.time = c.time;
    auto g = load_gltf<RGB>(path, opt);
    CHECK(g.warnings.empty());
    CHECK(g.deformed_instances == 1);
    const TriangleMesh& m = only_mesh(g);
    REQUIRE(m.positions.size() == 5);
    REQUIRE(m.normals.size() == 5);
    // The instance is the identity: the node's translation is not applied.
    const auto& inst = g.scene.accel().instances()[0];
    Point3f o = inst.object_to_world(Point3f(0, 0, 0));
    CHECK(length(Vector3f(o.x, o.y, o.z)) == 0);
    // Tolerance: float rounding of values below 3 after a few operations
    // in double, 4 ulps of 2: 1e-6.
    for (size_t v = 0; v < 5; ++v)
      for (size_t k = 0; k < 3; ++k) {
        INFO("vertex " << v << " axis " << k);
        CHECK(std::abs(double((&m.positions[v].x)[k]) - c.p[v][k]) <= 1e-6);
      }
    for (size_t k = 0; k < 3; ++k) {
      CHECK(std::abs(double((&m.normals[1].x)[k]) - c.n1[k]) <= 1e-6);
      CHECK(std::abs(double((&m.normals[2].x)[k]) - c.n2[k]) <= 1e-6);
    }
  }
}

TEST_CASE("skins: 8-bit weights give the float weights' pose, weights are normalised", "[gltf][skin]") {
  GltfOptions opt;
  opt.time = 1;
  auto f = load_gltf<RGB>(gltf_json::write_temp_gltf("skin", "float_w.gltf", two_bone_strip()), opt);
  auto q = load_gltf<RGB>(gltf_json::write_temp_gltf("skin", "u8_w.gltf", two_bone_strip(1, false)), opt);
  // Weights 0.998 x the valid ones (inside the 1e-2 the loader admits)
  // are normalised back: the same pose.
  auto s = load_gltf<RGB>(gltf_json::write_temp_gltf("skin", "scaled_w.gltf", two_bone_strip(0.998f)), opt);
  const auto &mf = only_mesh(f), &mq = only_mesh(q), &ms = only_mesh(s);
  // v1's 8-bit halves are 128/255 and 127/255: joint 1's share is off by
  // 0.5/255, which moves v1 by 0.5/255 x |J1 v1 - J0 v1| = 0.5/255 x
  // |(1, 0.5, 0) - (1.5, 0, 0)| = 1.387e-3 (plus float rounding, 1e-6).
  const double shift = 0.5 / 255 * std::sqrt(0.5);
  for (size_t v = 0; v < 5; ++v) {
    CHECK(length(mq.positions[v] - mf.positions[v]) <= (v == 1 ? shift + 1e-6 : 1e-6));
    CHECK(length(ms.positions[v] - mf.positions[v]) <= 1e-6);
  }
}

TEST_CASE("morph targets: default and animated weights against values worked out by hand", "[gltf][morph]") {
  // Default weights [0.25, 0]: every vertex up by 0.25; v0's normal
  // (0.25, 0, 1) normalised.
  auto still = load_gltf<RGB>(gltf_json::write_temp_gltf("morph", "still.gltf", morph_triangle(false)));
  CHECK(still.deformed_instances == 1);
  const auto& m = only_mesh(still);
  const double l = std::sqrt(0.25 * 0.25 + 1);
  CHECK(std::abs(m.positions[0].z - 0.25) <= 1e-7);
  CHECK(std::abs(m.positions[2].z - 0.25) <= 1e-7);
  CHECK(std::abs(m.positions[0].x) <= 1e-7);
  CHECK(std::abs(m.normals[0].x - 0.25 / l) <= 1e-6);
  CHECK(std::abs(m.normals[0].z - 1 / l) <= 1e-6);
  // Animated, at t = 0.5: weights [0.5, 0.25]: v0 at (0.25, 0, 0.5), v1 at
  // (1, 0, 0.5); at t = 2, past the last key: [1, 0.5], v0 at (0.5, 0, 1).
  GltfOptions half;
  half.time = 0.5;
  const std::string anim = gltf_json::write_temp_gltf("morph", "animated.gltf", morph_triangle(true));
  auto a = load_gltf<RGB>(anim, half);
  const auto& ma = only_mesh(a);
  CHECK(std::abs(ma.positions[0].x - 0.25) <= 1e-7);
  CHECK(std::abs(ma.positions[0].z - 0.5) <= 1e-7);
  CHECK(std::abs(ma.positions[1].x - 1) <= 1e-7);
  CHECK(std::abs(ma.positions[1].z - 0.5) <= 1e-7);
  GltfOptions late;
  late.time = 2;
  auto b = load_gltf<RGB>(anim, late);
  const auto& mb = only_mesh(b);
  CHECK(std::abs(mb.positions[0].x - 0.5) <= 1e-7);
  CHECK(std::abs(mb.positions[0].z - 1) <= 1e-7);
  // node.weights take precedence over mesh.weights.
  json g = morph_triangle(false);
  g["nodes"][0]["weights"] = {0.0, 1.0};
  auto n = load_gltf<RGB>(gltf_json::write_temp_gltf("morph", "node_weights.gltf", g));
  const auto& mn = only_mesh(n);
  CHECK(std::abs(mn.positions[0].x - 1) <= 1e-7);
  CHECK(mn.positions[0].z == 0);
}

TEST_CASE("morph targets: zero weights leave the mesh bit-identical to one without targets", "[gltf][morph]") {
  auto zero = load_gltf<RGB>(gltf_json::write_temp_gltf("morph", "zero.gltf", morph_triangle(false, {0, 0})));
  auto none = load_gltf<RGB>(gltf_json::write_temp_gltf("morph", "none.gltf", morph_triangle(false, {})));
  json bare = morph_triangle(false, {});
  bare["meshes"][0]["primitives"][0].erase("targets");
  auto plain = load_gltf<RGB>(gltf_json::write_temp_gltf("morph", "bare.gltf", bare));
  CHECK(zero.deformed_instances == 0);
  CHECK(none.deformed_instances == 0);
  for (const auto* g : {&zero, &none}) {
    const auto &a = only_mesh(*g), &b = only_mesh(plain);
    CHECK(a.positions == b.positions);
    CHECK(a.normals == b.normals);
  }
}

// ---- CesiumMan against a skinning written from the specification ----

namespace spec {

using M4 = std::array<double, 16>;  // row-major
M4 mul(const M4& a, const M4& b) {
  M4 r{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k) r[4 * i + j] += a[4 * i + k] * b[4 * k + j];
  return r;
}
const M4 identity{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

// Float accessor elements (CesiumMan stores every float attribute, matrix
// and key as FLOAT and JOINTS_0 as unsigned shorts), honouring byteStride.
std::vector<double> floats(const tinygltf::Model& m, int a) {
  const auto& acc = m.accessors[size_t(a)];
  const auto& view = m.bufferViews[size_t(acc.bufferView)];
  const unsigned char* base = m.buffers[size_t(view.buffer)].data.data() + view.byteOffset + acc.byteOffset;
  size_t comps = size_t(tinygltf::GetNumComponentsInType(uint32_t(acc.type)));
  size_t size = acc.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT ? 4 : 2;
  size_t stride = view.byteStride ? view.byteStride : comps * size;
  std::vector<double> out;
  for (size_t i = 0; i < acc.count; ++i)
    for (size_t c = 0; c < comps; ++c) {
      const unsigned char* p = base + i * stride + c * size;
      if (size == 4) {
        float f;
        std::memcpy(&f, p, 4);
        out.push_back(f);
      } else {
        uint16_t u;
        std::memcpy(&u, p, 2);
        out.push_back(u);
      }
    }
  return out;
}

// A node's local matrix at time t: T R S from its TRS, with animated values
// (LINEAR; rotations by spherical linear interpolation on the shorter arc).
M4 local(const tinygltf::Model& m, int n, double t) {
  const auto& node = m.nodes[size_t(n)];
  if (node.matrix.size() == 16) {
    M4 r;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) r[size_t(4 * i + j)] = node.matrix[size_t(4 * j + i)];
    return r;
  }
  std::array<double, 3> T{0, 0, 0}, S{1, 1, 1};
  std::array<double, 4> Q{0, 0, 0, 1};
  for (size_t i = 0; i < node.translation.size(); ++i) T[i] = node.translation[i];
  for (size_t i = 0; i < node.scale.size(); ++i) S[i] = node.scale[i];
  for (size_t i = 0; i < node.rotation.size(); ++i) Q[i] = node.rotation[i];
  for (const auto& anim : m.animations)
    for (const auto& ch : anim.channels) {
      if (ch.target_node != n) continue;
      const auto& s = anim.samplers[size_t(ch.sampler)];
      auto keys = floats(m, s.input), vals = floats(m, s.output);
      size_t comps = vals.size() / keys.size();
      size_t k = 0;
      while (k + 2 < keys.size() && keys[k + 1] <= t) ++k;
      double u = std::clamp((t - keys[k]) / (keys[k + 1] - keys[k]), 0.0, 1.0);
      std::vector<double> a(vals.begin() + long(k * comps), vals.begin() + long((k + 1) * comps));
      std::vector<double> b(vals.begin() + long((k + 1) * comps), vals.begin() + long((k + 2) * comps));
      std::vector<double> v(comps);
      if (ch.target_path == "rotation") {
        double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
        double sign = d < 0 ? -1 : 1;
        double theta = std::acos(std::min(1.0, std::abs(d)));
        double wa = 1 - u, wb = u;
        if (theta > 1e-9) {
          wa = std::sin((1 - u) * theta) / std::sin(theta);
          wb = std::sin(u * theta) / std::sin(theta);
        }
        for (size_t c = 0; c < 4; ++c) v[c] = wa * a[c] + wb * sign * b[c];
        for (size_t c = 0; c < 4; ++c) Q[c] = v[c];
      } else {
        for (size_t c = 0; c < comps; ++c) v[c] = (1 - u) * a[c] + u * b[c];
        for (size_t c = 0; c < 3; ++c) (ch.target_path == "translation" ? T : S)[c] = v[c];
      }
    }
  double qn = std::sqrt(Q[0] * Q[0] + Q[1] * Q[1] + Q[2] * Q[2] + Q[3] * Q[3]);
  double x = Q[0] / qn, y = Q[1] / qn, z = Q[2] / qn, w = Q[3] / qn;
  // The rotation matrix of a unit quaternion (x, y, z, w).
  M4 R{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y), 0,
       2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x), 0,
       2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y), 0,
       0, 0, 0, 1};
  // T R S: scale first, then rotate, then translate.
  M4 Sm{S[0], 0, 0, 0, 0, S[1], 0, 0, 0, 0, S[2], 0, 0, 0, 0, 1};
  M4 Tm{1, 0, 0, T[0], 0, 1, 0, T[1], 0, 0, 1, T[2], 0, 0, 0, 1};
  return mul(Tm, mul(R, Sm));
}

M4 global(const tinygltf::Model& m, int n, double t) {
  for (size_t p = 0; p < m.nodes.size(); ++p)
    for (int c : m.nodes[p].children)
      if (c == n) return mul(global(m, int(p), t), local(m, n, t));
  return local(m, n, t);
}

// The skinned mesh's triangles at time t, in the order of its indices.
std::vector<Tri> skinned(const std::string& path, double t) {
  tinygltf::Model m;
  tinygltf::TinyGLTF loader;
  std::string err, warn;
  REQUIRE(loader.LoadBinaryFromFile(&m, &err, &warn, path));
  const tinygltf::Node* node = nullptr;
  for (const auto& n : m.nodes)
    if (n.mesh >= 0 && n.skin >= 0) node = &n;
  REQUIRE(node);
  const auto& skin = m.skins[size_t(node->skin)];
  auto ibm = floats(m, skin.inverseBindMatrices);
  std::vector<M4> joint(skin.joints.size());
  for (size_t j = 0; j < joint.size(); ++j) {
    M4 inv;
    for (int r = 0; r < 4; ++r)
      for (int c = 0; c < 4; ++c) inv[size_t(4 * r + c)] = ibm[16 * j + size_t(4 * c + r)];
    joint[j] = mul(global(m, skin.joints[j], t), inv);
  }
  std::vector<Tri> out;
  for (const auto& prim : m.meshes[size_t(node->mesh)].primitives) {
    auto pos = floats(m, prim.attributes.at("POSITION"));
    auto js = floats(m, prim.attributes.at("JOINTS_0"));
    auto ws = floats(m, prim.attributes.at("WEIGHTS_0"));
    auto idx = floats(m, prim.indices);
    auto at = [&](size_t v) {
      std::array<double, 3> p{0, 0, 0};
      double sum = ws[4 * v] + ws[4 * v + 1] + ws[4 * v + 2] + ws[4 * v + 3];
      for (size_t k = 0; k < 4; ++k) {
        const M4& J = joint[size_t(js[4 * v + k])];
        double w = ws[4 * v + k] / sum;
        for (size_t r = 0; r < 3; ++r)
          p[r] += w * (J[4 * r] * pos[3 * v] + J[4 * r + 1] * pos[3 * v + 1] + J[4 * r + 2] * pos[3 * v + 2] + J[4 * r + 3]);
      }
      return p;
    };
    for (size_t i = 0; i + 2 < idx.size(); i += 3)
      out.push_back({at(size_t(idx[i])), at(size_t(idx[i + 1])), at(size_t(idx[i + 2]))});
  }
  return out;
}

}  // namespace spec

// CesiumMan's animation runs from 0.04 s to 2 s. Tolerance: prism stores
// positions as float after skinning in double; the figure is about 1.5 m
// tall, so a coordinate rounds by at most 2^-24 x 2 = 1.2e-7 m, and the
// instance transform (the identity) adds nothing: 1e-6 m leaves room for
// the few float operations of world_triangles.
TEST_CASE("skins: CesiumMan at three times against a skinning written from the specification", "[gltf][skin][shared]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
  const std::string path = scenes_dir + "CesiumMan/glTF-Binary/CesiumMan.glb";
  double previous_worst_move = 0;
  std::vector<Tri> previous;
  for (double t : {0.5, 1.0, 1.5}) {
    INFO("time " << t);
    GltfOptions opt;
    opt.time = t;
    auto g = load_gltf<RGB>(path, opt);
    CHECK(g.warnings.empty());
    CHECK(g.deformed_instances == 1);
    auto got = mesh_compare::world_triangles(g);
    auto want = spec::skinned(path, t);
    REQUIRE(got.size() == want.size());
    double worst = 0;
    for (size_t i = 0; i < got.size(); ++i)
      for (size_t k = 0; k < 3; ++k) worst = std::max(worst, mesh_compare::dist(got[i][k], want[i][k]));
    INFO("worst vertex distance " << worst << " m over " << got.size() << " triangles");
    CHECK(worst <= 1e-6);
    // A control: the pose changes between the three times (by centimetres).
    if (!previous.empty()) {
      double move = 0;
      for (size_t i = 0; i < got.size(); ++i) move = std::max(move, mesh_compare::dist(got[i][0], previous[i][0]));
      CHECK(move > 0.02);
      previous_worst_move = move;
    }
    previous = got;
  }
  CHECK(previous_worst_move > 0);
}

// The Draco twin quantizes positions to 11 bits of the model's extent and
// its skin weights to 8 bits over [-0.0039, 1.0039] (a step of 1.0078/255,
// the accessor's min and max): a vertex moves by at most one position step
// (extent / 2^11, as in extensions_test) plus, for each of its 4 weights,
// half a weight step times the distance between two joints' images of it
// (at most the extent): extent x (1/2048 + 4 x 0.5 x 1.0078/255).
TEST_CASE("skins and morph targets: the Draco and quantized twins deform as their plain files", "[gltf][skin][morph][shared]") {
  if (!have_scenes()) PRISM_TEST_SKIP("../shared/scenes is absent");
#if defined(PRISM_HAS_DRACO)
  for (double t : {0.5, 1.5}) {
    GltfOptions opt;
    opt.time = t;
    auto plain = load_gltf<RGB>(scenes_dir + "CesiumMan/glTF-Binary/CesiumMan.glb", opt);
    auto twin = load_gltf<RGB>(scenes_dir + "CesiumMan/glTF-Draco/CesiumMan.gltf", opt);
    auto a = mesh_compare::world_triangles(twin), b = mesh_compare::world_triangles(plain);
    Vector3f e = plain.bounds.max - plain.bounds.min;
    double extent = std::max({e.x, e.y, e.z});
    double tol = extent * (1.0 / 2048 + 2 * 1.0078 / 255);
    double ab = mesh_compare::worst_distance(a, b), ba = mesh_compare::worst_distance(b, a);
    INFO("CesiumMan at " << t << ": worst distance " << ab << " / " << ba << ", tolerance " << tol);
    CHECK(ab <= tol);
    CHECK(ba <= tol);
  }
  {
    // MorphPrimitivesTest's default weight 0.5 lifts a pyramid 0.1 high in
    // the red primitive; positions are quantized to 11 bits of the extent.
    auto plain = load_gltf<RGB>(scenes_dir + "MorphPrimitivesTest/glTF-Binary/MorphPrimitivesTest.glb");
    auto twin = load_gltf<RGB>(scenes_dir + "MorphPrimitivesTest/glTF-Draco/MorphPrimitivesTest.gltf");
    CHECK(plain.deformed_instances == 1);
    CHECK(twin.deformed_instances == 1);
    auto a = mesh_compare::world_triangles(twin), b = mesh_compare::world_triangles(plain);
    Vector3f e = plain.bounds.max - plain.bounds.min;
    double tol = std::max({e.x, e.y, e.z}) / 2048.0;
    CHECK(mesh_compare::worst_distance(a, b) <= tol);
    CHECK(mesh_compare::worst_distance(b, a) <= tol);
    CHECK(plain.bounds.max.y >= 0.09f);  // the morph happened (the base is flat at y = 0)
  }
#endif
  // AnimatedMorphCube's quantized twin stores positions and targets as
  // shorts (a step of 3.649e-6 x 100 world units, as in quantization_test:
  // 6.3e-4 per vertex) and its animated weights as normalized unsigned
  // bytes: each weight is off by up to 0.5/255, times its target's largest
  // displacement, 5188 and 5451 steps: 0.5/255 x (5188 + 5451) x 3.649e-4.
  for (double t : {1.0, 2.5}) {
    GltfOptions opt;
    opt.time = t;
    auto plain = load_gltf<RGB>(scenes_dir + "AnimatedMorphCube/glTF-Binary/AnimatedMorphCube.glb", opt);
    auto twin = load_gltf<RGB>(scenes_dir + "AnimatedMorphCube/glTF-Quantized/AnimatedMorphCube.gltf", opt);
    CHECK(plain.deformed_instances == 1);
    auto a = mesh_compare::world_triangles(twin), b = mesh_compare::world_triangles(plain);
    double tol = 3.65e-4 * std::sqrt(3.0) + 0.5 / 255 * (5188 + 5451) * 3.649e-4;
    double ab = mesh_compare::worst_distance(a, b), ba = mesh_compare::worst_distance(b, a);
    INFO("AnimatedMorphCube at " << t << ": worst distance " << ab << " / " << ba << ", tolerance " << tol);
    CHECK(ab <= tol);
    CHECK(ba <= tol);
  }
}

}  // namespace skin_test
