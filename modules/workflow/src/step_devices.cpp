// connect-devices and navigation steps: run the tracker (and the loop) for a
// while, report what arrived.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>
#include <thread>

#include "mrsns/deformation/deformation_trial.h"
#include "mrsns/deformation/shape_model_ops.h"
#include "mrsns/deformation/shape_tracker.h"
#include "mrsns/deformation/simulated_sweep.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/tracking/hologram_client_preset.h"
#include "mrsns/workflow/navigation.h"
#include "device_params.h"
#include "step_internal.h"
#include "step_navigation_robot.h"
#include "step_navigation_soft_tissue.h"

namespace mrsns::workflow::detail {

namespace {

// Sleeps `seconds` in small slices, reporting progress and honouring cancel.
void waitWhile(double seconds, double from, double to, const std::string& message, const StepContext& context) {
  const auto start = std::chrono::steady_clock::now();
  while (true) {
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (t >= seconds) break;
    context.report(from + (to - from) * t / seconds, message);
    if (context.cancelled()) throw Cancelled{};
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

// The GUI's plots want series, not every batch: an hour at 60 Hz would be a 200k-point JSON figure.
constexpr std::size_t kMaxSeriesPoints = 2000;

/// Every k-th latency sample (k chosen so at most kMaxSeriesPoints remain): a uniform thinning keeps the
/// histogram's shape; the mean and the maximum gap are reported from every batch separately.
void addLatencySeries(const std::vector<NavigationLatencySample>& samples, Json& figures) {
  const std::size_t stride = std::max<std::size_t>(1, (samples.size() + kMaxSeriesPoints - 1) / kMaxSeriesPoints);
  std::vector<double> time_s, latency_ms;
  for (std::size_t i = 0; i < samples.size(); i += stride) {
    time_s.push_back(samples[i].time_s);
    latency_ms.push_back(samples[i].latency_ms);
  }
  figures["loop_latency_ms"] = latency_ms;
  figures["loop_latency_ms_time_s"] = time_s;
  figures["loop_latency_decimation"] = stride;
}

/// The soft-tissue error over one sweep (the trial's first case): after each frame, the mean vertex distance
/// of the posterior shape to the held-out truth, at the frame's time since the sweep began (-1: the prior,
/// at 0 s). What the GUI's deformation plot shows for a live run, from the same simulation.
void addDeformationSeries(const deformation::DeformationTrialOptions& trial, std::uint64_t seed, Json& deformation) {
  const auto sweep = deformation::simulateSweep(trial, seed);
  deformation::ShapeTrackerOptions tracker_options = trial.tracker;
  tracker_options.posterior.noise_sigma_mm = trial.noise_sigma_mm;
  deformation::PosteriorShapeTracker tracker(sweep.model, tracker_options);
  const Eigen::VectorXd truth = deformation::shapeVector(sweep.truth.vertices);
  // Algorithm 1 works in image mm: the believed calibration without its pixel scale.
  Eigen::Matrix4d unscale = Eigen::Matrix4d::Identity();
  unscale.diagonal().head<3>().setConstant(1.0 / sweep.pixel_spacing_mm);
  const Eigen::Isometry3d probe_T_image(sweep.image_to_probe * unscale);
  const auto& frames = sweep.sequence.frames;
  const double t0 = frames.empty() ? 0.0 : frames.front().timestamp;
  std::vector<double> time_s{0.0}, error_mm{deformation::meanVertexDistance(tracker.currentShape(), truth)};
  for (std::size_t f = 0; f < frames.size() && f < sweep.true_contours.size(); ++f) {
    const Eigen::Isometry3d tracker_T_probe(frames[f].transforms.at("ProbeToTracker").matrix);
    const Eigen::Isometry3d tracker_T_reference(frames[f].transforms.at("ReferenceToTracker").matrix);
    tracker.update(tracker_T_reference.inverse() * tracker_T_probe * probe_T_image, sweep.true_contours[f]);
    time_s.push_back(frames[f].timestamp - t0);
    error_mm.push_back(deformation::meanVertexDistance(tracker.currentShape(), truth));
  }
  deformation["error_mm"] = error_mm;
  deformation["error_mm_time_s"] = time_s;
  deformation["error_definition"] =
      "case 1: mean vertex distance of the posterior shape to the held-out truth after each frame (first: prior)";
}

}  // namespace

StepResult runConnectDevices(Session& session, const Json& params, const StepContext& context) {
  const Params p("connect-devices", params, {MRSNS_DEVICE_KEYS, "duration_s"});
  const DeviceOptions devices = deviceOptions(p);
  const double duration = p.number("duration_s", 1.0);
  if (!(duration > 0.0 && duration <= 600.0)) {
    throw InvalidArgumentError("connect-devices: duration_s must be in (0, 600] s");
  }
  auto repository = std::make_shared<TransformRepository>();
  auto source = makeTrackingSource(devices, repository);
  std::mutex mutex;
  std::map<std::string, std::pair<std::uint64_t, std::uint64_t>> seen;  // name -> (ok, not ok)
  // Per tool: first and last timestamp of its valid samples. A PlusServer sends one TRANSFORM per tool, so
  // batches alone would count every tool's message as a tick of its own.
  std::map<std::string, std::pair<double, double>> valid_span;
  std::vector<double> stamps;
  source->setUpdateCallback([&](std::span<const tracking::ToolUpdate> updates) {
    std::lock_guard lock(mutex);
    for (const auto& u : updates) {
      auto& c = seen[u.name];
      (u.status == TransformStatus::Ok ? c.first : c.second)++;
      if (u.status == TransformStatus::Ok) {
        auto [it, fresh] = valid_span.try_emplace(u.name, u.timestamp, u.timestamp);
        if (!fresh) it->second.second = u.timestamp;
      }
    }
    if (!updates.empty()) stamps.push_back(updates.front().timestamp);
  });
  source->start();
  try {
    waitWhile(duration, 0.05, 0.95, "listening to the " + devices.source + " tracker", context);
  } catch (...) {
    source->stop();
    throw;
  }
  source->stop();
  const auto status = source->status();

  std::lock_guard lock(mutex);
  Json tools = Json::object();
  for (const auto& [name, counts] : seen) {
    tools[name] = {{"ok", counts.first}, {"not_ok", counts.second}};
    const auto span = valid_span.find(name);
    if (span != valid_span.end() && counts.first > 1 && span->second.second > span->second.first) {
      tools[name]["rate_hz"] = static_cast<double>(counts.first - 1) / (span->second.second - span->second.first);
    }
  }
  std::vector<double> intervals;
  for (std::size_t i = 1; i < stamps.size(); ++i) intervals.push_back(stamps[i] - stamps[i - 1]);
  double mean = 0.0, jitter = 0.0;
  for (double d : intervals) mean += d;
  if (!intervals.empty()) mean /= static_cast<double>(intervals.size());
  for (double d : intervals) jitter += (d - mean) * (d - mean);
  if (intervals.size() > 1) jitter = std::sqrt(jitter / static_cast<double>(intervals.size() - 1));

  StepResult result;
  result.ok = !seen.empty();
  const std::string identity = source->deviceIdentity();
  result.figures = {{"source", devices.source},
                    {"device_identity", identity},
                    // Provenance: the in-process simulator, or the simulated operating room saying what it is.
                    {"simulated", devices.source == "simulated" || identity.rfind("mrsns-sim", 0) == 0},
                    {"state", std::string(tracking::toString(status.state))},
                    {"message", status.message},
                    {"batches", stamps.size()},
                    {"tools", tools},
                    {"rate_hz", mean > 0.0 ? 1.0 / mean : 0.0},
                    {"interval_jitter_ms", jitter * 1e3}};
  std::ostringstream s;
  s.precision(3);
  if (result.ok) {
    // Per tool: a PlusServer sends each tool in its own message, so the batch rate is not the tracker's.
    std::vector<double> rates;
    for (const auto& [name, figure] : tools.items()) {
      if (figure.contains("rate_hz")) rates.push_back(figure["rate_hz"].get<double>());
    }
    std::sort(rates.begin(), rates.end());
    const double rate = rates.empty() ? (mean > 0.0 ? 1.0 / mean : 0.0) : rates[rates.size() / 2];
    s << seen.size() << " tools from the " << devices.source << " tracker at " << rate << " Hz"
      << (rates.empty() ? "" : " (median per tool)");
    if (result.figures["simulated"].get<bool>())
      s << " [SIMULATED: " << (identity.empty() ? devices.source : identity) << "]";
  } else {
    s << "no data from the " << devices.source << " tracker in " << duration << " s ("
      << tracking::toString(status.state) << (status.message.empty() ? "" : ": " + status.message)
      << "): check that it is running and reachable";
  }
  result.summary = s.str();
  static_cast<void>(session);
  return result;
}

StepResult runNavigation(Session& session, const Json& params, const StepContext& context) {
  const Params p("navigation", params,
                 {MRSNS_DEVICE_KEYS, MRSNS_NAVIGATION_ROBOT_KEYS, MRSNS_NAVIGATION_SOFT_TISSUE_KEYS, "duration_s", "record",
                  "deformation_cases",
                  "deformation_frames", "stream_holograms", "hmd_client"});
  NavigationOptions options;
  options.devices = deviceOptions(p);
  const double duration = p.number("duration_s", 3.0);
  if (!(duration > 0.0 && duration <= 3600.0)) {
    throw InvalidArgumentError("navigation: duration_s must be in (0, 3600] s");
  }
  std::vector<std::string> outputs;
  if (p.boolean("record", true)) {
    std::filesystem::create_directories(session.resolve("navigation"));
    int n = 1;
    std::string name;
    do {
      name = "navigation/tracking_" + std::to_string(n++) + ".mhd";
    } while (std::filesystem::exists(session.resolve(name)));
    options.recording = session.resolve(name);
    outputs.push_back(name);
    outputs.push_back(name.substr(0, name.size() - 4) + ".raw");
  }
  options.stream_holograms = p.boolean("stream_holograms", false);
  options.hologram_client = tracking::hologramClientPreset(p.text("hmd_client", "slicer")).name;
  // The supervisor needs the patient and the probe; a playback or PlusServer
  // source may name its tools differently, so only the simulator is supervised
  // by default.
  if (options.devices.source != "simulated") options.required_transforms.clear();
  // With a plan in the session the loop drives the simulated robot along it: a tracker loss then stops
  // the arm through its safety supervisor.
  configureNavigationRobot(session, p, options);
  // The soft tissue followed on the source's live ultrasound, and watched by the supervisor.
  configureNavigationSoftTissue(session, p, options);

  NavigationLoop loop(options);
  bool robot_stopped = false;
  std::string stop_reason;
  loop.setStopHandler([&](const std::string& reason) {
    robot_stopped = true;
    stop_reason = reason;
  });
  loop.start();
  try {
    waitWhile(duration, 0.02, 0.6, "navigating", context);
  } catch (...) {
    loop.stop();
    throw;
  }
  waitForArmAtRest(loop);
  loop.stop();
  const auto st = loop.status();
  Json events = Json::array();
  for (const auto& e : loop.events()) {
    events.push_back({{"time_s", e.time_s}, {"kind", e.kind}, {"message", e.message}});
    if (e.kind == "safety-stop") session.log("warn", "navigation: " + e.message);
  }
  checkCancel(context);

  std::filesystem::path soft_tissue_file;
  if (!options.recording.empty()) {
    soft_tissue_file = options.recording.parent_path() / (options.recording.stem().string() + "_soft_tissue.json");
  } else {
    soft_tissue_file = session.resolve("navigation/soft_tissue.json");
  }
  const Json soft_tissue = navigationSoftTissueFigures(session, options, loop, soft_tissue_file);
  if (soft_tissue.contains("file")) outputs.push_back(soft_tissue["file"].get<std::string>());
  for (const auto& e : loop.events()) {
    if (e.kind == "soft-tissue-refused") session.log("warn", "navigation: soft tissue refused: " + e.message);
  }

  // The deformation module's own trial on the simulated vessel protocol (paper 001 §III.A, Table I), in
  // process, only when asked for (deformation_cases > 0): the live soft tissue above is what navigation uses.
  Json deformation = Json::object();
  const int cases = p.integer("deformation_cases", 0);
  if (cases > 0) {
    context.report(0.65, "deformation tracking (posterior shape model)");
    deformation::DeformationTrialOptions trial;
    trial.cases = cases;
    trial.frames = p.integer("deformation_frames", 40);
    trial.seed = options.devices.seed;
    const auto r = deformation::runDeformationTrial(trial);
    deformation = {{"cases", cases},
                   {"posterior_sd_mean_mm", r.posterior_sd_mean_mm.mean},
                   {"posterior_sd_max_mm", r.posterior_sd_max_mm.mean},
                   {"posterior_fp_mm", r.posterior_fp_mm.mean},
                   {"prior_sd_mean_mm", r.prior_sd_mean_mm.mean},
                   {"prior_sd_max_mm", r.prior_sd_max_mm.mean},
                   {"prior_fp_mm", r.prior_fp_mm.mean},
                   {"update_ms_p50", r.update_ms_p50},
                   {"update_ms_p99", r.update_ms_p99},
                   {"model_modes", r.model_modes},
                   {"model_points", r.model_points},
                   // Paper 001 Table I (phantom): posterior E^SD and E^FP.
                   {"paper_posterior_sd_mean_mm", 1.52},
                   {"paper_posterior_fp_mm", 2.19}};
    checkCancel(context);
    addDeformationSeries(trial, options.devices.seed, deformation);
  }
  std::size_t recorded_frames = 0;
  if (!options.recording.empty()) {
    recorded_frames = io::readSequenceHeader(options.recording).frames.size();
  }

  if (!st.video_recording.empty()) {
    // The ultrasound video, beside the tracking (a source that delivers images: PlusServer, playback).
    const std::string video = std::filesystem::relative(st.video_recording, session.folder()).generic_string();
    outputs.push_back(video);
    outputs.push_back(video.substr(0, video.size() - 4) + ".raw");
  }
  StepResult result;
  result.ok = st.batches > 0 && st.recorder_error.empty();
  result.outputs = outputs;
  const std::string identity = loop.deviceIdentity();
  result.figures = {{"batches", st.batches},
                    // Provenance (as connect-devices): the in-process simulator, or the simulated operating room
                    // saying what it is; `mrsns-sim score` judges only what came from the room.
                    {"device_identity", identity},
                    {"simulated", options.devices.source == "simulated" || identity.rfind("mrsns-sim", 0) == 0},
                    {"frames_recorded", st.frames_recorded},
                    {"frames_in_file", recorded_frames},
                    {"video_frames_recorded", st.video_frames_recorded},
                    {"video_frames_dropped", st.video_frames_dropped},
                    {"max_batch_gap_ms", st.max_batch_gap_s * 1e3},
                    {"mean_loop_latency_ms", st.mean_loop_latency_ms},
                    {"robot_stopped", robot_stopped},
                    {"stop_reason", stop_reason},
                    {"events", events},
                    {"soft_tissue", soft_tissue},
                    {"deformation", deformation}};
  addLatencySeries(loop.latencySeries(), result.figures);
  if (options.robot.robot != "none") {
    result.figures["robot"] = navigationRobotFigures(options, st, loop.robotTransitions());
    result.figures["time_to_stop_s"] = result.figures["robot"]["time_to_stop_s"];
    result.figures["stop_latency_ms"] = result.figures["robot"]["stop_latency_ms"];
    result.figures["stop_latency_cycles"] = st.stop_latency_cycles;
  }
  std::ostringstream s;
  s.precision(3);
  s << st.batches << " tracking batches, " << recorded_frames << " recorded";
  if (robot_stopped) s << "; robot stopped (" << stop_reason << ")";
  if (robot_stopped && std::isfinite(st.time_to_stop_s)) {
    s << " " << st.stop_latency_ms << " ms after the loss, at rest " << st.time_to_stop_s << " s later";
  }
  if (st.soft_tissue != "off") {
    s << "; soft tissue " << st.soft_tissue << " (" << st.soft_tissue_updates << " posterior updates from "
      << st.us_frames_used << " of " << st.us_frames_received << " frames)";
  }
  if (!deformation.empty()) s << "; posterior E^SD " << deformation["posterior_sd_mean_mm"].get<double>() << " mm";
  if (st.video_frames_recorded > 0) s << "; " << st.video_frames_recorded << " ultrasound frames recorded";
  if (!st.video_error.empty()) s << "; video: " << st.video_error;
  if (!st.recorder_error.empty()) s << "; recording failed: " << st.recorder_error;
  result.summary = s.str();
  return result;
}

}  // namespace mrsns::workflow::detail
