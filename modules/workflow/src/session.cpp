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

}  // namespace

Session::Session(fs::path folder, nlohmann::json state) : folder_(std::move(folder)), state_(std::move(state)) {}

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
  Session session(fs::absolute(folder), std::move(state));
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
  if (version != kSessionVersion) {
    throw FormatError("session state '" + file.string() + "' has version " + std::to_string(version) +
                      ", this program reads version " + std::to_string(kSessionVersion) +
                      ": open it with a matching MR-SNS release");
  }
  if (!state.contains("steps") || !state["steps"].is_object()) {
    throw FormatError("session state '" + file.string() + "' has no \"steps\" object: the file is damaged");
  }
  if (!state.contains("log") || !state["log"].is_array()) state["log"] = nlohmann::json::array();
  return Session(fs::absolute(folder), std::move(state));
}

void Session::recordStep(const std::string& step, const nlohmann::json& result) {
  if (step.empty()) throw InvalidArgumentError("Session::recordStep: the step name is empty");
  nlohmann::json entry = result.is_object() ? result : nlohmann::json{{"value", result}};
  entry["time"] = isoTimeNow();
  state_["steps"][step] = std::move(entry);
  state_["modified"] = isoTimeNow();
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

}  // namespace mrsns::workflow
