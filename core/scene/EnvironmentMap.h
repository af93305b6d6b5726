#pragma once
// An equirectangular environment map (a sky from an .hdr or .exr file): linear radiance seen by
// rays that leave the scene. Direction convention (+Y up, glTF): the image's top row looks up
// (+Y), its bottom row down; the centre column looks towards -Z, the column at 3/4 of the width
// towards +X. For a unit direction d:
//   u = 1/2 + atan2(d.x, -d.z) / (2 pi)   (column: u * width)
//   v = acos(d.y) / pi                    (row: v * height)
// Each texel is a constant radiance over its patch of the sphere (no filtering).
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "core/math/Vec3.h"

namespace ps {

struct EnvironmentMap {
  std::string path;  ///< the file it was read from, as given
  int width = 0;
  int height = 0;
  std::vector<float> rgb;  ///< width * height * 3, linear radiance W/(m^2 sr), row 0 at the top
  /// Texels that were NaN, infinite or negative and were set to 0, one line per kind, naming the
  /// file; the CLI prints them to stderr.
  std::vector<std::string> warnings;

  /// The radiance arriving from direction `dir` (unit; need not be exactly normalized).
  Rgb radiance(Vec3 dir) const;
  /// The texel (column, row) seen in direction `dir`.
  void texelOf(Vec3 dir, int& column, int& row) const;
  /// The unit direction through the centre of texel (column, row).
  Vec3 directionOf(double column, double row) const;
  /// The solid angle of a texel of row `row` (sr): (2 pi / width) (cos theta0 - cos theta1).
  double texelSolidAngle(int row) const;

  /// Importance sampling (Pharr, Jakob & Humphreys, PBRT 3rd ed. sec. 14.2.4, piecewise-constant
  /// 2D distribution): texels are chosen with probability proportional to luminance times solid
  /// angle, then a direction uniform (in solid angle) within the texel. Empty until
  /// buildSampling(); loadEnvironmentMap builds it. False when the map is black.
  bool canSample() const { return !marginalCdf.empty(); }
  void buildSampling();
  /// A direction from two uniforms in [0, 1) and its pdf (per steradian). Precondition:
  /// canSample().
  Vec3 sample(double u1, double u2, double& pdf) const;
  /// The pdf (per steradian) with which sample() returns `dir`. Precondition: canSample().
  double pdf(Vec3 dir) const;

  std::vector<double> marginalCdf;       ///< height + 1 entries, 0 to 1: rows
  std::vector<double> conditionalCdf;    ///< height * (width + 1), 0 to 1 per row: columns
  std::vector<double> texelProbability;  ///< width * height, summing to 1
};

/// Reads an equirectangular map with OpenImageIO (any format it reads; .hdr and .exr are the
/// usual ones), keeping the first three channels (a grey map is replicated). NaN, infinite and
/// negative texels are set to 0 with a warning in EnvironmentMap::warnings.
/// Throws ps::FileError naming the file when it is missing, unreadable or has no pixels.
std::shared_ptr<const EnvironmentMap> loadEnvironmentMap(const std::filesystem::path& path);

}  // namespace ps
