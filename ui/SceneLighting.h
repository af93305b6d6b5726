#pragma once
// The viewport's light before any capture and its exposure, computed on the CPU (no GL here):
// the light that the scene's own lights and the rig's deliver to each point of a grid, straight
// and after one bounce (traced with the project's tracer), and the exposure metered from the lit
// surfaces the camera sees.
#include <functional>
#include <optional>
#include <span>
#include <vector>

#include "core/scene/LightingRig.h"
#include "core/trace/Tracer.h"
#include "ui/LightingField.h"

namespace ps::ui {

/// Sky and emissive-surface rays per grid cell in directLightGrid (a fixed spherical Fibonacci
/// set, the same at every cell, so the grid has no noise from cell to cell).
inline constexpr int kDirectSkyRays = 48;

/// True when the scene and the rig bring some light: a punctual or directional light, a sky
/// (constant or map), or an emissive surface.
bool hasAnyLight(const Scene& scene, const LightingRig& rig);

/// Direct light on a grid over `box` laid out as sampleGrid lays it out (cubic cells, the longest
/// side `maxCellsPerAxis` cells; sample i at ShGrid::centre(i)). At each cell centre, the SH of
/// the radiance arriving straight from
///   - the delta lights of the scene and the rig (sun, point and spot lights with their
///     inverse-square falloff and cones), each behind a shadow ray (as directDeltaSh), a point
///     or spot light nearer than the smallest cell side taken as that far,
///   - the sky (rig.skyRadiance plus its environment map) along those of `skyRays` fixed
///     directions that leave the scene, and the emission of the front faces they hit first,
///     projected with weight 4 pi / skyRays,
///   - and one bounce of all that, gathered on a grid of half the resolution with 8 skyRays
///     rays per cell and added trilinearly: each front face hit reflects albedo x E(n) / pi, E
///     read from the grid of the light above at the hit point.
/// A cell whose centre lies inside geometry (more than a quarter of its rays hit back faces)
/// takes the mean of its valid neighbours, so that surfaces beside a thick wall do not blend in
/// its dark inside. Cost: cells x (delta lights + 2 skyRays) rays.
/// `cancelled` is polled once per row of cells; when it returns true the result is empty.
/// Empty for an empty box. Throws what environmentOf throws for an unreadable map.
ShGrid directLightGrid(const Tracer& tracer, const LightingRig& rig, const Bounds3& box,
                       int maxCellsPerAxis, int skyRays = kDirectSkyRays,
                       const std::function<bool()>& cancelled = {});

/// The grid's SH at p, trilinear between cell centres and clamped at the outer ones: what the
/// viewport's 3D textures return there (GL_LINEAR, GL_CLAMP_TO_EDGE). Zero for an empty grid.
ShRgb sampleShGridAt(const ShGrid& grid, Vec3 p);

/// The outgoing radiance (luminance, W/(m^2 sr)) of the first front-facing surface along each
/// ray, lit by `grid` as the viewport lights it: albedo x E(n) / pi + emission, E from
/// sampleShGridAt and n the geometric normal. Rays that miss or meet a back face first are left
/// out (the background and the cut-away's caps are not lit surfaces).
std::vector<double> litSurfaceLuminances(const Tracer& tracer, const ShGrid& grid,
                                         std::span<const Ray> rays);

/// The tone mapper's input that the log-average of the lit surfaces maps to: a mid-tone (ACES
/// gives 0.27 linear, 141 in 8-bit sRGB).
inline constexpr double kExposureKey = 0.18;
/// The percentile of the surfaces' luminance kept below kExposureHighlight.
inline constexpr double kExposureHighlightPercentile = 0.97;
/// The tone mapper's input for that percentile: ACES gives 0.88 linear (241 in 8-bit sRGB),
/// bright but under white, so that at most about 3 % of the lit surfaces clip and the bright
/// ones keep some gradation.
inline constexpr double kExposureHighlight = 1.5;

/// The exposure (linear factor on radiance before tone mapping) for surfaces of these
/// luminances: kExposureKey over their log-average (Reinhard et al. 2002, eq. 1, with
/// delta = 1e-3 of their mean), lowered when that would put the kExposureHighlightPercentile
/// above kExposureHighlight. Nothing when there are none or all are black.
std::optional<double> meterExposure(std::vector<double> luminances);

}  // namespace ps::ui
