#pragma once
// The move handle ("gizmo") of the viewport: three axis arrows and three plane squares at the
// selection's centre. A drag is constrained to the picked axis or plane: the probes follow the
// point of the constraint under the cursor. Pure geometry, tested without GL.
#include <QPointF>
#include <QVector3D>
#include <array>
#include <functional>
#include <optional>

namespace ps::ui {

enum class HandlePart { None, AxisX, AxisY, AxisZ, PlaneYZ, PlaneXZ, PlaneXY };

struct PickRay {
  QVector3D origin;
  QVector3D direction;  ///< unit
};

/// Unit world axis of an axis part, or the normal of a plane part (zero for None).
QVector3D handleAxis(HandlePart part);
inline bool isPlane(HandlePart p) {
  return p == HandlePart::PlaneYZ || p == HandlePart::PlaneXZ || p == HandlePart::PlaneXY;
}

/// The point of the constraint through `origin` that the ray designates: for an axis, the point
/// of the axis line closest to the ray; for a plane, where the ray meets it. Nothing when the
/// ray is (nearly) parallel to the axis or to the plane, or the plane is behind the ray.
std::optional<QVector3D> constrainedPoint(HandlePart part, QVector3D origin, const PickRay& ray);

/// Displacement of a drag from `start` to `now` under the constraint (zero in the constrained
/// components: an axis drag moves along that axis only, a plane drag keeps the normal component).
std::optional<QVector3D> dragDelta(HandlePart part, QVector3D origin, const PickRay& start,
                                   const PickRay& now);

/// The handle part under the widget pixel `cursor`, given `project` (world -> widget pixel, or
/// nothing behind the camera), the handle's origin and its arm length in metres. Plane squares
/// (from 0.2 to 0.45 of the arm along their two axes) win over arms (within `tolerancePx` of
/// the projected arm).
HandlePart pickHandle(QPointF cursor, QVector3D origin, float armMeters,
                      const std::function<std::optional<QPointF>(QVector3D)>& project,
                      float tolerancePx = 7.0f);

}  // namespace ps::ui
