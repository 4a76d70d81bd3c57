// The simulated operating room as the process a trial runs: `mrsns-sim run`
// serving 8 tools at 60 Hz and 640x480 B-mode at 30 fps to a client that
// receives everything, for 10 s. Reports the cores the mrsns-sim process used
// (its user + system CPU time over wall time, from /proc) and its peak
// resident memory (VmHWM). Goal (issue 16): under one core and 500 MB.
// There is no peer to run beside it: PlusServer needs a device to replay and
// does not build here.
#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "mrsns/igtlink/client.h"

extern char** environ;

namespace {

std::filesystem::path simBinary() {
  return std::filesystem::path(MRSNS_BENCH_BINARY_DIR) / "app" / "sim" / "mrsns-sim";
}

// utime + stime of a process, seconds (/proc/PID/stat fields 14 and 15).
double cpuSeconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto close = text.rfind(')');
  std::istringstream rest(text.substr(close + 2));
  std::string field;
  double utime = 0, stime = 0;
  for (int i = 3; i <= 15 && rest >> field; ++i) {
    if (i == 14) utime = std::stod(field);
    if (i == 15) stime = std::stod(field);
  }
  return (utime + stime) / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

double peakRssMb(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  }
  return 0.0;
}

std::string scenario() {
  std::string tools;
  const char* names[] = {"PatientToTracker", "StylusToTracker", "ReferenceToTracker", "CubeToTracker",
                         "HeadsetToTracker", "DrillToTracker",  "NeedleToTracker"};
  for (int i = 0; i < 7; ++i) {
    tools += std::string(R"({"name": ")") + names[i] + R"(", "start": {"translation_mm": [)" +
             std::to_string(-150 + 50 * i) + R"(, 0, -1400]}, "hand": {"tremor_rms_mm": 0.3}}, )";
  }
  // The probe sweeps along the patient's neck: an axial image plane from the anterior skin, depth posterior.
  tools += R"({"name": "ProbeToTracker", "hand": {"tremor_rms_mm": 0.3}, "motion": [
      {"kind": "hold", "frame": "CT", "pose_of": "image", "duration_s": 0.5,
       "pose": {"translation_mm": [-32, -55, 10]}},
      {"kind": "sweep", "frame": "CT", "pose_of": "image", "duration_s": 60, "cycles": 12,
       "pose": {"translation_mm": [-32, -55, -30]}}]})";
  return R"({"format": "mrsns-scenario/1", "name": "benchmark room", "tracker": {"port": 0, "rate_hz": 60},
    "tools": [)" +
         tools + R"(],
    "patient": {"generated_phantom": {"spacing_mm": 0.8}, "reference_tool": "PatientToTracker"},
    "ultrasound": {"rate_hz": 30, "width": 640, "height": 480, "spacing_mm": [0.1, 0.1]}})";
}

void BM_SimulatedRoomServing(benchmark::State& state) {
  const auto dir = std::filesystem::temp_directory_path() / ("mrsns-bench-room-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "scenario.json") << scenario();
  std::filesystem::remove(dir / "ready.json");
  for (auto _ : state) {
    std::vector<std::string> args = {simBinary().string(),
                                     "run",
                                     "--scenario",
                                     (dir / "scenario.json").string(),
                                     "--truth",
                                     (dir / "truth.json").string(),
                                     "--ready-file",
                                     (dir / "ready.json").string(),
                                     "--json"};
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, 1, (dir / "out.txt").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    pid_t pid = -1;
    if (posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ) != 0) {
      state.SkipWithError("mrsns-sim could not be started (build it first)");
      return;
    }
    posix_spawn_file_actions_destroy(&actions);
    for (int i = 0; i < 600 && !std::filesystem::exists(dir / "ready.json"); ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    std::ifstream ready(dir / "ready.json");
    std::string text((std::istreambuf_iterator<char>(ready)), std::istreambuf_iterator<char>());
    const auto at = text.find("\"plus_port\":");
    if (at == std::string::npos) {
      ::kill(pid, SIGKILL);
      ::waitpid(pid, nullptr, 0);
      state.SkipWithError("mrsns-sim did not get ready");
      return;
    }
    mrsns::igtlink::ClientOptions o;
    o.port = static_cast<std::uint16_t>(std::stoi(text.substr(at + 12)));
    mrsns::igtlink::Client client(o);
    std::atomic<std::uint64_t> transforms{0}, images{0};
    client.onMessage([&](const mrsns::igtlink::Message& m) { (m.header.type == "IMAGE" ? images : transforms)++; });
    client.start();
    std::this_thread::sleep_for(std::chrono::seconds(1));  // connected, past the first frames
    const auto t0 = std::chrono::steady_clock::now();
    const double cpu0 = cpuSeconds(pid);
    const auto tr0 = transforms.load(), im0 = images.load();
    const double seconds = 10.0;
    std::this_thread::sleep_for(std::chrono::duration<double>(seconds));
    const double cpu1 = cpuSeconds(pid);
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const double rss = peakRssMb(pid);
    client.stop();
    ::kill(pid, SIGTERM);
    ::waitpid(pid, nullptr, 0);
    state.SetIterationTime(wall);
    state.counters["cores_used"] = (cpu1 - cpu0) / wall;
    state.counters["peak_rss_MB"] = rss;
    state.counters["transforms_per_s"] = static_cast<double>(transforms.load() - tr0) / wall;
    state.counters["images_per_s"] = static_cast<double>(images.load() - im0) / wall;
  }
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_SimulatedRoomServing)->Iterations(1)->UseManualTime()->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
