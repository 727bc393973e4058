// prism/math/transform.hpp — 4x4 affine transforms with their inverse, and point
// transforms that return a conservative bound on their rounding error
// (pbrt-v4 book, section 6.8.5: gamma(3) per row for a 3-term dot product plus
// the translation).
#pragma once
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <optional>
#include <utility>
#include "prism/math/bounds.hpp"
#include "prism/math/frame.hpp"

namespace prism {

struct Matrix4 {
  std::array<std::array<Float, 4>, 4> m{{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}}};

  Matrix4 operator*(const Matrix4& b) const {
    Matrix4 r;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        double s = 0;  // accumulate in double: composition happens once at scene build
        for (int k = 0; k < 4; ++k) s += double(m[i][k]) * double(b.m[k][j]);
        r.m[i][j] = Float(s);
      }
    return r;
  }
  Matrix4 transpose() const {
    Matrix4 r;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) r.m[i][j] = m[j][i];
    return r;
  }
  bool operator==(const Matrix4&) const = default;
  bool is_identity() const { return *this == Matrix4{}; }
};

// General 4x4 inverse by Gauss-Jordan elimination with partial pivoting, in
// double; empty when the matrix is singular.
inline std::optional<Matrix4> inverse(const Matrix4& a) {
  double w[4][8];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      w[i][j] = a.m[i][j];
      w[i][j + 4] = i == j ? 1.0 : 0.0;
    }
  for (int c = 0; c < 4; ++c) {
    int piv = c;
    for (int r = c + 1; r < 4; ++r)
      if (std::abs(w[r][c]) > std::abs(w[piv][c])) piv = r;
    if (w[piv][c] == 0 || !std::isfinite(w[piv][c])) return std::nullopt;
    if (piv != c)
      for (int j = 0; j < 8; ++j) std::swap(w[c][j], w[piv][j]);
    double inv = 1.0 / w[c][c];
    for (int j = 0; j < 8; ++j) w[c][j] *= inv;
    for (int r = 0; r < 4; ++r) {
      if (r == c) continue;
      double f = w[r][c];
      for (int j = 0; j < 8; ++j) w[r][j] -= f * w[c][j];
    }
  }
  Matrix4 r;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) r.m[i][j] = Float(w[i][j + 4]);
  return r;
}

class Transform {
 public:
  Transform() = default;
  // Throws nothing: a singular matrix gets an all-NaN inverse, which scene
  // building rejects with a clear error.
  explicit Transform(const Matrix4& m) : m_m(m) {
    auto inv = inverse(m);
    if (inv) {
      m_inv = *inv;
    } else {
      for (auto& row : m_inv.m) row.fill(std::numeric_limits<Float>::quiet_NaN());
    }
  }
  Transform(const Matrix4& m, const Matrix4& inv) : m_m(m), m_inv(inv) {}

  const Matrix4& matrix() const { return m_m; }
  const Matrix4& inverse_matrix() const { return m_inv; }
  bool invertible() const { return !std::isnan(m_inv.m[0][0]); }
  bool is_identity() const { return m_m.is_identity(); }
  // True if the upper 3x3 has a negative determinant (a mirroring transform:
  // it flips triangle winding and tangent-frame handedness).
  bool swaps_handedness() const {
    const auto& m = m_m.m;
    Float det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
                m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    return det < 0;
  }
  Transform operator*(const Transform& t) const { return {m_m * t.m_m, t.m_inv * m_inv}; }
  friend Transform inverse(const Transform& t) { return {t.m_inv, t.m_m}; }

  Point3f operator()(const Point3f& p) const {
    const auto& m = m_m.m;
    // Summed pairwise, as in pbrt-v4, so that no term is rounded more than
    // three times: apply()'s gamma(3) bound relies on this grouping.
    Float x = (m[0][0] * p.x + m[0][1] * p.y) + (m[0][2] * p.z + m[0][3]);
    Float y = (m[1][0] * p.x + m[1][1] * p.y) + (m[1][2] * p.z + m[1][3]);
    Float z = (m[2][0] * p.x + m[2][1] * p.y) + (m[2][2] * p.z + m[2][3]);
    Float w = (m[3][0] * p.x + m[3][1] * p.y) + (m[3][2] * p.z + m[3][3]);
    return w == 1 ? Point3f{x, y, z} : Point3f{x, y, z} / w;
  }
  Vector3f operator()(const Vector3f& v) const {
    const auto& m = m_m.m;
    return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z, m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
            m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
  }
  // Normals transform by the inverse transpose.
  Normal3f operator()(const Normal3f& n) const {
    const auto& mi = m_inv.m;
    return {mi[0][0] * n.x + mi[1][0] * n.y + mi[2][0] * n.z, mi[0][1] * n.x + mi[1][1] * n.y + mi[2][1] * n.z,
            mi[0][2] * n.x + mi[1][2] * n.y + mi[2][2] * n.z};
  }

