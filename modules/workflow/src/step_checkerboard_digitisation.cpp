// checkerboard-digitisation: paper 000 §2.3. The calibrated stylus touches
// every inner corner of the tracked checkerboard, one after the other as the
// workstation asks (on its screen and, when a headset is served, on the
// headset); a corner is captured when the tip holds still on it. The corners,
// in the board marker's frame, are fitted to the ideal grid (RANSAC, then least
// squares): GridToBoard (T_p^b) and the digitised corners, which the camera's
// hand-eye calibration (hmd-camera-calibration) then uses instead of the
// board's CAD. A touch far from where the board's definition puts the corner
// asked for is refused and the corner asked again; a corner that does not fit
// the grid the others make is asked again once all are in. source=file
// recomputes it from the recording and the touches file with the same numbers.
#include <algorithm>
#include <fstream>
#include <optional>
#include <sstream>

#include "checkerboard_board.h"
#include "landmark_touch_step.h"
#include "live_tracking_recording.h"
#include "mrsns/core/format.h"
#include "mrsns/core/frame_poses.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/wall_clock.h"
#include "mrsns/hmd/checkerboard_dataset.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/io/transform_io.h"
#include "mrsns/tracking/hologram_streamer.h"
#include "registration_acquisition.h"
#include "step_hologram_stream.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

namespace {

namespace fs = std::filesystem;

constexpr const char* kDigitisationStep = "checkerboard-digitisation";

// One corner's touch: the stretch of the recording the tip held still on it.
struct CornerTouch {
  int corner = 0;
  double start_s = 0.0, end_s = 0.0;
};

std::string cornerLabel(int corner, const hmd::CheckerboardSpec& spec) {
  return "row " + std::to_string(corner / spec.cols + 1) + ", column " + std::to_string(corner % spec.cols + 1);
}

// The tip in the board's frame averaged over a touch's samples: the same function live and offline.
std::optional<Eigen::Vector3d> touchedPoint(const std::vector<FramePose>& poses, const Eigen::Vector3d& tip,
                                            const CornerTouch& t, int& samples) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  samples = 0;
  for (const auto& p : poses) {
    if (p.timestamp < t.start_s || p.timestamp > t.end_s) continue;
    sum += p.to_T_from * tip;
    ++samples;
  }
  if (samples == 0) return std::nullopt;
  return Eigen::Vector3d(sum / samples);
}

Json touchesJson(const std::vector<CornerTouch>& touches, const std::string& transform, const Eigen::Vector3d& tip,
                 const hmd::CheckerboardSpec& spec) {
  Json list = Json::array();
  for (const auto& t : touches) list.push_back({{"corner", t.corner}, {"start_s", t.start_s}, {"end_s", t.end_s}});
  return {{"format", "mrsns-board-touches/1"},
          {"transform", transform},
          {"tip_marker_mm", {tip.x(), tip.y(), tip.z()}},
          {"board", {{"rows", spec.rows}, {"cols", spec.cols}, {"square_mm", spec.square_mm}}},
          {"touches", list}};
}

std::vector<CornerTouch> touchesFromJson(const Json& j, const std::string& file, int corners) {
  if (!j.is_object() || j.value("format", "") != "mrsns-board-touches/1" || !j.contains("touches") ||
      !j["touches"].is_array()) {
    throw FormatError("'" + file + "' is not a board touches file (\"format\": \"mrsns-board-touches/1\")");
  }
  std::vector<CornerTouch> out;
  for (const auto& t : j["touches"]) {
    if (!t.is_object() || !t.contains("corner") || !t["corner"].is_number_integer() || !t.contains("start_s") ||
        !t["start_s"].is_number() || !t.contains("end_s") || !t["end_s"].is_number()) {
      throw FormatError("'" + file + "': every touch needs corner (an integer), start_s and end_s");
    }
    const auto corner = t["corner"].get<long long>();
    if (corner < 0 || corner >= corners) {
      throw FormatError("'" + file + "': touch of corner " + std::to_string(corner) + " out of range (0-" +
                        std::to_string(corners - 1) + ")");
    }
    CornerTouch c{static_cast<int>(corner), t["start_s"].get<double>(), t["end_s"].get<double>()};
    if (!(c.end_s >= c.start_s)) throw FormatError("'" + file + "': a touch ends before it starts");
    out.push_back(c);
  }
  return out;
}

