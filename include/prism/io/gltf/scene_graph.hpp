// prism/io/gltf/scene_graph.hpp — the glTF scene graph into a prism Scene:
// the public GltfOptions, GltfCamera and GltfScene; the Loader, which reads
// the file (container.hpp, images.hpp) and walks the chosen scene's node
// tree, composing world transforms in double (with animation.hpp's values
// at the shutter's open and close), placing mesh instances (a glTF mesh's
// primitives and materials, built once; EXT_mesh_gpu_instancing; moving
// instances; skinned and morphed meshes built per node, deform.hpp), cameras and KHR_lights_punctual lights; and the framing camera
// for a scene without one.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>
#include <tiny_gltf.h>
#include "prism/bxdfs/bsdf.hpp"
#include "prism/bxdfs/metal_rough.hpp"
#include "prism/cameras/perspective.hpp"
#include "prism/error.hpp"
#include "prism/io/gltf/accessors.hpp"
#include "prism/io/gltf/animation.hpp"
#include "prism/io/gltf/container.hpp"
#include "prism/io/gltf/deform.hpp"
#include "prism/io/gltf/images.hpp"
#include "prism/io/gltf/materials.hpp"
#include "prism/io/gltf/meshes.hpp"
#include "prism/io/gltf/meshopt.hpp"
#include "prism/lights/punctual.hpp"
#include "prism/math/animated_transform.hpp"
#include "prism/math/bounds.hpp"
#include "prism/math/float.hpp"
#include "prism/math/transform.hpp"
#include "prism/render/scene.hpp"
#include "prism/spectra/rgb.hpp"

namespace prism {

struct GltfOptions {
  int scene = -1;   // the glTF scene to load; -1: the file's default (else scene 0)
  // Animations are sampled at this time (seconds): node transforms, skins
  // (linear blend skinning) and morph weights.
  double time = 0;
  // Motion blur: a shutter open from `time` to `time + shutter` seconds. A
  // mesh node that the animations move in that interval becomes a moving
  // instance with the node's world transforms at both ends as its keys
  // (AnimatedTransform: linear translation and stretch, slerp rotation); a
  // camera node that moves gets the same two keys as GltfCamera::motion
  // (camera motion blur). A skinned or morphing mesh whose animation runs
  // during the shutter deforms (deformation blur): it is skinned and morphed
  // at `deformation_keys` evenly spaced times from the shutter's open to its
  // close, and its vertices move in straight lines between them
  // (Scene::add_deforming_mesh). Punctual lights stay where they are at
  // `time`, and so do emissive meshes.
  double shutter = 0;
  // Vertex keys over the shutter for deformation blur, at least 2 (2: each
  // vertex moves along the chord from the shutter's open to its close; more
  // follow a turning limb; docs/motion_blur.md measures the cost).
  int deformation_keys = 5;
  // Kulla-Conty energy compensation on every material's rough lobes
  // (MetalRoughMaterial::multiple_scattering; docs/microfacets.md). Off by default:
  // glTF's reference viewers render single scattering.
  bool multiple_scattering = false;
  // How material textures filter over a pixel's footprint
  // (ImageTexture::filtering; the footprint comes from the scene's
  // PixelFootprint, Scene::set_pixel_footprint): bilinear, the default, as
  // the sampler says whatever the footprint; trilinear and ewa build each
  // image's MIP pyramid (a third more memory) unless its sampler's minFilter
  // asks for no mipmaps.
  TextureFilter texture_filter = TextureFilter::bilinear;
  // KHR_materials_variants: the name of the material variant to load; empty:
  // the file's default materials. A name the file does not define is an
  // error that lists the names it does.
  std::string variant;
};

// A camera of the file, placed by its node. camera_to_world maps prism's
// camera space (+x right, +y up, +z forward) to the world.
struct GltfCamera {
  std::string name;
  bool orthographic = false;
  Transform camera_to_world;  // at GltfOptions::time
  // Camera motion blur: the camera's transform from the shutter's open to its
  // close (GltfOptions::shutter), when its node moves in that interval; give
  // it to the camera with set_motion().
  std::optional<AnimatedTransform> motion;
  Float yfov = 0;          // perspective: vertical field of view, radians
  Float aspect_ratio = 0;  // perspective: 0 if the file leaves it to the viewer
  Float ymag = 0;          // orthographic: half the window height
  Float xmag = 0;
};

template <class S>
using gltf_bxdf_set = bxdf_set<MetalRoughBxDF<S>>;

template <class S, class Set = gltf_bxdf_set<S>>
struct GltfScene {
  Scene<S, Set> scene;           // not built: add lights, then call build()
  std::vector<GltfCamera> cameras;  // in the order the node tree meets them
  std::vector<std::string> warnings;
  Bounds3f bounds;               // world bounds of every instance
  size_t mesh_triangles = 0;     // summed over the file's meshes, each once
  size_t scene_triangles = 0;    // summed over every instance in the scene
  size_t punctual_lights = 0;    // KHR_lights_punctual lights placed
  size_t emissive_instances = 0;
  size_t moving_instances = 0;   // instances that move during the shutter (GltfOptions::shutter)
  size_t deformed_instances = 0; // instances of skinned or morphed meshes (at GltfOptions::time)
  size_t deforming_meshes = 0;   // meshes with vertex keys over the shutter (deformation blur)
  size_t images = 0, image_bytes = 0;
  std::vector<std::string> variants;  // KHR_materials_variants: the file's variant names, in order
  std::string variant;               // the variant loaded (GltfOptions::variant); empty: the defaults
  bool has_lights() const { return punctual_lights + emissive_instances > 0; }
};

namespace gltf_detail {

template <class S, class Set>
class Loader {
 public:
  Loader(std::string path, const GltfOptions& opt) : m_opt(opt) { m_doc.path = std::move(path); }
  Loader(const Loader&) = delete;  // m_materials and m_animation refer to members
  Loader& operator=(const Loader&) = delete;