  // Affine point transform; *err bounds |computed - exact| per component.
  Point3f apply(const Point3f& p, Vector3f* err) const {
    const auto& m = m_m.m;
    Point3f r = (*this)(p);
    *err = Vector3f{std::abs(m[0][0] * p.x) + std::abs(m[0][1] * p.y) + std::abs(m[0][2] * p.z) + std::abs(m[0][3]),
                    std::abs(m[1][0] * p.x) + std::abs(m[1][1] * p.y) + std::abs(m[1][2] * p.z) + std::abs(m[1][3]),
                    std::abs(m[2][0] * p.x) + std::abs(m[2][1] * p.y) + std::abs(m[2][2] * p.z) + std::abs(m[2][3])} *
           gamma(3);
    return r;
  }
  // Affine transform of a point that already carries error p_err.
  Point3f apply(const Point3f& p, const Vector3f& p_err, Vector3f* err) const {
    const auto& m = m_m.m;
    Vector3f own;
    Point3f r = apply(p, &own);
    Vector3f carried{std::abs(m[0][0]) * p_err.x + std::abs(m[0][1]) * p_err.y + std::abs(m[0][2]) * p_err.z,
                     std::abs(m[1][0]) * p_err.x + std::abs(m[1][1]) * p_err.y + std::abs(m[1][2]) * p_err.z,
                     std::abs(m[2][0]) * p_err.x + std::abs(m[2][1]) * p_err.y + std::abs(m[2][2]) * p_err.z};
    *err = carried * (gamma(3) + 1) + own;
    return r;
  }
  // Vector transform with its error bound.
  Vector3f apply(const Vector3f& v, Vector3f* err) const {
    const auto& m = m_m.m;
    *err = Vector3f{std::abs(m[0][0] * v.x) + std::abs(m[0][1] * v.y) + std::abs(m[0][2] * v.z),
                    std::abs(m[1][0] * v.x) + std::abs(m[1][1] * v.y) + std::abs(m[1][2] * v.z),
                    std::abs(m[2][0] * v.x) + std::abs(m[2][1] * v.y) + std::abs(m[2][2] * v.z)} *
           gamma(3);
    return (*this)(v);
  }

  Bounds3f operator()(const Bounds3f& b) const {
    Bounds3f r;
    for (int i = 0; i < 8; ++i) {
      Point3f c{b[i & 1].x, b[(i >> 1) & 1].y, b[(i >> 2) & 1].z};
      Vector3f e;
      Point3f p = apply(c, &e);
      r = union_bounds(r, p - e);
      r = union_bounds(r, p + e);
    }
    return r;
  }

 private:
  Matrix4 m_m, m_inv;
};

// A 4x4 matrix in double precision, row-major: m[4 * row + column]. For
// composing a chain of transforms with one rounding to Float at the end
// (to_float), where Matrix4's product rounds every step: a glTF node
// hierarchy, its instancing and animated TRS values (io/gltf/) compose in
// double, so a deep hierarchy does not drift with its depth.
struct Matrix4d {
  std::array<double, 16> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

  Matrix4d operator*(const Matrix4d& b) const {
    Matrix4d r;
    for (size_t i = 0; i < 4; ++i)
      for (size_t j = 0; j < 4; ++j) {
        double s = 0;
        for (size_t k = 0; k < 4; ++k) s += m[4 * i + k] * b.m[4 * k + j];
        r.m[4 * i + j] = s;
      }
    return r;
  }
  bool operator==(const Matrix4d&) const = default;

