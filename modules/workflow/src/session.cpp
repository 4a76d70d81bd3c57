// Session folder: session.json state with atomic saves.
#include "mrsns/workflow/session.h"

#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <sstream>
#include <utility>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "session_state.h"
#include "time_text.h"

namespace mrsns::workflow {

namespace fs = std::filesystem;

namespace {

constexpr const char* kStateFile = "session.json";

// write + fsync + rename: readers see the old file or the new one, never a
// truncated state (a GUI crash mid-save must not lose the session).
void writeFileAtomically(const fs::path& path, const std::string& text) {
  const fs::path temp = path.string() + ".tmp";
  const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) {
    throw FileError("cannot write session state '" + temp.string() +
                    "': check that the session folder exists and is writable");
  }
  std::size_t written = 0;
  while (written < text.size()) {
    const auto n = ::write(fd, text.data() + written, text.size() - written);
    if (n <= 0) {
      ::close(fd);
      throw FileError("writing session state '" + temp.string() + "' failed (disk full?)");
    }
    written += static_cast<std::size_t>(n);
  }
  ::fsync(fd);
  ::close(fd);
  std::error_code ec;
  fs::rename(temp, path, ec);
  if (ec) {
    throw FileError("cannot replace '" + path.string() + "': " + ec.message());
  }
}

template <typename T>
void replaceOrAppend(nlohmann::json& list, const char* key, const std::string& id, const T& value) {
  for (auto& item : list) {
    if (item.value(key, "") == id) {
      item = value;
      return;
    }
  }
  list.push_back(value);
}

}  // namespace

Session::Session(fs::path folder, nlohmann::json state, int opened_version)
    : folder_(std::move(folder)), state_(std::move(state)), opened_version_(opened_version) {}

Session Session::create(const fs::path& folder) {
  std::error_code ec;
  if (fs::exists(folder, ec)) {
    if (!fs::is_directory(folder, ec)) {
      throw FileError("session folder '" + folder.string() + "' exists and is a file: choose a new folder name");
    }
    if (!fs::is_empty(folder, ec)) {
      throw FileError("session folder '" + folder.string() +
                      "' exists and is not empty: choose a new folder or open it as a session");
    }
  }
  fs::create_directories(folder, ec);
  if (ec) {
    throw FileError("cannot create session folder '" + folder.string() + "': " + ec.message());
  }
  nlohmann::json state = {{"version", kSessionVersion},
                          {"created", isoTimeNow()},
                          {"steps", nlohmann::json::object()},
                          {"log", nlohmann::json::array()}};
  addTypedSections(state);
  Session session(fs::absolute(folder), std::move(state), kSessionVersion);
  session.save();
  return session;
}

Session Session::open(const fs::path& folder) {
  const fs::path file = folder / kStateFile;
  std::ifstream in(file, std::ios::binary);
  if (!in) {
    throw FileError("no session at '" + folder.string() + "': '" + file.string() +
                    "' is missing or unreadable; create one with 'mrsns-cli session create DIR'");
  }
  std::stringstream buffer;
  buffer << in.rdbuf();
  nlohmann::json state;
  try {
    state = nlohmann::json::parse(buffer.str());
  } catch (const nlohmann::json::parse_error& e) {
    throw FormatError("session state '" + file.string() + "' is not valid JSON (" + e.what() +
                      "); restore it from a backup or create a new session");
  }
  if (!state.is_object() || !state.contains("version") || !state["version"].is_number_integer()) {
    throw FormatError("session state '" + file.string() +
                      "' has no integer \"version\": it is not an MR-SNS session file");
  }
  const int version = state["version"].get<int>();
  if (version != 1 && version != kSessionVersion) {
    throw FormatError("session state '" + file.string() + "' has version " + std::to_string(version) +
                      ", this program reads versions 1 and " + std::to_string(kSessionVersion) +
                      ": open it with a matching MR-SNS release");
  }
  if (!state.contains("steps") || !state["steps"].is_object()) {
    throw FormatError("session state '" + file.string() + "' has no \"steps\" object: the file is damaged");
  }
  if (!state.contains("log") || !state["log"].is_array()) state["log"] = nlohmann::json::array();
  addTypedSections(state);
  Session session(fs::absolute(folder), std::move(state), version);
  if (version == 1) session.migrateFromVersion1(buffer.str());
  // Typed sections written by a newer build of this version are checked once, here, so a damaged entry is
  // reported at open with its place rather than later in the middle of a step.
  try {
    (void)session.ct();
    (void)session.labelMaps();
    (void)session.models();
    (void)session.shapeModel();
    (void)session.fiducials();
    (void)session.plans();
  } catch (const nlohmann::json::exception& e) {
    throw FormatError("session state '" + file.string() + "' has a damaged entry (" + e.what() +
                      "); restore it from a backup");
  } catch (const Error& e) {
    throw FormatError("session state '" + file.string() + "' has a damaged entry (" + e.what() +
                      "); restore it from a backup");
  }
  return session;
}