  GltfScene<S, Set> load() {
    load_model(m_doc, m_pending);
    check_extensions(m_doc);
    decode_meshopt(m_doc);
    read_variants();
    m_images = decode_images(m_doc.model, m_pending);
    m_out.images = m_images.count;
    m_out.image_bytes = m_images.bytes;
    int scene = m_opt.scene >= 0 ? m_opt.scene : (m_doc.model.defaultScene >= 0 ? m_doc.model.defaultScene : 0);
    if (m_doc.model.scenes.empty()) {
      if (m_opt.scene >= 0)
        m_doc.fail("scenes", "the file has no scenes, so scene " + std::to_string(m_opt.scene) + " does not exist");
      if (m_doc.model.defaultScene >= 0)
        m_doc.fail("scene", "index " + std::to_string(m_doc.model.defaultScene) + " out of range (the file has no scenes)");
      m_doc.warn("the file has no scenes: nothing to render");
      return finish();
    }
    if (scene >= int(m_doc.model.scenes.size()))
      m_doc.fail(m_opt.scene >= 0 ? std::string("scene") : std::string("scene"),
                 "index " + std::to_string(scene) + " out of range (" + std::to_string(m_doc.model.scenes.size()) +
                     " scenes)");
    m_mesh_tris = mesh_triangle_counts(m_doc.model);
    for (size_t t : m_mesh_tris) m_out.mesh_triangles += t;
    m_animation.prepare();
    const auto& sc = m_doc.model.scenes[size_t(scene)];
    std::vector<uint8_t> on_path(m_doc.model.nodes.size(), 0);
    for (size_t i = 0; i < sc.nodes.size(); ++i) {
      int n = sc.nodes[i];
      m_doc.check_index(n, m_doc.model.nodes.size(), idx("scenes", scene) + ".nodes[" + std::to_string(i) + "]", "node");
      visit(n, Matrix4d{}, Matrix4d{}, on_path, 0);
    }
    return finish();
  }

 private:
  GltfScene<S, Set> finish() {
    m_out.warnings = std::move(m_doc.warnings);
    return std::move(m_out);
  }

