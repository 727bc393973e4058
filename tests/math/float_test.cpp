// Floating-point utilities, interval arithmetic and the error-bounded affine
// transform, checked against exact (or monotonically rounded wider) arithmetic.
//
// Reference arithmetic: x86-64 long double has a 64-bit significand. Products
// of two floats are exact in it; sums, quotients and square roots are rounded
// once, monotonically. Rounding is monotone and leaves floats fixed, so for a
// float bound h, exact <= h implies rounded(exact) <= h: checking containment on
// the long-double result can only miss a violation smaller than 2^-64 relative.
#include <catch2/catch.hpp>

#include <bit>
#include <cfloat>
#include <cmath>
#include <cstring>

#include "prism/math/float.hpp"
#include "prism/math/interval.hpp"
#include "prism/math/transform.hpp"
#include "prism/sampling/pcg32.hpp"

namespace float_test {

using namespace prism;
using ld = long double;

static_assert(std::numeric_limits<long double>::digits >= 64, "these tests need an extended long double");

namespace {

constexpr int kCases = 100000;

double uniform(PCG32& rng, double a, double b) { return a + (b - a) * (double(rng.next_u32()) * 0x1p-32); }

// A float with a random sign, a uniformly random significand and a binary
// exponent uniform in [emin, emax].
float random_float(PCG32& rng, int emin, int emax) {
  int e = emin + int(rng.next_bounded(uint32_t(emax - emin + 1)));
  float m = 1.0f + float(rng.next_u32() >> 9) * 0x1p-23f;  // [1, 2)
  float v = std::ldexp(m, e);
  return rng.next_u32() & 1 ? -v : v;
}

// A random finite float from its bit pattern (every exponent, denormals included).
float random_finite_bits(PCG32& rng) {
  for (;;) {
    float v = std::bit_cast<float>(rng.next_u32());
    if (std::isfinite(v)) return v;
  }
}
double random_finite_bits_double(PCG32& rng) {
  for (;;) {
    uint64_t b = (uint64_t(rng.next_u32()) << 32) | rng.next_u32();
    double v = std::bit_cast<double>(b);
    if (std::isfinite(v)) return v;
  }
}

bool same_bits(float a, float b) { return std::bit_cast<uint32_t>(a) == std::bit_cast<uint32_t>(b); }
bool same_bits(double a, double b) { return std::bit_cast<uint64_t>(a) == std::bit_cast<uint64_t>(b); }

// An interval from_value_and_error over operands spanning many magnitudes and
// both signs: exact points, tight intervals, wide ones and ones straddling 0.
Interval random_interval(PCG32& rng, float* v_out = nullptr, float* err_out = nullptr) {
  float v = rng.next_bounded(16) == 0 ? 0.0f : random_float(rng, -60, 60);
  float err;
  switch (rng.next_bounded(4)) {
    case 0: err = 0; break;                                                                   // a point
    case 1: err = std::abs(v) * std::ldexp(float(uniform(rng, 0, 1)), -int(rng.next_bounded(24))); break;  // tight
    case 2: err = std::abs(v) * float(uniform(rng, 1, 4)); break;                                      // straddles 0
    default: err = std::abs(random_float(rng, -60, 60)); break;                                        // anything
  }
  if (v_out) *v_out = v;
  if (err_out) *err_out = err;
  return Interval::from_value_and_error(v, err);
}

// Float points of an interval at which to evaluate: both ends and one inside.
void sample_points(PCG32& rng, const Interval& i, float out[3]) {
  out[0] = i.lower();
  out[1] = i.upper();
  ld t = ld(uniform(rng, 0, 1));
  float mid = float(ld(i.lower()) + t * (ld(i.upper()) - ld(i.lower())));
  out[2] = std::clamp(mid, i.lower(), i.upper());
}

bool contains(const Interval& r, ld exact) { return ld(r.lower()) <= exact && exact <= ld(r.upper()); }

}  // namespace

TEST_CASE("next_float_up and next_float_down step by exactly one float", "[math][float]") {
  // Special values.
  CHECK(next_float_up(0.0f) == std::numeric_limits<float>::denorm_min());
  CHECK(next_float_up(-0.0f) == std::numeric_limits<float>::denorm_min());
  CHECK(next_float_down(0.0f) == -std::numeric_limits<float>::denorm_min());
  CHECK(next_float_down(-0.0f) == -std::numeric_limits<float>::denorm_min());
  CHECK(next_float_up(FLT_MAX) == infinity);
  CHECK(next_float_down(-FLT_MAX) == -infinity);
  CHECK(next_float_up(infinity) == infinity);
  CHECK(next_float_down(-infinity) == -infinity);
  CHECK(next_float_up(-infinity) == -FLT_MAX);
  CHECK(next_float_down(infinity) == FLT_MAX);
  CHECK(next_float_up(1.0f) == 1.0f + 0x1p-23f);
  CHECK(next_float_down(1.0f) == 1.0f - 0x1p-24f);
  CHECK(next_float_up(-std::numeric_limits<float>::denorm_min()) == 0.0f);
  CHECK(next_float_up(0.0) == std::numeric_limits<double>::denorm_min());
  CHECK(next_float_down(0.0) == -std::numeric_limits<double>::denorm_min());
  CHECK(next_float_up(1.0) == 1.0 + 0x1p-52);
  CHECK(next_float_down(std::numeric_limits<double>::infinity()) == DBL_MAX);

  // Random finite values of every exponent agree with std::nextafter bit for bit.
  PCG32 rng(1, 42);
  int bad_up = 0, bad_down = 0, bad_round_trip = 0;
  for (int i = 0; i < kCases; ++i) {
    float v = random_finite_bits(rng);
    float up = next_float_up(v), down = next_float_down(v);
    float ref_up = std::nextafter(v, infinity), ref_down = std::nextafter(v, -infinity);
    // nextafter(-0, +inf) and nextafter(+0, -inf) agree with ours; nextafter
    // keeps the sign of a zero result from its argument, so compare zeros by value.
    if (!(same_bits(up, ref_up) || (up == 0 && ref_up == 0))) ++bad_up;
    if (!(same_bits(down, ref_down) || (down == 0 && ref_down == 0))) ++bad_down;
    if (!(up > v && down < v)) ++bad_up;
    if (v != 0 && (next_float_down(up) != v || next_float_up(down) != v)) ++bad_round_trip;

    double d = random_finite_bits_double(rng);
    double dup = next_float_up(d), ddown = next_float_down(d);
    if (!(same_bits(dup, std::nextafter(d, HUGE_VAL)) || (dup == 0 && std::nextafter(d, HUGE_VAL) == 0))) ++bad_up;
    if (!(same_bits(ddown, std::nextafter(d, -HUGE_VAL)) || (ddown == 0 && std::nextafter(d, -HUGE_VAL) == 0)))
      ++bad_down;
  }
  CHECK(bad_up == 0);
  CHECK(bad_down == 0);
  CHECK(bad_round_trip == 0);
}

TEST_CASE("gamma bounds the error of chained roundings", "[math][float]") {
  constexpr double u = 0x1p-24;
  CHECK(double(machine_epsilon) == u);
  for (int n = 1; n <= 32; ++n) {
    // n u and 1 - n u are exact in float; only the division rounds (<= u).
    CHECK(double(gamma(n)) == Approx(n * u / (1 - n * u)).epsilon(u));
    CHECK(gamma(n) > gamma(n - 1));
    CHECK(double(gamma(n)) >= n * u);  // the bound is never below n u
  }
  CHECK(gamma(0) == 0);

  // Products of n + 1 floats: n roundings, relative error <= gamma(n).
  // Sums of n + 1 floats, left to right: error <= gamma(n) * sum |x_i|.
  PCG32 rng(2, 42);
  int bad_prod = 0, bad_sum = 0;
  for (int i = 0; i < kCases; ++i) {
    int n = 1 + int(rng.next_bounded(12));
    float p = random_float(rng, -4, 4), s = random_float(rng, -20, 20);
    ld pe = p, se = s, sabs = std::abs(ld(s));
    for (int k = 0; k < n; ++k) {
      float x = random_float(rng, -4, 4), y = random_float(rng, -20, 20);
      p *= x;
      pe *= x;
      s += y;
      se += y;
      sabs += std::abs(ld(y));
    }
    if (std::abs(ld(p) - pe) > ld(gamma(n)) * std::abs(pe)) ++bad_prod;
    if (std::abs(ld(s) - se) > ld(gamma(n)) * sabs) ++bad_sum;
  }
  CHECK(bad_prod == 0);
  CHECK(bad_sum == 0);

  // difference_of_products (Kahan's algorithm) has relative error <= 2 u
  // (Jeannerod, Louvet and Muller 2013), barring underflow.
  int bad_dop = 0;
  for (int i = 0; i < kCases; ++i) {
    float a = random_float(rng, -20, 20), b = random_float(rng, -20, 20);
    float c = random_float(rng, -20, 20), d = random_float(rng, -20, 20);
    if (rng.next_bounded(2)) {  // near-cancellation
      c = std::nextafter(a, 0.0f);
      d = b;
    }
    ld exact = ld(a) * ld(b) - ld(c) * ld(d);
    ld got = difference_of_products(a, b, c, d);
    if (std::abs(got - exact) > 2 * ld(u) * std::abs(exact)) ++bad_dop;
  }
  CHECK(bad_dop == 0);
}

TEST_CASE("directed rounding brackets the exact result", "[math][float]") {
  PCG32 rng(3, 42);
  int bad = 0;
  for (int i = 0; i < kCases; ++i) {
    float a = random_float(rng, -70, 70), b = random_float(rng, -70, 70);
    ld s = ld(a) + ld(b), d = ld(a) - ld(b), p = ld(a) * ld(b), q = ld(a) / ld(b), r = std::sqrt(std::abs(ld(a)));
    if (!(ld(add_round_down(a, b)) <= s && s <= ld(add_round_up(a, b)))) ++bad;
    if (!(ld(sub_round_down(a, b)) <= d && d <= ld(sub_round_up(a, b)))) ++bad;
    if (!(ld(mul_round_down(a, b)) <= p && p <= ld(mul_round_up(a, b)))) ++bad;
    if (!(ld(div_round_down(a, b)) <= q && q <= ld(div_round_up(a, b)))) ++bad;
    if (!(ld(sqrt_round_down(std::abs(a))) <= r && r <= ld(sqrt_round_up(std::abs(a))))) ++bad;
  }
  CHECK(bad == 0);
}

TEST_CASE("Interval from_value_and_error contains the error box", "[math][interval]") {
  PCG32 rng(4, 42);
  int bad = 0;
  for (int i = 0; i < kCases; ++i) {
    float v, err;
    Interval iv = random_interval(rng, &v, &err);
    if (!(contains(iv, ld(v) - ld(err)) && contains(iv, ld(v) + ld(err)))) ++bad;
    if (err == 0 && !iv.exactly(v)) ++bad;
  }
  CHECK(bad == 0);
}

TEST_CASE("Interval arithmetic contains every exact result", "[math][interval]") {
  // For +, -, *, / the extremes over a box of operands are at its corners, so
  // checking the ends (plus one interior point) of each operand covers the
  // whole set; sqr and sqrt are checked at their ends, an interior point and 0.
  PCG32 rng(5, 42);
  int bad_add = 0, bad_sub = 0, bad_mul = 0, bad_div = 0, bad_sqr = 0, bad_sqrt = 0, bad_neg = 0, bad_abs = 0;
  int wide = 0, div_by_zero = 0;
  for (int i = 0; i < kCases; ++i) {
    Interval a = random_interval(rng), b = random_interval(rng);
    Interval sum = a + b, diff = a - b, prod = a * b, quot = a / b, sq = sqr(a), rt = sqrt(a), neg = -a,
             ab = abs(a);
    bool b_has_zero = b.contains(0);
    if (b_has_zero) {
      ++div_by_zero;
      if (!(quot.lower() == -infinity && quot.upper() == infinity)) ++bad_div;
    }
    float pa[3], pb[3];
    sample_points(rng, a, pa);
    sample_points(rng, b, pb);
    for (float x : pa) {
      if (!contains(sq, ld(x) * ld(x))) ++bad_sqr;
      if (x >= 0 && !contains(rt, std::sqrt(ld(x)))) ++bad_sqrt;
      if (!contains(neg, -ld(x))) ++bad_neg;
      if (!contains(ab, std::abs(ld(x)))) ++bad_abs;
      for (float y : pb) {
        if (!contains(sum, ld(x) + ld(y))) ++bad_add;
        if (!contains(diff, ld(x) - ld(y))) ++bad_sub;
        if (!contains(prod, ld(x) * ld(y))) ++bad_mul;
        if (y != 0 && !contains(quot, ld(x) / ld(y))) ++bad_div;
      }
    }
    if (a.contains(0) && !contains(sq, 0)) ++bad_sqr;
    if (a.contains(0) && !contains(rt, 0)) ++bad_sqrt;

    // Outward rounding costs at most one float on each side: on point
    // operands the result lies within one float of the rounded result.
    float x = pa[2], y = pb[2];
    Interval px(x), py(y);
    auto tight = [&](Interval r, float rn) {
      return r.lower() >= next_float_down(rn) && r.upper() <= next_float_up(rn) && r.contains(rn);
    };
    if (!tight(px + py, x + y) || !tight(px - py, x - y) || !tight(px * py, x * y) || !tight(sqr(px), x * x))
      ++wide;
    if (y != 0 && !tight(px / py, x / y)) ++wide;
    if (x > 0 && !tight(sqrt(px), std::sqrt(x))) ++wide;
  }
  INFO("divisions by an interval containing 0: " << div_by_zero);
  CHECK(bad_add == 0);
  CHECK(bad_sub == 0);
  CHECK(bad_mul == 0);
  CHECK(bad_div == 0);
  CHECK(bad_sqr == 0);
  CHECK(bad_sqrt == 0);
  CHECK(bad_neg == 0);
  CHECK(bad_abs == 0);
  CHECK(wide == 0);
  CHECK(div_by_zero > 0);  // the case was exercised
}

namespace {

struct RandomAffine {
  Matrix4 m;
  bool positive = false;
  ld exact_row(int r, const ld p[3]) const {
    // Products of floats are exact in long double; the sum rounds once per add
    // at 2^-64 relative, negligible against float's 2^-24.
    return ld(m.m[r][0]) * p[0] + ld(m.m[r][1]) * p[1] + ld(m.m[r][2]) * p[2] + ld(m.m[r][3]);
  }
};

// A random affine matrix: linear part with entries over 2^[-6, 6] (all
// positive in a quarter of the cases, where rounding errors cannot cancel),
// translation over 2^[-30, 30] or zero.
RandomAffine random_affine(PCG32& rng) {
  RandomAffine a;
  bool positive = a.positive = rng.next_bounded(4) == 0;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) {
      float v = rng.next_bounded(8) == 0 ? 0.0f : random_float(rng, -6, 6);
      a.m.m[r][c] = positive ? std::abs(v) : v;
    }
    float t = rng.next_bounded(8) == 0 ? 0.0f : random_float(rng, -30, 30);
    a.m.m[r][3] = positive ? std::abs(t) : t;
  }
  return a;
}

