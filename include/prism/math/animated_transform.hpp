// prism/math/animated_transform.hpp — unit quaternions and a transform that
// moves between two keys during a time interval, for motion blur.
//
// A key is decomposed as M = T R S: a translation T, a rotation R (a unit
// quaternion) and a stretch S (a 3x3 matrix, diagonal for a plain scale; a
// general matrix comes from the polar decomposition of a sheared key). Between
// the keys T and S are interpolated linearly and R by slerp, so a rotating
// object turns at a constant angular velocity about a fixed axis instead of
// shrinking through the straight-line blend of two matrices.
//
// motion_bounds() bounds a box over a time interval conservatively: it samples
// the trajectories of the box's corners and widens the result by a bound on
// how far a trajectory can leave the chord between two samples (the second
// derivative bound h^2/8 max|p''|, with p'' bounded by the rotation's angular
// velocity), so a ray never misses a moving object because of its bounds.
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <string>
#include "prism/error.hpp"
#include "prism/math/transform.hpp"

namespace prism {

// A unit quaternion (x, y, z, w) = (axis * sin(angle / 2), cos(angle / 2)), the
// glTF convention for node rotations.
struct Quaternion {
  Float x = 0, y = 0, z = 0, w = 1;

  static Quaternion from_axis_angle(const Vector3f& axis, Float angle) {
    Vector3f a = normalize(axis);
    Float s = std::sin(angle / 2);
    return {a.x * s, a.y * s, a.z * s, std::cos(angle / 2)};
  }
  Float dot(const Quaternion& q) const { return x * q.x + y * q.y + z * q.z + w * q.w; }
  Quaternion normalized() const {
    Float n = std::sqrt(dot(*this));
    return n > 0 ? Quaternion{x / n, y / n, z / n, w / n} : Quaternion{};
  }
  bool is_finite() const { return std::isfinite(x) && std::isfinite(y) && std::isfinite(z) && std::isfinite(w); }

  // The rotation matrix of a unit quaternion (row-major 3x3).
  std::array<std::array<double, 3>, 3> matrix() const {
    double X = x, Y = y, Z = z, W = w;
    return {{{1 - 2 * (Y * Y + Z * Z), 2 * (X * Y - Z * W), 2 * (X * Z + Y * W)},
             {2 * (X * Y + Z * W), 1 - 2 * (X * X + Z * Z), 2 * (Y * Z - X * W)},
             {2 * (X * Z - Y * W), 2 * (Y * Z + X * W), 1 - 2 * (X * X + Y * Y)}}};
  }
  // The unit quaternion of a rotation matrix (proper: determinant +1).
  static Quaternion from_matrix(const std::array<std::array<double, 3>, 3>& m) {
    double tr = m[0][0] + m[1][1] + m[2][2];
    double q[4];  // x y z w
    if (tr > 0) {
      double s = std::sqrt(tr + 1) * 2;
      q[3] = s / 4;
      q[0] = (m[2][1] - m[1][2]) / s;
      q[1] = (m[0][2] - m[2][0]) / s;
      q[2] = (m[1][0] - m[0][1]) / s;
    } else {
      // The largest diagonal element gives the best-conditioned component.
      int i = m[1][1] > m[0][0] ? 1 : 0;
      if (m[2][2] > m[i][i]) i = 2;
      int j = (i + 1) % 3, k = (i + 2) % 3;
      double s = std::sqrt(std::max(0.0, m[i][i] - m[j][j] - m[k][k] + 1)) * 2;
      q[i] = s / 4;
      q[j] = (m[j][i] + m[i][j]) / s;
      q[k] = (m[k][i] + m[i][k]) / s;
      q[3] = (m[k][j] - m[j][k]) / s;
    }
    return Quaternion{Float(q[0]), Float(q[1]), Float(q[2]), Float(q[3])}.normalized();
  }
};

// One key of an animated transform: translation, rotation, stretch.
struct TransformKey {
  Vector3f translation{0, 0, 0};
  Quaternion rotation{};
  std::array<std::array<Float, 3>, 3> stretch{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};

  static TransformKey trs(const Vector3f& t, const Quaternion& r = {}, const Vector3f& s = {1, 1, 1}) {
    TransformKey k;
    k.translation = t;
    k.rotation = r.normalized();
    k.stretch = {{{s.x, 0, 0}, {0, s.y, 0}, {0, 0, s.z}}};
    return k;
  }

