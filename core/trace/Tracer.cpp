// The Embree 3 wrapper: one device, one scene, one triangle geometry over Scene's arrays.
#include "core/trace/Tracer.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "core/common/Check.h"
#include "core/common/Error.h"
#include "core/common/Tolerances.h"

namespace ps {

namespace {

const char* errorName(RTCError e) {
  switch (e) {
    case RTC_ERROR_NONE:
      return "no error";
    case RTC_ERROR_UNKNOWN:
      return "unknown error";
    case RTC_ERROR_INVALID_ARGUMENT:
      return "invalid argument";
    case RTC_ERROR_INVALID_OPERATION:
      return "invalid operation";
    case RTC_ERROR_OUT_OF_MEMORY:
      return "out of memory";
    case RTC_ERROR_UNSUPPORTED_CPU:
      return "unsupported CPU";
    case RTC_ERROR_CANCELLED:
      return "cancelled";
  }
  return "unrecognised error";
}

/// Embree takes floats; infinity stays infinity, finite values are rounded.
float toFloat(double x) {
  return static_cast<float>(x);
}

void fillRay(double ox, double oy, double oz, double dx, double dy, double dz, double tMin,
             double tMax, RTCRay& r) {
  r.org_x = toFloat(ox);
  r.org_y = toFloat(oy);
  r.org_z = toFloat(oz);
  r.dir_x = toFloat(dx);
  r.dir_y = toFloat(dy);
  r.dir_z = toFloat(dz);
  r.tnear = toFloat(tMin);
  r.tfar = tMax >= static_cast<double>(std::numeric_limits<float>::max())
               ? std::numeric_limits<float>::infinity()
               : toFloat(tMax);
  r.time = 0.0f;
  r.mask = 0xFFFFFFFFu;
  r.id = 0;
  r.flags = 0;
}

/// The ray and hit record of a closest-hit query, ready for Embree.
void fillRayHit(const Ray& ray, RTCRayHit& rh) {
  fillRay(ray.origin.x, ray.origin.y, ray.origin.z, ray.direction.x, ray.direction.y,
          ray.direction.z, ray.tMin, ray.tMax, rh.ray);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
}

/// Embree sets an occlusion ray's tfar to -inf when something is hit.
bool wasOccluded(const RTCRay& r) {
  return r.tfar < 0.0f && std::isinf(r.tfar);
}

/// Per-thread buffers of the stream calls (Embree wants 16-byte aligned records; RTCRayHit and
/// RTCRay are declared so, and std::vector honours it).
thread_local std::vector<RTCRayHit> tStreamHits;
thread_local std::vector<RTCRay> tStreamRays;

/// Embree intersection and occlusion filter for alphaMode MASK (glTF 3.9.4): a candidate hit on
/// a cut-out point (alpha < alphaCutoff) is rejected, so the ray passes through it. Installed
/// only when some material is a mask; called by Embree for every candidate hit.
void alphaMaskFilter(const RTCFilterFunctionNArguments* args) {
  const auto* scene = static_cast<const Scene*>(args->geometryUserPtr);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
    const float u = RTCHitN_u(args->hit, args->N, i);
    const float v = RTCHitN_v(args->hit, args->N, i);
    if (scene->isCutOutAt(prim, u, v)) args->valid[i] = 0;
  }
}

/// oppositeFaceAt(): the context Embree hands its filter (the Embree context first, so that
/// the filter's context pointer is this), and what the filter found.
struct OppositeContext {
  RTCIntersectContext context;
  const std::vector<Vec3>* faceNormals = nullptr;
  Vec3 normal;  ///< the hit triangle's
  uint32_t found = RTC_INVALID_GEOMETRY_ID;
};

/// Context filter of oppositeFaceAt(): notes the first candidate whose normal is opposite the
/// hit's and rejects every candidate, so that the traversal sees all of them in the ray's short
/// range. Embree calls it after the geometry's own (alpha mask) filter, so cut-out points are
/// not seen. Degenerate triangles (normal 0) are opposite nothing.
void oppositeFilter(const RTCFilterFunctionNArguments* args) {
  auto* c = reinterpret_cast<OppositeContext*>(args->context);
  for (unsigned i = 0; i < args->N; ++i) {
    if (args->valid[i] != -1) continue;
    const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
    if (c->found == RTC_INVALID_GEOMETRY_ID && prim < c->faceNormals->size() &&
        dot((*c->faceNormals)[prim], c->normal) < -0.999)
      c->found = prim;
    args->valid[i] = 0;
  }
}

}  // namespace

