// prism/io/gltf/deform.hpp — morph targets and skins evaluated at one time,
// on the CPU, before a primitive becomes a prism mesh: the morph weights a
// node uses (node.weights, else mesh.weights, else zeros), each target's
// POSITION, NORMAL and TANGENT displacements added with them, then linear
// blend skinning with the joint matrices world(joint) · inverseBindMatrix
// and each vertex's weights normalised to sum 1. Positions take the blended
// matrix, normals its inverse transpose, tangents its linear part; normals
// and tangents are renormalised. Everything is computed in double.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <string>
#include <utility>
#include <vector>
#include <tiny_gltf.h>
#include "prism/io/gltf/accessors.hpp"
#include "prism/io/gltf/container.hpp"
#include "prism/math/transform.hpp"

namespace prism::gltf_detail {

// What deforms a primitive: the morph weights (one per target; empty: no
// morphing) and the skin's joint matrices (empty: no skin).
struct Deformation {
  std::vector<double> morph_weights;
  std::vector<Matrix4d> joints;
  bool morphs() const {
    for (double w : morph_weights)
      if (w != 0) return true;
    return false;
  }
  bool skins() const { return !joints.empty(); }
  bool any() const { return morphs() || skins(); }
};

// The default morph weights of a node's mesh: node.weights, else
// mesh.weights, else zeros, one per target of the mesh's first primitive.
inline std::vector<double> default_morph_weights(const Document& doc, int n) {
  const auto& node = doc.model.nodes[size_t(n)];
  const auto& mesh = doc.model.meshes[size_t(node.mesh)];
  size_t targets = mesh.primitives.empty() ? 0 : mesh.primitives[0].targets.size();
  std::vector<double> w(targets, 0.0);
  const std::vector<double>* given = !node.weights.empty() ? &node.weights : !mesh.weights.empty() ? &mesh.weights : nullptr;
  if (given) {
    std::string where = !node.weights.empty() ? idx("nodes", n) + ".weights" : idx("meshes", node.mesh) + ".weights";
    if (given->size() != targets)
      doc.fail(where, "has " + std::to_string(given->size()) + " weights, the mesh's morph targets are " +
                          std::to_string(targets));
    for (size_t i = 0; i < targets; ++i) {
      doc.check_finite_number((*given)[i], where);
      w[i] = (*given)[i];
    }
  }
  return w;
}

// The joint matrices of skins[s] at the time `world` evaluates node
// transforms: world(joint j) · inverseBindMatrices[j] (identity when the
// skin has none).
template <class WorldOf>
std::vector<Matrix4d> joint_matrices(const Document& doc, int s, WorldOf&& world) {
  const auto& skin = doc.model.skins[size_t(s)];
  std::string where = idx("skins", s);
  if (skin.joints.empty()) doc.fail(where + ".joints", "is empty (a skin needs at least one joint)");
  std::vector<double> ibm;
  if (skin.inverseBindMatrices != -1) {
    ibm = read_accessor(doc, skin.inverseBindMatrices, where + ".inverseBindMatrices", 16,
                        {TINYGLTF_COMPONENT_TYPE_FLOAT});
    if (ibm.size() / 16 < skin.joints.size())
      doc.fail(where + ".inverseBindMatrices", "has " + std::to_string(ibm.size() / 16) + " matrices for " +
                                                   std::to_string(skin.joints.size()) + " joints");
  }
  std::vector<Matrix4d> out(skin.joints.size());
  for (size_t j = 0; j < skin.joints.size(); ++j) {
    std::string jw = where + ".joints[" + std::to_string(j) + "]";
    doc.check_index(skin.joints[j], doc.model.nodes.size(), jw, "node");
    Matrix4d inv_bind;
    if (!ibm.empty())
      for (size_t r = 0; r < 4; ++r)
        for (size_t c = 0; c < 4; ++c) {
          double v = ibm[16 * j + 4 * c + r];  // column-major
          doc.check_finite_number(v, where + ".inverseBindMatrices");
          inv_bind.m[4 * r + c] = v;
        }
    out[j] = world(skin.joints[j]) * inv_bind;
  }
  return out;
}

// Deforms one primitive's vertices. Built once per primitive from its
// attributes (`read(name, accessor, element, components)` reads one, from
// Draco data where the primitive has it); then positions(), normals() and
// tangents() deform the attribute arrays in place.
class PrimitiveDeformer {
 public:
  template <class Read>
  PrimitiveDeformer(const Document& doc, const tinygltf::Primitive& prim, const std::string& where,
                    const Deformation& d, size_t vertices, Read&& read)
      : m_doc(doc), m_prim(prim), m_where(where), m_def(d), m_nv(vertices) {
    if (d.morphs() && d.morph_weights.size() != prim.targets.size())
      doc.fail(where + ".targets", "has " + std::to_string(prim.targets.size()) + " morph targets, the weights are " +
                                       std::to_string(d.morph_weights.size()));
    if (d.skins()) blend(read);
  }