  // The prism meshes (with materials) of a glTF mesh, built once.
  struct Part {
    uint32_t mesh;
    uint32_t material;
    int gltf_material;
  };
  // With a deformation, the parts are the node's own: built each time. With
  // several (`keys`: deformations at evenly spaced times over the shutter),
  // they are deforming meshes with those vertex keys.
  const std::vector<Part>& mesh_parts(int m, const Deformation* deform = nullptr,
                                      const std::vector<Deformation>& keys = {}) {
    if (!keys.empty()) deform = &keys[0];
    auto found = m_mesh_cache.find(m);
    if (!deform && found != m_mesh_cache.end()) return found->second;
    std::vector<Part> parts;
    const auto& mesh = m_doc.model.meshes[size_t(m)];
    if (mesh.primitives.empty())
      m_doc.fail(idx("meshes", m) + ".primitives", "is empty (a mesh needs at least one primitive)");
    for (size_t p = 0; p < mesh.primitives.size(); ++p) {
      const auto& prim = mesh.primitives[p];
      std::string where = idx("meshes", m) + ".primitives[" + std::to_string(p) + "]";
      if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != TINYGLTF_MODE_TRIANGLE_STRIP &&
          prim.mode != TINYGLTF_MODE_TRIANGLE_FAN) {
        if (prim.mode < 0 || prim.mode > 6) m_doc.fail(where + ".mode", "invalid mode " + std::to_string(prim.mode));
        if (!m_warned_points)
          m_doc.warn(where + ": points and lines are not rendered (skipped; further ones not reported)");
        m_warned_points = true;
        continue;
      }
      // Primitives with the same accessors share one prism mesh.
      auto attr = [&](const char* name) {
        auto it = prim.attributes.find(name);
        return it == prim.attributes.end() ? -1 : it->second;
      };
      auto key = std::make_tuple(attr("POSITION"), attr("NORMAL"), attr("TEXCOORD_0"), attr("TEXCOORD_1"),
                                 attr("TANGENT"), attr("COLOR_0"), prim.indices, prim.mode);
      if (prim.material != -1)
        m_doc.check_index(prim.material, m_doc.model.materials.size(), where + ".material", "material");
      int mat = variant_material(prim, where);
      uint32_t mesh_id;
      auto shared = m_prim_cache.find(key);
      if (!deform && shared != m_prim_cache.end()) {
        mesh_id = shared->second;
      } else {
        TriangleMesh tm = build_primitive(m_doc, prim, where, deform);
        if (tm.triangle_count() == 0) m_doc.fail(where, "has no triangle (too few vertices or indices)");
        if (keys.size() > 1)
          mesh_id = add_keyed_mesh(std::move(tm), prim, where, keys, m_materials.emission(mat).has_value());
        else
          mesh_id = m_out.scene.add_mesh(std::move(tm));
        if (!deform) m_prim_cache.emplace(key, mesh_id);
      }
      parts.push_back({mesh_id, material(mat), mat});
    }
    if (deform) return m_deformed_parts = std::move(parts);
    return m_mesh_cache.emplace(m, std::move(parts)).first->second;
  }

  // A primitive deformed at each of `keys` (tm: at the first): a deforming
  // mesh, or a still one when the keys do not differ or it emits (area
  // lights do not deform: it stays as it is when the shutter opens).
  uint32_t add_keyed_mesh(TriangleMesh tm, const tinygltf::Primitive& prim, const std::string& where,
                          const std::vector<Deformation>& keys, bool emits) {
    if (emits) {
      if (!m_warned_deforming_emitter)
        m_doc.warn(where + ": an emissive mesh deforms during the shutter; area lights do not deform: drawn as it is "
                           "when the shutter opens");
      m_warned_deforming_emitter = true;
      return m_out.scene.add_mesh(std::move(tm));
    }
    VertexMotion vm;
    vm.time0 = Float(m_opt.time);
    vm.time1 = Float(m_opt.time + m_opt.shutter);
    if (!(vm.time1 > vm.time0)) {  // a shutter shorter than a float's step at this time
      if (!m_warned_short_shutter)
        m_doc.warn(where + ": the shutter is too short to tell its ends apart at this time: drawn as it is when it "
                           "opens");
      m_warned_short_shutter = true;
      return m_out.scene.add_mesh(std::move(tm));
    }
    bool moves = false;
    Bounds3f box;
    for (size_t k = 0; k < keys.size(); ++k) {
      TriangleMesh key = k == 0 ? tm : build_primitive(m_doc, prim, where, &keys[k]);
      if (key.positions.size() != tm.positions.size())  // the same accessors: cannot happen
        m_doc.fail(where, "its vertex count changes between deformation keys");
      moves = moves || key.positions != tm.positions;
      for (const auto& p : key.positions) box = union_bounds(box, p);
      vm.positions.push_back(std::move(key.positions));
      if (!tm.normals.empty()) vm.normals.push_back(std::move(key.normals));
      if (!tm.tangents.empty()) vm.tangents.push_back(std::move(key.tangents));
    }
    if (!moves) return m_out.scene.add_mesh(std::move(tm));
    uint32_t id;
    try {
      id = m_out.scene.add_deforming_mesh(std::move(tm), std::move(vm));
    } catch (const Error& e) {
      m_doc.fail(where, e.what());
    }
    m_bounds_cache.emplace(id, box);
    ++m_out.deforming_meshes;
    return id;
  }

