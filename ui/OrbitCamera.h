#pragma once
// An orbit camera around a target point: yaw about world +Y, pitch above the horizon, distance.
// World frame is the scene's (glTF +Y up, metres). Angles in degrees.
#include <QMatrix4x4>
#include <QVector3D>

#include "core/math/Vec3.h"

namespace ps::ui {

struct OrbitCamera {
  QVector3D target;
  float distance = 5.0f;
  float yawDeg = 35.0f;    ///< rotation of the eye about +Y, 0 = on +Z looking towards -Z
  float pitchDeg = 50.0f;  ///< elevation of the eye above the target, 90 = straight down
  float fovYDeg = 40.0f;

  /// Unit vector from the target towards the eye.
  QVector3D backward() const;
  QVector3D eye() const { return target + backward() * distance; }
  QVector3D right() const;
  QVector3D up() const;
  QMatrix4x4 view() const;
  QMatrix4x4 projection(float aspect, float nearDist, float farDist) const;

  /// Keeps the angles and places the target and distance so that the box fills the view
  /// (all 8 corners inside, with a small margin) for the given width / height aspect.
  void frame(const Bounds3& box, float aspect, float margin = 0.9f);
  /// Rotates by pixel deltas (0.4 deg per pixel); pitch stays in [-89, 89].
  void orbit(float dxPixels, float dyPixels);
  /// Moves the target in the view plane so the point under the cursor follows it.
  void pan(float dxPixels, float dyPixels, float viewportHeightPixels);
  /// Wheel steps (positive = closer).
  void zoom(float steps);
  /// Turns the view by pixel deltas like orbit() but about the eye, which stays in place (fly
  /// mode mouse look).
  void lookAround(float dxPixels, float dyPixels);
  /// Moves eye and target together by `right`, `up` (world +Y) and `forward` metres, forward
  /// being the view direction.
  void fly(float rightMeters, float upMeters, float forwardMeters);
};

}  // namespace ps::ui
