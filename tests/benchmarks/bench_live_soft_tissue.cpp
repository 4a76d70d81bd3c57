// A live ultrasound frame to the supervisor's updated soft-tissue margin, end to end in one process on
// loopback: the simulated operating room (simulation::OperatingRoom, its PlusServer) renders 640 x 480 B-mode
// frames at 30 frames/s of a ~19k-vertex, 19-mode vessel model (bench_posterior's) swinging sideways, and
// streams them with the tracking at 60 Hz; the navigation loop (IgtlTrackingSource) decodes each frame,
// places it by Eq. 4, segments the lumens, updates the posterior (Algorithm 1) and builds the surface near
// the planned path (10 mm beside the vessel) with each face's SD for the supervisor of the docked simulated arm. Latency = the frame's arrival from the source ->
// the surface handed to the supervisor (SoftTissueSample::frame_to_margin_ms; the control loop installs it at
// its next cycle, <= 2 ms later at 500 Hz). The room renders on the same two cores, as mrsns-sim would.
// Frames that arrive while one is processed wait (only the newest), counted as skipped.
//
//   ./mrsns_bench_live_soft_tissue   (counters p50_ms, p99_ms, max_ms, frames_used, frames_skipped; the
//                                     goal, p99 <= 15 ms at 30 frames/s, printed beside them)
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "mrsns/deformation/model_building.h"
#include "mrsns/deformation/vessel_phantom.h"
#include "mrsns/io/statismo_io.h"
#include "mrsns/simulation/operating_room.h"
#include "mrsns/simulation/scenario.h"
#include "mrsns/workflow/navigation.h"