// What the live acquisition decides, frame after frame.
class CornerTouchAcquisition {
 public:
  struct Settings {
    BoardDefinition board;
    RegistrationAcquisitionOptions holds;
    double tolerance_mm = 10.0;
    double inlier_threshold_mm = 1.5;
    int max_retouch_rounds = 2;
  };

  CornerTouchAcquisition(Settings s, tracking::HologramStreamer* streamer)
      : s_(std::move(s)), streamer_(streamer), expected_(s_.board.cornersMarker()) {
    for (int k = 0; k < static_cast<int>(expected_.size()); ++k) queue_.push_back(k);
    touch_of_corner_.assign(expected_.size(), std::nullopt);
  }

  bool step(const std::vector<TrackedFrame>& frames, std::string& message) {
    if (streamer_ != nullptr) streamer_->update(unixTimeSeconds());
    if (frames.empty()) return false;
    if (!asked_) {
      ask(frames.back().timestamp, "");
      message = prompt_;
      return false;
    }
    // Only what came after the question: a hold before it answered an earlier one.
    std::vector<TrackedFrame> since;
    for (auto it = frames.rbegin(); it != frames.rend() && it->timestamp > asked_at_; ++it) since.push_back(*it);
    std::reverse(since.begin(), since.end());
    std::vector<LandmarkCapture> holds;
    try {
      holds = findTipHolds(since, s_.holds);
    } catch (const FrameError&) {
      holds.clear();  // neither stylus nor board seen since the question
    }
    // A tip still resting where the last touch was when the question came is that touch going on, not the next
    // one; a hold there that starts later (the tip lifted and put back: a corner asked again) is a new touch.
    for (const auto& hold : holds) {
      const bool going_on = since.empty() || hold.start_s - since.front().timestamp < 0.1;
      if (last_point_ && going_on && (hold.tip_patient - *last_point_).norm() < s_.holds.rearm_mm) continue;
      judge(hold, frames);
      break;
    }
    message = done_ ? "all " + std::to_string(expected_.size()) + " corners digitised" : prompt_ + status();
    return done_ || !failure_.empty();
  }

  [[nodiscard]] const std::vector<CornerTouch>& touches() const { return touches_; }
  [[nodiscard]] const std::vector<std::string>& rejected() const { return rejected_; }
  [[nodiscard]] const std::string& failure() const { return failure_; }
  [[nodiscard]] bool done() const { return done_; }
  std::function<void()> on_touches_changed = [] {};

 private:
  int corner() const { return queue_.front(); }

  void ask(double now, const std::string& why) {
    asked_ = true;
    asked_at_ = now;
    const int n = static_cast<int>(expected_.size());
    prompt_ = "Board digitisation: touch corner " + std::to_string(corner() + 1) + " of " + std::to_string(n) + " (" +
              cornerLabel(corner(), s_.board.spec) + ") with the stylus tip and hold it still" +
              (why.empty() ? "" : " (again: " + why + ")");
    if (streamer_ != nullptr) streamer_->setPrompt(prompt_);
  }

  std::string status() const {
    int have = 0;
    for (const auto& t : touch_of_corner_) have += t.has_value();
    return "; " + std::to_string(have) + " of " + std::to_string(expected_.size()) + " corners";
  }