  // Decomposes an affine transform into T R S by the polar decomposition of
  // its 3x3 part (Higham's iteration M <- (M + M^-T) / 2 converges to R). A
  // mirroring transform keeps R proper and puts the reflection in S. Throws
  // prism::Error if the matrix is singular, projective or not finite.
  static TransformKey decompose(const Transform& t, const std::string& what = "transform") {
    const auto& m = t.matrix().m;
    for (const auto& row : m)
      for (Float v : row)
        if (!std::isfinite(v)) throw Error(what + ": not finite");
    if (m[3][0] != 0 || m[3][1] != 0 || m[3][2] != 0 || m[3][3] != 1) throw Error(what + ": not affine");
    using M3 = std::array<std::array<double, 3>, 3>;
    M3 a{};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) a[size_t(i)][size_t(j)] = m[size_t(i)][size_t(j)];
    double det = det3(a);
    if (!(std::abs(det) > 0)) throw Error(what + ": singular");
    M3 r = a;
    if (det < 0)
      for (auto& row : r)
        for (double& v : row) v = -v;
    for (int it = 0; it < 100; ++it) {
      M3 inv_t = inverse_transpose3(r);
      double change = 0;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          double v = 0.5 * (r[size_t(i)][size_t(j)] + inv_t[size_t(i)][size_t(j)]);
          change = std::max(change, std::abs(v - r[size_t(i)][size_t(j)]));
          r[size_t(i)][size_t(j)] = v;
        }
      if (change < 1e-15) break;
    }
    // S = R^T A.
    TransformKey k;
    k.translation = {m[0][3], m[1][3], m[2][3]};
    k.rotation = Quaternion::from_matrix(r);
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        double s = 0;
        for (int l = 0; l < 3; ++l) s += r[size_t(l)][size_t(i)] * a[size_t(l)][size_t(j)];
        k.stretch[size_t(i)][size_t(j)] = Float(s);
      }
    return k;
  }

  static double det3(const std::array<std::array<double, 3>, 3>& a) {
    return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
           a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  }
  // (A^-1)^T by cofactors: the cofactor matrix over the determinant.
  static std::array<std::array<double, 3>, 3> inverse_transpose3(const std::array<std::array<double, 3>, 3>& a) {
    double d = det3(a);
    std::array<std::array<double, 3>, 3> c{};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        int i1 = (i + 1) % 3, i2 = (i + 2) % 3, j1 = (j + 1) % 3, j2 = (j + 2) % 3;
        c[size_t(i)][size_t(j)] = (a[size_t(i1)][size_t(j1)] * a[size_t(i2)][size_t(j2)] -
                                   a[size_t(i1)][size_t(j2)] * a[size_t(i2)][size_t(j1)]) /
                                  d;
      }
    return c;
  }
};

