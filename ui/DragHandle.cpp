#include "ui/DragHandle.h"

#include <QLineF>
#include <QPolygonF>
#include <algorithm>
#include <cmath>

namespace ps::ui {

QVector3D handleAxis(HandlePart part) {
  switch (part) {
    case HandlePart::AxisX:
    case HandlePart::PlaneYZ:
      return {1, 0, 0};
    case HandlePart::AxisY:
    case HandlePart::PlaneXZ:
      return {0, 1, 0};
    case HandlePart::AxisZ:
    case HandlePart::PlaneXY:
      return {0, 0, 1};
    case HandlePart::None:
      break;
  }
  return {};
}

std::optional<QVector3D> constrainedPoint(HandlePart part, QVector3D origin, const PickRay& ray) {
  const QVector3D a = handleAxis(part);
  if (a.isNull()) return std::nullopt;
  const QVector3D d = ray.direction;
  if (isPlane(part)) {
    const float dn = QVector3D::dotProduct(d, a);
    if (std::abs(dn) < 1e-4f) return std::nullopt;
    const float t = QVector3D::dotProduct(origin - ray.origin, a) / dn;
    if (t <= 0) return std::nullopt;
    return ray.origin + d * t;
  }
  // Closest points of the lines origin + s a and ray.origin + t d (a, d unit):
  // s = (b e - d0) / (1 - b^2) with b = a.d, d0 = a.w, e = d.w, w = origin - ray.origin.
  const QVector3D w = origin - ray.origin;
  const float b = QVector3D::dotProduct(a, d);
  const float denom = 1.0f - b * b;
  if (denom < 1e-6f) return std::nullopt;
  const float s = (b * QVector3D::dotProduct(d, w) - QVector3D::dotProduct(a, w)) / denom;
  return origin + a * s;
}

std::optional<QVector3D> dragDelta(HandlePart part, QVector3D origin, const PickRay& start,
                                   const PickRay& now) {
  const auto p0 = constrainedPoint(part, origin, start);
  const auto p1 = constrainedPoint(part, origin, now);
  if (!p0 || !p1) return std::nullopt;
  QVector3D delta = *p1 - *p0;
  const QVector3D a = handleAxis(part);
  // Remove the rounding that leaks into the constrained components.
  if (isPlane(part))
    delta -= a * QVector3D::dotProduct(delta, a);
  else
    delta = a * QVector3D::dotProduct(delta, a);
  return delta;
}

HandlePart pickHandle(QPointF cursor, QVector3D origin, float armMeters,
                      const std::function<std::optional<QPointF>(QVector3D)>& project,
                      float tolerancePx) {
  const QVector3D axes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  // Planes first: the square spanned by the two axes other than the normal.
  const HandlePart planes[3] = {HandlePart::PlaneYZ, HandlePart::PlaneXZ, HandlePart::PlaneXY};
  for (int n = 0; n < 3; ++n) {
    const QVector3D u = axes[(n + 1) % 3] * armMeters, v = axes[(n + 2) % 3] * armMeters;
    QPolygonF quad;
    for (const QVector3D& c : {origin + u * 0.2f + v * 0.2f, origin + u * 0.45f + v * 0.2f,
                               origin + u * 0.45f + v * 0.45f, origin + u * 0.2f + v * 0.45f}) {
      const auto p = project(c);
      if (!p) break;
      quad << *p;
    }
    if (quad.size() == 4 && quad.containsPoint(cursor, Qt::OddEvenFill)) return planes[n];
  }
  const auto o = project(origin);
  if (!o) return HandlePart::None;
  const HandlePart arms[3] = {HandlePart::AxisX, HandlePart::AxisY, HandlePart::AxisZ};
  HandlePart best = HandlePart::None;
  float bestDist = tolerancePx;
  for (int i = 0; i < 3; ++i) {
    const auto e = project(origin + axes[i] * armMeters);
    if (!e) continue;
    // Distance from the cursor to the projected segment o-e.
    const QPointF ab = *e - *o, ap = cursor - *o;
    const double len2 = QPointF::dotProduct(ab, ab);
    const double t = len2 > 0 ? std::clamp(QPointF::dotProduct(ap, ab) / len2, 0.0, 1.0) : 0.0;
    const float dist = float(QLineF(cursor, *o + ab * t).length());
    if (dist <= bestDist) {
      bestDist = dist;
      best = arms[i];
    }
  }
  return best;
}

}  // namespace ps::ui