  void positions(std::vector<double>& p) const {
    add_targets("POSITION", p, 3);
    if (!m_def.skins()) return;
    for (size_t i = 0; i < m_nv; ++i) {
      const auto& m = m_blend[i];
      double x = p[3 * i], y = p[3 * i + 1], z = p[3 * i + 2];
      for (size_t r = 0; r < 3; ++r) p[3 * i + r] = m[4 * r] * x + m[4 * r + 1] * y + m[4 * r + 2] * z + m[4 * r + 3];
    }
  }
  void normals(std::vector<double>& n) const {
    add_targets("NORMAL", n, 3);
    if (!m_def.skins() && !m_def.morphs()) return;
    for (size_t i = 0; i < m_nv; ++i) {
      std::array<double, 3> v{n[3 * i], n[3 * i + 1], n[3 * i + 2]};
      if (m_def.skins()) {
        // The inverse transpose up to a positive factor: the cofactor matrix,
        // its sign flipped where the determinant is negative.
        const auto& m = m_blend[i];
        auto a = [&](size_t r, size_t c) { return m[4 * r + c]; };
        double cof[9];
        for (size_t r = 0; r < 3; ++r)
          for (size_t c = 0; c < 3; ++c) {
            size_t r1 = (r + 1) % 3, r2 = (r + 2) % 3, c1 = (c + 1) % 3, c2 = (c + 2) % 3;
            cof[3 * r + c] = a(r1, c1) * a(r2, c2) - a(r1, c2) * a(r2, c1);
          }
        double det = a(0, 0) * cof[0] + a(0, 1) * cof[1] + a(0, 2) * cof[2];
        double sign = det < 0 ? -1 : 1;
        v = {sign * (cof[0] * n[3 * i] + cof[1] * n[3 * i + 1] + cof[2] * n[3 * i + 2]),
             sign * (cof[3] * n[3 * i] + cof[4] * n[3 * i + 1] + cof[5] * n[3 * i + 2]),
             sign * (cof[6] * n[3 * i] + cof[7] * n[3 * i + 1] + cof[8] * n[3 * i + 2])};
      }
      store_unit(n, 3 * i, v);
    }
  }
  // Tangents: xyz and the handedness w, 4 numbers per vertex.
  void tangents(std::vector<double>& t) const {
    if (m_def.morphs())
      for (size_t k = 0; k < m_prim.targets.size(); ++k) {
        double w = m_def.morph_weights[k];
        auto d = target("TANGENT", k);
        if (w == 0 || d.empty()) continue;
        for (size_t i = 0; i < m_nv; ++i)
          for (size_t c = 0; c < 3; ++c) t[4 * i + c] += w * d[3 * i + c];
      }
    if (!m_def.skins() && !m_def.morphs()) return;
    for (size_t i = 0; i < m_nv; ++i) {
      std::array<double, 3> v{t[4 * i], t[4 * i + 1], t[4 * i + 2]};
      if (m_def.skins()) {
        const auto& m = m_blend[i];
        for (size_t r = 0; r < 3; ++r) v[r] = m[4 * r] * t[4 * i] + m[4 * r + 1] * t[4 * i + 1] + m[4 * r + 2] * t[4 * i + 2];
      }
      store_unit(t, 4 * i, v);
    }
  }