// A transform moving from `start` at time t0 to `end` at time t1; before t0
// it stays at the start key, after t1 at the end key.
class AnimatedTransform {
 public:
  AnimatedTransform() = default;
  // Throws prism::Error (prefixed with `what`) for a non-finite key, a
  // singular stretch, a stretch whose handedness differs between the keys
  // (the object would turn inside out) or an empty interval with two
  // different keys.
  AnimatedTransform(const TransformKey& start, const TransformKey& end, Float t0 = 0, Float t1 = 1,
                    const std::string& what = "animated transform")
      : m_key{start, end}, m_t0(t0), m_t1(t1) {
    if (!std::isfinite(t0) || !std::isfinite(t1) || t1 < t0)
      throw Error(what + ": the time interval [" + std::to_string(t0) + ", " + std::to_string(t1) + "] is not valid");
    double det[2];
    for (int k = 0; k < 2; ++k) {
      TransformKey& key = m_key[k];
      bool finite = std::isfinite(key.translation.x) && std::isfinite(key.translation.y) &&
                    std::isfinite(key.translation.z) && key.rotation.is_finite();
      std::array<std::array<double, 3>, 3> s{};
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          finite = finite && std::isfinite(key.stretch[size_t(i)][size_t(j)]);
          s[size_t(i)][size_t(j)] = key.stretch[size_t(i)][size_t(j)];
        }
      if (!finite) throw Error(what + ": key " + std::to_string(k) + " is not finite");
      if (!(key.rotation.dot(key.rotation) > 0)) throw Error(what + ": key " + std::to_string(k) + " has a zero rotation quaternion");
      key.rotation = key.rotation.normalized();
      det[k] = TransformKey::det3(s);
      if (!(std::abs(det[k]) > 0)) throw Error(what + ": key " + std::to_string(k) + " is singular");
    }
    if ((det[0] < 0) != (det[1] < 0))
      throw Error(what + ": the keys differ in handedness (the object would turn inside out)");
    m_mirror = det[0] < 0;
    // Slerp the short way round.
    if (m_key[0].rotation.dot(m_key[1].rotation) < 0) {
      Quaternion& q = m_key[1].rotation;
      q = {-q.x, -q.y, -q.z, -q.w};
    }
    Float c = std::clamp(m_key[0].rotation.dot(m_key[1].rotation), Float(-1), Float(1));
    m_half_angle = std::acos(c);
    m_sin_half = std::sin(m_half_angle);
    m_moving = !same_key(m_key[0], m_key[1]);
    if (m_moving && !(t1 > t0))
      throw Error(what + ": the keys differ but the time interval has zero length");
  }
  // A transform that does not move.
  explicit AnimatedTransform(const Transform& t, const std::string& what = "transform")
      : AnimatedTransform(TransformKey::decompose(t, what), TransformKey::decompose(t, what), 0, 0, what) {}

  bool is_moving() const { return m_moving; }
  bool swaps_handedness() const { return m_mirror; }
  Float start_time() const { return m_t0; }
  Float end_time() const { return m_t1; }
  const TransformKey& key(int i) const { return m_key[i]; }
  // The rotation angle between the keys, in radians.
  Float rotation_angle() const { return 2 * m_half_angle; }

  // The fraction of the way from t0 to t1 at `time`, clamped to [0, 1].
  Float fraction(Float time) const {
    if (!(m_t1 > m_t0)) return 0;
    return std::clamp((time - m_t0) / (m_t1 - m_t0), Float(0), Float(1));
  }

  // The transform at `time`, with its inverse (built from the factors, not by
  // a general inversion): M = T R S, M^-1 = S^-1 R^T T^-1.
  Transform at(Float time) const { return interpolate(fraction(time)); }

  // The transform at fraction u of the way between the keys.
  Transform interpolate(Float u) const {
    const TransformKey &a = m_key[0], &b = m_key[1];
    Quaternion q;
    if (m_sin_half > Float(1e-4)) {
      Float s0 = std::sin((1 - u) * m_half_angle) / m_sin_half, s1 = std::sin(u * m_half_angle) / m_sin_half;
      q = {s0 * a.rotation.x + s1 * b.rotation.x, s0 * a.rotation.y + s1 * b.rotation.y,
           s0 * a.rotation.z + s1 * b.rotation.z, s0 * a.rotation.w + s1 * b.rotation.w};
    } else {  // nearly the same rotation: the linear blend is exact to rounding
      q = {a.rotation.x + u * (b.rotation.x - a.rotation.x), a.rotation.y + u * (b.rotation.y - a.rotation.y),
           a.rotation.z + u * (b.rotation.z - a.rotation.z), a.rotation.w + u * (b.rotation.w - a.rotation.w)};
    }
    q = q.normalized();
    auto r = q.matrix();
    std::array<std::array<double, 3>, 3> s{};
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        s[size_t(i)][size_t(j)] =
            double(a.stretch[size_t(i)][size_t(j)]) +
            double(u) * (double(b.stretch[size_t(i)][size_t(j)]) - double(a.stretch[size_t(i)][size_t(j)]));
    double t[3] = {double(a.translation.x) + double(u) * (double(b.translation.x) - double(a.translation.x)),
                   double(a.translation.y) + double(u) * (double(b.translation.y) - double(a.translation.y)),
                   double(a.translation.z) + double(u) * (double(b.translation.z) - double(a.translation.z))};
    // S^-1 = (cofactor matrix)^T / det.
    auto s_inv_t = TransformKey::inverse_transpose3(s);
    Matrix4 m, mi;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        double rs = 0, sr = 0;  // (R S)_ij and (S^-1 R^T)_ij
        for (int l = 0; l < 3; ++l) {
          rs += r[size_t(i)][size_t(l)] * s[size_t(l)][size_t(j)];
          sr += s_inv_t[size_t(l)][size_t(i)] * r[size_t(j)][size_t(l)];
        }
        m.m[size_t(i)][size_t(j)] = Float(rs);
        mi.m[size_t(i)][size_t(j)] = Float(sr);
      }
      m.m[size_t(i)][3] = Float(t[i]);
    }
    for (int i = 0; i < 3; ++i) {
      double v = 0;
      for (int j = 0; j < 3; ++j) v -= double(mi.m[size_t(i)][size_t(j)]) * t[j];
      mi.m[size_t(i)][3] = Float(v);
    }
    return Transform(m, mi);
  }

  // A box enclosing object-space box b as it moves during [ta, tb] (world
  // space). Conservative: see the file comment.
  Bounds3f motion_bounds(const Bounds3f& b, Float ta, Float tb) const {
    if (b.empty()) return b;
    Float ua = fraction(std::min(ta, tb)), ub = fraction(std::max(ta, tb));
    if (!m_moving || ua == ub) return interpolate(ua)(b);
    // Samples: enough that the chord bound stays a small fraction of the box.
    const Float theta = rotation_angle() * (ub - ua);
    const int n = std::clamp(int(std::ceil(theta * 16)) + 2, 2, 256);
    const double h = double(ub - ua) / n;
    Bounds3f r;
    for (int k = 0; k <= n; ++k) r = union_bounds(r, interpolate(Float(ua + h * k))(b));
    if (theta > 0) {
      // Corner c's trajectory is p(u) = T(u) + R(u) q(u) with q(u) = S(u) c
      // linear in u, so |p''| <= w^2 |q| + 2 w |q'| with w = angle per unit u.
      const double w = double(rotation_angle());
      double pad = 0;
      for (int i = 0; i < 8; ++i) {
        Point3f c{b[i & 1].x, b[(i >> 1) & 1].y, b[(i >> 2) & 1].z};
        double q0 = stretch_length(m_key[0], c), q1 = stretch_length(m_key[1], c);
        double dq = stretch_delta_length(c);
        pad = std::max(pad, (h * h / 8) * (w * w * std::max(q0, q1) + 2 * w * dq));
      }
      // Widen by the pad and a few ulps of the box's magnitude for rounding.
      Float e = Float(pad) + gamma(8) * std::max({std::abs(r.min.x), std::abs(r.min.y), std::abs(r.min.z),
                                                   std::abs(r.max.x), std::abs(r.max.y), std::abs(r.max.z)});
      r.min = r.min - Vector3f{e, e, e};
      r.max += Vector3f{e, e, e};
    }
    return r;
  }

 private:
  static bool same_key(const TransformKey& a, const TransformKey& b) {
    if (a.translation.x != b.translation.x || a.translation.y != b.translation.y || a.translation.z != b.translation.z)
      return false;
    if (a.rotation.x != b.rotation.x || a.rotation.y != b.rotation.y || a.rotation.z != b.rotation.z ||
        a.rotation.w != b.rotation.w)
      return false;
    return a.stretch == b.stretch;
  }
  static double stretch_length(const TransformKey& k, const Point3f& c) {
    double s2 = 0;
    for (int i = 0; i < 3; ++i) {
      double v = double(k.stretch[size_t(i)][0]) * c.x + double(k.stretch[size_t(i)][1]) * c.y +
                 double(k.stretch[size_t(i)][2]) * c.z;
      s2 += v * v;
    }
    return std::sqrt(s2);
  }
  double stretch_delta_length(const Point3f& c) const {
    double s2 = 0;
    for (int i = 0; i < 3; ++i) {
      double v = 0;
      for (int j = 0; j < 3; ++j)
        v += (double(m_key[1].stretch[size_t(i)][size_t(j)]) - double(m_key[0].stretch[size_t(i)][size_t(j)])) *
             double(c[j]);
      s2 += v * v;
    }
    return std::sqrt(s2);
  }

  TransformKey m_key[2];
  Float m_t0 = 0, m_t1 = 0;
  Float m_half_angle = 0, m_sin_half = 0;
  bool m_moving = false, m_mirror = false;
};

}  // namespace prism
