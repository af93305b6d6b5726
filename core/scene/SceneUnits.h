#pragma once
// Scene units: the core works in metres; a scene authored in another unit is scaled on load,
// and every length the user reads or writes (probe positions in the probe set and the volume,
// points on the command line) stays in the scene's own unit. Physical settings (the walkable
// band, the doorway width, a spacing "in metres") are metres in every unit.
#include <optional>
#include <string>
#include <string_view>

#include "core/math/Vec3.h"

namespace ps {

struct Scene;

/// Metres per scene unit from its name: "m" (1), "cm" (0.01), "mm" (0.001), or a positive
/// finite number of metres per unit ("0.0254" for inches). nullopt for anything else.
std::optional<double> parseSceneUnit(std::string_view text);

/// The name of a unit: "m", "cm" or "mm" for those exact scales, else the number (shortest text
/// that reads back to the same double).
std::string sceneUnitName(double metresPerUnit);

/// What parseSceneUnit accepts, for error messages.
inline constexpr const char* kSceneUnitExpected =
    "expected \"m\", \"cm\", \"mm\" or a positive number of metres per unit";

/// Scales a scene loaded in its own unit to metres: vertex positions, the bounds, punctual
/// light positions and ranges are multiplied by `metresPerUnit`. Normals, directions, light
/// intensities (W/sr, or irradiance W/m^2 for a directional light) and emission (W/(m^2 sr))
/// are unchanged: radiance and intensity do not depend on the distance unit. `metresPerUnit`
/// must be positive and finite (PS_CHECK).
void scaleScene(Scene& scene, double metresPerUnit);

/// The unit a scene's size suggests when it was loaded without one (as metres), from its
/// bounding box in its own unit: nullopt when it looks like metres.
///
/// Rule: a room or a storey is 2 to 4 m tall, and a scene in metres is rarely taller than
/// kUnitHintHeightLimit units (the generated four-storey level is about 16 m tall, a 50-storey
/// tower about 200 m). A scene whose height (its extent along +Y, which glTF makes up) is above
/// that limit is flagged: as millimetres when the height is above 10 times the limit (a room in
/// mm is 2000 to 4000 units tall), as centimetres otherwise (a room in cm is 200 to 400). Its
/// width does not count: a level in metres may be kilometres wide. Known misses: a tower or a
/// mountain in metres taller than the limit is flagged, and a building in cm taller than 20 m
/// is called mm; the hint is one line on stderr, never a refusal.
std::optional<double> suggestedSceneUnit(const Bounds3& boundsInSceneUnits);
inline constexpr double kUnitHintHeightLimit = 200;

/// The one-line warning for a scene whose size suggests another unit, e.g. "SCENE is 10240
/// units across and 3000 tall; if it is in millimetres, pass --units mm" (`flag` names the
/// option, e.g. "--units"); empty when suggestedSceneUnit() gives nothing.
std::string sceneUnitHint(const std::string& sceneName, const Bounds3& boundsInSceneUnits,
                          const std::string& flag);

}  // namespace ps
