// hmd-calibration acquired with the headset (paper 001 §II.C): the workstation
// serves the cube's hologram to the HMD client, asks for each view in turn,
// takes the operator's confirmation (from the headset, a key or a pedal),
// records the cube's tracked hold, and solves with tremor compensation per
// fiducial and the views averaged. Afterwards the patient's fiducials are shown
// on the headset through the new calibration, so the overlay can be checked
// (and, in mrsns-sim, scored at the headset: Eq. 23).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>

#include "hmd_cube_calibration.h"
#include "landmark_touch_step.h"
#include "step_hologram_stream.h"
#include "live_tracking_recording.h"
#include "mrsns/core/format.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/transform_repository.h"
#include "mrsns/core/wall_clock.h"
#include "mrsns/igtlink/server.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/tracking/hologram_streamer.h"
#include "step_internal.h"
#include "time_text.h"

namespace mrsns::workflow::detail {

namespace {

namespace fs = std::filesystem;

constexpr const char* kStep = "hmd-calibration";
constexpr const char* kCubeModel = "CalibrationCube";
constexpr const char* kFiducialModel = "CTFiducials";

std::vector<std::string> splitNames(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  std::string name;
  while (std::getline(ss, name, ',')) {
    const auto a = name.find_first_not_of(' ');
    const auto b = name.find_last_not_of(' ');
    if (a != std::string::npos) out.push_back(name.substr(a, b - a + 1));
  }
  return out;
}

Eigen::Vector3d vectorParam(const Params& p, const std::string& key, const Eigen::Vector3d& fallback) {
  if (!p.has(key)) return fallback;
  const auto parts = splitNames(p.text(key, ""));
  Eigen::Vector3d v;
  if (parts.size() != 3) throw InvalidArgumentError(std::string(kStep) + ": " + key + " must be x,y,z in mm");
  for (int i = 0; i < 3; ++i) {
    try {
      v[i] = std::stod(parts[static_cast<std::size_t>(i)]);
    } catch (const std::exception&) {
      throw InvalidArgumentError(std::string(kStep) + ": " + key + " must be x,y,z in mm");
    }
  }
  if (!v.allFinite()) throw InvalidArgumentError(std::string(kStep) + ": " + key + " must be finite");
  return v;
}

fs::path cubeFile(const Params& p) {
  if (p.has("cube")) return p.text("cube", "");
  return resourceDirectory() / "devices" / "calibration_cube.json";
}

// Small octahedra at the CT fiducials: the overlay the operator checks after the calibration.
TriangleMesh fiducialMarkers(const std::vector<Eigen::Vector3d>& points, double radius_mm) {
  TriangleMesh m;
  m.vertices.resize(static_cast<Eigen::Index>(6 * points.size()), 3);
  m.faces.resize(static_cast<Eigen::Index>(8 * points.size()), 3);
  const Eigen::Vector3d axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  static const int kFaces[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                   {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto base = static_cast<Eigen::Index>(6 * i);
    for (int k = 0; k < 6; ++k) m.vertices.row(base + k) = (points[i] + radius_mm * axes[k]).transpose();
    for (int f = 0; f < 8; ++f) {
      m.faces.row(static_cast<Eigen::Index>(8 * i) + f) << static_cast<int>(base) + kFaces[f][0],
          static_cast<int>(base) + kFaces[f][1], static_cast<int>(base) + kFaces[f][2];
    }
  }
  return m;
}

// The session's patient registration, when there is one: the fiducials to show and the chain to show them by.
struct RegisteredPatient {
  Eigen::Isometry3d patient_T_ct = Eigen::Isometry3d::Identity();
  std::string reference = "Patient";
  std::vector<Eigen::Vector3d> fiducials_ct;
};

std::optional<RegisteredPatient> registeredPatient(const Session& session) {
  const auto entry = session.step("registration");
  if (entry.is_null() || entry.value("status", "") != "ok" || !entry.contains("figures")) return std::nullopt;
  const auto& f = entry["figures"];
  if (!f.contains("transforms") || !f["transforms"].contains("CTToPatient") || !f.contains("landmarks")) {
    return std::nullopt;
  }
  RegisteredPatient r;
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.matrix() = matrixFromJson(f["transforms"]["CTToPatient"], "registration.CTToPatient");
  r.patient_T_ct = t;
  // The marker the registration registered to (its `reference` parameter, Patient by default).
  if (entry.contains("params") && entry["params"].is_object() && entry["params"].contains("reference") &&
      entry["params"]["reference"].is_string()) {
    r.reference = entry["params"]["reference"].get<std::string>();
  }
  for (const auto& fid : f["landmarks"].value("fiducials", Json::array())) {
    if (!fid.contains("ct_mm") || !fid["ct_mm"].is_array() || fid["ct_mm"].size() != 3) continue;
    r.fiducials_ct.emplace_back(fid["ct_mm"][0].get<double>(), fid["ct_mm"][1].get<double>(),
                                fid["ct_mm"][2].get<double>());
  }
  if (r.fiducials_ct.empty()) return std::nullopt;
  return r;
}

Json viewFigures(const std::vector<CubeHold>& holds, const CubeHoldsSolution& s) {
  Json views = Json::array();
  for (std::size_t i = 0; i < holds.size(); ++i) {
    const auto& v = s.views[i];
    views.push_back({{"view", holds[i].view},
                     {"confirmed_by", holds[i].confirmed_by},
                     {"hold_s", holds[i].end - holds[i].start},
                     {"samples", v.samples},
                     {"untracked_samples", v.untracked},
                     {"tremor_dropped_samples", v.dropped},
                     {"largest_spread_mm", v.largest_spread_mm},
                     {"rigid_rms_mm", v.rigid_rms_mm},
                     {"affine_rms_mm", v.affine_rms_mm},
                     {"HologramToTracker", matrixJson(v.tracker_T_hologram.matrix())}});
  }
  return views;
}

// What the live acquisition decides, frame after frame.
class CubeHoldAcquisition {
 public:
  struct Settings {
    std::vector<std::string> views;
    double hold_s = 2.0;
    double hmd_wait_s = 120.0;
    double verify_s = 5.0;
    double max_spread_mm = 3.0;
    double max_view_disagreement_mm = 15.0;
    Eigen::Isometry3d hologram_T_marker = Eigen::Isometry3d::Identity();
    std::string endpoint;  // address:port of the hologram stream, for messages
  };

  CubeHoldAcquisition(Settings settings, const CubeDefinition& cube, const CubeHoldsOptions& options,
                      tracking::HologramStreamer& streamer, TransformRepository& repository,
                      std::optional<RegisteredPatient> patient, const std::atomic<std::uint64_t>& hmd_confirmations,
                      const std::atomic<std::uint64_t>* key_confirmations)
      : s_(std::move(settings)),
        cube_(cube),
        options_(options),
        streamer_(streamer),
        repository_(repository),
        patient_(std::move(patient)),
        hmd_confirmations_(hmd_confirmations),
        key_confirmations_(key_confirmations) {
    seen_hmd_ = hmd_confirmations_.load();
    seen_key_ = key_confirmations_ ? key_confirmations_->load() : 0;
    waiting_since_ = std::chrono::steady_clock::now();
  }

  /// The monitor of the live recording: true when done (or failed: see failure()).
  bool step(const std::vector<TrackedFrame>& frames, std::string& message) {
    const double now = frames.back().timestamp;
    if (patient_) {
      const auto it = frames.back().transforms.find(patient_->reference + "ToTracker");
      if (it != frames.back().transforms.end() && it->second.status == TransformStatus::Ok &&
          isRigid(it->second.matrix, 1e-3)) {
        repository_.setTransform(patient_->reference, "Tracker", orthonormalize(it->second.matrix),
                                 TransformStatus::Ok, now);
        reference_seen_ = true;
      } else if (reference_seen_) {
        // Not seen now: the overlay is hidden until it is (an edge never set stays Missing by itself).
        repository_.setStatus(patient_->reference, "Tracker", TransformStatus::Invalid, now);
      }
    }
    streamer_.update(unixTimeSeconds());
    const bool headset = streamer_.readyClients() > 0;
    const std::string confirmed_by = takeConfirmation();
    switch (phase_) {
      case Phase::WaitHeadset:
        if (headset) {
          askForView();
          break;
        }
        failure_ = headsetWaitFailure(drops_, s_.endpoint, elapsedWaiting(), s_.hmd_wait_s);
        if (!failure_.empty()) return true;
        message = headsetWaitMessage(drops_, s_.endpoint, "view " + viewLabel());
        return false;
      case Phase::Aligning:
        if (!headset) return headsetLeft(message);
        if (!confirmed_by.empty()) {
          hold_ = CubeHold{s_.views[view_], s_.hologram_T_marker, now, now + s_.hold_s, confirmed_by};
          phase_ = Phase::Holding;
          streamer_.setPrompt("Hold the cube still: recording view " + viewLabel());
        }
        break;
      case Phase::Holding:
        if (!headset) return headsetLeft(message);
        if (now >= hold_.end) judgeHold(frames);
        break;
      case Phase::Verifying:
        if (now >= verify_until_) return true;
        break;
      case Phase::Done:
        break;
    }
    message = status();
    return phase_ == Phase::Done;
  }

  [[nodiscard]] const std::vector<CubeHold>& holds() const { return holds_; }
  [[nodiscard]] const std::string& failure() const { return failure_; }
  [[nodiscard]] const std::vector<std::string>& rejected() const { return rejected_; }
  [[nodiscard]] int drops() const { return drops_; }
  [[nodiscard]] std::optional<Eigen::Isometry3d> calibration() const { return calibration_; }
  [[nodiscard]] bool verified() const { return verified_; }

 private:
  enum class Phase { WaitHeadset, Aligning, Holding, Verifying, Done };

  std::string viewLabel() const {
    return std::to_string(view_ + 1) + " of " + std::to_string(s_.views.size()) + " (" + s_.views[view_] + ")";
  }
  double elapsedWaiting() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - waiting_since_).count();
  }