void Session::migrateFromVersion1(const std::string& original_text) {
  // The version-1 file is kept beside the new one: nothing the user had is lost, and an older build can still
  // open the copy.
  std::string backup;
  std::error_code ec;
  for (int n = 1;; ++n) {
    backup = n == 1 ? "session.v1.json" : "session.v1-" + std::to_string(n) + ".json";
    if (!fs::exists(folder_ / backup, ec)) break;
  }
  bool kept = true;
  try {
    writeFileAtomically(folder_ / backup, original_text);
  } catch (const FileError& e) {
    kept = false;
    logger()->warn("session {}: could not keep the version-1 file as {}: {}", folder_.string(), backup, e.what());
  }
  migrateVersion1Content(state_, folder_);
  state_["version"] = kSessionVersion;
  state_["migrated_from"] = {{"version", 1}, {"time", isoTimeNow()}, {"backup", kept ? backup : ""}};
  deriveFromSteps();
  state_["log"].push_back({{"time", isoTimeNow()},
                           {"level", "info"},
                           {"message", "upgraded from session version 1" +
                                           (kept ? " (the original is kept as " + backup + ")" : std::string())}});
  try {
    save();
  } catch (const FileError& e) {
    // A read-only session (a copy on a DVD, an installed sample) still opens; it is upgraded in memory only.
    logger()->warn("session {}: upgraded to version {} in memory only: {}", folder_.string(), kSessionVersion,
                   e.what());
  }
}

void Session::recordStep(const std::string& step, const nlohmann::json& result) {
  if (step.empty()) throw InvalidArgumentError("Session::recordStep: the step name is empty");
  nlohmann::json entry = result.is_object() ? result : nlohmann::json{{"value", result}};
  entry["time"] = isoTimeNow();
  // The order steps were recorded in: seconds-resolution times tie, and the latest calibration must win.
  const std::int64_t sequence = state_.value("step_sequence", std::int64_t{0}) + 1;
  state_["step_sequence"] = sequence;
  entry["sequence"] = sequence;
  state_["steps"][step] = std::move(entry);
  state_["modified"] = isoTimeNow();
  deriveFromSteps();
  save();
}

nlohmann::json Session::step(const std::string& step) const {
  const auto& steps = state_.at("steps");
  const auto it = steps.find(step);
  return it == steps.end() ? nlohmann::json() : *it;
}

void Session::log(const std::string& level, const std::string& message) {
  state_["log"].push_back({{"time", isoTimeNow()}, {"level", level}, {"message", message}});
  save();
}

void Session::save() const {
  writeFileAtomically(folder_ / kStateFile, state_.dump(2) + "\n");
}

fs::path Session::resolve(const std::string& relative) const {
  const fs::path p(relative);
  if (relative.empty() || p.is_absolute()) {
    throw InvalidArgumentError("session path '" + relative +
                               "' must be relative to the session folder (files live inside the session)");
  }
  for (const auto& part : p) {
    if (part == "..") {
      throw InvalidArgumentError("session path '" + relative + "' climbs out of the session folder with '..'");
    }
  }
  return folder_ / p;
}

