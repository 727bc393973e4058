// prism/math/vector.hpp — Vector3, Point3 and Normal3 as distinct types, so that a
// point transformed as a vector (or a normal as a point) fails to compile.
// Shared arithmetic lives in the CRTP base Tuple3; only meaningful mixed
// operations (point - point = vector, point + vector = point, ...) exist.
#pragma once
#include <cassert>
#include <cmath>
#include <type_traits>
#include "prism/math/float.hpp"

namespace prism {

template <template <class> class Child, class T>
struct Tuple3 {
  T x{}, y{}, z{};
  constexpr Tuple3() = default;
  constexpr Tuple3(T x_, T y_, T z_) : x(x_), y(y_), z(z_) {}

  constexpr T operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr T& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr Child<T> operator*(T s) const { return {x * s, y * s, z * s}; }
  constexpr Child<T> operator/(T s) const { T inv = T(1) / s; return {x * inv, y * inv, z * inv}; }
  constexpr Child<T> operator-() const { return {-x, -y, -z}; }
  constexpr Child<T>& operator*=(T s) { x *= s; y *= s; z *= s; return self(); }
  constexpr Child<T>& operator/=(T s) { return self() = self() / s; }
  friend constexpr Child<T> operator*(T s, const Child<T>& v) { return v * s; }
  constexpr bool operator==(const Tuple3&) const = default;
  bool has_nan() const { return std::isnan(x) || std::isnan(y) || std::isnan(z); }

 private:
  constexpr Child<T>& self() { return static_cast<Child<T>&>(*this); }
};

template <class T> struct Vector3;
template <class T> struct Point3;
template <class T> struct Normal3;

template <class T>
struct Vector3 : Tuple3<Vector3, T> {
  using Tuple3<Vector3, T>::Tuple3;
  using Tuple3<Vector3, T>::operator-;
  constexpr Vector3() = default;
  template <class U> explicit constexpr Vector3(const Point3<U>& p) : Tuple3<Vector3, T>(T(p.x), T(p.y), T(p.z)) {}
  template <class U> explicit constexpr Vector3(const Normal3<U>& n) : Tuple3<Vector3, T>(T(n.x), T(n.y), T(n.z)) {}
  template <class U> explicit constexpr Vector3(const Vector3<U>& v) : Tuple3<Vector3, T>(T(v.x), T(v.y), T(v.z)) {}
  constexpr Vector3 operator+(const Vector3& v) const { return {this->x + v.x, this->y + v.y, this->z + v.z}; }
  constexpr Vector3 operator-(const Vector3& v) const { return {this->x - v.x, this->y - v.y, this->z - v.z}; }
  constexpr Vector3& operator+=(const Vector3& v) { this->x += v.x; this->y += v.y; this->z += v.z; return *this; }
  constexpr Vector3& operator-=(const Vector3& v) { this->x -= v.x; this->y -= v.y; this->z -= v.z; return *this; }
};

template <class T>
struct Point3 : Tuple3<Point3, T> {
  using Tuple3<Point3, T>::Tuple3;
  using Tuple3<Point3, T>::operator-;
  constexpr Point3() = default;
  template <class U> explicit constexpr Point3(const Vector3<U>& v) : Tuple3<Point3, T>(T(v.x), T(v.y), T(v.z)) {}
  template <class U> explicit constexpr Point3(const Point3<U>& p) : Tuple3<Point3, T>(T(p.x), T(p.y), T(p.z)) {}
  constexpr Point3 operator+(const Vector3<T>& v) const { return {this->x + v.x, this->y + v.y, this->z + v.z}; }
  constexpr Point3 operator-(const Vector3<T>& v) const { return {this->x - v.x, this->y - v.y, this->z - v.z}; }
  constexpr Vector3<T> operator-(const Point3& p) const { return {this->x - p.x, this->y - p.y, this->z - p.z}; }
  constexpr Point3& operator+=(const Vector3<T>& v) { this->x += v.x; this->y += v.y; this->z += v.z; return *this; }
  // Weighted sums of points (barycentric interpolation) need point + point.
  constexpr Point3 operator+(const Point3& p) const { return {this->x + p.x, this->y + p.y, this->z + p.z}; }
};

template <class T>
struct Normal3 : Tuple3<Normal3, T> {
  using Tuple3<Normal3, T>::Tuple3;
  using Tuple3<Normal3, T>::operator-;
  constexpr Normal3() = default;
  template <class U> explicit constexpr Normal3(const Vector3<U>& v) : Tuple3<Normal3, T>(T(v.x), T(v.y), T(v.z)) {}
  constexpr Normal3 operator+(const Normal3& n) const { return {this->x + n.x, this->y + n.y, this->z + n.z}; }
  constexpr Normal3 operator-(const Normal3& n) const { return {this->x - n.x, this->y - n.y, this->z - n.z}; }
  constexpr Normal3& operator+=(const Normal3& n) { this->x += n.x; this->y += n.y; this->z += n.z; return *this; }
};

template <class T>
struct Point2 {
  T x{}, y{};
  constexpr T operator[](int i) const { return i == 0 ? x : y; }
  constexpr T& operator[](int i) { return i == 0 ? x : y; }
  constexpr Point2 operator+(const Point2& p) const { return {x + p.x, y + p.y}; }
  constexpr Point2 operator-(const Point2& p) const { return {x - p.x, y - p.y}; }
  constexpr Point2 operator*(T s) const { return {x * s, y * s}; }
  friend constexpr Point2 operator*(T s, const Point2& p) { return p * s; }
  constexpr bool operator==(const Point2&) const = default;
};

using Vector3f = Vector3<Float>;
using Point3f = Point3<Float>;
using Normal3f = Normal3<Float>;
using Point2f = Point2<Float>;
using Point2i = Point2<int>;

// Free functions on any of the three 3-tuples.
template <template <class> class C, class T> constexpr T hsum(const Tuple3<C, T>& a) { return a.x + a.y + a.z; }
template <template <class> class C, class T> C<T> abs(const Tuple3<C, T>& a) { return {std::abs(a.x), std::abs(a.y), std::abs(a.z)}; }
template <template <class> class C, class T> constexpr C<T> min(const Tuple3<C, T>& a, const Tuple3<C, T>& b) {
  return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)};
}
template <template <class> class C, class T> constexpr C<T> max(const Tuple3<C, T>& a, const Tuple3<C, T>& b) {
  return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)};
}
template <template <class> class C, class T> constexpr T max_component(const Tuple3<C, T>& a) { return std::max({a.x, a.y, a.z}); }
template <template <class> class C, class T> constexpr int max_dimension(const Tuple3<C, T>& a) {
  return a.x > a.y ? (a.x > a.z ? 0 : 2) : (a.y > a.z ? 1 : 2);
}
template <template <class> class C, class T> constexpr C<T> permute(const Tuple3<C, T>& a, int i, int j, int k) { return {a[i], a[j], a[k]}; }
template <template <class> class C, class T> constexpr C<T> hmul(const Tuple3<C, T>& a, const Tuple3<C, T>& b) {
  return {a.x * b.x, a.y * b.y, a.z * b.z};
}

