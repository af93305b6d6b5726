#pragma once
// The one long-lived stateful object of the core: an RAII wrapper around an Embree 3 scene
// built over a Scene's triangles. Thread-safe for concurrent queries once constructed.
#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "core/math/Vec3.h"
#include "core/scene/Scene.h"

namespace ps {

struct Ray {
  Vec3 origin;
  Vec3 direction;  ///< need not be unit; t is in units of its length
  double tMin = 0;
  double tMax = std::numeric_limits<double>::infinity();
};

struct Hit {
  double t = 0;
  uint32_t triangle = 0;
  double u = 0, v = 0;    ///< barycentrics of vertices 1 and 2 of the triangle
  Vec3 geometricNormal;   ///< unit, world space, on the counter-clockwise (front) side
  bool frontFace = true;  ///< the ray arrived against geometricNormal
};

/// A ray as traced, for benchmarks that replay a stage's rays through bare Embree.
struct LoggedRay {
  Ray ray;
  bool occlusion = false;  ///< traced by occluded() (a shadow ray), else by intersect()
};

class Tracer {
 public:
  /// Builds the BVH. The scene must outlive the tracer.
  explicit Tracer(const Scene& scene);
  ~Tracer();
  Tracer(const Tracer&) = delete;
  Tracer& operator=(const Tracer&) = delete;

  /// Closest hit in (tMin, tMax), or nothing. Points cut out by an alphaMode MASK material
  /// (Scene::isCutOutAt) are not hit: rays pass through them (here and in occluded()).
  std::optional<Hit> intersect(const Ray& ray) const {
    return intersect(ray.origin.x, ray.origin.y, ray.origin.z, ray.direction.x, ray.direction.y,
                     ray.direction.z, ray.tMin, ray.tMax);
  }
  /// True when anything lies in (tMin, tMax).
  bool occluded(const Ray& ray) const {
    return occluded(ray.origin.x, ray.origin.y, ray.origin.z, ray.direction.x, ray.direction.y,
                    ray.direction.z, ray.tMin, ray.tMax);
  }

  /// Closest hits of many rays in one Embree stream call (rtcIntersect1M): hits[i] for rays[i]
  /// (the sizes must match), what intersect() gives each ray up to the last bits of Embree's
  /// packet kernels. `coherent`: the rays share an origin (a probe's first rays), and Embree
  /// gathers them into SIMD packets; else it traces them one by one. Thread-safe.
  void intersectStream(std::span<const Ray> rays, std::span<std::optional<Hit>> hits,
                       bool coherent) const;
  /// occluded() for many rays in one stream call (rtcOccluded1M): blocked[i] is 1 when something
  /// lies on rays[i] (the sizes must match). `coherent` as for intersectStream().
  void occludedStream(std::span<const Ray> rays, std::span<uint8_t> blocked, bool coherent) const;

  /// A triangle within `halfWidth` of `hit`'s distance along `ray` whose plane is the hit
  /// triangle's turned round (normals within about 2.6 degrees of opposite), or nothing. Where
  /// two solids share a face (two boxes stacked, a wall standing on a floor slab), or a sheet
  /// is made of two triangles back to back, two coincident triangles face opposite ways and
  /// intersect() reports either one; this finds the other. Faces that merely meet the hit
  /// triangle at an edge are not opposite, however near.
  std::optional<uint32_t> oppositeFaceAt(const Ray& ray, const Hit& hit, double halfWidth) const;

  /// Distance by which ray origins are offset from surfaces (scaled to the scene,
  /// tol::kRayOffsetRelative of the bounds diagonal).
  double rayEpsilon() const { return rayEpsilon_; }

  /// Benchmarks only: while set, every ray traced is appended to `log` (not thread-safe: trace
  /// from one thread while it is set). Null (off) by default.
  void setRayLog(std::vector<LoggedRay>* log) { rayLog_ = log; }
  const Scene& scene() const { return scene_; }

 private:
  // The ray as eight scalars, which the calling convention passes in registers: a Ray in
  // memory, written by the caller field by field and read back here in 16-byte pairs, stalls
  // on store forwarding (a measurable share of the capture's time).
  std::optional<Hit> intersect(double ox, double oy, double oz, double dx, double dy, double dz,
                               double tMin, double tMax) const;
  bool occluded(double ox, double oy, double oz, double dx, double dy, double dz, double tMin,
                double tMax) const;

  struct Impl;
  const Scene& scene_;
  std::unique_ptr<Impl> impl_;
  double rayEpsilon_ = 0;
  std::vector<LoggedRay>* rayLog_ = nullptr;
};

}  // namespace ps