Point3f random_point(PCG32& rng, bool positive) {
  Point3f p;
  for (int i = 0; i < 3; ++i) {
    float v = rng.next_bounded(16) == 0 ? 0.0f : random_float(rng, -30, 30);
    p[i] = positive ? std::abs(v) : v;
  }
  return p;
}

}  // namespace

TEST_CASE("Transform apply bounds the error of an affine point transform", "[math][transform]") {
  PCG32 rng(6, 42);
  int bad = 0;
  ld worst = 0;  // largest |error| / bound seen
  for (int i = 0; i < kCases; ++i) {
    RandomAffine a = random_affine(rng);
    Transform t(a.m, a.m);  // the inverse is irrelevant here
    Point3f p = random_point(rng, a.positive);
    Vector3f err;
    Point3f q = t.apply(p, &err);
    ld pe[3] = {p.x, p.y, p.z};
    for (int r = 0; r < 3; ++r) {
      ld e = std::abs(ld(q[r]) - a.exact_row(r, pe));
      if (e > ld(err[r])) ++bad;
      if (err[r] > 0) worst = std::max(worst, e / ld(err[r]));
    }
  }
  INFO("largest error / bound: " << double(worst));
  CHECK(bad == 0);
}

TEST_CASE("Transform apply carries an input error bound", "[math][transform]") {
  // p is known only to within +-p_err: the result's bound must cover the exact
  // transform of every point of that box (checked at random corners and inside).
  PCG32 rng(7, 42);
  int bad = 0;
  for (int i = 0; i < kCases; ++i) {
    RandomAffine a = random_affine(rng);
    Transform t(a.m, a.m);
    Point3f p = random_point(rng, false);
    Vector3f p_err;
    for (int k = 0; k < 3; ++k) p_err[k] = std::abs(p[k]) * std::ldexp(float(uniform(rng, 0, 1)), -int(rng.next_bounded(24)));
    Vector3f err;
    Point3f q = t.apply(p, p_err, &err);
    for (int trial = 0; trial < 4; ++trial) {
      ld pe[3];
      for (int k = 0; k < 3; ++k) {
        ld s = trial < 2 ? (rng.next_u32() & 1 ? 1 : -1) : ld(uniform(rng, -1, 1));
        pe[k] = ld(p[k]) + s * ld(p_err[k]);
      }
      for (int r = 0; r < 3; ++r)
        if (std::abs(ld(q[r]) - a.exact_row(r, pe)) > ld(err[r])) ++bad;
    }
  }
  CHECK(bad == 0);
}

TEST_CASE("Transform apply bounds the error of a vector transform", "[math][transform]") {
  PCG32 rng(8, 42);
  int bad = 0;
  for (int i = 0; i < kCases; ++i) {
    RandomAffine a = random_affine(rng);
    Transform t(a.m, a.m);
    Point3f p = random_point(rng, false);
    Vector3f v(p), err;
    Vector3f w = t.apply(v, &err);
    for (int r = 0; r < 3; ++r) {
      ld exact = ld(a.m.m[r][0]) * ld(v.x) + ld(a.m.m[r][1]) * ld(v.y) + ld(a.m.m[r][2]) * ld(v.z);
      if (std::abs(ld(w[r]) - exact) > ld(err[r])) ++bad;
    }
  }
  CHECK(bad == 0);
}

TEST_CASE("Transform of a singular matrix is not invertible", "[math][transform]") {
  Matrix4 singular;
  singular.m[2][2] = 0;
  CHECK_FALSE(Transform(singular).invertible());
  CHECK(Transform(Matrix4{}).invertible());
  CHECK(Transform(Matrix4{}).is_identity());
}

}  // namespace float_test
