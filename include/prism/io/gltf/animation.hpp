// prism/io/gltf/animation.hpp — glTF animations: the channels that move
// nodes (translation, rotation, scale), their samplers evaluated at a time
// (STEP, LINEAR with slerp for rotations, CUBICSPLINE), and a node's local
// transform at a time, composed in double (math/transform.hpp's Matrix4d);
// and the channels that set a node's morph weights.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <map>
#include <string>
#include <vector>
#include <tiny_gltf.h>
#include "prism/io/gltf/accessors.hpp"
#include "prism/io/gltf/container.hpp"
#include "prism/math/transform.hpp"

namespace prism::gltf_detail {

class Animation {
 public:
  explicit Animation(const Document& doc) : m_doc(doc) {}

  // Checks the channels and collects those that move nodes, by node.
  void prepare() {
    for (size_t a = 0; a < m_doc.model.animations.size(); ++a) {
      const auto& an = m_doc.model.animations[a];
      for (size_t c = 0; c < an.channels.size(); ++c) {
        const auto& ch = an.channels[c];
        std::string where = idx("animations", int(a)) + ".channels[" + std::to_string(c) + "]";
        if (ch.target_node < 0) continue;  // targets nothing (or an extension)
        m_doc.check_index(ch.target_node, m_doc.model.nodes.size(), where + ".target.node", "node");
        m_doc.check_index(ch.sampler, an.samplers.size(), where + ".sampler", "sampler");
        if (ch.target_path == "translation" || ch.target_path == "rotation" || ch.target_path == "scale")
          m_channels[ch.target_node].push_back({ch.sampler, &an, ch.target_path, int(a)});
        else if (ch.target_path == "weights")
          m_weights[ch.target_node] = {ch.sampler, &an, ch.target_path, int(a)};
      }
    }
  }
  // True if no channel moves a node or sets morph weights.
  bool empty() const { return m_channels.empty() && m_weights.empty(); }
  // True if a channel sets node n's morph weights.
  bool animates_weights(int n) const { return m_weights.count(n) > 0; }

  // Node n's morph weights at `time`: `defaults` (default_morph_weights),
  // replaced by the animated ones where a channel sets them.
  std::vector<double> morph_weights(int n, double time, std::vector<double> defaults) const {
    auto it = m_weights.find(n);
    if (it == m_weights.end() || defaults.empty()) return defaults;
    auto w = sample_channel(it->second, int(defaults.size()), time);
    for (double v : w) m_doc.check_finite_number(v, idx("nodes", n) + ".weights (animated)");
    return w;
  }

  // A node's transform relative to its parent at `time`: its matrix, or its
  // translation, rotation and scale with the animated ones sampled.
  Matrix4d local_matrix(int n, double time) const {
    const auto& node = m_doc.model.nodes[size_t(n)];
    std::string where = idx("nodes", n);
    auto it = m_channels.find(n);
    if (!node.matrix.empty() && it == m_channels.end()) {
      if (node.matrix.size() != 16) m_doc.fail(where + ".matrix", "must have 16 numbers");
      Matrix4d m;
      for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) m.m[size_t(4 * i + j)] = node.matrix[size_t(4 * j + i)];  // column-major
      for (double v : m.m) m_doc.check_finite_number(v, where + ".matrix");
      return m;
    }
    std::array<double, 3> t{0, 0, 0}, s{1, 1, 1};
    std::array<double, 4> q{0, 0, 0, 1};
    auto copy = [&](const std::vector<double>& v, auto& dst, const char* what) {
      if (v.empty()) return;
      if (v.size() != dst.size()) m_doc.fail(where + "." + what, "has " + std::to_string(v.size()) + " numbers");
      for (size_t i = 0; i < dst.size(); ++i) {
        m_doc.check_finite_number(v[i], where + "." + what);
        dst[i] = v[i];
      }
    };
    copy(node.translation, t, "translation");
    copy(node.rotation, q, "rotation");
    copy(node.scale, s, "scale");
    if (it != m_channels.end())
      for (const Channel& ch : it->second) {
        if (ch.path == "translation") copy(sample_channel(ch, 3, time), t, "translation (animated)");
        else if (ch.path == "rotation") copy(sample_channel(ch, 4, time), q, "rotation (animated)");
        else copy(sample_channel(ch, 3, time), s, "scale (animated)");
      }
    return Matrix4d::trs(t, q, s);
  }

