// prism/math/float.hpp — floating-point utilities for conservative error bounds.
// Reference: pbrt-v4 book, section 6.8 ("Managing Rounding Error"). Every bound in
// prism is built from gamma(n) and next_float_up/down; there is no tuned epsilon.
#pragma once
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <algorithm>

namespace prism {

using Float = float;

inline constexpr Float pi = 3.14159265358979323846f;
inline constexpr Float inv_pi = 0.31830988618379067154f;
inline constexpr Float inv_2pi = 0.15915494309189533577f;
inline constexpr Float inv_4pi = 0.07957747154594766788f;
inline constexpr Float pi_over_2 = 1.57079632679489661923f;
inline constexpr Float pi_over_4 = 0.78539816339744830961f;
inline constexpr Float infinity = std::numeric_limits<Float>::infinity();
// Half an ulp at 1: the unit roundoff of IEEE single precision.
inline constexpr Float machine_epsilon = std::numeric_limits<Float>::epsilon() * 0.5f;
inline constexpr Float one_minus_epsilon = 0x1.fffffep-1f;

// gamma(n) = n u / (1 - n u) bounds the relative error of n chained roundings
// (Higham 2002, section 3.1; pbrt-v4 eq. 6.20).
constexpr Float gamma(int n) {
  return (Float(n) * machine_epsilon) / (1 - Float(n) * machine_epsilon);
}

// gamma(n) of double precision: bounds n chained roundings of doubles (the
// double-precision fallbacks of the sphere and triangle tests).
constexpr double gamma_double(int n) {
  constexpr double u = std::numeric_limits<double>::epsilon() * 0.5;
  return (n * u) / (1 - n * u);
}

// The next representable float above v (v itself for +inf); -0 steps to the
// smallest positive denormal.
inline float next_float_up(float v) {
  if (std::isinf(v) && v > 0.f) return v;
  if (v == -0.f) v = 0.f;
  uint32_t bits = std::bit_cast<uint32_t>(v);
  bits = v >= 0 ? bits + 1 : bits - 1;
  return std::bit_cast<float>(bits);
}
inline float next_float_down(float v) {
  if (std::isinf(v) && v < 0.f) return v;
  if (v == 0.f) v = -0.f;
  uint32_t bits = std::bit_cast<uint32_t>(v);
  bits = v > 0 ? bits - 1 : bits + 1;
  return std::bit_cast<float>(bits);
}
inline double next_float_up(double v) {
  if (std::isinf(v) && v > 0.) return v;
  if (v == -0.) v = 0.;
  uint64_t bits = std::bit_cast<uint64_t>(v);
  bits = v >= 0 ? bits + 1 : bits - 1;
  return std::bit_cast<double>(bits);
}
inline double next_float_down(double v) {
  if (std::isinf(v) && v < 0.) return v;
  if (v == 0.) v = -0.;
  uint64_t bits = std::bit_cast<uint64_t>(v);
  bits = v > 0 ? bits - 1 : bits + 1;
  return std::bit_cast<double>(bits);
}

// Directed-rounding arithmetic emulated by stepping one ulp outwards from the
// round-to-nearest result: the true result lies within half an ulp of it.
inline float add_round_up(float a, float b) { return next_float_up(a + b); }
inline float add_round_down(float a, float b) { return next_float_down(a + b); }
inline float sub_round_up(float a, float b) { return add_round_up(a, -b); }
inline float sub_round_down(float a, float b) { return add_round_down(a, -b); }
inline float mul_round_up(float a, float b) { return next_float_up(a * b); }
inline float mul_round_down(float a, float b) { return next_float_down(a * b); }
inline float div_round_up(float a, float b) { return next_float_up(a / b); }
inline float div_round_down(float a, float b) { return next_float_down(a / b); }
inline float sqrt_round_up(float a) { return next_float_up(std::sqrt(a)); }
inline float sqrt_round_down(float a) { return std::max(0.f, next_float_down(std::sqrt(a))); }

template <class T> constexpr T sqr(T v) { return v * v; }
template <class T> constexpr T lerp(Float t, T a, T b) { return (1 - t) * a + t * b; }
inline Float safe_sqrt(Float x) { return std::sqrt(std::max(Float(0), x)); }
inline Float safe_asin(Float x) { return std::asin(std::clamp(x, Float(-1), Float(1))); }
inline Float safe_acos(Float x) { return std::acos(std::clamp(x, Float(-1), Float(1))); }
constexpr Float radians(Float deg) { return (pi / 180) * deg; }
constexpr Float degrees(Float rad) { return (180 / pi) * rad; }

// PRISM_FAST_FMAF: std::fma on floats compiles to one instruction. <cmath>
// says so with FP_FAST_FMAF under GCC; clang does not define it (version 14
// with -march=native on an FMA machine), so the target's own FMA macros count
// too (x86 __FMA__, Arm __ARM_FEATURE_FMA).
#if defined(FP_FAST_FMAF) || defined(__FMA__) || defined(__ARM_FEATURE_FMA)
#define PRISM_FAST_FMAF 1
#endif

// PRISM_AVX512_ZMM: the compiler may use 512-bit AVX-512 registers:
// __AVX512F__, unless it has the AVX10 notion of AVX-512 limited to 256 bits
// (GCC 14 and clang 18 define __EVEX512__ when 512-bit registers are allowed;
// older ones always allow them). The triangle packets and the BVH's nodes
// take 16 lanes then.
#if defined(__AVX512F__) &&                                                                   \
    (defined(__EVEX512__) || (defined(__clang__) && __clang_major__ < 18) ||                  \
     (defined(__GNUC__) && !defined(__clang__) && __GNUC__ < 14))
#define PRISM_AVX512_ZMM 1
#endif

// a*b - c*d and a*b + c*d, accurate to within 1.5 ulp, with the exact sign.
// With a hardware FMA (PRISM_FAST_FMAF): Kahan's algorithm, two FMAs. Without
// one, where std::fma is a slow library call: in double, where the product of
// two floats is exact, so the result is the exact value rounded to double and
// then to float (within about half an ulp); it is zero exactly when the exact
// value is (unless that underflows in float).
#if defined(PRISM_FAST_FMAF)
inline Float difference_of_products(Float a, Float b, Float c, Float d) {
  Float cd = c * d;
  Float diff = std::fma(a, b, -cd);
  Float err = std::fma(-c, d, cd);
  return diff + err;
}
inline Float sum_of_products(Float a, Float b, Float c, Float d) {
  Float cd = c * d;
  Float sum = std::fma(a, b, cd);
  Float err = std::fma(c, d, -cd);
  return sum + err;
}
#else
inline Float difference_of_products(Float a, Float b, Float c, Float d) {
  return Float(double(a) * double(b) - double(c) * double(d));
}
inline Float sum_of_products(Float a, Float b, Float c, Float d) {
  return Float(double(a) * double(b) + double(c) * double(d));
}
#endif

}  // namespace prism