  // A confirmation since the last look: from the headset or the keyboard/pedal. Confirmations that arrive
  // while nothing waits for one are used up, so a stray tap does not confirm the next view.
  std::string takeConfirmation() {
    std::string by;
    const auto h = hmd_confirmations_.load();
    if (h != seen_hmd_) by = "headset";
    seen_hmd_ = h;
    if (key_confirmations_) {
      const auto k = key_confirmations_->load();
      if (k != seen_key_ && by.empty()) by = "key";
      seen_key_ = k;
    }
    return phase_ == Phase::Aligning ? by : std::string();
  }

  void askForView() {
    phase_ = Phase::Aligning;
    streamer_.setPrompt("HMD calibration, view " + viewLabel() +
                        ": line up the cube with its hologram, hold it still and confirm");
  }

  bool headsetLeft(std::string& message) {
    // The operator cannot see the hologram: a hold under way is not trusted, the view is asked again.
    ++drops_;
    phase_ = Phase::WaitHeadset;
    // What a headset that comes back sees first, until the view is asked again.
    streamer_.setPrompt("HMD calibration paused: the headset was away");
    waiting_since_ = std::chrono::steady_clock::now();
    message = "the headset left the hologram stream: waiting for it to come back (view " + viewLabel() + " again)";
    return false;
  }