  // Node n's world transform at `time`, through its parents (the first node
  // that lists it as a child), wherever it is in the file: a skin's joints
  // need not be in the scene being loaded.
  Matrix4d node_world(int n, double time) {
    const auto& nodes = m_doc.model.nodes;
    if (m_parent.empty()) {
      m_parent.assign(nodes.size(), -1);
      for (size_t p = 0; p < nodes.size(); ++p)
        for (size_t c = 0; c < nodes[p].children.size(); ++c) {
          int child = nodes[p].children[c];
          m_doc.check_index(child, nodes.size(), idx("nodes", int(p)) + ".children[" + std::to_string(c) + "]", "node");
          if (m_parent[size_t(child)] == -1) m_parent[size_t(child)] = int(p);
        }
    }
    Matrix4d w = m_animation.local_matrix(n, time);
    int depth = 0;
    for (int p = m_parent[size_t(n)]; p != -1; p = m_parent[size_t(p)]) {
      if (++depth > 4096) m_doc.fail(idx("nodes", n), "its ancestors form a cycle or are deeper than 4096 levels");
      w = m_animation.local_matrix(p, time) * w;
    }
    return w;
  }

  // What deforms node n's mesh at `time`: its morph weights and its skin's
  // joint matrices (deform.hpp).
  Deformation deformation(int n, const tinygltf::Node& node, double time) {
    Deformation d;
    d.morph_weights = m_animation.morph_weights(n, time, default_morph_weights(m_doc, n));
    if (node.skin != -1) {
      m_doc.check_index(node.skin, m_doc.model.skins.size(), idx("nodes", n) + ".skin", "skin");
      d.joints = joint_matrices(m_doc, node.skin, [&](int j) { return node_world(j, time); });
    }
    return d;
  }

  // KHR_materials_variants: the file's variant names, and the index of the
  // one GltfOptions::variant asks for (-1: the default materials).
  void read_variants() {
    const char* key = "KHR_materials_variants";
    const std::string where = "extensions.KHR_materials_variants.variants";
    if (const auto* e = ext(m_doc.model.extensions, key)) {
      if (e->Has("variants")) {
        const auto& v = e->Get("variants");
        if (!v.IsArray()) m_doc.fail(where, "must be an array");
        for (size_t i = 0; i < v.ArrayLen(); ++i) {
          const auto& item = v.Get(int(i));
          std::string w = where + "[" + std::to_string(i) + "]";
          if (!item.IsObject() || !item.Has("name") || !item.Get("name").IsString())
            m_doc.fail(w, "must be an object with a string 'name'");
          m_out.variants.push_back(item.Get("name").Get<std::string>());
        }
      }
    }
    if (m_opt.variant.empty()) return;
    for (size_t i = 0; i < m_out.variants.size(); ++i)
      if (m_out.variants[i] == m_opt.variant) {
        m_variant = int(i);
        m_out.variant = m_opt.variant;
        return;
      }
    if (m_out.variants.empty())
      throw Error(m_doc.path + ": material variant '" + m_opt.variant +
                  "' asked for, but the file defines no variants (KHR_materials_variants)");
    std::string names;
    for (const auto& n : m_out.variants) names += (names.empty() ? "'" : ", '") + n + "'";
    throw Error(m_doc.path + ": no material variant named '" + m_opt.variant + "'; the file's variants: " + names);
  }

