// prism/geometry/triangle.hpp — triangle meshes and the watertight ray–triangle
// test of Woop, Benthin and Wald 2013 ("Watertight Ray/Triangle Intersection",
// JCGT 2(1)): rays that hit a shared edge or vertex hit at least one of the
// triangles that share it. The hit parameter t is accepted only when it exceeds
// its own conservative error bound (pbrt-v4 book, section 6.8.4; when single
// precision cannot decide, the bound is recomputed in double, see
// detail::refine_triangle_t), and the hit point carries the error bound
// gamma(7) * sum |b_i p_i| (section 6.8.5).
#pragma once
#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <vector>
#include "prism/geometry/interaction.hpp"
#include "prism/math/bounds.hpp"

namespace prism {

struct TriangleMesh {
  std::vector<Point3f> positions;
  std::vector<uint32_t> indices;  // 3 per triangle
  std::vector<Normal3f> normals;  // optional, per vertex
  std::vector<Point2f> uvs;       // optional, per vertex (glTF TEXCOORD_0)
  std::vector<Point2f> uvs1;      // optional, per vertex (glTF TEXCOORD_1)
  // optional, per vertex: tangent xyz and the bitangent's handedness w = +-1
  // (glTF TANGENT: bitangent = w cross(normal, tangent)).
  std::vector<std::array<Float, 4>> tangents;
  std::vector<std::array<Float, 4>> colors;  // optional, per vertex linear RGBA (glTF COLOR_0)

  size_t triangle_count() const { return indices.size() / 3; }
};

// The box of the triangle (a, b, c).
inline Bounds3f triangle_box(const Point3f& a, const Point3f& b, const Point3f& c) {
  return union_bounds(union_bounds(Bounds3f(a), b), c);
}

// Per-ray set-up of the watertight test: the axis permutation that makes z the
// direction's largest component, and the shear that aligns the ray with +z.
struct RayTrianglePrecomp {
  int kx = 0, ky = 1, kz = 2;
  Float sx = 0, sy = 0, sz = 1;