  void judgeHold(const std::vector<TrackedFrame>& frames) {
    const auto samples = holdSamples(frames, hold_, options_.transform);
    std::string why;
    if (samples.frames == 0) {
      why = "no tracking arrived during the hold";
    } else if (samples.tracker_T_marker.size() <= static_cast<std::size_t>(options_.k_close) ||
               2 * samples.untracked > samples.frames) {
      why = "the cube was not tracked in " + std::to_string(samples.untracked) + " of " +
            std::to_string(samples.frames) + " samples: keep its marker in the camera's view";
    } else {
      try {
        const auto solution = solveCubeHold(samples, hold_, cube_, options_);
        if (solution.largest_spread_mm > s_.max_spread_mm) {
          why = "the cube moved during the hold (spread " + formatFixed(solution.largest_spread_mm, 1) +
                " mm, at most " + formatFixed(s_.max_spread_mm, 1) + "): hold it still";
        }
      } catch (const Error& e) {
        why = std::string("its samples give no calibration (") + e.what() + ")";
      }
    }
    if (!why.empty()) {
      reject(why);
      return;
    }
    if (retry_single_) {
      // The view asked again after it disagreed: back in its place, then the views are judged again.
      holds_.insert(holds_.begin() + static_cast<std::ptrdiff_t>(view_), hold_);
      onHoldsChanged_();
      retry_single_ = false;
      view_ = s_.views.size();
    } else {
      holds_.push_back(hold_);
      onHoldsChanged_();
      ++view_;
    }
    if (view_ < s_.views.size()) {
      askForView();
      return;
    }
    view_ = s_.views.size() - 1;
    // A view far from the others was not matched with the hologram (the cube left lying somewhere, the wrong
    // hologram): it is asked again.
    if (const auto outlier = disagreeingView(frames)) {
      view_ = *outlier;
      holds_.erase(holds_.begin() + static_cast<std::ptrdiff_t>(view_));
      onHoldsChanged_();
      // Only that view is asked again; the others are kept.
      reject("it puts the cube's hologram more than " + formatFixed(s_.max_view_disagreement_mm, 0) +
             " mm from where the other views put it");
      retry_single_ = true;
      return;
    }
    finish(frames);
  }

