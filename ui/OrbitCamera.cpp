#include "ui/OrbitCamera.h"

#include <QtMath>
#include <algorithm>
#include <cmath>

namespace ps::ui {

QVector3D OrbitCamera::backward() const {
  const float yaw = qDegreesToRadians(yawDeg), pitch = qDegreesToRadians(pitchDeg);
  return QVector3D(std::cos(pitch) * std::sin(yaw), std::sin(pitch),
                   std::cos(pitch) * std::cos(yaw));
}

QVector3D OrbitCamera::right() const {
  const float yaw = qDegreesToRadians(yawDeg);
  return QVector3D(std::cos(yaw), 0.0f, -std::sin(yaw));
}

QVector3D OrbitCamera::up() const {
  return QVector3D::crossProduct(backward(), right());
}

QMatrix4x4 OrbitCamera::view() const {
  QMatrix4x4 m;
  m.lookAt(eye(), target, up());
  return m;
}

QMatrix4x4 OrbitCamera::projection(float aspect, float nearDist, float farDist) const {
  QMatrix4x4 m;
  m.perspective(fovYDeg, aspect, nearDist, farDist);
  return m;
}

void OrbitCamera::frame(const Bounds3& box, float aspect, float margin) {
  if (box.empty()) return;
  const Vec3 c = box.center();
  target = QVector3D(float(c.x), float(c.y), float(c.z));
  const QVector3D r = right(), u = up(), b = backward();
  const float tanY = std::tan(qDegreesToRadians(fovYDeg) * 0.5f) * margin;
  const float tanX = tanY * std::max(aspect, 1e-3f);
  QVector3D corners[8];
  for (int i = 0; i < 8; ++i)
    corners[i] = QVector3D((i & 1) ? box.hi.x : box.lo.x, (i & 2) ? box.hi.y : box.lo.y,
                           (i & 4) ? box.hi.z : box.lo.z);
  // A corner at camera-space (x, y, z) (z towards the eye) is at depth d - z; it is inside the
  // frustum when |x| <= (d - z) tanX and |y| <= (d - z) tanY. Fit the distance, then slide the
  // target in the view plane so the projected box is centred, and fit again.
  for (int pass = 0; pass < 4; ++pass) {
    float d = 0.0f;
    for (const QVector3D& p : corners) {
      const QVector3D o = p - target;
      const float x = QVector3D::dotProduct(o, r), y = QVector3D::dotProduct(o, u),
                  z = QVector3D::dotProduct(o, b);
      d = std::max({d, z + std::abs(x) / tanX, z + std::abs(y) / tanY});
    }
    distance = std::max(d, 1e-3f);
    float xMin = 1e30f, xMax = -1e30f, yMin = 1e30f, yMax = -1e30f;
    for (const QVector3D& p : corners) {
      const QVector3D o = p - target;
      const float depth = distance - QVector3D::dotProduct(o, b);
      const float x = QVector3D::dotProduct(o, r) / depth, y = QVector3D::dotProduct(o, u) / depth;
      xMin = std::min(xMin, x), xMax = std::max(xMax, x);
      yMin = std::min(yMin, y), yMax = std::max(yMax, y);
    }
    // Shift by the projected centre offset, measured at the target's depth.
    target += (r * (xMin + xMax) * 0.5f + u * (yMin + yMax) * 0.5f) * distance;
  }
}

void OrbitCamera::orbit(float dxPixels, float dyPixels) {
  yawDeg = std::fmod(yawDeg - dxPixels * 0.4f, 360.0f);
  pitchDeg = std::clamp(pitchDeg + dyPixels * 0.4f, -89.0f, 89.0f);
}

void OrbitCamera::pan(float dxPixels, float dyPixels, float viewportHeightPixels) {
  const float worldPerPixel = 2.0f * distance * std::tan(qDegreesToRadians(fovYDeg) * 0.5f) /
                              std::max(viewportHeightPixels, 1.0f);
  target += (-dxPixels * right() + dyPixels * up()) * worldPerPixel;
}

void OrbitCamera::zoom(float steps) {
  distance *= std::pow(0.85f, steps);
}

void OrbitCamera::lookAround(float dxPixels, float dyPixels) {
  const QVector3D e = eye();
  // The eye sees the target along -backward(); turning the view right moves the target right.
  yawDeg = std::fmod(yawDeg - dxPixels * 0.25f, 360.0f);
  pitchDeg = std::clamp(pitchDeg + dyPixels * 0.25f, -89.0f, 89.0f);
  target = e - backward() * distance;
}

void OrbitCamera::fly(float rightMeters, float upMeters, float forwardMeters) {
  target += right() * rightMeters + QVector3D(0, 1, 0) * upMeters - backward() * forwardMeters;
}

}  // namespace ps::ui
