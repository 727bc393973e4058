// prism/math/interval.hpp — interval arithmetic with outward rounding.
// Each operation returns an interval that contains every exact result for
// operands inside its inputs (pbrt-v4 book, section 6.8.6).
#pragma once
#include <utility>
#include "prism/math/float.hpp"

namespace prism {

class Interval {
 public:
  Interval() = default;
  explicit Interval(float v) : m_lo(v), m_hi(v) {}
  Interval(float lo, float hi) : m_lo(std::min(lo, hi)), m_hi(std::max(lo, hi)) {}
  static Interval from_value_and_error(float v, float err) {
    if (err == 0) return Interval(v);
    return Interval(sub_round_down(v, err), add_round_up(v, err));
  }

  float lower() const { return m_lo; }
  float upper() const { return m_hi; }
  float midpoint() const { return (m_lo + m_hi) / 2; }
  float width() const { return m_hi - m_lo; }
  bool exactly(float v) const { return m_lo == v && m_hi == v; }
  bool contains(float v) const { return v >= m_lo && v <= m_hi; }
  explicit operator float() const { return midpoint(); }

  Interval operator-() const { return {-m_hi, -m_lo}; }
  Interval operator+(Interval i) const {
    return {add_round_down(m_lo, i.m_lo), add_round_up(m_hi, i.m_hi)};
  }
  Interval operator-(Interval i) const {
    return {sub_round_down(m_lo, i.m_hi), sub_round_up(m_hi, i.m_lo)};
  }
  Interval operator*(Interval i) const {
    float lp[4] = {mul_round_down(m_lo, i.m_lo), mul_round_down(m_hi, i.m_lo),
                   mul_round_down(m_lo, i.m_hi), mul_round_down(m_hi, i.m_hi)};
    float hp[4] = {mul_round_up(m_lo, i.m_lo), mul_round_up(m_hi, i.m_lo),
                   mul_round_up(m_lo, i.m_hi), mul_round_up(m_hi, i.m_hi)};
    return {std::min({lp[0], lp[1], lp[2], lp[3]}), std::max({hp[0], hp[1], hp[2], hp[3]})};
  }
  // Division by an interval that straddles zero gives the whole real line.
  Interval operator/(Interval i) const {
    if (i.contains(0)) return {-infinity, infinity};
    float lq[4] = {div_round_down(m_lo, i.m_lo), div_round_down(m_hi, i.m_lo),
                   div_round_down(m_lo, i.m_hi), div_round_down(m_hi, i.m_hi)};
    float hq[4] = {div_round_up(m_lo, i.m_lo), div_round_up(m_hi, i.m_lo),
                   div_round_up(m_lo, i.m_hi), div_round_up(m_hi, i.m_hi)};
    return {std::min({lq[0], lq[1], lq[2], lq[3]}), std::max({hq[0], hq[1], hq[2], hq[3]})};
  }
  Interval& operator+=(Interval i) { return *this = *this + i; }
  Interval& operator-=(Interval i) { return *this = *this - i; }
  Interval& operator*=(Interval i) { return *this = *this * i; }
  Interval& operator/=(Interval i) { return *this = *this / i; }
  friend Interval operator+(float f, Interval i) { return Interval(f) + i; }
  friend Interval operator-(float f, Interval i) { return Interval(f) - i; }
  friend Interval operator*(float f, Interval i) { return Interval(f) * i; }
  friend Interval operator/(float f, Interval i) { return Interval(f) / i; }
  Interval operator+(float f) const { return *this + Interval(f); }
  Interval operator-(float f) const { return *this - Interval(f); }
  Interval operator*(float f) const { return *this * Interval(f); }
  Interval operator/(float f) const { return *this / Interval(f); }

 private:
  float m_lo = 0, m_hi = 0;
};

inline Interval sqr(Interval i) {
  float alo = std::abs(i.lower()), ahi = std::abs(i.upper());
  if (alo > ahi) std::swap(alo, ahi);
  if (i.contains(0)) return {0.f, mul_round_up(ahi, ahi)};
  return {mul_round_down(alo, alo), mul_round_up(ahi, ahi)};
}
inline Interval sqrt(Interval i) {
  return {sqrt_round_down(std::max(0.f, i.lower())), sqrt_round_up(std::max(0.f, i.upper()))};
}
inline Interval abs(Interval i) {
  if (i.lower() >= 0) return i;
  if (i.upper() <= 0) return -i;
  return {0.f, std::max(-i.lower(), i.upper())};
}

}  // namespace prism