std::string Session::relativeName(const fs::path& file) const {
  std::error_code ec;
  const fs::path relative = fs::weakly_canonical(file, ec).lexically_relative(fs::weakly_canonical(folder_, ec));
  if (ec || relative.empty()) return {};
  const std::string text = relative.generic_string();
  if (text == "." || text.rfind("..", 0) == 0) return {};
  return text;
}

// ---- the typed document -------------------------------------------------------------------------------------

std::optional<ImageEntry> Session::ct() const {
  for (const auto& image : state_.at("images")) {
    if (image.value("role", "") == "ct") return image.get<ImageEntry>();
  }
  return std::nullopt;
}

void Session::setCt(const ImageEntry& ct) {
  auto& images = state_["images"];
  nlohmann::json kept = nlohmann::json::array();
  for (const auto& image : images) {
    if (image.value("role", "") != "ct") kept.push_back(image);
  }
  kept.push_back(ct);
  images = std::move(kept);
  touchAndSave();
}

std::vector<LabelMapEntry> Session::labelMaps() const {
  return state_.at("label_maps").get<std::vector<LabelMapEntry>>();
}

std::optional<LabelMapEntry> Session::labelMap(const std::string& id) const {
  for (const auto& l : state_.at("label_maps")) {
    if (l.value("id", "") == id) return l.get<LabelMapEntry>();
  }
  return std::nullopt;
}

void Session::putLabelMap(const LabelMapEntry& labels) {
  if (labels.id.empty()) throw InvalidArgumentError("Session::putLabelMap: the label map has no id");
  replaceOrAppend(state_["label_maps"], "id", labels.id, labels);
  touchAndSave();
}

std::vector<ModelEntry> Session::models() const {
  return state_.at("models").get<std::vector<ModelEntry>>();
}

std::vector<ModelEntry> Session::models(ModelRole role) const {
  std::vector<ModelEntry> out;
  for (auto& m : models()) {
    if (m.role == role) out.push_back(std::move(m));
  }
  return out;
}

std::optional<ModelEntry> Session::model(const std::string& id) const {
  for (const auto& m : state_.at("models")) {
    if (m.value("id", "") == id) return m.get<ModelEntry>();
  }
  return std::nullopt;
}

void Session::putModels(const std::vector<ModelEntry>& models) {
  for (const auto& m : models) {
    if (m.id.empty()) throw InvalidArgumentError("Session::putModels: a model has no id");
    replaceOrAppend(state_["models"], "id", m.id, m);
  }
  touchAndSave();
}

bool Session::removeModel(const std::string& id) {
  auto& list = state_["models"];
  for (auto it = list.begin(); it != list.end(); ++it) {
    if (it->value("id", "") == id) {
      list.erase(it);
      touchAndSave();
      return true;
    }
  }
  return false;
}

std::string Session::freeModelId(const std::string& base) const {
  for (int n = 1;; ++n) {
    const std::string id = n == 1 ? base : base + "-" + std::to_string(n);
    if (!model(id)) return id;
  }
}

std::optional<ShapeModelEntry> Session::shapeModel() const {
  const auto& list = state_.at("shape_models");
  if (list.empty()) return std::nullopt;
  return list.back().get<ShapeModelEntry>();
}

void Session::setShapeModel(const ShapeModelEntry& model) {
  state_["shape_models"] = nlohmann::json::array({model});
  touchAndSave();
}

std::optional<FiducialSet> Session::fiducials() const {
  const auto& f = state_.at("fiducials");
  if (f.is_null()) return std::nullopt;
  return f.get<FiducialSet>();
}

void Session::setFiducials(const FiducialSet& fiducials) {
  state_["fiducials"] = fiducials;
  touchAndSave();
}

std::vector<PlannedScrew> Session::plans() const {
  return state_.at("plans").get<std::vector<PlannedScrew>>();
}

std::optional<PlannedScrew> Session::plan(const std::string& name) const {
  for (const auto& p : state_.at("plans")) {
    if (p.value("name", "") == name) return p.get<PlannedScrew>();
  }
  return std::nullopt;
}