  void judge(const LandmarkCapture& hold, const std::vector<TrackedFrame>& frames) {
    const int k = corner();
    last_point_ = hold.tip_patient;
    // The board's definition says roughly where each corner is: a touch far from the one asked for is another.
    int nearest = 0;
    for (int c = 1; c < static_cast<int>(expected_.size()); ++c) {
      if ((hold.tip_patient - expected_[c]).norm() < (hold.tip_patient - expected_[nearest]).norm()) nearest = c;
    }
    const double off = (hold.tip_patient - expected_[k]).norm();
    if (off > s_.tolerance_mm) {
      const std::string why =
          nearest != k && (hold.tip_patient - expected_[nearest]).norm() <= s_.tolerance_mm
              ? "that was corner " + std::to_string(nearest + 1) + " (" + cornerLabel(nearest, s_.board.spec) + ")"
              : "the tip was " + formatFixed(off, 0) + " mm from where the board's definition puts it";
      rejected_.push_back("corner " + std::to_string(k + 1) + ": " + why);
      ask(hold.end_s, why);
      return;
    }
    const CornerTouch t{k, hold.start_s, hold.end_s};
    touches_.push_back(t);
    touch_of_corner_[static_cast<std::size_t>(k)] = t;
    on_touches_changed();
    queue_.erase(queue_.begin());
    if (!queue_.empty()) {
      ask(hold.end_s, "");
      return;
    }
    checkGrid(frames, hold.end_s);
  }

  // All corners in: those that do not fit the grid the others make are asked again.
  void checkGrid(const std::vector<TrackedFrame>& frames, double now) {
    std::vector<Eigen::Vector3d> points;
    const auto poses = extractFramePoses(frames, s_.holds.transform).poses;
    for (const auto& t : touch_of_corner_) {
      int samples = 0;
      points.push_back(touchedPoint(poses, s_.holds.tip_marker, *t, samples).value_or(Eigen::Vector3d::Zero()));
    }
    hmd::GridFitOptions fit;
    fit.inlier_threshold_mm = s_.inlier_threshold_mm;
    std::vector<int> outliers;
    try {
      const auto grid = hmd::fitCheckerboardGrid(points, s_.board.spec, fit);
      for (std::size_t c = 0; c < grid.inliers.size(); ++c) {
        if (!grid.inliers[c]) outliers.push_back(static_cast<int>(c));
      }
    } catch (const ComputationError& e) {
      failure_ = std::string("the touched corners do not make the board's grid (") + e.what() +
                 "): check the square size in the board's definition and touch them again";
      return;
    }
    if (outliers.empty()) {
      done_ = true;
      if (streamer_ != nullptr) streamer_->setPrompt("Board digitisation done");
      return;
    }
    if (++rounds_ > s_.max_retouch_rounds) {
      failure_ = std::to_string(outliers.size()) + " corner(s) still off the grid after " +
                 std::to_string(s_.max_retouch_rounds) + " rounds of touching them again (is the board rigid on its "
                 "marker?)";
      return;
    }
    for (const int c : outliers) {
      rejected_.push_back("corner " + std::to_string(c + 1) + ": more than " + formatFixed(s_.inlier_threshold_mm, 1) +
                          " mm off the grid the other corners make");
      touch_of_corner_[static_cast<std::size_t>(c)].reset();
      queue_.push_back(c);
    }
    on_touches_changed();
    ask(now, "off the grid the other corners make");
  }

  Settings s_;
  tracking::HologramStreamer* streamer_;
  std::vector<Eigen::Vector3d> expected_;
  std::vector<int> queue_;
  std::vector<std::optional<CornerTouch>> touch_of_corner_;
  std::vector<CornerTouch> touches_;
  std::vector<std::string> rejected_;
  std::string prompt_, failure_;
  bool asked_ = false, done_ = false;
  double asked_at_ = 0.0;
  std::optional<Eigen::Vector3d> last_point_;
  int rounds_ = 0;

 public:
  /// The latest touch of every corner, in corner order (all present once done()).
  [[nodiscard]] std::vector<CornerTouch> latestTouches() const {
    std::vector<CornerTouch> out;
    for (const auto& t : touch_of_corner_) {
      if (t) out.push_back(*t);
    }
    return out;
  }
};

}  // namespace