 private:
  // The displacements of targets[k]'s attribute `name` (empty if it has none).
  std::vector<double> target(const char* name, size_t k) const {
    auto it = m_prim.targets[k].find(name);
    if (it == m_prim.targets[k].end()) return {};
    std::string tw = m_where + ".targets[" + std::to_string(k) + "]." + name;
    auto d = read_accessor(m_doc, it->second, tw, 3);
    if (d.size() / 3 != m_nv)
      m_doc.fail(tw, "has " + std::to_string(d.size() / 3) + " elements, POSITION has " + std::to_string(m_nv));
    for (double v : d)
      if (!std::isfinite(v)) m_doc.fail(tw, "holds a non-finite value");
    return d;
  }
  void add_targets(const char* name, std::vector<double>& a, size_t comps) const {
    if (!m_def.morphs()) return;
    for (size_t k = 0; k < m_prim.targets.size(); ++k) {
      double w = m_def.morph_weights[k];
      if (w == 0) continue;
      auto d = target(name, k);
      if (d.empty()) continue;
      for (size_t i = 0; i < m_nv; ++i)
        for (size_t c = 0; c < 3; ++c) a[comps * i + c] += w * d[3 * i + c];
    }
  }
  // Writes v normalised at a[at..at+2]; a vector the deformation collapsed
  // keeps its undeformed value.
  static void store_unit(std::vector<double>& a, size_t at, const std::array<double, 3>& v) {
    double l = std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (!(l > 0) || !std::isfinite(l)) return;
    for (size_t c = 0; c < 3; ++c) a[at + c] = v[c] / l;
  }
  // Each vertex's blended joint matrix (the top three rows): the sum over
  // JOINTS_n/WEIGHTS_n of weight × joint matrix, weights normalised.
  template <class Read>
  void blend(Read& read) {
    std::vector<std::pair<std::vector<double>, std::vector<double>>> sets;  // joints, weights
    for (int s = 0;; ++s) {
      std::string jn = "JOINTS_" + std::to_string(s), wn = "WEIGHTS_" + std::to_string(s);
      auto ji = m_prim.attributes.find(jn), wi = m_prim.attributes.find(wn);
      if (ji == m_prim.attributes.end() && wi == m_prim.attributes.end()) break;
      if (ji == m_prim.attributes.end() || wi == m_prim.attributes.end())
        m_doc.fail(m_where + ".attributes", "has " + (ji == m_prim.attributes.end() ? wn : jn) + " without " +
                                                (ji == m_prim.attributes.end() ? jn : wn));
      auto j = read(jn, ji->second, m_where + ".attributes." + jn, 4);
      auto w = read(wn, wi->second, m_where + ".attributes." + wn, 4);
      for (auto* a : {&j, &w})
        if (a->size() / 4 != m_nv)
          m_doc.fail(m_where + ".attributes." + (a == &j ? jn : wn),
                     "has " + std::to_string(a->size() / 4) + " elements, POSITION has " + std::to_string(m_nv));
      sets.emplace_back(std::move(j), std::move(w));
    }
    if (sets.empty())
      m_doc.fail(m_where + ".attributes", "has no JOINTS_0 and WEIGHTS_0, but its node has a skin");
    const size_t joints = m_def.joints.size();
    m_blend.assign(m_nv, {});
    for (size_t i = 0; i < m_nv; ++i) {
      double sum = 0;
      for (size_t s = 0; s < sets.size(); ++s)
        for (size_t c = 0; c < 4; ++c) {
          double w = sets[s].second[4 * i + c], j = sets[s].first[4 * i + c];
          std::string ew = m_where + ".attributes.WEIGHTS_" + std::to_string(s);
          // Quantizing encoders (Draco's 8-bit weights) leave zeros a step
          // below 0: up to 1e-2 below is read as 0, more is an error.
          if (!std::isfinite(w) || w < -1e-2)
            m_doc.fail(ew, "element " + std::to_string(i) + " has a negative or non-finite weight");
          w = std::max(w, 0.0);
          if (!(j >= 0) || j >= double(joints) || j != std::floor(j))
            m_doc.fail(m_where + ".attributes.JOINTS_" + std::to_string(s),
                       "element " + std::to_string(i) + " names joint " +
                           (j == std::floor(j) && std::abs(j) < 1e9 ? std::to_string((long long)j) : std::to_string(j)) +
                           ", the skin has " + std::to_string(joints) + " joints");
          sum += w;
        }
      // The specification asks for weights that sum to 1 (exactly, for
      // normalized integers). 1e-2 admits float weights rounded to a few
      // digits and eight 8-bit weights each half a step (1/510) off.
      if (!(std::abs(sum - 1) <= 1e-2))
        m_doc.fail(m_where + ".attributes.WEIGHTS_0",
                   "element " + std::to_string(i) + ": the weights sum to " + std::to_string(sum) + ", not 1");
      auto& m = m_blend[i];
      for (size_t s = 0; s < sets.size(); ++s)
        for (size_t c = 0; c < 4; ++c) {
          double w = std::max(sets[s].second[4 * i + c], 0.0) / sum;
          if (w == 0) continue;
          const auto& jm = m_def.joints[size_t(sets[s].first[4 * i + c])].m;
          for (size_t e = 0; e < 12; ++e) m[e] += w * jm[e];
        }
    }
  }

  const Document& m_doc;
  const tinygltf::Primitive& m_prim;
  std::string m_where;
  const Deformation& m_def;
  size_t m_nv;
  std::vector<std::array<double, 12>> m_blend;
};

}  // namespace prism::gltf_detail