  // The material a primitive uses: its KHR_materials_variants mapping for the
  // chosen variant, else its own material. Mappings are checked whatever
  // the variant, so a broken file fails the same way every time.
  int variant_material(const tinygltf::Primitive& prim, const std::string& where) {
    int chosen = prim.material;
    const auto* e = ext(prim.extensions, "KHR_materials_variants");
    if (!e || !e->Has("mappings")) return chosen;
    std::string mw = where + ".extensions.KHR_materials_variants.mappings";
    const auto& maps = e->Get("mappings");
    if (!maps.IsArray()) m_doc.fail(mw, "must be an array");
    for (size_t i = 0; i < maps.ArrayLen(); ++i) {
      const auto& m = maps.Get(int(i));
      std::string w = mw + "[" + std::to_string(i) + "]";
      if (!m.IsObject() || !m.Has("material") || !m.Get("material").IsNumber() || !m.Has("variants") ||
          !m.Get("variants").IsArray())
        m_doc.fail(w, "must be an object with a 'material' index and a 'variants' array");
      int material = as_index(m.Get("material").GetNumberAsDouble());
      m_doc.check_index(material, m_doc.model.materials.size(), w + ".material", "material");
      const auto& vs = m.Get("variants");
      for (size_t k = 0; k < vs.ArrayLen(); ++k) {
        const auto& v = vs.Get(int(k));
        if (!v.IsNumber()) m_doc.fail(w + ".variants[" + std::to_string(k) + "]", "must be a variant index");
        int vi = as_index(v.GetNumberAsDouble());
        m_doc.check_index(vi, m_out.variants.size(), w + ".variants[" + std::to_string(k) + "]", "variant");
        if (vi == m_variant) chosen = material;
      }
    }
    return chosen;
  }

  // The scene's material for materials[i] (-1: the default), added once.
  uint32_t material(int i) {
    auto found = m_material_cache.find(i);
    if (found != m_material_cache.end()) return found->second;
    uint32_t id = m_out.scene.add_material(m_materials.material(i));
    m_material_cache.emplace(i, id);
    return id;
  }

  // parent and parent_end: the parent's world transform when the shutter
  // opens and when it closes (the same without motion blur).
  void visit(int n, const Matrix4d& parent, const Matrix4d& parent_end, std::vector<uint8_t>& on_path, int depth) {
    std::string where = idx("nodes", n);
    if (on_path[size_t(n)]) m_doc.fail(where, "is its own ancestor (the node hierarchy has a cycle)");
    if (depth > 4096) m_doc.fail(where, "the node hierarchy is deeper than 4096 levels");
    on_path[size_t(n)] = 1;
    const auto& node = m_doc.model.nodes[size_t(n)];
    Matrix4d world = parent * m_animation.local_matrix(n, m_opt.time);
    Matrix4d world_end = m_opt.shutter > 0 && !m_animation.empty()
                             ? parent_end * m_animation.local_matrix(n, m_opt.time + m_opt.shutter)
                             : world;
    if (node.mesh != -1) {
      m_doc.check_index(node.mesh, m_doc.model.meshes.size(), where + ".mesh", "mesh");
      place_mesh(n, node, world, world_end);
    }
    if (node.camera != -1) {
      m_doc.check_index(node.camera, m_doc.model.cameras.size(), where + ".camera", "camera");
      place_camera(node.camera, world, world_end);
    }
    if (const auto* e = ext(node.extensions, "KHR_lights_punctual")) {
      int l = int(number(e, "light", -1));
      m_doc.check_index(l, m_doc.model.lights.size(), where + ".extensions.KHR_lights_punctual.light", "light");
      place_light(l, world);
    }
    for (size_t c = 0; c < node.children.size(); ++c) {
      int child = node.children[c];
      m_doc.check_index(child, m_doc.model.nodes.size(), where + ".children[" + std::to_string(c) + "]", "node");
      visit(child, world, world_end, on_path, depth + 1);
    }
    on_path[size_t(n)] = 0;
  }