StepResult runCheckerboardDigitisation(Session& session, const Json& params, const StepContext& context) {
  const Params p(kDigitisationStep, params,
                 {"source", "host", "port", "duration_s", "connect_timeout_s", "hmd_address", "hmd_port", "unity",
                  "tool", "board_tool", "board", "tolerance_mm", "inlier_threshold_mm", "dwell_s", "dwell_radius_mm",
                  "recording", "touches", "webxr_port", "webxr_address", "webxr_code", "webxr_tls_dir"});
  checkCancel(context);
  const std::string source = p.text("source", "plus");
  const BoardDefinition board = boardOfStep(p);
  const std::string tool = p.text("tool", "Stylus");
  const std::string board_tool = p.text("board_tool", "Board");
  // source=file takes the tip the touches were acquired with (from their file).
  Eigen::Vector3d tip = p.text("source", "plus") == "file" ? Eigen::Vector3d::Zero()
                                                            : calibratedTip(session, tool, kDigitisationStep);
  RegistrationAcquisitionOptions holds;
  holds.transform = tool + "To" + board_tool;
  holds.tip_marker = tip;
  holds.dwell_s = p.number("dwell_s", holds.dwell_s);
  holds.dwell_radius_mm = p.number("dwell_radius_mm", holds.dwell_radius_mm);
  const double tolerance_mm = p.number("tolerance_mm", 10.0);
  const double inlier_threshold_mm = p.number("inlier_threshold_mm", 1.5);
  if (!(holds.dwell_s >= 0.2 && holds.dwell_s <= 10.0) || !(holds.dwell_radius_mm > 0.0) ||
      !(tolerance_mm > 0.0) || !(inlier_threshold_mm > 0.0) || tolerance_mm >= 0.5 * board.spec.square_mm) {
    throw InvalidArgumentError(std::string(kDigitisationStep) +
                               ": dwell_s must be 0.2-10 s, dwell_radius_mm and inlier_threshold_mm > 0, and "
                               "tolerance_mm > 0 and below half the square size (else a neighbour corner passes)");
  }
  // The tip must leave a corner by less than the way to the next one before the next touch counts.
  holds.rearm_mm = std::min(holds.rearm_mm, 0.4 * board.spec.square_mm);
  const int corner_count = board.spec.rows * board.spec.cols;

  StepResult result;
  std::vector<TrackedFrame> frames;
  std::vector<CornerTouch> touches;
  std::string recording, touches_file;
  Json acquisition = Json::object();
  if (source == "plus") {
    if (p.has("touches")) throw InvalidArgumentError(std::string(kDigitisationStep) + ": touches is for source=file");
    LiveTrackingOptions live = touchRecordingOptions(session, p, kDigitisationStep, "BoardTouches", 300.0, recording);
    touches_file = freeSessionName(session, kDigitisationStep, "touches", ".json");
    // The prompts also go to the headset when one is served (the operator may wear it while touching).
    std::optional<StepHologramStream> stream;
    std::string endpoint;
    if (p.has("hmd_port")) {
      const StepStreamAddress address = stepStreamAddress(kDigitisationStep, p, 64 * 1024);
      endpoint = address.endpoint;
      stream.emplace(kDigitisationStep, address, std::make_shared<TransformRepository>(),
                     std::vector<tracking::HologramModel>{}, tracking::HologramStreamOptions{});
    }
    CornerTouchAcquisition::Settings s;
    s.board = board;
    s.holds = holds;
    s.tolerance_mm = tolerance_mm;
    s.inlier_threshold_mm = inlier_threshold_mm;
    CornerTouchAcquisition state(s, stream ? &stream->streamer() : nullptr);
    // The touches are on disk as soon as they are taken: a cancelled or failed acquisition keeps them.
    const fs::path touches_path = session.resolve(touches_file);
    state.on_touches_changed = [&] {
      std::ofstream(touches_path) << touchesJson(state.latestTouches(), holds.transform, tip, board.spec).dump(2)
                                  << "\n";
    };
    state.on_touches_changed();
    context.report(0.02, "tracking from " + live.host + ":" + std::to_string(live.port) +
                             (endpoint.empty() ? "" : "; prompts on the headset at " + endpoint));
    const auto monitor = [&](const std::vector<TrackedFrame>& so_far, std::string& message) {
      return state.step(so_far, message);
    };
    const LiveTrackingRecording r = recordLiveTracking(live, monitor, context);
    if (stream) stream->stop();
    frames = r.frames;
    touches = state.latestTouches();
    result.figures["recorded"] = recordedFigures(r, recording, live);
    result.figures["simulated"] = fromSimulatedRoom(r.device_identity);
    result.outputs.push_back(recording);
    result.outputs.push_back(touches_file);
    acquisition = {{"rejected_touches", state.rejected()}, {"touches_taken", state.touches().size()}};
    if (!endpoint.empty()) acquisition["hologram_stream"] = endpoint;
    if (!state.done()) {
      result.ok = false;
      result.figures["recorded"]["complete"] = false;
      result.figures["acquisition"] = acquisition;
      result.summary = (state.failure().empty() ? "the time ran out after " + std::to_string(touches.size()) +
                                                      " of " + std::to_string(corner_count) + " corners"
                                                : state.failure()) +
                       " (kept: " + recording + ", " + touches_file + ")";
      return result;
    }
  } else if (source == "file") {
    for (const char* key : {"host", "port", "duration_s", "connect_timeout_s", "hmd_address", "hmd_port", "unity",
                            "webxr_port", "webxr_address", "webxr_code", "webxr_tls_dir"}) {
      if (p.has(key)) throw InvalidArgumentError(std::string(kDigitisationStep) + ": " + key + " is for source=plus");
    }
    if (!p.has("recording") || !p.has("touches")) {
      throw InvalidArgumentError(std::string(kDigitisationStep) +
                                 ": source=file needs recording (the tracking of the touches) and touches "
                                 "(touches.json)");
    }
    recording = p.text("recording", "");
    touches_file = p.text("touches", "");
    frames = io::readSequenceHeader(recordingPath(session, recording), {}).frames;
    std::ifstream in(recordingPath(session, touches_file));
    if (!in) throw FileError(std::string(kDigitisationStep) + ": cannot read touches '" + touches_file + "'");
    Json j;
    try {
      j = Json::parse(in);
    } catch (const Json::parse_error& e) {
      throw FormatError(touches_file + " is not valid JSON (" + e.what() + ")");
    }
    touches = touchesFromJson(j, touches_file, corner_count);
    // As it was acquired: the tip and the transform the file names, on a board of the same pattern.
    const Json b = j.value("board", Json::object());
    if (b.value("rows", 0) != board.spec.rows || b.value("cols", 0) != board.spec.cols ||
        std::abs(b.value("square_mm", 0.0) - board.spec.square_mm) > 1e-9) {
      throw InvalidArgumentError(std::string(kDigitisationStep) + ": '" + touches_file + "' was acquired on a board " +
                                 b.dump() + ", not this step's " + board.file + " (give its board=)");
    }
    if (j.contains("transform") && j["transform"].is_string()) holds.transform = j["transform"].get<std::string>();
    if (j.contains("tip_marker_mm") && j["tip_marker_mm"].is_array() && j["tip_marker_mm"].size() == 3) {
      for (int k = 0; k < 3; ++k) {
        if (!j["tip_marker_mm"][k].is_number()) throw FormatError(touches_file + ": tip_marker_mm must be numbers");
        tip[k] = j["tip_marker_mm"][k].get<double>();
      }
    }
  } else {
    throw InvalidArgumentError(std::string(kDigitisationStep) + ": source must be plus (live) or file, not '" +
                               source + "'");
  }

  checkCancel(context);
  // Every corner once, in order.
  std::vector<std::optional<CornerTouch>> of_corner(static_cast<std::size_t>(corner_count));
  for (const auto& t : touches) of_corner[static_cast<std::size_t>(t.corner)] = t;
  const auto poses = extractFramePoses(frames, holds.transform).poses;
  std::vector<Eigen::Vector3d> points;
  Json per_corner = Json::array();
  for (int c = 0; c < corner_count; ++c) {
    int samples = 0;
    const auto point =
        of_corner[static_cast<std::size_t>(c)] ? touchedPoint(poses, tip, *of_corner[static_cast<std::size_t>(c)], samples)
                                               : std::nullopt;
    if (!point) {
      throw InvalidArgumentError(std::string(kDigitisationStep) + ": corner " + std::to_string(c + 1) + " (" +
                                 cornerLabel(c, board.spec) + ") has no touch with tracking in " + recording);
    }
    points.push_back(*point);
    per_corner.push_back({{"corner", c + 1}, {"label", cornerLabel(c, board.spec)}, {"samples", samples}});
  }
  hmd::GridFitOptions fit;
  fit.inlier_threshold_mm = inlier_threshold_mm;
  const auto grid = hmd::fitCheckerboardGrid(points, board.spec, fit);
  if (grid.inlier_count < corner_count) {
    std::string off;
    for (int c = 0; c < corner_count; ++c) {
      if (!grid.inliers[static_cast<std::size_t>(c)]) off += (off.empty() ? "" : ", ") + std::to_string(c + 1);
    }
    throw ComputationError(std::string(kDigitisationStep) + ": corner(s) " + off + " lie more than " +
                           formatFixed(inlier_threshold_mm, 1) + " mm off the grid the others make: touch them again");
  }
  for (int c = 0; c < corner_count; ++c) per_corner[static_cast<std::size_t>(c)]["residual_mm"] = grid.residuals_mm[c];
  const std::string corners_file = freeSessionName(session, kDigitisationStep, "corners", ".csv");
  hmd::writeBoardCorners(session.resolve(corners_file), points);
  const std::string tfm = freeSessionName(session, kDigitisationStep, "GridToBoard", ".tfm");
  // The node GridToBoard (io/transform_io.h: the .tfm holds the inverse of its ToParent).
  io::writeChildToParent(grid.board_T_grid.matrix(), session.resolve(tfm));
  result.outputs.push_back(corners_file);
  result.outputs.push_back(tfm);
  result.ok = true;
  result.figures["source"] = source;
  if (!acquisition.empty()) result.figures["acquisition"] = acquisition;
  result.figures["tool"] = tool;
  result.figures["board_tool"] = board_tool;
  result.figures["board"] = {{"name", board.name},
                             {"file", board.file},
                             {"rows", board.spec.rows},
                             {"cols", board.spec.cols},
                             {"square_mm", board.spec.square_mm}};
  result.figures["grid"] = {{"rms_mm", grid.rms_mm},
                            {"inliers", grid.inlier_count},
                            {"line_rms_mm", grid.line_rms_mm},
                            {"row_column_angle_deg", grid.row_column_angle_deg},
                            {"mean_spacing_mm", grid.mean_spacing_mm}};
  // How far the board's CAD is from the digitised board, at its corners.
  double cad_max = 0.0;
  const auto cad = board.cornersMarker();
  for (int c = 0; c < corner_count; ++c) {
    cad_max = std::max(cad_max, (grid.board_T_grid * hmd::idealGridCorners(board.spec)[c] - cad[c]).norm());
  }
  result.figures["definition_max_difference_mm"] = cad_max;
  result.figures["corners"] = per_corner;
  result.figures["corners_file"] = corners_file;
  result.figures["transforms"] = {{"GridToBoard", matrixJson(grid.board_T_grid.matrix())}};
  result.figures["touches_file"] = touches_file;
  result.figures["offline_command"] = "mrsns-cli session run " + session.folder().string() + " " +
                                      kDigitisationStep + " --param source=file --param recording=" +
                                      recordingPath(session, recording).string() +
                                      " --param touches=" + recordingPath(session, touches_file).string() +
                                      (p.has("board") ? " --param board=" + board.file : "") +
                                      (p.has("inlier_threshold_mm")
                                           ? " --param inlier_threshold_mm=" + formatFixed(inlier_threshold_mm, 6)
                                           : "");
  std::ostringstream summary;
  summary << corner_count << " corners digitised: they fit the board's grid within " << formatFixed(grid.rms_mm, 2)
          << " mm RMS (rows and columns at " << formatFixed(grid.row_column_angle_deg, 1) << " deg, spacing "
          << formatFixed(grid.mean_spacing_mm, 1) << " mm); the board's definition is up to "
          << formatFixed(cad_max, 1) << " mm off";
  result.summary = summary.str();
  return result;
}

}  // namespace mrsns::workflow::detail
