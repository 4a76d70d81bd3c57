// mrsns-sim child processes (see simulated_room_process.h).
#include "simulated_room_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>
#include <thread>
#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/igtlink/server.h"

namespace mrsns::workflow::detail {

namespace fs = std::filesystem;

namespace {

/// fork + exec with stdout and stderr into `log` (appended); returns the pid.
// A scenario whose headset is enabled (mrsns-sim reads it again and reports its errors).
bool hasHeadset(const fs::path& scenario) {
  try {
    std::ifstream in(scenario);
    const auto j = nlohmann::json::parse(in);
    return j.contains("hmd") && j["hmd"].is_object() && j["hmd"].value("enabled", true);
  } catch (const nlohmann::json::exception&) {
    return false;
  }
}

pid_t spawn(const fs::path& program, const std::vector<std::string>& args, const fs::path& log) {
  std::vector<char*> argv;
  std::string program_text = program.string();
  argv.push_back(program_text.data());
  std::vector<std::string> copies = args;
  for (auto& a : copies) argv.push_back(a.data());
  argv.push_back(nullptr);
  const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd < 0) throw FileError("cannot create " + log.string());
  const pid_t pid = ::fork();
  if (pid < 0) {
    ::close(fd);
    throw FileError("cannot start " + program.string() + " (fork failed)");
  }
  if (pid == 0) {
    ::dup2(fd, STDOUT_FILENO);
    ::dup2(fd, STDERR_FILENO);
    ::execv(program_text.c_str(), argv.data());
    _exit(127);
  }
  ::close(fd);
  return pid;
}

std::string tail(const fs::path& log) {
  std::ifstream in(log);
  std::string line, last;
  while (std::getline(in, line)) {
    if (!line.empty()) last = line;
  }
  return last;
}

/// Waits up to `timeout_s` for the child; its exit code, or nullopt while it runs.
std::optional<int> waitFor(pid_t pid, double timeout_s) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (true) {
    int status = 0;
    const pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    if (r < 0) return -1;
    if (std::chrono::steady_clock::now() >= until) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

}  // namespace

fs::path findSimProgram() {
  if (const char* env = std::getenv("MRSNS_SIM"); env != nullptr && *env != '\0') return env;
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) return {};
  const fs::path here = self.parent_path();
  // Installed: beside mrsns-cli. Build tree: app/cli/mrsns-cli and app/sim/mrsns-sim (tests: tests/<x>/).
  for (const fs::path& candidate : {here / "mrsns-sim", here / ".." / "sim" / "mrsns-sim",
                                    here / ".." / ".." / "app" / "sim" / "mrsns-sim"}) {
    if (fs::is_regular_file(candidate, ec) && ::access(candidate.c_str(), X_OK) == 0) {
      return fs::weakly_canonical(candidate, ec);
    }
  }
  return {};
}

SimulatedRoomProcess::SimulatedRoomProcess(const fs::path& program, const fs::path& scenario, const fs::path& truth,
                                           const fs::path& log, double ready_timeout_s,
                                           std::optional<std::uint64_t> seed)
    : log_(log) {
  const fs::path ready = truth.parent_path() / "ready.json";
  fs::remove(ready);
  // Until stopped: the trial's steps take as long as they take, the room waits for them.
  std::vector<std::string> args = {"run",         "--scenario", scenario.string(), "--truth",      truth.string(),
                                   "--any-ports", "--duration", "0",               "--ready-file", ready.string(),
                                   "--json"};
  if (seed) {
    args.push_back("--seed");
    args.push_back(std::to_string(*seed));
  }
  if (hasHeadset(scenario)) {
    args.push_back("--hmd-port");
    args.push_back(std::to_string(igtlink::freeLocalPort()));
  }
  pid_ = spawn(program, args, log);
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(ready_timeout_s);
  while (!fs::exists(ready)) {
    if (const auto code = waitFor(pid_, 0.0)) {
      pid_ = -1;
      throw FileError("the simulated operating room (" + program.string() + ") ended with code " +
                      std::to_string(*code) + " before it was ready: " + tail(log));
    }
    if (std::chrono::steady_clock::now() >= until) {
      stop();
      throw FileError("the simulated operating room was not ready within " +
                      std::to_string(static_cast<int>(ready_timeout_s)) + " s: " + tail(log));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  std::ifstream in(ready);
  try {
    endpoints_ = nlohmann::json::parse(in);
    host_ = endpoints_.at("host").get<std::string>();
    plus_port_ = endpoints_.at("plus_port").get<int>();
  } catch (const nlohmann::json::exception& e) {
    stop();
    throw FormatError("the simulated operating room's ready file " + ready.string() + " is not what it writes (" +
                      e.what() + ")");
  }
}

SimulatedRoomProcess::~SimulatedRoomProcess() {
  stop();
}

int SimulatedRoomProcess::stop() {
  if (pid_ <= 0) return 0;
  ::kill(pid_, SIGTERM);
  auto code = waitFor(pid_, 30.0);
  if (!code) {
    ::kill(pid_, SIGKILL);
    code = waitFor(pid_, 5.0);
    code = -1;
  }
  pid_ = -1;
  return *code;
}

nlohmann::json scoreWithSim(const fs::path& program, const fs::path& session, const fs::path& truth,
                            const fs::path& log) {
  const fs::path out = log.parent_path() / "score.json";
  const pid_t pid = spawn(program, {"score", session.string(), truth.string(), "--json"}, out);
  const auto code = waitFor(pid, 120.0);
  if (!code) {
    ::kill(pid, SIGKILL);
    waitFor(pid, 5.0);
    throw ComputationError("mrsns-sim score did not finish within 120 s");
  }
  std::ifstream in(out);
  std::stringstream text;
  text << in.rdbuf();
  if (*code != 0) {
    throw ComputationError("mrsns-sim score failed (code " + std::to_string(*code) + "): " + tail(out));
  }
  try {
    return nlohmann::json::parse(text.str());
  } catch (const nlohmann::json::exception& e) {
    throw ComputationError("mrsns-sim score printed no JSON object (" + std::string(e.what()) + ")");
  }
}

}  // namespace mrsns::workflow::detail