struct Tracer::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  /// Per triangle, the unit geometric normal from the counter-clockwise winding, computed in
  /// double once here instead of per hit; (0, 0, 0) for a degenerate triangle.
  std::vector<Vec3> faceNormals;

  /// The Hit of a finished closest-hit query along `direction`, or nothing on a miss.
  std::optional<Hit> hitOf(const RTCRayHit& rh, Vec3 direction) const {
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
    Hit hit;
    hit.t = rh.ray.tfar;
    hit.triangle = rh.hit.primID;
    hit.u = rh.hit.u;
    hit.v = rh.hit.v;
    const Vec3 n = faceNormals[hit.triangle];
    // A degenerate triangle Embree still reported: face the ray.
    hit.geometricNormal = n == Vec3{} ? normalize(-direction) : n;
    hit.frontFace = dot(direction, hit.geometricNormal) < 0;
    return hit;
  }

  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }

  void throwIfError(const char* what) const {
    const RTCError e = rtcGetDeviceError(device);
    if (e != RTC_ERROR_NONE)
      throw Error(std::string("Embree: ") + what + " failed: " + errorName(e));
  }
};

Tracer::Tracer(const Scene& scene) : scene_(scene), impl_(std::make_unique<Impl>()) {
  PS_CHECK_EQ(scene.indices.size() % 3, size_t{0});
  PS_CHECK_EQ(scene.positions.size() % 3, size_t{0});

  impl_->device = rtcNewDevice(nullptr);
  if (!impl_->device)
    throw Error(std::string("Embree: cannot create a device: ") +
                errorName(rtcGetDeviceError(nullptr)));
  impl_->scene = rtcNewScene(impl_->device);
  impl_->throwIfError("rtcNewScene");
  // The context filter serves oppositeFaceAt() only; other rays pass no filter.
  rtcSetSceneFlags(impl_->scene, RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);

  const size_t vertexCount = scene.vertexCount();
  const size_t triangleCount = scene.triangleCount();
  if (triangleCount > 0) {
    RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    impl_->throwIfError("rtcNewGeometry");
    // Copied (not shared) buffers: Embree needs 16 bytes of readable padding after a vertex
    // buffer, which a std::vector does not promise.
    auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), vertexCount));
    auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), triangleCount));
    if (!vertices || !indices) {
      rtcReleaseGeometry(geom);
      impl_->throwIfError("rtcSetNewGeometryBuffer");
      throw Error("Embree: rtcSetNewGeometryBuffer returned no buffer");
    }
    for (size_t i = 0; i < scene.positions.size(); ++i) vertices[i] = scene.positions[i];
    for (size_t i = 0; i < scene.indices.size(); ++i) {
      PS_CHECK_LT(static_cast<size_t>(scene.indices[i]), vertexCount);
      indices[i] = scene.indices[i];
    }
    bool anyMask = false;
    for (const Material& m : scene.materials) anyMask = anyMask || m.isCutOut();
    if (anyMask) {
      PS_CHECK_EQ(scene.triangleMaterial.size(), triangleCount);
      for (uint32_t m : scene.triangleMaterial) PS_CHECK_LT(size_t{m}, scene.materials.size());
      rtcSetGeometryUserData(geom, const_cast<Scene*>(&scene));
      rtcSetGeometryIntersectFilterFunction(geom, &alphaMaskFilter);
      rtcSetGeometryOccludedFilterFunction(geom, &alphaMaskFilter);
    }
    rtcCommitGeometry(geom);
    rtcAttachGeometry(impl_->scene, geom);
    rtcReleaseGeometry(geom);
  }
  rtcCommitScene(impl_->scene);
  impl_->throwIfError("rtcCommitScene");

  // Geometric normals in double (Embree's Ng has its own sign convention and float precision).
  impl_->faceNormals.resize(triangleCount);
  for (size_t t = 0; t < triangleCount; ++t) {
    const uint32_t* tri = &scene.indices[3 * t];
    const Vec3 p0 = scene.vertex(tri[0]), p1 = scene.vertex(tri[1]), p2 = scene.vertex(tri[2]);
    const Vec3 n = cross(p1 - p0, p2 - p0);
    const double len = length(n);
    impl_->faceNormals[t] = len > 0 ? n / len : Vec3{};
  }

  rayEpsilon_ = tol::kRayOffsetRelative * scene.bounds.diagonal() + tol::kRayOffsetAbsolute;
}