namespace {

using namespace mrsns;
using Json = nlohmann::json;

constexpr double kRunS = 20.0;
const Eigen::Vector3d kModelInCt(-20.0, -25.0, -15.0);

std::filesystem::path scratch() {
  auto d = std::filesystem::temp_directory_path() / ("mrsns-bench-live-soft-tissue-" + std::to_string(::getpid()));
  std::filesystem::create_directories(d);
  return d;
}

ShapeModel vesselModel() {
  deformation::VesselPhantomOptions po;
  po.ring_vertices = 64;
  po.ring_spacing_mm = 0.3;  // 3 x 101 rings x 64 = 19 392 vertices
  std::mt19937_64 rng(1);
  std::vector<TriangleMesh> training;
  for (int i = 0; i < 20; ++i) training.push_back(deformation::makeVesselPhantom(deformation::randomVesselDeformation(rng), po));
  deformation::ShapeModelBuildOptions b;
  b.align = false;
  return deformation::buildShapeModel(training, b).model;
}

Json imagePose(double z) {
  // 640 x 480 pixels of 0.06 mm: 38.4 mm wide, 28.8 mm deep; the vessel 12 mm deep, centred.
  const Eigen::Vector3d o = kModelInCt + Eigen::Vector3d(-19.2, -12.0, z);
  return {{"matrix", {1, 0, 0, o.x(), 0, 1, 0, o.y(), 0, 0, 1, o.z(), 0, 0, 0, 1}}};
}

void BM_LiveFrameToSupervisorMargin(benchmark::State& state) {
  const auto dir = scratch();
  io::writeStatismoModel(vesselModel(), dir / "vessel.h5");
  for (auto _ : state) {
    const Json s = {
        {"format", "mrsns-scenario/1"},
        {"seed", 1},
        {"duration_s", 0.0},
        {"tracker", {{"port", 0}, {"rate_hz", 60}}},
        {"tools",
         {{{"name", "PatientToTracker"}, {"start", {{"translation_mm", {0, 0, -1400}}}}},
          {{"name", "ProbeToTracker"},
           {"hand", {{"tremor_rms_mm", 0.3}, {"tremor_hz", {8.0, 12.0}}}},
           {"motion",
            {{{"kind", "hold"}, {"frame", "CT"}, {"pose_of", "image"}, {"pose", imagePose(-25.0)}, {"duration_s", 0.5}},
             {{"kind", "sweep"},
              {"frame", "CT"},
              {"pose_of", "image"},
              {"pose", imagePose(-5.0)},
              {"cycles", 20},
              {"duration_s", 80.0}}}}}}},
        {"patient",
         {{"generated_phantom", {{"spacing_mm", 2.0}}},
          {"reference_tool", "PatientToTracker"},
          {"ct_to_reference", {{"translation_mm", {0.0, 90.0, -30.0}}, {"rotation_deg", {90.0, 0.0, 0.0}}}},
          {"soft_tissue",
           {{"shape_model", "vessel.h5"},
            {"model_to_ct", {{"translation_mm", {kModelInCt.x(), kModelInCt.y(), kModelInCt.z()}}}},
            {"modes", 3},
            {"amplitude_sd", 1.0},
            {"period_s", 10.0}}}}},
        {"ultrasound",
         {{"enabled", true},
          {"rate_hz", 30.0},
          {"width", 640},
          {"height", 480},
          {"spacing_mm", {0.06, 0.06}},
          {"probe_tool", "ProbeToTracker"},
          {"image_to_probe", {{"translation_mm", {-19.2, 5.0, 0.0}}}},
          {"video_lag_s", 0.0}}}};
    const auto scenario = simulation::parseScenario(s.dump(), dir);
    simulation::OperatingRoom room(scenario);
    room.start();

    workflow::NavigationOptions o;
    o.devices.source = "plus";
    o.devices.port = room.endpoints().plus_port;
    o.required_transforms.clear();
    auto& st = o.soft_tissue;
    st.shape_model = dir / "vessel.h5";
    st.ct_T_model = scenario.patient->soft_tissue->ct_T_model;
    st.patient_T_ct = scenario.patient->reference_T_ct;
    const auto& us = scenario.ultrasound;
    st.probe_T_pixel = us.probe_T_image.matrix();
    st.probe_T_pixel.col(0) *= us.spacing_x_mm;
    st.probe_T_pixel.col(1) *= us.spacing_y_mm;
    st.image_width = us.width;
    st.image_height = us.height;
    // The arm docked, a path planned 10 mm beside the vessel: every update builds the posterior surface within
    // 40 mm of the path with its per-face SD and hands it to the control loop (the arm waits in Ready).
    o.robot.robot = "simulated";
    o.robot.auto_start = false;
    o.robot.max_cycle_time_s = 0.2;
    o.robot.max_missed_cycles = 200;
    o.robot.plan.entry = kModelInCt + Eigen::Vector3d(10.0, -15.0, -15.0);
    o.robot.plan.target = kModelInCt + Eigen::Vector3d(10.0, 10.0, -15.0);
    o.robot.patient_T_plan = scenario.patient->reference_T_ct;
    o.silence_timeout_s = 1.0;
    workflow::NavigationLoop loop(o);
    loop.start();
    std::this_thread::sleep_for(std::chrono::duration<double>(kRunS));
    loop.stop();
    room.stop();

    const auto status = loop.status();
    std::vector<double> ms;
    for (const auto& sample : loop.softTissueSeries()) ms.push_back(sample.frame_to_margin_ms);
    if (ms.empty()) {
      state.SkipWithError(("no posterior update: " + status.soft_tissue).c_str());
      break;
    }
    std::sort(ms.begin(), ms.end());
    auto pct = [&](double p) { return ms[std::min(ms.size() - 1, static_cast<std::size_t>(p * (ms.size() - 1)))]; };
    state.counters["p50_ms"] = pct(0.5);
    state.counters["p99_ms"] = pct(0.99);
    state.counters["max_ms"] = ms.back();
    state.counters["frames_received"] = static_cast<double>(status.us_frames_received);
    state.counters["frames_used"] = static_cast<double>(status.us_frames_used);
    state.counters["frames_skipped"] = static_cast<double>(status.us_frames_skipped);
    state.counters["frames_refused"] = static_cast<double>(status.us_frames_refused);
    state.counters["last_installed_ms"] = status.us_frame_to_margin_ms;
    std::printf("frame -> supervisor margin over %zu updates: p50 %.2f ms, p99 %.2f ms (goal <= 15 ms: %s), max "
                "%.2f ms; %llu frames received, %llu skipped, %llu without a pose\n",
                ms.size(), pct(0.5), pct(0.99), pct(0.99) <= 15.0 ? "met" : "NOT met", ms.back(),
                static_cast<unsigned long long>(status.us_frames_received),
                static_cast<unsigned long long>(status.us_frames_skipped),
                static_cast<unsigned long long>(status.us_frames_refused));
  }
  std::filesystem::remove_all(dir);
}
BENCHMARK(BM_LiveFrameToSupervisorMargin)->Iterations(1)->Unit(benchmark::kSecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
