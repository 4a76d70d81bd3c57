#pragma once
// A surgical session: one folder holding session.json (the state of every
// workflow step, its figures and the files it wrote) and those data files,
// referred to by paths relative to the folder so a session can be moved or
// copied as a whole. The state is saved after every step, atomically (a
// temporary file renamed over session.json), so a crash never leaves a
// half-written state behind.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

namespace mrsns::workflow {

/// The session.json layout version this build writes and reads.
inline constexpr int kSessionVersion = 1;

class Session {
 public:
  /// Makes `folder` (and its parents) and writes a fresh session.json.
  /// Throws FileError when `folder` exists and is not empty, or cannot be made.
  static Session create(const std::filesystem::path& folder);
  /// Reads `folder`/session.json. Throws FileError when it is missing or
  /// unreadable, FormatError when it is not valid JSON, lacks "version" or
  /// "steps", or has a version this build does not know.
  static Session open(const std::filesystem::path& folder);

  [[nodiscard]] const std::filesystem::path& folder() const { return folder_; }
  /// {"version":1,"created":ISO-8601,"steps":{name:{status,summary,figures,outputs,params,time}},"log":[...]}
  [[nodiscard]] const nlohmann::json& state() const { return state_; }

  /// Stores `result` under steps[step] (with the time it was recorded) and saves.
  void recordStep(const std::string& step, const nlohmann::json& result);
  /// The recorded result of `step`, or null when it has not run.
  [[nodiscard]] nlohmann::json step(const std::string& step) const;
  /// Appends a line to the session log ({"time","level","message"}) and saves.
  void log(const std::string& level, const std::string& message);
  /// Writes session.json atomically (temporary file, fsync, rename).
  void save() const;
  /// folder()/relative; throws InvalidArgumentError for an absolute path or
  /// one that climbs out of the folder ("..").
  [[nodiscard]] std::filesystem::path resolve(const std::string& relative) const;

 private:
  Session(std::filesystem::path folder, nlohmann::json state);
  std::filesystem::path folder_;
  nlohmann::json state_;
};

}  // namespace mrsns::workflow
