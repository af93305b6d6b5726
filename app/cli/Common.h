#pragma once
// Shared pieces of the probestudio subcommands.
#include <CLI/CLI.hpp>
#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/capture/Capture.h"
#include "core/common/Progress.h"
#include "core/domain/DomainPoints.h"
#include "core/io/ProbeSet.h"
#include "core/io/VolumeFile.h"
#include "core/scene/LightingRig.h"
#include "core/scene/SceneUnits.h"
#include "core/traversal/ProbeVolume.h"

namespace ps::cli {

/// Lighting-rig options shared by capture and place: --sun, --env, --env-map, --point.
struct RigOptions {
  std::vector<std::string> suns, points;
  std::string env, envMap;
  void add(CLI::App& cmd);
  /// Throws ps::ParameterError naming the option and what was expected.
  LightingRig build() const;
};

/// The domain of interest where the set has no importance volume (DomainPoints.h), shared by
/// place, bake and eval: --domain reachable|bounds and the reachable rule's parameters.
struct DomainOptions {
  std::string rule = "reachable";
  ReachableSettings reachable;
  void add(CLI::App& cmd);
  /// Throws ps::ParameterError naming the flag and what was expected.
  DomainSettings build() const;
};

/// The scene's unit, --units m|cm|mm|METRES_PER_UNIT (core/scene/SceneUnits.h), on every
/// subcommand that reads a scene. The core works in metres; positions on the command line and
/// in the files and outputs are in the scene's unit.
struct UnitOptions {
  std::string units;  ///< as given; empty when not given
  void add(CLI::App& cmd);
  /// Metres per unit, or nullopt when --units was not given. Throws ps::ParameterError naming
  /// --units for a malformed value.
  std::optional<double> given() const;
  /// The unit of a command that reads a probe set or a volume stating its unit (`fileUnit`,
  /// metres per unit, from `file`): that unit. --units, when given, must agree with it; else
  /// throws ps::ParameterError naming both.
  double agreeWith(double fileUnit, const std::string& file) const;
};

/// Loads the scene in `metresPerUnit` and prints its warnings on stderr. When `unitGiven` is
/// false and the scene is read as metres, also prints the unit hint (sceneUnitHint) when its
/// size suggests centimetres or millimetres: one line, naming --units.
Scene loadSceneReporting(const std::string& path, double metresPerUnit, bool unitGiven);

/// Samples per probe, fixed (--spp N) or adaptive (--target-error E [--max-spp N]), shared by
/// capture and bake.
struct SamplingOptions {
  int spp;
  double targetError = 0;
  int maxSpp = 65536;
  explicit SamplingOptions(int defaultSpp) : spp(defaultSpp) {}
  void add(CLI::App& cmd);
  /// Sets samplesPerProbe, targetRelativeError and maxSamplesPerProbe.
  void apply(CaptureSettings& settings) const;
  /// "1024 spp" or "target error 0.02 (at most 65536 spp)".
  std::string describe() const;
};

/// "x,y,z" (or more numbers) -> doubles; throws ParameterError naming `option`.
std::vector<double> parseNumbers(const std::string& text, const std::string& option);
Vec3 parseVec3(const std::string& text, const std::string& option);

/// Reads one "x y z" per line (blank lines and lines starting with # skipped).
/// Throws ps::FileError naming the file and the line.
std::vector<Vec3> readPointsFile(const std::filesystem::path& path);

/// Stderr progress bar for long stages ("label  42%"), silent when stderr is not a terminal.
ProgressFn terminalProgress(const std::string& label);

/// Seconds of wall time since t0.
double secondsSince(std::chrono::steady_clock::time_point t0);

/// [r, g, b] as a JSON array.
nlohmann::ordered_json rgbJson(Rgb c);

/// True when the file starts with the volume magic (it is a .psv, not a probe set).
bool isVolumePath(const std::filesystem::path& p);

/// Scene path stored in a volume's metadata, resolved against the volume's folder, and the rig.
struct VolumeSource {
  std::string scenePath;
  LightingRig rig;  ///< metres (the metadata holds it in the scene's unit)
  /// The baked set's importance volumes (metadata "domain", in the scene's unit there), in
  /// metres; empty when it had none.
  std::vector<Bounds3> domain;
};
/// Reads the metadata of `vf` (loaded with loadVolume: vf.metresPerUnit is its unit).
/// Throws ps::FileError naming the volume and the metadata field.
VolumeSource volumeSource(const VolumeFile& vf, const std::filesystem::path& volumePath);

/// A removed option, still parsed (a flag, or with `takesValue` an option with
/// one value; hidden from --help) so that an old command fails saying what replaced it rather
/// than "unrecognised". Giving it throws ps::ParameterError(name, "removed; " + replacement)
/// before the subcommand runs: exit code 1, as for any bad parameter.
void addRemovedOption(CLI::App& cmd, const std::string& name, bool takesValue,
                      const std::string& replacement);

/// What replaced bake's leak refinement and leak cuts, for addRemovedOption.
inline constexpr const char* kLeakBakeReplacement =
    "the baked volume's visibility maps weigh each probe by whether it sees the query, and a "
    "query whose tetrahedron's probes are all hidden takes its light from the neighbouring "
    "tetrahedra's probes that see it (docs/leaks.md); the volume holds exactly the accepted "
    "probes";
/// What replaced place's leak refinement, for addRemovedOption.
inline constexpr const char* kLeakPlaceReplacement =
    "coverage-first placement puts probes in every room and the budget is the set's probe "
    "count; the baked volume's visibility maps and their neighbour search keep light from "
    "crossing walls (docs/leaks.md)";

void registerPlace(CLI::App& app);
void registerBake(CLI::App& app);
void registerCapture(CLI::App& app);
void registerTetra(CLI::App& app);
void registerQuery(CLI::App& app);
void registerEval(CLI::App& app);
void registerInfo(CLI::App& app);

}  // namespace ps::cli