  // The view whose calibration puts the cube's hologram farthest from the others' median, when that is more
  // than max_view_disagreement_mm.
  std::optional<std::size_t> disagreeingView(const std::vector<TrackedFrame>& frames) const {
    if (holds_.size() < 3) return std::nullopt;
    std::vector<Eigen::Vector3d> centre;
    const Eigen::Vector3d c = s_.hologram_T_marker * cube_.marker_T_cube.translation();
    for (const auto& hold : holds_) {
      try {
        centre.push_back(solveCubeHold(holdSamples(frames, hold, options_.transform), hold, cube_, options_)
                             .tracker_T_hologram *
                         c);
      } catch (const Error&) {
        return std::nullopt;
      }
    }
    Eigen::Vector3d median;
    for (int k = 0; k < 3; ++k) {
      std::vector<double> v;
      for (const auto& p : centre) v.push_back(p[k]);
      std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
      median[k] = v[v.size() / 2];
    }
    std::size_t worst = 0;
    for (std::size_t i = 1; i < centre.size(); ++i) {
      if ((centre[i] - median).norm() > (centre[worst] - median).norm()) worst = i;
    }
    if ((centre[worst] - median).norm() <= s_.max_view_disagreement_mm) return std::nullopt;
    return worst;
  }

  void reject(const std::string& why) {
    rejected_.push_back("view " + s_.views[view_] + ": " + why);
    askForViewAfter(why);
  }

  void finish(const std::vector<TrackedFrame>& frames) {
    const auto solution = solveCubeHolds(frames, holds_, cube_, options_);
    calibration_ = solution.tracker_T_hologram;
    repository_.setTransform("Hologram", "Tracker", solution.tracker_T_hologram, TransformStatus::Ok);
    repository_.setStatus(kCubeModel, "Hologram", TransformStatus::Missing);
    if (patient_ && s_.verify_s > 0.0) {
      verified_ = true;
      phase_ = Phase::Verifying;
      verify_until_ = frames.back().timestamp + s_.verify_s;
      streamer_.setPrompt("HMD calibration done: check that the patient's fiducials lie on the markers");
      view_ = s_.views.size() - 1;
      return;
    }
    streamer_.setPrompt("HMD calibration done");
    view_ = s_.views.size() - 1;
    phase_ = Phase::Done;
  }

  void askForViewAfter(const std::string& why) {
    phase_ = Phase::Aligning;
    streamer_.setPrompt("HMD calibration, view " + viewLabel() + " again (" + why +
                        "): line up the cube with its hologram, hold it still and confirm");
  }

  std::string status() const {
    const std::string done = std::to_string(holds_.size()) + " of " + std::to_string(s_.views.size()) + " views";
    switch (phase_) {
      case Phase::Aligning:
        return "view " + viewLabel() + ": line up the cube with its hologram and confirm (headset, F8 or the pedal); " +
               done;
      case Phase::Holding:
        return "view " + viewLabel() + ": hold the cube still (" + formatFixed(s_.hold_s, 0) + " s); " + done;
      case Phase::Verifying:
        return "calibrated from " + done + ": the patient's fiducials are shown on the headset for checking";
      default:
        return done;
    }
  }

