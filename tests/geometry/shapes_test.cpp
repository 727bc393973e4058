// geometry/shapes.hpp: meshes built in code are closed where they should be,
// face outwards, and approach the surfaces they tessellate.
#include <catch2/catch.hpp>
#include <cmath>
#include <map>
#include <utility>
#include <prism/error.hpp>
#include <prism/geometry/shapes.hpp>

namespace shapes_test {
using namespace prism;

// Each undirected edge of a closed, consistently wound mesh is used exactly
// twice, once in each direction.
bool closed_and_consistent(const TriangleMesh& m) {
  std::map<std::pair<uint32_t, uint32_t>, int> directed;
  for (size_t t = 0; t < m.triangle_count(); ++t)
    for (int k = 0; k < 3; ++k) {
      uint32_t a = m.indices[3 * t + size_t(k)], b = m.indices[3 * t + size_t((k + 1) % 3)];
      ++directed[{a, b}];
    }
  for (const auto& [e, n] : directed)
    if (n != 1 || directed.count({e.second, e.first}) == 0) return false;
  return true;
}
// Merges vertices at the same position (uv seams duplicate them).
TriangleMesh welded(const TriangleMesh& m) {
  std::map<std::tuple<float, float, float>, uint32_t> id;
  std::vector<uint32_t> remap(m.positions.size());
  TriangleMesh out;
  for (size_t i = 0; i < m.positions.size(); ++i) {
    auto key = std::make_tuple(m.positions[i].x, m.positions[i].y, m.positions[i].z);
    auto it = id.find(key);
    if (it == id.end()) {
      it = id.emplace(key, uint32_t(out.positions.size())).first;
      out.positions.push_back(m.positions[i]);
    }
    remap[i] = it->second;
  }
  for (uint32_t i : m.indices) out.indices.push_back(remap[i]);
  return out;
}
// Sum over triangles of area, and of the outward test against a centre.
struct Stats {
  double area = 0;
  int inward = 0;
};
Stats stats(const TriangleMesh& m, Point3f centre) {
  Stats s;
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    Point3f a = m.positions[m.indices[3 * t]], b = m.positions[m.indices[3 * t + 1]],
            c = m.positions[m.indices[3 * t + 2]];
    Vector3f n = cross(b - a, c - a);
    s.area += 0.5 * double(length(n));
    Vector3f to_face = (Vector3f(a) + Vector3f(b) + Vector3f(c)) / 3 - Vector3f(centre);
    if (dot(n, to_face) <= 0) ++s.inward;
  }
  return s;
}
}  // namespace shapes_test

using namespace shapes_test;

TEST_CASE("make_box is closed, faces outwards and has the box's area", "[geometry][shapes]") {
  TriangleMesh m = make_box({-1, -2, -3}, {1, 2, 3});
  CHECK(closed_and_consistent(welded(m)));
  Stats s = stats(m, {0, 0, 0});
  CHECK(s.inward == 0);
  // 1e-6 relative: float areas of 12 triangles with integer corners (exact products, a few roundings in the sums)
  CHECK(s.area == Approx(2 * (2 * 4 + 2 * 6 + 4 * 6)).epsilon(1e-6));
}

TEST_CASE("make_uv_sphere is closed, faces outwards and converges to the sphere", "[geometry][shapes]") {
  const Point3f c{0.5f, -1, 2};
  const double r = 1.5;
  double previous_error = 1;
  for (int n : {8, 32, 128}) {
    TriangleMesh m = make_uv_sphere(c, Float(r), n, 2 * n);
    CHECK(closed_and_consistent(welded(m)));
    REQUIRE(m.normals.size() == m.positions.size());
    REQUIRE(m.uvs.size() == m.positions.size());
    Stats s = stats(m, c);
    CHECK(s.inward == 0);
    for (size_t i = 0; i < m.positions.size(); ++i) {
      // 1e-5 relative: float sin/cos of the grid angles times r = 1.5 plus c, a few ulps of coordinates ≤ 3.5
      CHECK(length(m.positions[i] - c) == Approx(r).epsilon(1e-5));
      CHECK(dot(Vector3f(m.normals[i]), (m.positions[i] - c) / Float(r)) == Approx(1).epsilon(1e-5));
    }
    // An inscribed polyhedron: its area is below 4 pi r^2 and the error
    // falls as the tessellation refines (by about 16x per 4x finer here).
    double error = 1 - s.area / (4 * 3.14159265358979323846 * r * r);
    INFO("n = " << n << " relative area error " << error);
    CHECK(error > 0);
    CHECK(error < previous_error / 8);
    previous_error = error;
  }
}

TEST_CASE("make_uv_sphere rejects bad tessellations and radii", "[geometry][shapes]") {
  CHECK_THROWS_AS(make_uv_sphere({0, 0, 0}, 1, 1, 8), Error);
  CHECK_THROWS_AS(make_uv_sphere({0, 0, 0}, 1, 4, 2), Error);
  CHECK_THROWS_AS(make_uv_sphere({0, 0, 0}, 0, 4, 8), Error);
  CHECK_THROWS_AS(make_uv_sphere({0, 0, 0}, std::nanf(""), 4, 8), Error);
}

TEST_CASE("make_triangular_prism is closed and faces outwards", "[geometry][shapes]") {
  TriangleMesh m = make_triangular_prism({0, 0}, {0, 1}, {1, 0}, -1, 1);  // either winding of the base
  CHECK(closed_and_consistent(welded(m)));
  CHECK(stats(m, {1.f / 3, 0, 1.f / 3}).inward == 0);
}