  // From a permutation's z axis and the shear computed for it already (a
  // caller that picks code per axis hands over the three floats).
  RayTrianglePrecomp(int z_axis, Float shear_x, Float shear_y, Float shear_z)
      : kx(z_axis + 1 == 3 ? 0 : z_axis + 1), ky(z_axis == 0 ? 2 : z_axis - 1), kz(z_axis),
        sx(shear_x), sy(shear_y), sz(shear_z) {}
  explicit RayTrianglePrecomp(const Vector3f& d) {
    kz = max_dimension(abs(d));
    kx = kz + 1 == 3 ? 0 : kz + 1;
    ky = kx + 1 == 3 ? 0 : kx + 1;
    Vector3f dp = permute(d, kx, ky, kz);
    sz = 1 / dp.z;
    sx = -dp.x * sz;
    sy = -dp.y * sz;
  }
};

struct TriangleHit {
  Float t;
  Float b0, b1, b2;  // barycentrics of p0, p1, p2
};

namespace detail {

// (1 + 4 eps) >= 1 / (1 - eps)^3: t_max * widen * det, rounded twice, is at
// least t_scaled whenever t_scaled / det rounds to below t_max.
inline constexpr Float triangle_range_widen = 1 + gamma(4);

// The t test of intersect_triangle redone in double precision, for hits that
// single precision cannot prove to lie in front of the origin: the same
// translation, shear and edge functions (the shear coefficients, floats, are
// exact in double and define the same sheared ray), and the same error bound
// with gamma_double in place of gamma. A ray that starts a few 1e-7 from a
// face meeting its own at a concave edge (the inside of a box, spawned near
// the edge) has a t of that size, below the single-precision bound of a
// triangle that extends ~1 along the ray; in double the bound is ~1e-16 and
// the hit is kept, so the ray cannot leave a closed mesh through the edge.
// Returns t when it is provably in (0, t_max).
inline std::optional<Float> refine_triangle_t(const Point3f& o, const RayTrianglePrecomp& pc, Float t_max,
                                              const Point3f& p0, const Point3f& p1, const Point3f& p2) {
  struct V {
    double x, y, z;
  };
  auto to_ray_space = [&](const Point3f& p) {
    V v{double(p[pc.kx]) - double(o[pc.kx]), double(p[pc.ky]) - double(o[pc.ky]),
        double(p[pc.kz]) - double(o[pc.kz])};
    v.x += double(pc.sx) * v.z;
    v.y += double(pc.sy) * v.z;
    return v;
  };
  V a = to_ray_space(p0), b = to_ray_space(p1), c = to_ray_space(p2);
  double e0 = b.x * c.y - b.y * c.x, e1 = c.x * a.y - c.y * a.x, e2 = a.x * b.y - a.y * b.x;
  double det = e0 + e1 + e2;
  if (det == 0 || !std::isfinite(det)) return std::nullopt;
  double max_z = std::max({std::abs(a.z), std::abs(b.z), std::abs(c.z)});
  double sz = pc.sz;
  a.z *= sz;
  b.z *= sz;
  c.z *= sz;
  double t = (e0 * a.z + e1 * b.z + e2 * c.z) / det;
  double max_zt = std::max({std::abs(a.z), std::abs(b.z), std::abs(c.z)});
  double max_xt = std::max({std::abs(a.x), std::abs(b.x), std::abs(c.x)});
  double max_yt = std::max({std::abs(a.y), std::abs(b.y), std::abs(c.y)});
  double delta_z = gamma_double(3) * max_zt;
  double delta_x = gamma_double(5) * (max_xt + max_z), delta_y = gamma_double(5) * (max_yt + max_z);
  double delta_e = 2 * (gamma_double(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
  double max_e = std::max({std::abs(e0), std::abs(e1), std::abs(e2)});
  double delta_t = 3 * (gamma_double(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) / std::abs(det);
  // One more rounding for the division.
  delta_t += gamma_double(1) * std::abs(t);
  if (!(t > delta_t) || !(t + delta_t < double(t_max))) return std::nullopt;
  Float tf = Float(t);
  if (!(tf > 0) || !(tf < t_max)) return std::nullopt;
  return tf;
}

}  // namespace detail

inline std::optional<TriangleHit> intersect_triangle(const Point3f& o, const RayTrianglePrecomp& pc, Float t_max,
                                                     const Point3f& p0, const Point3f& p1, const Point3f& p2) {
  // Translate to the ray origin, permute, shear in x and y.
  Vector3f p0t = permute(p0 - o, pc.kx, pc.ky, pc.kz);
  Vector3f p1t = permute(p1 - o, pc.kx, pc.ky, pc.kz);
  Vector3f p2t = permute(p2 - o, pc.kx, pc.ky, pc.kz);
  p0t.x += pc.sx * p0t.z; p0t.y += pc.sy * p0t.z;
  p1t.x += pc.sx * p1t.z; p1t.y += pc.sy * p1t.z;
  p2t.x += pc.sx * p2t.z; p2t.y += pc.sy * p2t.z;

  // Edge functions; an exact zero is re-evaluated in double so that a ray
  // through an edge is classified consistently for both triangles sharing it.
  Float e0 = difference_of_products(p1t.x, p2t.y, p1t.y, p2t.x);
  Float e1 = difference_of_products(p2t.x, p0t.y, p2t.y, p0t.x);
  Float e2 = difference_of_products(p0t.x, p1t.y, p0t.y, p1t.x);
  if (e0 == 0 || e1 == 0 || e2 == 0) [[unlikely]] {
    e0 = Float(double(p1t.x) * double(p2t.y) - double(p1t.y) * double(p2t.x));
    e1 = Float(double(p2t.x) * double(p0t.y) - double(p2t.y) * double(p0t.x));
    e2 = Float(double(p0t.x) * double(p1t.y) - double(p0t.y) * double(p1t.x));
  }
  if ((e0 < 0 || e1 < 0 || e2 < 0) && (e0 > 0 || e1 > 0 || e2 > 0)) return std::nullopt;
  Float det = e0 + e1 + e2;
  if (det == 0) return std::nullopt;

  // Largest |z| before scaling, in the same (spatial) units as x and y: the
  // shear's error bound below needs it, not the scaled z (which is in units of
  // the ray parameter and differs by 1 / d_z when d is not unit length).
  Float max_z = max_component(abs(Vector3f{p0t.z, p1t.z, p2t.z}));

  // Scaled hit distance, compared against the range before dividing. That
  // test only rejects what certainly lies beyond t_max: t_max is widened by
  // detail::triangle_range_widen to cover the rounding of the product and of
  // the division below; the exact test is on t itself. So whether a hit is
  // kept depends on its computed t alone, never on which triangle came first.
  p0t.z *= pc.sz; p1t.z *= pc.sz; p2t.z *= pc.sz;
  Float t_scaled = e0 * p0t.z + e1 * p1t.z + e2 * p2t.z;
  Float lim = t_max * detail::triangle_range_widen * det;
  if (det < 0 && (t_scaled >= 0 || t_scaled < lim)) return std::nullopt;
  if (det > 0 && (t_scaled <= 0 || t_scaled > lim)) return std::nullopt;

  Float inv_det = 1 / det;
  Float b0 = e0 * inv_det, b1 = e1 * inv_det, b2 = e2 * inv_det;
  Float t = t_scaled * inv_det;

  // Reject t unless it is provably positive: bound its error from the
  // magnitudes of the sheared coordinates (pbrt-v4 book, eqs. 6.29-6.33).
  Float max_zt = max_component(abs(Vector3f{p0t.z, p1t.z, p2t.z}));
  Float delta_z = gamma(3) * max_zt;
  Float max_xt = max_component(abs(Vector3f{p0t.x, p1t.x, p2t.x}));
  Float max_yt = max_component(abs(Vector3f{p0t.y, p1t.y, p2t.y}));
  Float delta_x = gamma(5) * (max_xt + max_z);
  Float delta_y = gamma(5) * (max_yt + max_z);
  Float delta_e = 2 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
  Float max_e = max_component(abs(Vector3f{e0, e1, e2}));
  Float delta_t = 3 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * std::abs(inv_det);
  // Written to reject NaN and infinite t too (overflowing products of huge
  // coordinates make det or t_scaled infinite, and their quotient NaN).
  if (!(t < t_max)) return std::nullopt;
  if (!(t > delta_t)) {
    // Inconclusive in single precision: decide in double (rare).
    std::optional<Float> td = detail::refine_triangle_t(o, pc, t_max, p0, p1, p2);
    if (!td) return std::nullopt;
    t = *td;
  }
  return TriangleHit{t, b0, b1, b2};
}

// Geometry of a hit on a triangle (object space): point with error bound,
// geometric normal from the winding (p1 - p0) x (p2 - p0), shading normal from
// interpolated vertex normals when present, uv and dpdu.
// The vertices may be given instead of read from the mesh (a deforming
// mesh's at the ray's time, accel/deforming_mesh.hpp): `positions`, and
// `normals` and `tangents` (three each) where not null; the rest comes from
// the mesh.
inline void triangle_interaction(const TriangleMesh& mesh, uint32_t tri, const TriangleHit& h,
                                 SurfaceInteraction* si, const Point3f* positions,
                                 const Normal3f* normals = nullptr,
                                 const std::array<Float, 4>* tangents = nullptr) {
  uint32_t i0 = mesh.indices[3 * tri], i1 = mesh.indices[3 * tri + 1], i2 = mesh.indices[3 * tri + 2];
  const Point3f &p0 = positions[0], &p1 = positions[1], &p2 = positions[2];
  si->p = Point3f(Vector3f(p0) * h.b0 + Vector3f(p1) * h.b1 + Vector3f(p2) * h.b2);
  si->p_error = (abs(Vector3f(p0) * h.b0) + abs(Vector3f(p1) * h.b1) + abs(Vector3f(p2) * h.b2)) * gamma(7);

  Vector3f e1 = p1 - p0, e2 = p2 - p0;
  Normal3f ng(normalize(cross(e1, e2)));
  si->n = ng;

  Point2f uv0{0, 0}, uv1{1, 0}, uv2{1, 1};
  if (!mesh.uvs.empty()) {
    uv0 = mesh.uvs[i0];
    uv1 = mesh.uvs[i1];
    uv2 = mesh.uvs[i2];
  }
  si->uv = uv0 * h.b0 + uv1 * h.b1 + uv2 * h.b2;
  // dpdu, dpdv from the uv parameterisation; fall back to edges when degenerate.
  Float du02 = uv0.x - uv2.x, du12 = uv1.x - uv2.x, dv02 = uv0.y - uv2.y, dv12 = uv1.y - uv2.y;
  Float det = difference_of_products(du02, dv12, dv02, du12);
  Vector3f dp02 = p0 - p2, dp12 = p1 - p2;
  bool uv_ok = std::abs(det) > 1e-20f;
  Vector3f dpdu = uv_ok ? (dp02 * dv12 - dp12 * dv02) / det : e1;
  Vector3f dpdv = uv_ok ? (dp12 * du02 - dp02 * du12) / det : e2;
  if (!(length_squared(dpdu) > 0) || dpdu.has_nan()) dpdu = e1;
  if (!(length_squared(dpdv) > 0) || dpdv.has_nan()) dpdv = e2;
  si->dpdu = dpdu;
  si->dpdv = dpdv;
  if (!mesh.uvs1.empty()) si->uv1 = mesh.uvs1[i0] * h.b0 + mesh.uvs1[i1] * h.b1 + mesh.uvs1[i2] * h.b2;
  if (tangents || !mesh.tangents.empty()) {
    const auto &t0 = tangents ? tangents[0] : mesh.tangents[i0], &t1 = tangents ? tangents[1] : mesh.tangents[i1],
               &t2 = tangents ? tangents[2] : mesh.tangents[i2];
    si->tangent = Vector3f(t0[0], t0[1], t0[2]) * h.b0 + Vector3f(t1[0], t1[1], t1[2]) * h.b1 +
                  Vector3f(t2[0], t2[1], t2[2]) * h.b2;
    si->tangent_w = t0[3] < 0 ? Float(-1) : Float(1);
  }
  if (!mesh.colors.empty()) {
    const auto &c0 = mesh.colors[i0], &c1 = mesh.colors[i1], &c2 = mesh.colors[i2];
    for (int k = 0; k < 3; ++k) si->color[k] = c0[size_t(k)] * h.b0 + c1[size_t(k)] * h.b1 + c2[size_t(k)] * h.b2;
    si->alpha = c0[3] * h.b0 + c1[3] * h.b1 + c2[3] * h.b2;
  }

  si->ns = ng;
  if (normals || !mesh.normals.empty()) {
    Normal3f ns = normals ? normals[0] * h.b0 + normals[1] * h.b1 + normals[2] * h.b2
                          : mesh.normals[i0] * h.b0 + mesh.normals[i1] * h.b1 + mesh.normals[i2] * h.b2;
    Float l2 = length_squared(ns);
    if (l2 > 0 && std::isfinite(l2)) {
      ns = ns / std::sqrt(l2);
      // The geometric normal follows the shading normal's side, as in pbrt.
      si->n = face_forward(ng, ns);
      si->ns = ns;
    }
  }
}

inline void triangle_interaction(const TriangleMesh& mesh, uint32_t tri, const TriangleHit& h,
                                 SurfaceInteraction* si) {
  const Point3f p[3] = {mesh.positions[mesh.indices[3 * tri]], mesh.positions[mesh.indices[3 * tri + 1]],
                        mesh.positions[mesh.indices[3 * tri + 2]]};
  triangle_interaction(mesh, tri, h, si, p);
}

}  // namespace prism
