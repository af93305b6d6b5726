#pragma once
// Small value types passed by value (after pbrt-v4): Vec3 for positions and directions in
// metres (world frame, glTF +Y up), Rgb for linear radiometric colours, Bounds3 for boxes.
#include <algorithm>
#include <cmath>
#include <limits>
#include <ostream>

namespace ps {

struct Vec3 {
  double x = 0, y = 0, z = 0;
  constexpr Vec3() = default;
  constexpr Vec3(double x_, double y_, double z_) : x(x_), y(y_), z(z_) {}
  constexpr double operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr double& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr Vec3 operator+(Vec3 b) const { return {x + b.x, y + b.y, z + b.z}; }
  constexpr Vec3 operator-(Vec3 b) const { return {x - b.x, y - b.y, z - b.z}; }
  constexpr Vec3 operator-() const { return {-x, -y, -z}; }
  constexpr Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
  constexpr Vec3 operator/(double s) const { return {x / s, y / s, z / s}; }
  constexpr Vec3& operator+=(Vec3 b) {
    x += b.x;
    y += b.y;
    z += b.z;
    return *this;
  }
  constexpr Vec3& operator-=(Vec3 b) {
    x -= b.x;
    y -= b.y;
    z -= b.z;
    return *this;
  }
  constexpr Vec3& operator*=(double s) {
    x *= s;
    y *= s;
    z *= s;
    return *this;
  }
  constexpr bool operator==(const Vec3&) const = default;
};
constexpr Vec3 operator*(double s, Vec3 v) {
  return v * s;
}
constexpr double dot(Vec3 a, Vec3 b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
constexpr Vec3 cross(Vec3 a, Vec3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double length(Vec3 v) {
  return std::sqrt(dot(v, v));
}
inline Vec3 normalize(Vec3 v) {
  return v / length(v);
}
constexpr Vec3 min(Vec3 a, Vec3 b) {
  return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)};
}
constexpr Vec3 max(Vec3 a, Vec3 b) {
  return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)};
}
inline bool isFinite(Vec3 v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}
inline std::ostream& operator<<(std::ostream& os, Vec3 v) {
  return os << '[' << v.x << ", " << v.y << ", " << v.z << ']';
}

/// Builds an orthonormal basis (t, b) around the unit vector n (Duff et al. 2017).
inline void orthonormalBasis(Vec3 n, Vec3& t, Vec3& b) {
  const double sign = std::copysign(1.0, n.z);
  const double a = -1.0 / (sign + n.z);
  const double c = n.x * n.y * a;
  t = {1.0 + sign * n.x * n.x * a, sign * c, -sign * n.x};
  b = {c, sign + n.y * n.y * a, -n.y};
}

struct Rgb {
  double r = 0, g = 0, b = 0;
  constexpr Rgb() = default;
  constexpr Rgb(double r_, double g_, double b_) : r(r_), g(g_), b(b_) {}
  constexpr double operator[](int i) const { return i == 0 ? r : (i == 1 ? g : b); }
  constexpr double& operator[](int i) { return i == 0 ? r : (i == 1 ? g : b); }
  constexpr Rgb operator+(Rgb o) const { return {r + o.r, g + o.g, b + o.b}; }
  constexpr Rgb operator-(Rgb o) const { return {r - o.r, g - o.g, b - o.b}; }
  constexpr Rgb operator*(Rgb o) const { return {r * o.r, g * o.g, b * o.b}; }
  constexpr Rgb operator*(double s) const { return {r * s, g * s, b * s}; }
  constexpr Rgb operator/(double s) const { return {r / s, g / s, b / s}; }
  constexpr Rgb& operator+=(Rgb o) {
    r += o.r;
    g += o.g;
    b += o.b;
    return *this;
  }
  constexpr Rgb& operator*=(double s) {
    r *= s;
    g *= s;
    b *= s;
    return *this;
  }
  constexpr bool operator==(const Rgb&) const = default;
  constexpr bool isBlack() const { return r == 0 && g == 0 && b == 0; }
  constexpr double maxComponent() const { return std::max(r, std::max(g, b)); }
};
constexpr Rgb operator*(double s, Rgb c) {
  return c * s;
}
/// Rec. 709 / sRGB-primaries luminance of a linear colour.
constexpr double luminance(Rgb c) {
  return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b;
}
inline std::ostream& operator<<(std::ostream& os, Rgb c) {
  return os << '[' << c.r << ", " << c.g << ", " << c.b << ']';
}

/// Axis-aligned box; empty (lo > hi) when default-constructed.
struct Bounds3 {
  Vec3 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
          std::numeric_limits<double>::infinity()};
  Vec3 hi{-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity(),
          -std::numeric_limits<double>::infinity()};
  bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  void extend(Vec3 p) {
    lo = min(lo, p);
    hi = max(hi, p);
  }
  Vec3 extent() const { return hi - lo; }
  Vec3 center() const { return (lo + hi) * 0.5; }
  double diagonal() const { return empty() ? 0.0 : length(hi - lo); }
  /// 0 for an empty box (and along an axis whose extent is NaN).
  double volume() const {
    const Vec3 e = hi - lo;
    return empty() ? 0.0 : std::max(0.0, e.x) * std::max(0.0, e.y) * std::max(0.0, e.z);
  }
  bool contains(Vec3 p) const {
    return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z;
  }
};

inline constexpr double kPi = 3.14159265358979323846;

}  // namespace ps
