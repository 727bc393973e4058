// Matrix4d, the double-precision 4x4 the glTF loader composes node
// hierarchies with: trs against translate * rotate * scale, products,
// points, and one rounding to Float at the end.
#include <catch2/catch.hpp>
#include <cmath>
#include <prism/math/transform.hpp>

namespace matrix4d_test {

using namespace prism;

TEST_CASE("Matrix4d::trs is translate * rotate * scale, normalising the quaternion", "[math]") {
  const double angle = 0.7;
  const Vector3f axis = normalize(Vector3f{1, -2, 0.5f});
  const double s = std::sin(angle / 2), c = std::cos(angle / 2);
  std::array<double, 4> q{axis.x * s, axis.y * s, axis.z * s, c};
  Matrix4d m = Matrix4d::trs({1, 2, 3}, q, {2, 0.5, -1});
  Transform expected = translate({1, 2, 3}) * rotate(Float(angle), axis) * scale(2, 0.5f, -1);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      // 1e-6: the float chain's roundings (a few ulps of entries ≤ 3: ulp 2.4e-7) against the double one rounded once
      CHECK(m.to_float().m[size_t(i)][size_t(j)] == Approx(expected.matrix().m[size_t(i)][size_t(j)]).margin(1e-6));
  // A quaternion of any non-zero length is normalised; zero gives no rotation.
  std::array<double, 4> q3{3 * q[0], 3 * q[1], 3 * q[2], 3 * q[3]};
  Matrix4d m3 = Matrix4d::trs({1, 2, 3}, q3, {2, 0.5, -1});
  // 1e-15: double rounding of the normalisation (a few 2^-53 of entries ≤ 3)
  for (size_t k = 0; k < 16; ++k) CHECK(m3.m[k] == Approx(m.m[k]).margin(1e-15));
  CHECK(Matrix4d::trs({0, 0, 0}, {0, 0, 0, 0}, {1, 1, 1}) == Matrix4d{});
}

TEST_CASE("Matrix4d products and points, rounded to Float once", "[math]") {
  Matrix4d a = Matrix4d::trs({1, 0, 0}, {0, 0, std::sin(0.25), std::cos(0.25)}, {1, 1, 1});
  Matrix4d b = Matrix4d::trs({0, 2, 0}, {0, 0, 0, 1}, {3, 3, 3});
  Matrix4d ab = a * b;
  CHECK(Matrix4d{} * a == a);
  CHECK(a * Matrix4d{} == a);
  // (a * b) p == a (b p).
  std::array<double, 3> p{0.5, -1, 2};
  auto direct = ab.apply_point(p), chained = a.apply_point(b.apply_point(p));
  // 1e-12: double rounding, ~10 roundings of 2^-53 on values ≤ 5
  for (size_t i = 0; i < 3; ++i) CHECK(direct[i] == Approx(chained[i]).margin(1e-12));
  // Small integers compose exactly, as Matrix4's product does.
  Matrix4d x, y;
  for (size_t k = 0; k < 16; ++k) {
    x.m[k] = double(int(k % 5) - 2);
    y.m[k] = double(int(k % 3) - 1);
  }
  CHECK((x * y).to_float() == x.to_float() * y.to_float());
  // A hundred small rotations composed in double and rounded once match the
  // single rotation by their sum more closely than a Float chain does.
  const double step = 0.01;
  Matrix4d r = Matrix4d::trs({0, 0, 0}, {0, 0, std::sin(step / 2), std::cos(step / 2)}, {1, 1, 1}), chain;
  Matrix4 chain_f;
  for (int i = 0; i < 100; ++i) {
    chain = chain * r;
    chain_f = chain_f * r.to_float();
  }
  Matrix4 exact = Matrix4d::trs({0, 0, 0}, {0, 0, std::sin(0.5), std::cos(0.5)}, {1, 1, 1}).to_float();
  double err_d = 0, err_f = 0;
  for (size_t i = 0; i < 4; ++i)
    for (size_t j = 0; j < 4; ++j) {
      err_d = std::max(err_d, double(std::abs(chain.to_float().m[i][j] - exact.m[i][j])));
      err_f = std::max(err_f, double(std::abs(chain_f.m[i][j] - exact.m[i][j])));
    }
  // 1e-7: 100 double products (~300 roundings of 2^-53, ~3e-14) then one float rounding: half an ulp of entries ≤ 1 (6e-8)
  CHECK(err_d <= 1e-7);
  CHECK(err_d <= err_f);
}

}  // namespace matrix4d_test
