// bench/procedural_mesh.hpp — the benches' code-built ~1M-triangle mesh: a
// cube-sphere displaced by fractal value noise (deterministic). Shared by
// traversal_bench.cpp and ab_traversal.cpp, so both trace the same triangles.
// Also the pinhole raster and the incoherent rays from its hits that
// ab_traversal and tree_compare trace, and traversal_bench's framing camera
// (which ab_traversal's "framed" rays use too).
#pragma once
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "prism/geometry/triangle.hpp"
#include "prism/math/frame.hpp"
#include "prism/sampling/pcg32.hpp"
#include "prism/sampling/warps.hpp"

namespace prism_bench {

using namespace prism;

// Deterministic 3D value noise (hashed lattice, smoothstep interpolation).
inline Float lattice(int x, int y, int z) {
  uint64_t h = hash_values(uint64_t(uint32_t(x)), uint64_t(uint32_t(y)), uint64_t(uint32_t(z)));
  return Float(h >> 40) * 0x1p-24f * 2 - 1;
}
inline Float value_noise(Float x, Float y, Float z) {
  int ix = int(std::floor(x)), iy = int(std::floor(y)), iz = int(std::floor(z));
  Float fx = x - Float(ix), fy = y - Float(iy), fz = z - Float(iz);
  auto s = [](Float t) { return t * t * (3 - 2 * t); };
  Float ux = s(fx), uy = s(fy), uz = s(fz);
  Float c[2][2][2];
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b)
      for (int e = 0; e < 2; ++e) c[a][b][e] = lattice(ix + a, iy + b, iz + e);
  auto l = [](Float t, Float p, Float q) { return p + t * (q - p); };
  return l(uz, l(uy, l(ux, c[0][0][0], c[1][0][0]), l(ux, c[0][1][0], c[1][1][0])),
           l(uy, l(ux, c[0][0][1], c[1][0][1]), l(ux, c[0][1][1], c[1][1][1])));
}
inline Float fbm(Vector3f p) {
  Float sum = 0, amp = 0.5f;
  for (int o = 0; o < 6; ++o) {
    sum += amp * value_noise(p.x, p.y, p.z);
    p = p * 2.03f;
    amp *= 0.5f;
  }
  return sum;
}

// A cube-sphere: each cube face an n x n grid projected onto the unit sphere,
// then displaced radially by fractal noise. 12 n^2 triangles. Vertices on the
// cube's edges are computed from the same cube point on both faces, so the
// mesh is closed.
inline TriangleMesh make_displaced_sphere(int n) {
  TriangleMesh m;
  auto idx = [n](int i, int j) { return uint32_t(i * (n + 1) + j); };
  for (int face = 0; face < 6; ++face) {
    int axis = face / 2;
    Float sign = face % 2 ? -1.f : 1.f;
    uint32_t base = uint32_t(m.positions.size());
    for (int i = 0; i <= n; ++i)
      for (int j = 0; j <= n; ++j) {
        Float u = Float(2 * i - n) / Float(n), v = Float(2 * j - n) / Float(n);
        Float c[3];
        c[axis] = sign;
        c[(axis + 1) % 3] = sign * u;
        c[(axis + 2) % 3] = v;
        Vector3f d = normalize(Vector3f{c[0], c[1], c[2]});
        Float r = 1 + 0.35f * fbm(d * 3.0f);
        m.positions.push_back(Point3f(d * r));
      }
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        uint32_t a = base + idx(i, j), b = base + idx(i + 1, j), c = base + idx(i + 1, j + 1),
                 d = base + idx(i, j + 1);
        m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
      }
  }
  return m;
}

// Pixel (x, y) of a res x res pinhole raster looking down -z (from an eye
// in front of the mesh, +z): the ray's direction.
inline Vector3f raster_direction(int x, int y, int res) {
  return normalize(Vector3f{(Float(x) + 0.5f) / Float(res) * 0.8f - 0.45f,
                            0.35f - (Float(y) + 0.5f) / Float(res) * 0.8f, -1.0f});
}
// traversal_bench's primary rays: a pinhole camera looking at the centre of
// box b (the mesh's bounds) from direction view_dir, at 2.5 times the box's
// half diagonal, its image window fitted to the projected vertices (1%
// margin) so that it frames the mesh.
struct FramingCamera {
  Point3f eye;
  Frame f;
  Float x0 = infinity, x1 = -infinity, y0 = infinity, y1 = -infinity;
  FramingCamera(const TriangleMesh& mesh, const Bounds3f& b, Vector3f view_dir) {
    Point3f c = b.centroid();
    Float radius = 0.5f * length(b.diagonal());
    Vector3f w = normalize(view_dir);  // from the target towards the eye
    eye = c + w * (2.5f * radius);
    f = Frame::from_z(-w);
    for (const Point3f& p : mesh.positions) {
      Vector3f l = f.to_local(p - eye);
      x0 = std::min(x0, l.x / l.z);
      x1 = std::max(x1, l.x / l.z);
      y0 = std::min(y0, l.y / l.z);
      y1 = std::max(y1, l.y / l.z);
    }
    Float margin = 0.01f * std::max(x1 - x0, y1 - y0);
    x0 -= margin;
    x1 += margin;
    y0 -= margin;
    y1 += margin;
  }
  // Pixel (x, y) of a res x res raster: the ray's direction.
  Vector3f direction(int x, int y, int res) const {
    Float sx = x0 + (x1 - x0) * (Float(x) + 0.5f) / Float(res);
    Float sy = y1 - (y1 - y0) * (Float(y) + 0.5f) / Float(res);
    return normalize(f.from_local({sx, sy, 1}));
  }
};
// The view direction of traversal_bench's procedural case.
inline const Vector3f procedural_view{0.55f, 0.35f, 0.75f};

// The pixel's random stream (rays derived from its hit).
inline PCG32 pixel_rng(int x, int y, int res) { return PCG32(uint64_t(y) * uint64_t(res) + uint64_t(x), 0x5eed); }

// From a hit at p on triangle (a, b, c) seen along d: the geometric normal
// facing the viewer (*facing), and an incoherent ray, its origin 1e-4 off the
// surface (far more than the hit's rounding) and its direction
// cosine-distributed about that normal (two numbers from rng).
struct BounceRay {
  Point3f o;
  Vector3f d;
};
inline BounceRay incoherent_ray(const Point3f& p, const Point3f& a, const Point3f& b, const Point3f& c,
                                const Vector3f& d, PCG32& rng, Vector3f* facing = nullptr) {
  Vector3f n = normalize(cross(b - a, c - a));
  if (dot(n, d) > 0) n = -n;
  if (facing) *facing = n;
  Vector3f w = Frame::from_z(n).from_local(sample_cosine_hemisphere({rng.next_float(), rng.next_float()}));
  return {p + n * 1e-4f, normalize(w)};
}

}  // namespace prism_bench