Tracer::~Tracer() = default;

std::optional<Hit> Tracer::intersect(double ox, double oy, double oz, double dx, double dy,
                                     double dz, double tMin, double tMax) const {
  if (rayLog_) rayLog_->push_back({Ray{{ox, oy, oz}, {dx, dy, dz}, tMin, tMax}, false});
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh;
  fillRayHit(Ray{{ox, oy, oz}, {dx, dy, dz}, tMin, tMax}, rh);
  rtcIntersect1(impl_->scene, &context, &rh);
  return impl_->hitOf(rh, Vec3{dx, dy, dz});
}

void Tracer::intersectStream(std::span<const Ray> rays, std::span<std::optional<Hit>> hits,
                             bool coherent) const {
  PS_CHECK_EQ(rays.size(), hits.size());
  if (rayLog_)
    for (const Ray& r : rays) rayLog_->push_back({r, false});
  std::vector<RTCRayHit>& buffer = tStreamHits;
  buffer.resize(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) fillRayHit(rays[i], buffer[i]);
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags =
      coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  rtcIntersect1M(impl_->scene, &context, buffer.data(), static_cast<unsigned>(buffer.size()),
                 sizeof(RTCRayHit));
  for (size_t i = 0; i < rays.size(); ++i) hits[i] = impl_->hitOf(buffer[i], rays[i].direction);
}

void Tracer::occludedStream(std::span<const Ray> rays, std::span<uint8_t> blocked,
                            bool coherent) const {
  PS_CHECK_EQ(rays.size(), blocked.size());
  if (rayLog_)
    for (const Ray& r : rays) rayLog_->push_back({r, true});
  std::vector<RTCRay>& buffer = tStreamRays;
  buffer.resize(rays.size());
  for (size_t i = 0; i < rays.size(); ++i) {
    const Ray& r = rays[i];
    fillRay(r.origin.x, r.origin.y, r.origin.z, r.direction.x, r.direction.y, r.direction.z, r.tMin,
            r.tMax, buffer[i]);
  }
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags =
      coherent ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
  rtcOccluded1M(impl_->scene, &context, buffer.data(), static_cast<unsigned>(buffer.size()),
                sizeof(RTCRay));
  for (size_t i = 0; i < rays.size(); ++i) blocked[i] = wasOccluded(buffer[i]) ? 1 : 0;
}

std::optional<uint32_t> Tracer::oppositeFaceAt(const Ray& ray, const Hit& hit,
                                               double halfWidth) const {
  OppositeContext c;
  rtcInitIntersectContext(&c.context);
  c.context.filter = &oppositeFilter;
  c.faceNormals = &impl_->faceNormals;
  c.normal = hit.geometricNormal;
  RTCRayHit rh;
  fillRayHit(Ray{ray.origin, ray.direction, std::max(0.0, hit.t - halfWidth), hit.t + halfWidth},
             rh);
  rtcIntersect1(impl_->scene, &c.context, &rh);
  if (c.found == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
  return c.found;
}

bool Tracer::occluded(double ox, double oy, double oz, double dx, double dy, double dz, double tMin,
                      double tMax) const {
  if (rayLog_) rayLog_->push_back({Ray{{ox, oy, oz}, {dx, dy, dz}, tMin, tMax}, true});
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay r;
  fillRay(ox, oy, oz, dx, dy, dz, tMin, tMax, r);
  rtcOccluded1(impl_->scene, &context, &r);
  return wasOccluded(r);
}

}  // namespace ps