// dot/cross accept any mix of vectors and normals.
template <template <class> class A, template <class> class B, class T>
  requires(!std::is_same_v<A<T>, Point3<T>> && !std::is_same_v<B<T>, Point3<T>>)
constexpr T dot(const Tuple3<A, T>& a, const Tuple3<B, T>& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
template <template <class> class A, template <class> class B, class T>
  requires(!std::is_same_v<A<T>, Point3<T>> && !std::is_same_v<B<T>, Point3<T>>)
T abs_dot(const Tuple3<A, T>& a, const Tuple3<B, T>& b) { return std::abs(dot(a, b)); }

// Cross product with FMA-based difference of products: accurate for nearly parallel inputs.
template <template <class> class A, template <class> class B>
Vector3f cross(const Tuple3<A, Float>& a, const Tuple3<B, Float>& b) {
  return {difference_of_products(a.y, b.z, a.z, b.y), difference_of_products(a.z, b.x, a.x, b.z),
          difference_of_products(a.x, b.y, a.y, b.x)};
}
template <template <class> class A>
  requires(!std::is_same_v<A<Float>, Point3<Float>>)
Float length_squared(const Tuple3<A, Float>& v) { return dot(v, v); }
template <template <class> class A>
  requires(!std::is_same_v<A<Float>, Point3<Float>>)
Float length(const Tuple3<A, Float>& v) { return std::sqrt(length_squared(v)); }
template <template <class> class A>
  requires(!std::is_same_v<A<Float>, Point3<Float>>)
A<Float> normalize(const Tuple3<A, Float>& v) { return static_cast<const A<Float>&>(v) / length(v); }

inline Float distance(const Point3f& a, const Point3f& b) { return length(a - b); }
inline Float distance_squared(const Point3f& a, const Point3f& b) { return length_squared(a - b); }

// Flip v to the hemisphere of n.
template <template <class> class A, template <class> class B>
A<Float> face_forward(const Tuple3<A, Float>& v, const Tuple3<B, Float>& n) {
  const auto& vv = static_cast<const A<Float>&>(v);
  return dot(v, n) < 0 ? -vv : vv;
}

// Spherical coordinates: theta from +z, phi from +x towards +y.
inline Vector3f spherical_direction(Float sin_theta, Float cos_theta, Float phi) {
  Float s = std::clamp(sin_theta, Float(-1), Float(1));
  return {s * std::cos(phi), s * std::sin(phi), std::clamp(cos_theta, Float(-1), Float(1))};
}

}  // namespace prism