  void place_mesh(int n, const tinygltf::Node& node, const Matrix4d& world, const Matrix4d& world_end) {
    std::vector<Matrix4d> transforms, transforms_end;
    const Deformation deform = deformation(n, node, m_opt.time);
    // Deformation blur: the deformation at each key over the shutter (also
    // for morph weights that are all 0 when the shutter opens).
    std::vector<Deformation> keys;
    if (m_opt.shutter > 0 && (deform.skins() || m_animation.animates_weights(n))) {
      const int count = m_opt.deformation_keys;
      keys.push_back(deform);
      for (int k = 1; k < count; ++k)
        keys.push_back(deformation(n, node, m_opt.time + m_opt.shutter * double(k) / double(count - 1)));
    }
    if (deform.skins()) {
      // A skinned mesh is placed by its joints alone: the specification
      // has the node's own transform (and so its instancing) ignored.
      if (ext(node.extensions, "EXT_mesh_gpu_instancing"))
        m_doc.warn(idx("nodes", n) + ": EXT_mesh_gpu_instancing on a skinned mesh is ignored");
      transforms.push_back(Matrix4d{});
      transforms_end.push_back(Matrix4d{});
    } else if (const auto* e = ext(node.extensions, "EXT_mesh_gpu_instancing")) {
      std::string ew = idx("nodes", n) + ".extensions.EXT_mesh_gpu_instancing.attributes";
      const tinygltf::Value* attrs = e->Has("attributes") ? &e->Get("attributes") : nullptr;
      std::vector<double> t, r, s;
      size_t count = 0;
      bool have = false;
      auto get = [&](const char* key, int comps, std::vector<double>& dst) {
        if (!attrs || !attrs->Has(key)) return;
        dst = read_accessor(m_doc, int(number(attrs, key, -1)), ew + "." + key, comps);
        size_t c = dst.size() / size_t(comps);
        if (have && c != count) m_doc.fail(ew + "." + key, "count differs from the other instancing attributes");
        count = c;
        have = true;
      };
      get("TRANSLATION", 3, t);
      get("ROTATION", 4, r);
      get("SCALE", 3, s);
      for (size_t i = 0; i < count; ++i) {
        std::array<double, 3> ti{0, 0, 0}, si{1, 1, 1};
        std::array<double, 4> qi{0, 0, 0, 1};
        if (!t.empty()) ti = {t[3 * i], t[3 * i + 1], t[3 * i + 2]};
        if (!r.empty()) qi = {r[4 * i], r[4 * i + 1], r[4 * i + 2], r[4 * i + 3]};
        if (!s.empty()) si = {s[3 * i], s[3 * i + 1], s[3 * i + 2]};
        transforms.push_back(world * Matrix4d::trs(ti, qi, si));
        transforms_end.push_back(world_end * Matrix4d::trs(ti, qi, si));
      }
      if (!have) {
        transforms.push_back(world);
        transforms_end.push_back(world_end);
      }
    } else {
      transforms.push_back(world);
      transforms_end.push_back(world_end);
    }
    const auto& parts = mesh_parts(node.mesh, deform.any() ? &deform : nullptr, keys);
    if (deform.any() || !keys.empty()) m_out.deformed_instances += transforms.size();
    for (size_t i = 0; i < transforms.size(); ++i) {
      const Matrix4d& m = transforms[i];
      for (double v : m.m)
        if (!std::isfinite(v)) m_doc.fail(idx("nodes", n), "world transform is not finite");
      for (double v : transforms_end[i].m)
        if (!std::isfinite(v)) m_doc.fail(idx("nodes", n), "world transform at the shutter's close is not finite");
      Transform xf(m.to_float());
      if (!xf.invertible()) {
        m_doc.warn(idx("nodes", n) + ": singular transform (zero scale): instance skipped");
        continue;
      }
      std::optional<AnimatedTransform> motion;
      if (transforms_end[i] != m) {
        Transform xf_end(transforms_end[i].to_float());
        if (!xf_end.invertible()) {
          m_doc.warn(idx("nodes", n) + ": singular transform at the shutter's close: motion blur ignored");
        } else {
          try {
            motion = AnimatedTransform(TransformKey::decompose(xf), TransformKey::decompose(xf_end), Float(m_opt.time),
                                       Float(m_opt.time + m_opt.shutter), "motion");
          } catch (const Error& e) {
            m_doc.fail(idx("nodes", n), e.what());
          }
        }
      }
      for (const Part& p : parts) {
        auto em = m_materials.emission(p.gltf_material);
        if (motion && !em) {
          m_out.scene.add_instance(p.mesh, p.material, *motion);
          m_out.bounds = union_bounds(m_out.bounds, motion->motion_bounds(mesh_bounds(p.mesh), motion->start_time(),
                                                                          motion->end_time()));
          ++m_out.moving_instances;
          continue;
        }
        if (motion && em && !m_warned_moving_emitter) {
          m_doc.warn(idx("nodes", n) + ": an emissive mesh moves during the shutter; area lights stay still: drawn where "
                                       "it is when the shutter opens");
          m_warned_moving_emitter = true;
        }
        m_out.scene.add_instance(p.mesh, p.material, xf, em);
        if (em) ++m_out.emissive_instances;
        m_out.bounds = union_bounds(m_out.bounds, xf(mesh_bounds(p.mesh)));
      }
      m_out.scene_triangles += m_mesh_tris[size_t(node.mesh)];
    }
  }
  Bounds3f mesh_bounds(uint32_t mesh) {
    auto it = m_bounds_cache.find(mesh);
    if (it != m_bounds_cache.end()) return it->second;
    Bounds3f b;
    for (const auto& p : m_out.scene.accel().meshes()[mesh].positions) b = union_bounds(b, p);
    m_bounds_cache.emplace(mesh, b);
    return b;
  }

