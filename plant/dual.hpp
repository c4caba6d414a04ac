#pragma once
// Forward-mode dual numbers for the Lagrangian path.
//
// Dual<T> is a + b·ε with ε² = 0. One level gives first derivatives along a
// seeded direction; nesting gives mixed higher derivatives: in
// Dual<Dual<double>> x = x.v.v + x.v.d·ε1 + x.d.v·ε2 + x.d.d·ε1ε2, so seeding
// two inputs with ε1 and ε2 returns ∂²f/∂a∂b in x.d.d. Energies written as
// templates over the scalar type work unchanged with double and every Dual.

#include <cmath>

namespace lagrange {

template <class T>
struct Dual {
  T v{};  // value
  T d{};  // derivative along the seeded direction

  constexpr Dual() = default;
  constexpr Dual(double value) : v(value), d(0.0) {}  // NOLINT: constants mix freely
  constexpr Dual(T value, T derivative) : v(value), d(derivative) {}
};

using Dual1 = Dual<double>;
using Dual2 = Dual<Dual1>;
using Dual3 = Dual<Dual2>;

template <class T>
constexpr Dual<T> operator-(const Dual<T>& a) {
  return {-a.v, -a.d};
}

template <class T>
constexpr Dual<T> operator+(const Dual<T>& a, const Dual<T>& b) {
  return {a.v + b.v, a.d + b.d};
}
template <class T>
constexpr Dual<T> operator-(const Dual<T>& a, const Dual<T>& b) {
  return {a.v - b.v, a.d - b.d};
}
template <class T>
constexpr Dual<T> operator*(const Dual<T>& a, const Dual<T>& b) {
  return {a.v * b.v, a.v * b.d + a.d * b.v};
}
template <class T>
constexpr Dual<T> operator/(const Dual<T>& a, const Dual<T>& b) {
  const T inv = 1.0 / b.v;
  return {a.v * inv, (a.d - a.v * inv * b.d) * inv};
}

template <class T>
constexpr Dual<T> operator+(const Dual<T>& a, double s) {
  return {a.v + s, a.d};
}
template <class T>
constexpr Dual<T> operator+(double s, const Dual<T>& a) {
  return {s + a.v, a.d};
}
template <class T>
constexpr Dual<T> operator-(const Dual<T>& a, double s) {
  return {a.v - s, a.d};
}
template <class T>
constexpr Dual<T> operator-(double s, const Dual<T>& a) {
  return {s - a.v, -a.d};
}
template <class T>
constexpr Dual<T> operator*(const Dual<T>& a, double s) {
  return {a.v * s, a.d * s};
}
template <class T>
constexpr Dual<T> operator*(double s, const Dual<T>& a) {
  return {s * a.v, s * a.d};
}
template <class T>
constexpr Dual<T> operator/(const Dual<T>& a, double s) {
  return {a.v / s, a.d / s};
}
template <class T>
constexpr Dual<T> operator/(double s, const Dual<T>& a) {
  return Dual<T>(s) / a;
}

template <class T>
constexpr Dual<T>& operator+=(Dual<T>& a, const Dual<T>& b) {
  return a = a + b;
}
template <class T>
constexpr Dual<T>& operator-=(Dual<T>& a, const Dual<T>& b) {
  return a = a - b;
}
template <class T>
constexpr Dual<T>& operator*=(Dual<T>& a, const Dual<T>& b) {
  return a = a * b;
}
template <class T>
constexpr Dual<T>& operator+=(Dual<T>& a, double s) {
  return a = a + s;
}
template <class T>
constexpr Dual<T>& operator*=(Dual<T>& a, double s) {
  return a = a * s;
}

template <class T>
Dual<T> sin(const Dual<T>& a) {
  using std::cos;
  using std::sin;
  return {sin(a.v), cos(a.v) * a.d};
}
template <class T>
Dual<T> cos(const Dual<T>& a) {
  using std::cos;
  using std::sin;
  return {cos(a.v), -(sin(a.v) * a.d)};
}
template <class T>
Dual<T> sqrt(const Dual<T>& a) {
  using std::sqrt;
  const T r = sqrt(a.v);
  return {r, a.d / (2.0 * r)};
}

}  // namespace lagrange