  Settings s_;
  const CubeDefinition& cube_;
  CubeHoldsOptions options_;
  tracking::HologramStreamer& streamer_;
  TransformRepository& repository_;
  std::optional<RegisteredPatient> patient_;
  const std::atomic<std::uint64_t>& hmd_confirmations_;
  const std::atomic<std::uint64_t>* key_confirmations_;
  std::uint64_t seen_hmd_ = 0, seen_key_ = 0;
  Phase phase_ = Phase::WaitHeadset;
  std::size_t view_ = 0;
  CubeHold hold_;
  std::vector<CubeHold> holds_;
  std::vector<std::string> rejected_;
  std::chrono::steady_clock::time_point waiting_since_;
  int drops_ = 0;
  std::string failure_;
  std::optional<Eigen::Isometry3d> calibration_;
  bool verified_ = false;
  double verify_until_ = 0.0;
  bool reference_seen_ = false;
  bool retry_single_ = false;
  std::function<void()> onHoldsChanged_ = [] {};

 public:
  /// Called whenever the accepted holds change (to keep them on disk as they are acquired).
  void onHoldsChanged(std::function<void()> f) { onHoldsChanged_ = std::move(f); }
};

}  // namespace

StepResult runAcquiredHmdCalibration(Session& session, const Json& params, const StepContext& context) {
  const Params p(kStep, params,
                 {"source", "host", "port", "recording", "holds", "duration_s", "connect_timeout_s", "hmd_address",
                  "hmd_port", "unity", "tool", "cube", "views", "hold_s", "hmd_wait_s", "verify_s",
                  "max_spread_mm", "max_view_disagreement_mm", "hologram_position_mm", "k_close", "omega",
                  "tremor_compensation", "webxr_port", "webxr_address", "webxr_code", "webxr_tls_dir"});
  checkCancel(context);
  const std::string source = p.text("source", "hmd");
  const CubeDefinition cube = readCubeDefinition(cubeFile(p));
  CubeHoldsOptions options;
  options.transform = p.text("tool", "Cube") + "ToTracker";
  options.k_close = p.integer("k_close", options.k_close);
  options.omega = p.number("omega", options.omega);
  options.tremor_compensation = p.boolean("tremor_compensation", options.tremor_compensation);
  if (options.k_close < 2 || !(options.omega > 0.0)) {
    throw InvalidArgumentError(std::string(kStep) + ": k_close must be >= 2 and omega > 0 (Eq. 13-14)");
  }

  StepResult result;
  std::vector<TrackedFrame> frames;
  std::vector<CubeHold> holds;
  std::string recording, holds_file;
  Json recorded;
  Json acquisition = Json::object();
  if (source == "hmd") {
    CubeHoldAcquisition::Settings s;
    s.views = splitNames(p.text("views", "front,left,right,ground"));
    s.hold_s = p.number("hold_s", s.hold_s);
    s.hmd_wait_s = p.number("hmd_wait_s", s.hmd_wait_s);
    s.verify_s = p.number("verify_s", s.verify_s);
    s.max_spread_mm = p.number("max_spread_mm", s.max_spread_mm);
    s.max_view_disagreement_mm = p.number("max_view_disagreement_mm", s.max_view_disagreement_mm);
    if (s.views.empty() || s.views.size() > 12 || !(s.hold_s >= 0.5 && s.hold_s <= 30.0) ||
        !(s.hmd_wait_s > 0.0 && s.hmd_wait_s <= 1800.0) || !(s.verify_s >= 0.0 && s.verify_s <= 600.0) ||
        !(s.max_spread_mm > 0.0) || !(s.max_view_disagreement_mm > 0.0)) {
      throw InvalidArgumentError(std::string(kStep) +
                                 ": views must name 1 to 12 views, hold_s be 0.5-30 s, hmd_wait_s in (0, 1800] s, "
                                 "verify_s 0-600 s, max_spread_mm and max_view_disagreement_mm > 0");
    }
    // Where the headset shows the cube, in its own world frame: half a metre ahead of where its app started
    // (a HoloLens app's world origin: +z ahead in Unity; in a WebXR 'local' space -z is ahead), unless the lab
    // places it elsewhere.
    const double ahead_mm = p.integer("webxr_port", 0) > 0 ? -500.0 : 500.0;
    s.hologram_T_marker.translation() = vectorParam(p, "hologram_position_mm", Eigen::Vector3d(0.0, 0.0, ahead_mm));
    // A headset sends confirmations and status, nothing large.
    const StepStreamAddress address = stepStreamAddress(kStep, p, 64 * 1024);
    s.endpoint = address.endpoint;
    auto repository = std::make_shared<TransformRepository>();
    repository->setTransform(kCubeModel, "Hologram", s.hologram_T_marker, TransformStatus::Ok);
    std::vector<tracking::HologramModel> models;
    TriangleMesh cube_mesh = cube.mesh();
    models.push_back({kCubeModel, cube_mesh, kCubeModel});
    auto patient = registeredPatient(session);
    if (patient) {
      repository->setTransform("CT", patient->reference, patient->patient_T_ct, TransformStatus::Ok);
      models.push_back({kFiducialModel, fiducialMarkers(patient->fiducials_ct, 2.0), "CT"});
    }
    // Everything the parameters can refuse is refused before the stream is served.
    LiveTrackingOptions live = touchRecordingOptions(session, p, kStep, "CubeHolds", 600.0, recording);
    holds_file = freeSessionName(session, kStep, "holds", ".json");
    std::atomic<std::uint64_t> hmd_confirmations{0};
    tracking::HologramStreamOptions stream_options;
    // The headset's confirmation reaches this step and nothing else.
    stream_options.on_confirmation = [&hmd_confirmations](igtlink::ClientId, const std::string& text) {
      if (!text.empty()) hmd_confirmations.fetch_add(1);
    };
    StepHologramStream stream(kStep, address, repository, models, stream_options);
    CubeHoldAcquisition acquisition_state(s, cube, options, stream.streamer(), *repository, patient, hmd_confirmations,
                                          context.confirmations);
    // The accepted holds are on disk as soon as they are accepted: a cancelled or failed acquisition keeps them
    // beside its recording.
    const fs::path holds_path = session.resolve(holds_file);
    acquisition_state.onHoldsChanged([&] {
      std::ofstream(holds_path) << holdsJson(cube, options, acquisition_state.holds()).dump(2) << "\n";
    });
    std::ofstream(holds_path) << holdsJson(cube, options, {}).dump(2) << "\n";
    context.report(0.02, "serving the cube's hologram on " + s.endpoint + "; tracking from " + live.host + ":" +
                             std::to_string(live.port));
    const auto monitor = [&](const std::vector<TrackedFrame>& so_far, std::string& message) {
      return acquisition_state.step(so_far, message);
    };
    const LiveTrackingRecording r = recordLiveTracking(live, monitor, context);
    stream.stop();
    recorded = recordedFigures(r, recording, live);
    frames = r.frames;
    holds = acquisition_state.holds();
    result.figures["simulated"] = fromSimulatedRoom(r.device_identity);
    result.outputs.push_back(recording);
    acquisition = {{"hologram_stream", s.endpoint},
                   {"headset_drops", acquisition_state.drops()},
                   {"rejected_holds", acquisition_state.rejected()},
                   {"verification_model", acquisition_state.verified() ? Json(kFiducialModel) : Json(nullptr)},
                   {"hologram_position_mm",
                    {s.hologram_T_marker.translation().x(), s.hologram_T_marker.translation().y(),
                     s.hologram_T_marker.translation().z()}}};
    result.outputs.push_back(holds_file);
    const std::string kept = " (kept: " + recording + ", " + holds_file + ")";
    if (!acquisition_state.failure().empty() || holds.size() < s.views.size()) {
      result.ok = false;
      result.figures["recorded"] = recorded;
      result.figures["acquisition"] = acquisition;
      result.figures["views_done"] = holds.size();
      result.summary = (acquisition_state.failure().empty()
                            ? "the time ran out after " + std::to_string(holds.size()) + " of " +
                                  std::to_string(s.views.size()) + " views"
                            : acquisition_state.failure() + "; " + std::to_string(holds.size()) + " of " +
                                  std::to_string(s.views.size()) + " views done") +
                       kept;
      return result;
    }
  } else if (source == "file") {
    for (const char* key : {"host", "port", "duration_s", "connect_timeout_s", "hmd_address", "hmd_port", "unity",
                            "views", "hold_s", "hmd_wait_s", "verify_s", "max_spread_mm", "max_view_disagreement_mm",
                            "hologram_position_mm", "webxr_port", "webxr_address", "webxr_code", "webxr_tls_dir"}) {
      if (p.has(key)) throw InvalidArgumentError(std::string(kStep) + ": " + key + " is for source=hmd");
    }
    if (!p.has("recording") || !p.has("holds")) {
      throw InvalidArgumentError(std::string(kStep) +
                                 ": source=file needs recording (the tracking of the holds) and holds (holds.json)");
    }
    recording = p.text("recording", "");
    holds_file = p.text("holds", "");
    frames = io::readSequenceHeader(recordingPath(session, recording), {}).frames;
    std::ifstream in(recordingPath(session, holds_file));
    if (!in) throw FileError(std::string(kStep) + ": cannot read holds '" + holds_file + "'");
    Json j;
    try {
      j = Json::parse(in);
    } catch (const Json::parse_error& e) {
      throw FormatError(holds_file + " is not valid JSON (" + e.what() + ")");
    }
    holds = holdsFromJson(j, holds_file);
    if (j.contains("transform") && j["transform"].is_string() && !p.has("tool")) {
      options.transform = j["transform"].get<std::string>();
    }
    if (j.contains("tremor_compensation") && j["tremor_compensation"].is_boolean() && !p.has("tremor_compensation")) {
      options.tremor_compensation = j["tremor_compensation"].get<bool>();
    }
    recorded = {{"file", recording}, {"frames", frames.size()}};
  } else {
    throw InvalidArgumentError(std::string(kStep) + ": source must be hmd (live, with the headset), file or " +
                               "simulated, not '" + source + "'");
  }

  checkCancel(context);
  context.report(0.9, "tremor compensation per fiducial and the views averaged");
  const auto solution = solveCubeHolds(frames, holds, cube, options);
  const std::string points = freeSessionName(session, kStep, "cube_points", ".csv");
  writeCubePointsCsv(session.resolve(points), frames, holds, cube, options);
  result.outputs.push_back(points);
  result.ok = true;
  result.figures["source"] = source;
  result.figures["recorded"] = recorded;
  if (!acquisition.empty()) result.figures["acquisition"] = acquisition;
  result.figures["method"] =
      options.tremor_compensation
          ? "paper 001 §II.C: tremor compensation (Eq. 12-16, K_close " + std::to_string(options.k_close) +
                ", omega " + formatFixed(options.omega, 2) +
                ") per fiducial, cube calibration per view (Eq. 17), views averaged (Eq. 18-20)"
          : "paper 001's uncompensated control: each fiducial from the sample at the confirmation, cube "
            "calibration per view (Eq. 2-3), views averaged (Eq. 18-20)";
  result.figures["cube"] = {{"name", cube.name}, {"file", cube.file}, {"edge_mm", cube.edge_mm}};
  result.figures["views"] = viewFigures(holds, solution);
  result.figures["view_spread"] = {{"at_cube_rms_mm", solution.at_cube_rms_mm},
                                   {"max_pairwise_rotation_deg", solution.max_pairwise_rotation_deg},
                                   {"max_pairwise_translation_mm", solution.max_pairwise_translation_mm}};
  result.figures["transforms"] = {{"HologramToTracker", matrixJson(solution.tracker_T_hologram.matrix())}};
  result.figures["holds_file"] = holds_file;
  result.figures["offline_command"] = "mrsns-cli session run " + session.folder().string() + " " + kStep +
                                      " --param source=file --param recording=" +
                                      recordingPath(session, recording).string() +
                                      " --param holds=" + recordingPath(session, holds_file).string();
  // The verb's tremor filter has K_close 4 (the paper's): it recomputes the step only with that.
  if (options.k_close == 4) {
    result.figures["offline_verb"] = "mrsns-cli hmd-calibrate-cube --points " + session.resolve(points).string() +
                                     " --omega " + formatFixed(options.omega, 17);
  }
  std::ostringstream s;
  s << "HologramToTracker from " << holds.size() << " views: at the cube they agree within "
    << formatFixed(solution.at_cube_rms_mm, 2) << " mm RMS (" << formatFixed(solution.max_pairwise_rotation_deg, 2)
    << " deg apart at most)";
  if (acquisition.value("headset_drops", 0) > 0) {
    s << "; the headset left " << acquisition["headset_drops"].get<int>() << " time(s), its views were asked again";
  }
  result.summary = s.str();
  return result;
}

}  // namespace mrsns::workflow::detail
