#pragma once
// The one root error type for bad external input (files, parameters), with typed children.
// Bugs are checked with PS_CHECK (always on); "nothing there" is std::optional.
// Caught once: in the CLI's main, in the editor's actions and in the editor's main.
#include <stdexcept>
#include <string>

namespace ps {

/// Root of every error the user can cause. what() is one line: "<where>: <problem>".
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// A file could not be read or parsed, or a field in it is wrong.
/// `file` is the path as given; `field` is the path inside the file (a glTF path like
/// `meshes[3].primitives[0]`, a JSON path like `probes[12].position`), or empty.
class FileError : public Error {
 public:
  FileError(std::string file, std::string field, const std::string& problem)
      : Error(format(file, field, problem)), file_(std::move(file)), field_(std::move(field)) {}
  const std::string& file() const { return file_; }
  const std::string& field() const { return field_; }

 private:
  static std::string format(const std::string& file, const std::string& field,
                            const std::string& problem) {
    std::string s = file;
    if (!field.empty()) s += (s.empty() ? "" : ": ") + field;
    return s + (s.empty() ? "" : ": ") + problem;
  }
  std::string file_, field_;
};

/// A parameter given by the user is out of range or inconsistent. `parameter` is the core's
/// name of it (a placement method's parameter such as `swapPasses`, see
/// core/placement/PlacementMethod.h), or empty; callers that show it under another name (a CLI
/// flag, an editor field) rebuild the message from parameter() and problem().
class ParameterError : public Error {
 public:
  using Error::Error;
  ParameterError(std::string parameter, std::string problem)
      : Error(parameter + ": " + problem),
        parameter_(std::move(parameter)),
        problem_(std::move(problem)) {}
  const std::string& parameter() const { return parameter_; }
  /// The message without the parameter's name (what() when there is no name).
  std::string problem() const { return parameter_.empty() ? std::string(what()) : problem_; }

 private:
  std::string parameter_, problem_;
};

/// A long-running stage was cancelled through its progress callback.
class Cancelled : public Error {
 public:
  Cancelled() : Error("cancelled") {}
};

}  // namespace ps