  // T * R * S from a translation, a rotation quaternion (x, y, z, w; glTF's
  // order), normalised here unless it is zero, and a scale.
  static Matrix4d trs(const std::array<double, 3>& t, std::array<double, 4> q, const std::array<double, 3>& s) {
    double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (n > 0)
      for (auto& c : q) c /= n;
    double x = q[0], y = q[1], z = q[2], w = q[3];
    double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - z * w),     2 * (x * z + y * w),
                   2 * (x * y + z * w),     1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
                   2 * (x * z - y * w),     2 * (y * z + x * w),     1 - 2 * (x * x + y * y)};
    Matrix4d out;
    for (size_t i = 0; i < 3; ++i) {
      for (size_t j = 0; j < 3; ++j) out.m[4 * i + j] = r[3 * i + j] * s[j];
      out.m[4 * i + 3] = t[i];
    }
    return out;
  }
  // The point p transformed (affine: the bottom row is not used).
  std::array<double, 3> apply_point(const std::array<double, 3>& p) const {
    std::array<double, 3> r{};
    for (size_t i = 0; i < 3; ++i) r[i] = m[4 * i] * p[0] + m[4 * i + 1] * p[1] + m[4 * i + 2] * p[2] + m[4 * i + 3];
    return r;
  }
  // Each element rounded to Float.
  Matrix4 to_float() const {
    Matrix4 r;
    for (size_t i = 0; i < 4; ++i)
      for (size_t j = 0; j < 4; ++j) r.m[i][j] = Float(m[4 * i + j]);
    return r;
  }
};

inline Transform translate(const Vector3f& d) {
  Matrix4 m, mi;
  m.m[0][3] = d.x; m.m[1][3] = d.y; m.m[2][3] = d.z;
  mi.m[0][3] = -d.x; mi.m[1][3] = -d.y; mi.m[2][3] = -d.z;
  return {m, mi};
}
inline Transform scale(Float x, Float y, Float z) {
  Matrix4 m, mi;
  m.m[0][0] = x; m.m[1][1] = y; m.m[2][2] = z;
  mi.m[0][0] = 1 / x; mi.m[1][1] = 1 / y; mi.m[2][2] = 1 / z;
  return {m, mi};
}
// Rotation by theta radians about an axis (need not be normalised).
inline Transform rotate(Float theta, const Vector3f& axis) {
  Vector3f a = normalize(axis);
  Float s = std::sin(theta), c = std::cos(theta);
  Matrix4 m;
  m.m[0][0] = a.x * a.x + (1 - a.x * a.x) * c;
  m.m[0][1] = a.x * a.y * (1 - c) - a.z * s;
  m.m[0][2] = a.x * a.z * (1 - c) + a.y * s;
  m.m[1][0] = a.x * a.y * (1 - c) + a.z * s;
  m.m[1][1] = a.y * a.y + (1 - a.y * a.y) * c;
  m.m[1][2] = a.y * a.z * (1 - c) - a.x * s;
  m.m[2][0] = a.x * a.z * (1 - c) - a.y * s;
  m.m[2][1] = a.y * a.z * (1 - c) + a.x * s;
  m.m[2][2] = a.z * a.z + (1 - a.z * a.z) * c;
  return {m, m.transpose()};
}
// Camera-to-world transform of a camera at `eye` looking at `target`. Camera
// space has +x to the image's right, +y up and +z forward, so that a world
// seen through it is not mirrored.
// The handedness of the WORLD a look-at is written for. Camera space is
// always +x right, +y up, +z forward. A right-handed world (glTF, prism's own
// scenes) puts the camera's +x at dir x up; a left-handed world (pbrt,
// RenderMan) at up x dir, so that a pbrt scene's LookAt gives the image pbrt
// gives rather than its mirror image.
enum class Handedness { right, left };

inline Transform look_at_camera_to_world(const Point3f& eye, const Point3f& target, const Vector3f& up,
                                         Handedness world = Handedness::right) {
  Vector3f dir = normalize(target - eye);
  Vector3f right = world == Handedness::right ? normalize(cross(dir, normalize(up))) : normalize(cross(normalize(up), dir));
  Vector3f new_up = world == Handedness::right ? cross(right, dir) : cross(dir, right);
  Matrix4 m;
  for (int i = 0; i < 3; ++i) {
    m.m[i][0] = right[i];
    m.m[i][1] = new_up[i];
    m.m[i][2] = dir[i];
    m.m[i][3] = eye[i];
  }
  return Transform(m);
}

}  // namespace prism