 private:
  struct Channel {
    int sampler;
    const tinygltf::Animation* anim;
    std::string path;
    int anim_index;
  };
  // The animated value of a channel at time t.
  std::vector<double> sample_channel(const Channel& ch, int comps, double t) const {
    const auto& s = ch.anim->samplers[size_t(ch.sampler)];
    std::string where = idx("animations", ch.anim_index) + ".samplers[" + std::to_string(ch.sampler) + "]";
    auto times = read_accessor(m_doc, s.input, where + ".input", 1);
    // Morph weights are scalars, one per target and key.
    auto values = read_accessor(m_doc, s.output, where + ".output", ch.path == "weights" ? 1 : comps);
    bool cubic = s.interpolation == "CUBICSPLINE";
    size_t per_key = cubic ? 3 : 1;
    if (times.empty() || values.size() != times.size() * per_key * size_t(comps))
      m_doc.fail(where, "input and output counts do not match");
    auto value = [&](size_t k) {
      size_t base = (k * per_key + (cubic ? 1 : 0)) * size_t(comps);
      return std::vector<double>(values.begin() + long(base), values.begin() + long(base) + comps);
    };
    if (t <= times.front()) return value(0);
    if (t >= times.back()) return value(times.size() - 1);
    size_t k = size_t(std::upper_bound(times.begin(), times.end(), t) - times.begin()) - 1;
    double t0 = times[k], t1 = times[k + 1];
    double u = t1 > t0 ? (t - t0) / (t1 - t0) : 0;
    auto a = value(k), b = value(k + 1);
    if (s.interpolation == "STEP") return a;
    if (cubic) {
      double dt = t1 - t0, u2 = u * u, u3 = u2 * u;
      std::vector<double> r(static_cast<size_t>(comps));
      for (int c = 0; c < comps; ++c) {
        double out_tan = values[(k * 3 + 2) * size_t(comps) + size_t(c)] * dt;
        double in_tan = values[((k + 1) * 3) * size_t(comps) + size_t(c)] * dt;
        r[size_t(c)] = (2 * u3 - 3 * u2 + 1) * a[size_t(c)] + (u3 - 2 * u2 + u) * out_tan +
                       (-2 * u3 + 3 * u2) * b[size_t(c)] + (u3 - u2) * in_tan;
      }
      return r;
    }
    if (ch.path == "rotation") {  // slerp
      double d = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
      if (d < 0) {
        for (auto& x : b) x = -x;
        d = -d;
      }
      std::vector<double> r(4);
      if (d > 0.9995) {
        for (int c = 0; c < 4; ++c) r[size_t(c)] = a[size_t(c)] + u * (b[size_t(c)] - a[size_t(c)]);
      } else {
        double th = std::acos(d), s0 = std::sin((1 - u) * th) / std::sin(th), s1 = std::sin(u * th) / std::sin(th);
        for (int c = 0; c < 4; ++c) r[size_t(c)] = s0 * a[size_t(c)] + s1 * b[size_t(c)];
      }
      return r;
    }
    std::vector<double> r(static_cast<size_t>(comps));
    for (int c = 0; c < comps; ++c) r[size_t(c)] = a[size_t(c)] + u * (b[size_t(c)] - a[size_t(c)]);
    return r;
  }

  const Document& m_doc;
  std::map<int, std::vector<Channel>> m_channels;
  std::map<int, Channel> m_weights;  // morph-weight channels, by node
};

}  // namespace prism::gltf_detail