void Session::setPlans(const std::vector<PlannedScrew>& plans) {
  state_["plans"] = plans;
  touchAndSave();
}

std::optional<TransformEntry> Session::transform(const std::string& name) const {
  for (const char* section : {"registrations", "calibrations"}) {
    const auto& map = state_.at(section);
    if (map.contains(name)) return map.at(name).get<TransformEntry>();
  }
  return std::nullopt;
}

std::vector<TransformEntry> Session::calibrations() const {
  std::vector<TransformEntry> out;
  for (const auto& [name, entry] : state_.at("calibrations").items()) out.push_back(entry.get<TransformEntry>());
  return out;
}

std::vector<TransformEntry> Session::registrations() const {
  std::vector<TransformEntry> out;
  for (const auto& [name, entry] : state_.at("registrations").items()) out.push_back(entry.get<TransformEntry>());
  return out;
}

std::vector<RecordingEntry> Session::recordings() const {
  return state_.at("recordings").get<std::vector<RecordingEntry>>();
}

namespace {

/// Moves the session file `relative` (when it exists) to `folder`/`relative` and returns the new name; a
/// name that is not a file of the session is returned unchanged.
std::string moveAside(const Session& session, const std::string& relative, const std::string& folder) {
  std::error_code ec;
  fs::path from;
  try {
    from = session.resolve(relative);
  } catch (const mrsns::Error&) {
    return relative;
  }
  if (relative.empty() || !fs::is_regular_file(from, ec)) return relative;
  const std::string moved = folder + "/" + relative;
  const fs::path to = session.resolve(moved);
  fs::create_directories(to.parent_path(), ec);
  fs::rename(from, to, ec);
  if (ec) {
    throw FileError("setting the old patient data aside: moving '" + from.string() + "' to '" + to.string() +
                    "' failed (" + ec.message() + "): the session keeps the old data; files moved before it are in " +
                    session.resolve(folder).string());
  }
  return moved;
}

/// Every "file"/"hmd_file" of `entry` (recursively) moved into `folder`.
void moveFilesAside(const Session& session, nlohmann::json& entry, const std::string& folder) {
  if (entry.is_array()) {
    for (auto& item : entry) moveFilesAside(session, item, folder);
  } else if (entry.is_object()) {
    for (auto& [key, value] : entry.items()) {
      if ((key == "file" || key == "hmd_file") && value.is_string()) {
        value = moveAside(session, value.get<std::string>(), folder);
      } else if (key != "provenance") {  // a provenance's file is the user's original, outside the session
        moveFilesAside(session, value, folder);
      }
    }
  }
}

}  // namespace

void Session::setAsidePatientData(const std::string& reason) {
  nlohmann::json aside = {{"time", isoTimeNow()}, {"reason", reason}};
  if (!state_.contains("set_aside") || !state_["set_aside"].is_array()) state_["set_aside"] = nlohmann::json::array();
  // The files move too (set_aside/N/...): the new patient's models and plan reuse names such as models/L1.vtp and
  // plans/Plan.mrk.json, which would otherwise overwrite the old ones.
  const std::string folder = "set_aside/" + std::to_string(state_["set_aside"].size() + 1);
  const nlohmann::json before = state_;
  try {
  for (const char* key : {"images", "label_maps", "models", "shape_models", "plans"}) {
    aside[key] = state_[key];
    state_[key] = nlohmann::json::array();
  }
  aside["fiducials"] = state_["fiducials"];
  state_["fiducials"] = nullptr;
  moveFilesAside(*this, aside, folder);
  aside["plan_file"] = moveAside(*this, "plans/Plan.mrk.json", folder);
  aside["folder"] = folder;
  } catch (...) {
    state_ = before;
    throw;
  }
  state_["set_aside"].push_back(std::move(aside));
  touchAndSave();
}

void Session::touchAndSave() {
  state_["modified"] = isoTimeNow();
  save();
}

void Session::deriveFromSteps() {
  deriveStepProducts(state_);
}

}  // namespace mrsns::workflow