  // world_end: the node's world transform when the shutter closes.
  void place_camera(int c, const Matrix4d& world, const Matrix4d& world_end) {
    const auto& cam = m_doc.model.cameras[size_t(c)];
    std::string where = idx("cameras", c);
    GltfCamera out;
    out.name = cam.name.empty() ? where : cam.name;
    // glTF cameras look down -z; prism's camera space looks down +z.
    Matrix4d flip;
    flip.m[10] = -1;
    // Remove the node's scale: a camera's frame is rigid.
    auto rigid = [&](Matrix4d w) {
      for (double v : w.m)
        if (!std::isfinite(v)) m_doc.fail(where, "its node's world transform is not finite");
      for (size_t j = 0; j < 3; ++j) {
        double l = std::sqrt(w.m[j] * w.m[j] + w.m[4 + j] * w.m[4 + j] + w.m[8 + j] * w.m[8 + j]);
        if (!(l > 0)) m_doc.fail(where, "its node's transform is singular");
        for (size_t i = 0; i < 3; ++i) w.m[4 * i + j] /= l;
      }
      return Transform((w * flip).to_float());
    };
    out.camera_to_world = rigid(world);
    if (world_end != world) {
      try {
        out.motion = AnimatedTransform(TransformKey::decompose(out.camera_to_world),
                                       TransformKey::decompose(rigid(world_end)), Float(m_opt.time),
                                       Float(m_opt.time + m_opt.shutter), where + ": motion");
      } catch (const Error& e) {
        m_doc.fail(where, e.what());
      }
      if (!out.motion->is_moving()) out.motion.reset();
    }
    if (cam.type == "perspective") {
      out.yfov = Float(cam.perspective.yfov);
      out.aspect_ratio = Float(cam.perspective.aspectRatio);
      if (!(out.yfov > 0) || !(out.yfov < pi)) m_doc.fail(where + ".perspective.yfov", "must be in (0, pi)");
    } else if (cam.type == "orthographic") {
      out.orthographic = true;
      out.xmag = Float(cam.orthographic.xmag);
      out.ymag = Float(cam.orthographic.ymag);
      if (!(std::abs(out.ymag) > 0) || !std::isfinite(out.ymag))
        m_doc.fail(where + ".orthographic.ymag", "must be non-zero and finite");
      out.ymag = std::abs(out.ymag);
    } else {
      m_doc.fail(where + ".type", "'" + cam.type + "' is not perspective or orthographic");
    }
    m_out.cameras.push_back(out);
  }

