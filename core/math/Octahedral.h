#pragma once
// Octahedral maps of the unit sphere (Cigolle et al. 2014, "A Survey of Efficient
// Representations for Independent Unit Vectors", JCGT 3(2), sec. 3.3), as DDGI stores its
// per-probe distances (Majercik et al. 2019, "Dynamic Diffuse Global Illumination with
// Ray-Traced Irradiance Probes", JCGT 8(2), sec. 4). A direction maps to (u, v) in [-1, 1]^2;
// an R x R map has texel (i, j) over [-1 + 2 i / R, -1 + 2 (i + 1) / R] in u and likewise in v,
// stored at index i + R j. The runtime reader (core/runtime/ps_volume_reader.h) repeats these
// formulas operation for operation.
#include <algorithm>
#include <cmath>

#include "core/math/Vec3.h"

namespace ps {

struct OctUv {
  double u = 0, v = 0;
};

/// The octahedral coordinates of unit direction d, in [-1, 1]^2. The lower hemisphere (z < 0)
/// folds onto the corners.
inline OctUv octEncode(Vec3 d) {
  const double s = std::abs(d.x) + std::abs(d.y) + std::abs(d.z);
  double u = d.x / s, v = d.y / s;
  if (d.z < 0) {
    const double fu = (1.0 - std::abs(v)) * (u >= 0 ? 1.0 : -1.0);
    const double fv = (1.0 - std::abs(u)) * (v >= 0 ? 1.0 : -1.0);
    u = fu;
    v = fv;
  }
  return {std::clamp(u, -1.0, 1.0), std::clamp(v, -1.0, 1.0)};
}

/// The unit direction of octahedral coordinates (u, v) in [-1, 1]^2 (inverse of octEncode).
inline Vec3 octDecode(double u, double v) {
  Vec3 d{u, v, 1.0 - std::abs(u) - std::abs(v)};
  if (d.z < 0) {
    const double fx = (1.0 - std::abs(v)) * (u >= 0 ? 1.0 : -1.0);
    const double fy = (1.0 - std::abs(u)) * (v >= 0 ? 1.0 : -1.0);
    d.x = fx;
    d.y = fy;
  }
  return normalize(d);
}

/// The texel of an R x R map holding unit direction d: its index i + R j.
inline int octTexel(Vec3 d, int R) {
  const OctUv o = octEncode(d);
  const int i = std::min(R - 1, static_cast<int>((o.u + 1.0) * 0.5 * R));
  const int j = std::min(R - 1, static_cast<int>((o.v + 1.0) * 0.5 * R));
  return i + R * j;
}

/// The direction at the centre of texel (i, j) of an R x R map.
inline Vec3 octTexelDirection(int i, int j, int R) {
  return octDecode(-1.0 + (2.0 * i + 1.0) / R, -1.0 + (2.0 * j + 1.0) / R);
}

/// Texel (i, j) of an R x R map for i, j in [-1, R]: a texel one step beyond an edge is the
/// texel it touches across the octahedron's seam (the edge mirrored: (-1, j) is (0, R - 1 - j)),
/// so that a bilinear lookup is continuous over the whole sphere. Returns the index i + R j.
inline int octWrappedTexel(int i, int j, int R) {
  if (i < 0) {
    i = 0;
    j = R - 1 - j;
  } else if (i >= R) {
    i = R - 1;
    j = R - 1 - j;
  }
  if (j < 0) {
    j = 0;
    i = R - 1 - i;
  } else if (j >= R) {
    j = R - 1;
    i = R - 1 - i;
  }
  return i + R * j;
}

}  // namespace ps