  void place_light(int l, const Matrix4d& world) {
    const auto& g = m_doc.model.lights[size_t(l)];
    std::string where = idx("extensions.KHR_lights_punctual.lights", l);
    RGB color(1);
    if (!g.color.empty()) {
      if (g.color.size() != 3) m_doc.fail(where + ".color", "must have 3 numbers");
      color = RGB(Float(g.color[0]), Float(g.color[1]), Float(g.color[2]));
    }
    if (!color.is_finite() || color.r < 0 || color.g < 0 || color.b < 0)
      m_doc.fail(where + ".color", "must be finite and >= 0");
    if (!std::isfinite(g.intensity) || g.intensity < 0) m_doc.fail(where + ".intensity", "must be finite and >= 0");
    // Photometric to radiometric: candela (point, spot) and lux (directional)
    // over 683 lm/W; an RGB of (1, 1, 1) has luminance Y = 1 (docs/gltf.md).
    Float scale = Float(g.intensity / 683.0);
    auto o = world.apply_point({0, 0, 0});
    auto z = world.apply_point({0, 0, -1});
    Point3f p{Float(o[0]), Float(o[1]), Float(o[2])};
    Vector3f d{Float(z[0] - o[0]), Float(z[1] - o[1]), Float(z[2] - o[2])};
    try {
      if (g.type == "point") {
        m_out.scene.add_light(PointLight<S>(p, color, scale));
      } else if (g.type == "spot") {
        m_out.scene.add_light(SpotLight<S>(p, d, color, scale, Float(g.spot.innerConeAngle), Float(g.spot.outerConeAngle)));
      } else if (g.type == "directional") {
        m_out.scene.add_light(DistantLight<S>(d, color, scale));
      } else {
        m_doc.fail(where + ".type", "'" + g.type + "' is not point, spot or directional");
      }
    } catch (const Error& e) {
      if (std::string(e.what()).rfind(m_doc.path, 0) == 0) throw;
      m_doc.fail(where, e.what());
    }
    ++m_out.punctual_lights;
  }

  Document m_doc;
  GltfOptions m_opt;
  bool m_warned_moving_emitter = false;
  bool m_warned_deforming_emitter = false;
  bool m_warned_short_shutter = false;
  std::vector<int> m_parent;            // node_world: each node's parent, -1 for roots
  std::vector<Part> m_deformed_parts;   // mesh_parts with a deformation: the last node's
  PendingImages m_pending;
  Images m_images;
  Materials m_materials{m_doc, m_images, m_opt.multiple_scattering, m_opt.texture_filter};
  Animation m_animation{m_doc};
  GltfScene<S, Set> m_out;
  std::vector<size_t> m_mesh_tris;
  std::map<int, std::vector<Part>> m_mesh_cache;
  std::map<std::tuple<int, int, int, int, int, int, int, int>, uint32_t> m_prim_cache;
  std::map<uint32_t, Bounds3f> m_bounds_cache;
  std::map<int, uint32_t> m_material_cache;
  bool m_warned_points = false;
  int m_variant = -1;  // KHR_materials_variants: the index of GltfOptions::variant, -1: the defaults
};

}  // namespace gltf_detail

// The camera for a scene without one: the bounds' centre seen from +z
// (glTF's front), the bounding sphere framed with a 40 degree vertical field
// of view (narrower horizontally for portrait images). A flat model that
// +z would see edge-on is seen from 30 degrees above (flat in y, a ground
// plane) or 45 degrees to the side (flat in x) instead: flat means thinner
// than a thousandth of its largest extent.
inline PerspectiveCamera gltf_framing_camera(const Bounds3f& bounds, int width, int height, Float lens_radius = 0,
                                             Float focus_distance = 1) {
  Bounds3f b = bounds.empty() ? Bounds3f(Point3f(0, 0, 0)) : bounds;
  Point3f c = b.min + (b.max - b.min) * Float(0.5);
  Float r = std::max(length(b.max - b.min) / 2, Float(1e-3));
  Float fov = Float(40) * pi / 180;
  Float aspect = Float(width) / Float(height);
  Float half = std::min(fov / 2, std::atan(std::tan(fov / 2) * aspect));
  Float dist = r / std::sin(half) * Float(1.05);
  Vector3f e = b.max - b.min, dir(0, 0, 1);
  Float largest = std::max({e.x, e.y, e.z});
  if (e.y <= largest * Float(1e-3)) dir = Vector3f(0, Float(0.5), Float(0.8660254));
  else if (e.x <= largest * Float(1e-3)) dir = Vector3f(Float(0.70710678), 0, Float(0.70710678));
  Transform to_world = look_at_camera_to_world(c + dir * dist, c, Vector3f(0, 1, 0));
  return PerspectiveCamera(to_world, fov, width, height, lens_radius, focus_distance);
}

}  // namespace prism
