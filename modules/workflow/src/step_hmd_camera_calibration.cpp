// hmd-camera-calibration: paper 000's checkerboard hand-eye calibration of the
// headset's camera (T_c^h, CameraToHeadset) from the photos the headset sends.
// The workstation asks for each view on the headset ("view K of N": nearer
// views first), takes the photo the headset's app sends on the hologram stream
// (IMAGE "HmdCamera"), pairs it with the tracked headset and board averaged
// over the moment before it arrived (both held still, else the view is asked
// again), finds the board in it, and keeps every accepted view on disk as a
// checkerboard data set (modules/hmd/doc/checkerboard.md). The solution is the
// data set's, so `mrsns-cli hmd-calibrate-checkerboard --dataset` gives the
// same numbers. source=file solves a data set already on disk.
#include <atomic>
#include <chrono>
#include <fstream>
#include <mutex>
#include <optional>
#include <sstream>

#include "checkerboard_board.h"
#include "landmark_touch_step.h"
#include "step_hologram_stream.h"
#include "live_tracking_recording.h"
#include "mrsns/core/format.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/rotation_average.h"
#include "mrsns/core/wall_clock.h"
#include "mrsns/hmd/checkerboard_dataset.h"
#include "mrsns/igtlink/server.h"
#include "mrsns/io/pose_csv.h"
#include "mrsns/io/transform_io.h"
#include "mrsns/tracking/hologram_streamer.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

namespace {

namespace fs = std::filesystem;

constexpr const char* kCameraStep = "hmd-camera-calibration";
constexpr double kCameraRadToDeg = 57.29577951308232;

std::string photoFileName(std::size_t i) {
  std::string n = std::to_string(i + 1);
  return "view_" + std::string(n.size() < 3 ? 3 - n.size() : 0, '0') + n + ".png";
}

// What the headset sent, waiting for the step's thread.
struct PhotoInbox {
  std::mutex mutex;
  std::vector<tracking::HeadsetCameraImage> photos;
  std::atomic<std::uint64_t> received{0};
};

// The still moment before a photo arrived: the mean of each tool's samples, and how far they strayed from it.
struct StillPose {
  Eigen::Isometry3d mean = Eigen::Isometry3d::Identity();
  int samples = 0, missing = 0;
  double spread_mm = 0.0, spread_deg = 0.0;
};

StillPose stillPoseBefore(const std::vector<TrackedFrame>& frames, double from, double to, const std::string& transform) {
  StillPose s;
  std::vector<Eigen::Isometry3d> poses;
  for (auto it = frames.rbegin(); it != frames.rend() && it->timestamp >= from; ++it) {
    if (it->timestamp > to) continue;
    const auto t = it->transforms.find(transform);
    if (t == it->transforms.end() || t->second.status != TransformStatus::Ok || !isRigid(t->second.matrix, 1e-3)) {
      ++s.missing;
      continue;
    }
    poses.push_back(orthonormalize(t->second.matrix));
  }
  s.samples = static_cast<int>(poses.size());
  if (poses.empty()) return s;
  s.mean = averagePoses(poses).mean;
  for (const auto& p : poses) {
    s.spread_mm = std::max(s.spread_mm, (p.translation() - s.mean.translation()).norm());
    s.spread_deg = std::max(s.spread_deg, rotationAngle(s.mean.linear().transpose() * p.linear()) * kCameraRadToDeg);
  }
  return s;
}

class CameraViewAcquisition {
 public:
  struct Settings {
    int views = 10;
    std::string hmd_transform = "HeadsetToTracker", board_transform = "BoardToTracker";
    hmd::CheckerboardSpec board;
    double still_s = 0.5;
    double max_still_mm = 1.0, max_still_deg = 0.5;
    double hmd_wait_s = 120.0;
    double photo_wait_s = 30.0;
    std::optional<hmd::CameraIntrinsics> given_intrinsics;
    fs::path dataset;
    std::string endpoint;
  };

  CameraViewAcquisition(Settings s, tracking::HologramStreamer& streamer, PhotoInbox& inbox)
      : s_(std::move(s)), streamer_(streamer), inbox_(inbox) {
    waiting_since_ = std::chrono::steady_clock::now();
  }

  bool step(const std::vector<TrackedFrame>& frames, std::string& message) {
    const bool headset = streamer_.readyClients() > 0;
    std::vector<tracking::HeadsetCameraImage> photos;
    {
      std::lock_guard lock(inbox_.mutex);
      photos.swap(inbox_.photos);
    }
    switch (phase_) {
      case Phase::WaitHeadset:
        if (headset) {
          ask("");
          break;
        }
        failure_ = headsetWaitFailure(drops_, s_.endpoint, elapsed(), s_.hmd_wait_s);
        if (!failure_.empty()) return true;
        message = headsetWaitMessage(drops_, s_.endpoint, "view " + viewLabel());
        return false;
      case Phase::Asking:
        if (!headset) {
          ++drops_;
          phase_ = Phase::WaitHeadset;
          waiting_since_ = std::chrono::steady_clock::now();
          message = "the headset left the hologram stream: waiting for it to come back (view " + viewLabel() +
                    " again)";
          return false;
        }
        // A photo is the operator's: the latest one answers the view asked for (earlier ones are stale). It is
        // judged once tracking newer than its arrival is in: the poses of the moment it was taken are then all
        // there, and a tracker that stalled does not pass off older ones as its.
        if (!photos.empty()) {
          pending_ = std::move(photos.back());
          pending_seen_at_ = frames.size();
          timeouts_ = 0;
        }
        if (pending_ && frames.size() > pending_seen_at_) {
          const double arrived = frames[pending_seen_at_].timestamp;
          const auto photo = std::move(*pending_);
          pending_.reset();
          judge(photo, frames, arrived);
          if (!failure_.empty()) return true;
          if (accepted_.size() == static_cast<std::size_t>(s_.views)) {
            streamer_.setPrompt("HMD camera calibration: all " + std::to_string(s_.views) + " photos taken");
            phase_ = Phase::Done;
            message = status();
            return true;
          }
        } else if (!pending_ && elapsed() > s_.photo_wait_s) {
          if (++timeouts_ >= 3) {
            failure_ = "no photo came from the headset for view " + viewLabel() + " in " +
                       formatFixed(3 * s_.photo_wait_s, 0) +
                       " s (does its app send camera images, IMAGE \"HmdCamera\", on the hologram stream?)";
            return true;
          }
          ask("no photo came");
        }
        break;
      case Phase::Done:
        return true;
    }
    message = status();
    return false;
  }

  struct Accepted {
    std::string image;
    Eigen::Isometry3d tracker_T_hmd, tracker_T_board;
    StillPose hmd, board;
    int corners = 0;
  };
  [[nodiscard]] const std::vector<Accepted>& accepted() const { return accepted_; }
  [[nodiscard]] const std::vector<std::string>& rejected() const { return rejected_; }
  [[nodiscard]] const std::string& failure() const { return failure_; }
  [[nodiscard]] int drops() const { return drops_; }
  [[nodiscard]] const std::optional<hmd::CameraIntrinsics>& intrinsics() const { return intrinsics_; }
  [[nodiscard]] bool intrinsicsChanged() const { return intrinsics_changed_; }
  [[nodiscard]] const std::string& intrinsicsWarning() const { return intrinsics_warning_; }

 private:
  enum class Phase { WaitHeadset, Asking, Done };

  double elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - waiting_since_).count();
  }
  std::string viewLabel() const {
    return std::to_string(accepted_.size() + 1) + " of " + std::to_string(s_.views);
  }

  void ask(const std::string& why) {
    phase_ = Phase::Asking;
    waiting_since_ = std::chrono::steady_clock::now();
    streamer_.setPrompt("HMD camera calibration, view " + viewLabel() + (why.empty() ? "" : " again (" + why + ")") +
                        ": look at the checkerboard " + distanceHint() +
                        ", the whole board in sight, and hold your head still for the photo");
  }

  // Paper 000 took its views at 0.5-1.5 m: nearer ones first.
  std::string distanceHint() const {
    const double f = s_.views > 1 ? static_cast<double>(accepted_.size()) / (s_.views - 1) : 0.5;
    return "from about " + formatFixed(0.5 + f * 0.7, 1) + " m";
  }

  void reject(const std::string& why) {
    rejected_.push_back("view " + viewLabel() + ": " + why);
    ask(why);
  }

  void judge(const tracking::HeadsetCameraImage& photo, const std::vector<TrackedFrame>& frames, double arrived) {
    // The photo was taken before it arrived: the tracked poses of the moment before are its.
    const StillPose hmd = stillPoseBefore(frames, arrived - s_.still_s, arrived, s_.hmd_transform);
    const StillPose board = stillPoseBefore(frames, arrived - s_.still_s, arrived, s_.board_transform);
    auto tracked = [](const StillPose& p) { return p.samples >= 3 && p.missing <= p.samples; };
    if (!tracked(hmd)) {
      reject("the headset's marker was not tracked when the photo was taken: keep it in the tracker's view");
      return;
    }
    if (!tracked(board)) {
      reject("the board's marker was not tracked when the photo was taken: keep it in the tracker's view");
      return;
    }
    if (hmd.spread_mm > s_.max_still_mm || hmd.spread_deg > s_.max_still_deg) {
      reject("the head moved during the photo (" + formatFixed(hmd.spread_mm, 1) + " mm, " +
             formatFixed(hmd.spread_deg, 2) + " deg; at most " + formatFixed(s_.max_still_mm, 1) + " mm, " +
             formatFixed(s_.max_still_deg, 2) + " deg): hold it still");
      return;
    }
    if (board.spread_mm > s_.max_still_mm || board.spread_deg > s_.max_still_deg) {
      reject("the board moved during the photo: leave it where it stands");
      return;
    }
    hmd::GrayImage image{photo.width, photo.height, photo.pixels};
    const auto corners = hmd::detectCheckerboard(image, s_.board);
    if (!corners) {
      reject("the board is not whole in the photo (" + std::to_string(s_.board.rows) + " x " +
             std::to_string(s_.board.cols) + " inner corners not found): look at it so every square shows");
      return;
    }
    if (!accepted_.empty() && (photo.width != width_ || photo.height != height_)) {
      reject("the photo is " + std::to_string(photo.width) + " x " + std::to_string(photo.height) +
             " pixels, the first " + std::to_string(width_) + " x " + std::to_string(height_) +
             ": keep the camera in one mode");
      return;
    }
    if (s_.given_intrinsics && (s_.given_intrinsics->width != photo.width ||
                                s_.given_intrinsics->height != photo.height)) {
      failure_ = "the intrinsics given are for " + std::to_string(s_.given_intrinsics->width) + " x " +
                 std::to_string(s_.given_intrinsics->height) + " pixels, the headset's photos are " +
                 std::to_string(photo.width) + " x " + std::to_string(photo.height);
      return;
    }
    width_ = photo.width;
    height_ = photo.height;
    // What the headset says of its camera, checked and kept at once (a failed acquisition keeps it too).
    if (!photo.intrinsics.empty() && photo.intrinsics != intrinsics_text_) {
      try {
        const auto k = hmd::intrinsicsFromText(photo.intrinsics);
        if (k.width != photo.width || k.height != photo.height) {
          throw FormatError("they are for " + std::to_string(k.width) + " x " + std::to_string(k.height) +
                            " pixels, the photo " + std::to_string(photo.width) + " x " + std::to_string(photo.height));
        }
        if (!intrinsics_text_.empty()) intrinsics_changed_ = true;
        intrinsics_text_ = photo.intrinsics;
        intrinsics_ = k;
        if (!s_.given_intrinsics) hmd::writeCameraIntrinsics(s_.dataset / "intrinsics.json", k);
      } catch (const FormatError& e) {
        intrinsics_warning_ = std::string("the headset's intrinsics were not usable: ") + e.what();
      }
    }
    Accepted a;
    a.image = photoFileName(accepted_.size());
    a.tracker_T_hmd = hmd.mean;
    a.tracker_T_board = board.mean;
    a.hmd = hmd;
    a.board = board;
    a.corners = static_cast<int>(corners->size());
    // On disk at once: a cancelled or failed acquisition keeps every accepted view.
    hmd::writeGrayImage(s_.dataset / "images" / a.image, image);
    accepted_.push_back(a);
    std::vector<Eigen::Isometry3d> hmd_poses, board_poses;
    for (const auto& v : accepted_) {
      hmd_poses.push_back(v.tracker_T_hmd);
      board_poses.push_back(v.tracker_T_board);
    }
    io::writePoseCsv(s_.dataset / "hmd_poses.csv", hmd_poses);
    io::writePoseCsv(s_.dataset / "board_poses.csv", board_poses);
    if (accepted_.size() < static_cast<std::size_t>(s_.views)) ask("");
  }

  std::string status() const {
    const std::string done = std::to_string(accepted_.size()) + " of " + std::to_string(s_.views) + " photos";
    if (phase_ == Phase::Asking) {
      return "view " + viewLabel() + ": waiting for the headset's photo of the checkerboard; " + done;
    }
    return done;
  }

  Settings s_;
  tracking::HologramStreamer& streamer_;
  PhotoInbox& inbox_;
  Phase phase_ = Phase::WaitHeadset;
  std::chrono::steady_clock::time_point waiting_since_;
  std::vector<Accepted> accepted_;
  std::vector<std::string> rejected_;
  std::string failure_;
  int drops_ = 0, timeouts_ = 0;
  int width_ = 0, height_ = 0;
  std::optional<hmd::CameraIntrinsics> intrinsics_;
  std::string intrinsics_text_, intrinsics_warning_;
  bool intrinsics_changed_ = false;
  std::optional<tracking::HeadsetCameraImage> pending_;
  std::size_t pending_seen_at_ = 0;
};

Json cameraPoseJson(const Eigen::Isometry3d& T) {
  return {{"translation_mm", {T.translation().x(), T.translation().y(), T.translation().z()}},
          {"rotation_angle_deg", rotationAngle(T.linear()) * kCameraRadToDeg}};
}

}  // namespace

StepResult runHmdCameraCalibration(Session& session, const Json& params, const StepContext& context) {
  const Params p(kCameraStep, params,
                 {"source", "host", "port", "duration_s", "connect_timeout_s", "hmd_address", "hmd_port", "unity",
                  "hmd_wait_s", "photo_wait_s", "views", "hmd_tool", "board_tool", "board", "corners", "intrinsics",
                  "still_s", "max_still_mm", "max_still_deg", "dataset"});
  checkCancel(context);
  const std::string source = p.text("source", "hmd");
  const BoardDefinition board = boardOfStep(p);
  const std::string board_tool = p.text("board_tool", "Board");
  // Where the corners are on the board's marker: as given, else as this session digitised them with the stylus
  // (paper 000 §2.3), else as the board's definition puts them.
  std::vector<Eigen::Vector3d> corners;
  std::string corners_from;
  if (p.has("corners")) {
    corners = hmd::readBoardCorners(recordingPath(session, p.text("corners", "")));
    corners_from = p.text("corners", "");
  } else if (const auto digitised = digitisedCorners(session, board_tool, board.spec)) {
    corners = hmd::readBoardCorners(*digitised);
    corners_from = "checkerboard-digitisation";
  }
  if (!corners.empty() && corners.size() != static_cast<std::size_t>(board.spec.rows * board.spec.cols)) {
    throw InvalidArgumentError(std::string(kCameraStep) + ": " + corners_from + " holds " +
                               std::to_string(corners.size()) + " corners, the board " +
                               std::to_string(board.spec.rows * board.spec.cols) + " (" + board.file + ")");
  }
  std::optional<hmd::CameraIntrinsics> given_intrinsics;
  if (p.has("intrinsics")) given_intrinsics = hmd::readCameraIntrinsics(recordingPath(session, p.text("intrinsics", "")));

  StepResult result;
  fs::path dataset;
  Json acquisition = Json::object();
  if (source == "hmd") {
    for (const char* key : {"dataset"}) {
      if (p.has(key)) throw InvalidArgumentError(std::string(kCameraStep) + ": " + key + " is for source=file");
    }
    CameraViewAcquisition::Settings s;
    s.views = p.integer("views", s.views);
    s.hmd_transform = p.text("hmd_tool", "Headset") + "ToTracker";
    s.board_transform = board_tool + "ToTracker";
    s.board = board.spec;
    s.still_s = p.number("still_s", s.still_s);
    s.max_still_mm = p.number("max_still_mm", s.max_still_mm);
    s.max_still_deg = p.number("max_still_deg", s.max_still_deg);
    s.hmd_wait_s = p.number("hmd_wait_s", s.hmd_wait_s);
    s.photo_wait_s = p.number("photo_wait_s", s.photo_wait_s);
    s.given_intrinsics = given_intrinsics;
    if (s.views < 3 || s.views > 50 || !(s.still_s >= 0.1 && s.still_s <= 5.0) || !(s.max_still_mm > 0.0) ||
        !(s.max_still_deg > 0.0) || !(s.hmd_wait_s > 0.0 && s.hmd_wait_s <= 1800.0) ||
        !(s.photo_wait_s >= 1.0 && s.photo_wait_s <= 600.0)) {
      throw InvalidArgumentError(std::string(kCameraStep) +
                                 ": views must be 3-50 (paper 000 used 10), still_s 0.1-5 s, max_still_mm and "
                                 "max_still_deg > 0, hmd_wait_s in (0, 1800] s, photo_wait_s 1-600 s");
    }
    // The largest photo the stream takes (4096 x 4096 grey) and its header; nothing else a headset sends is large.
    const StepStreamAddress address = stepStreamAddress(kCameraStep, p, tracking::kMaxCameraImageBodyBytes);
    s.endpoint = address.endpoint;
    std::string recording;
    LiveTrackingOptions live = touchRecordingOptions(session, p, kCameraStep, "CameraViews", 600.0, recording);
    const std::string dataset_name = freeSessionName(session, kCameraStep, "dataset", "");
    dataset = session.resolve(dataset_name);
    fs::create_directories(dataset / "images");
    s.dataset = dataset;
    PhotoInbox inbox;
    tracking::HologramStreamOptions stream_options;
    // The headset's photos reach this step and nothing else.
    stream_options.on_camera_image = [&inbox](igtlink::ClientId, tracking::HeadsetCameraImage image) {
      std::lock_guard lock(inbox.mutex);
      // Only the latest few wait: a client that floods the stream cannot fill the memory.
      if (inbox.photos.size() >= 4) inbox.photos.erase(inbox.photos.begin());
      inbox.photos.push_back(std::move(image));
      inbox.received.fetch_add(1);
    };
    StepHologramStream stream(kCameraStep, address, std::make_shared<TransformRepository>(), {}, stream_options);
    CameraViewAcquisition state(s, stream.streamer(), inbox);
    context.report(0.02, "asking the headset for photos on " + s.endpoint + "; tracking from " + live.host + ":" +
                             std::to_string(live.port));
    const auto monitor = [&](const std::vector<TrackedFrame>& so_far, std::string& message) {
      return state.step(so_far, message);
    };
    const LiveTrackingRecording r = recordLiveTracking(live, monitor, context);
    stream.stop();
    result.figures["recorded"] = recordedFigures(r, recording, live);
    result.figures["simulated"] = fromSimulatedRoom(r.device_identity);
    result.outputs.push_back(recording);
    result.outputs.push_back(dataset_name);
    Json views = Json::array();
    for (const auto& a : state.accepted()) {
      views.push_back({{"image", a.image},
                       {"corners", a.corners},
                       {"headset_samples", a.hmd.samples},
                       {"headset_spread_mm", a.hmd.spread_mm},
                       {"headset_spread_deg", a.hmd.spread_deg},
                       {"board_samples", a.board.samples},
                       {"board_spread_mm", a.board.spread_mm}});
    }
    acquisition = {{"hologram_stream", s.endpoint},
                   {"photos_received", inbox.received.load()},
                   {"headset_drops", state.drops()},
                   {"rejected_views", state.rejected()},
                   {"views", views}};
    if (!state.failure().empty() || state.accepted().size() < static_cast<std::size_t>(s.views)) {
      result.ok = false;
      result.figures["recorded"]["complete"] = false;
      result.figures["acquisition"] = acquisition;
      result.summary = (state.failure().empty() ? "the time ran out after " + std::to_string(state.accepted().size()) +
                                                      " of " + std::to_string(s.views) + " photos"
                                                : state.failure() + "; " + std::to_string(state.accepted().size()) +
                                                      " of " + std::to_string(s.views) + " photos taken") +
                       " (kept: " + recording + ", " + dataset_name + ")";
      return result;
    }
    // The intrinsics: the user's file, else what the headset reported with its photos, else from the views.
    if (given_intrinsics) {
      hmd::writeCameraIntrinsics(dataset / "intrinsics.json", *given_intrinsics);
      acquisition["intrinsics_from"] = "file " + p.text("intrinsics", "");
    } else if (state.intrinsics()) {
      acquisition["intrinsics_from"] = "the headset (metadata CameraIntrinsics of its photos)";
      if (state.intrinsicsChanged()) {
        acquisition["intrinsics_warning"] = "the headset's intrinsics changed during the acquisition: the last used";
      }
    }
    if (!state.intrinsicsWarning().empty()) acquisition["intrinsics_warning"] = state.intrinsicsWarning();
  } else if (source == "file") {
    for (const char* key : {"host", "port", "duration_s", "connect_timeout_s", "hmd_address", "hmd_port", "unity",
                            "hmd_wait_s", "photo_wait_s", "views", "hmd_tool", "still_s",
                            "max_still_mm", "max_still_deg"}) {
      if (p.has(key)) throw InvalidArgumentError(std::string(kCameraStep) + ": " + key + " is for source=hmd");
    }
    if (!p.has("dataset")) {
      throw InvalidArgumentError(std::string(kCameraStep) +
                                 ": source=file needs dataset (a folder with images/, hmd_poses.csv, board_poses.csv)");
    }
    dataset = recordingPath(session, p.text("dataset", ""));
    if (!fs::is_directory(dataset)) {
      throw FileError(std::string(kCameraStep) + ": the data set '" + dataset.string() + "' is not a folder");
    }
  } else {
    throw InvalidArgumentError(std::string(kCameraStep) + ": source must be hmd (live, with the headset) or file, not '" +
                               source + "'");
  }

  checkCancel(context);
  context.report(0.9, "the board found in every photo, the hand-eye calibration solved");
  // The live acquisition's data set gets its corners; a user's data set on disk is never written to: what the
  // step chose goes into its own folder and the solution reads it from there.
  auto files = hmd::checkerboardDatasetIn(dataset);
  const bool own = source == "hmd";
  auto keep_corners = [&](const std::vector<Eigen::Vector3d>& points) {
    files.corners = own ? dataset / "corners.csv"
                        : session.resolve(freeSessionName(session, kCameraStep, "corners", ".csv"));
    hmd::writeBoardCorners(files.corners, points);
  };
  if (!corners.empty()) {
    keep_corners(corners);
  } else if (own || !fs::exists(dataset / "corners.csv")) {
    keep_corners(board.cornersMarker());
    corners_from = "the board definition " + board.file;
  } else {
    corners_from = (dataset / "corners.csv").string();
  }
  if (!own && given_intrinsics) files.intrinsics = recordingPath(session, p.text("intrinsics", ""));
  hmd::CheckerboardDatasetOptions options;
  options.board = board.spec;
  const auto solution = hmd::calibrateCheckerboardDataset(files, options);
  const auto& he = solution.hand_eye;
  const std::string tfm = freeSessionName(session, kCameraStep, "CameraToHeadset", ".tfm");
  // The node CameraToHeadset (io/transform_io.h: the .tfm holds the inverse of its ToParent).
  io::writeChildToParent(he.hmd_T_camera.matrix(), session.resolve(tfm));
  result.outputs.push_back(tfm);
  result.ok = true;
  result.figures["source"] = source;
  if (!acquisition.empty()) result.figures["acquisition"] = acquisition;
  result.figures["method"] = "paper 000 §2.4: T_c^h = (T_h^w)^-1 T_b^w T_p^b T_c^p per photo (solvePnP), averaged";
  result.figures["board"] = {{"name", board.name},
                             {"file", board.file},
                             {"rows", board.spec.rows},
                             {"cols", board.spec.cols},
                             {"square_mm", board.spec.square_mm},
                             {"corners_from", corners_from},
                             {"grid_fit_rms_mm", solution.grid.rms_mm}};
  const auto& k = solution.camera.intrinsics;
  // Within this step a data set's intrinsics file holds what the user gave or the headset reported.
  const std::string intrinsics_from =
      solution.intrinsics_source == "file" && acquisition.contains("intrinsics_from")
          ? acquisition["intrinsics_from"].get<std::string>()
          : solution.intrinsics_source == "file" && given_intrinsics ? "file " + p.text("intrinsics", "")
                                                                     : solution.intrinsics_source;
  result.figures["camera"] = {{"intrinsics_from", intrinsics_from},
                              {"fx", k.fx},
                              {"fy", k.fy},
                              {"cx", k.cx},
                              {"cy", k.cy},
                              {"distortion", k.distortion},
                              {"width", k.width},
                              {"height", k.height}};
  if (solution.intrinsics_source != "file") {
    result.figures["camera"]["rms_reprojection_px"] = solution.camera.rms_reprojection_px;
  }
  result.figures["photos"] = solution.image_names.size();
  result.figures["CameraToHeadset"] = cameraPoseJson(he.hmd_T_camera);
  result.figures["spread"] = {{"rotation_rms_deg", he.rotation_rms_rad * kCameraRadToDeg},
                              {"translation_rms_mm", he.translation_rms_mm}};
  result.figures["per_photo_pnp_rms_px"] = he.per_view_pnp_rms_px;
  result.figures["rpee"] = {{"mean_mm", solution.rpee.mean_mm},
                            {"std_mm", solution.rpee.std_mm},
                            {"mean_px", solution.rpee.mean_px},
                            {"std_px", solution.rpee.std_px},
                            {"paper_000_mm", "3.2 +- 1.6 (HoloLens 2, 150 patterns)"}};
  result.figures["transforms"] = {{"CameraToHeadset", matrixJson(he.hmd_T_camera.matrix())}};
  result.figures["dataset"] = dataset.string();
  std::string inputs = "--images " + files.images.string() + " --hmd-poses " + files.hmd_poses.string() +
                       " --board-poses " + files.board_poses.string() + " --corners " + files.corners.string();
  if (!files.intrinsics.empty()) inputs += " --intrinsics " + files.intrinsics.string();
  if (files.intrinsics.empty() && !files.calibration_images.empty()) {
    inputs += " --calibration-images " + files.calibration_images.string();
  }
  result.figures["offline_command"] = "mrsns-cli hmd-calibrate-checkerboard " + inputs +
                                      " --rows " + std::to_string(board.spec.rows) + " --cols " +
                                      std::to_string(board.spec.cols) + " --square " +
                                      formatFixed(board.spec.square_mm, 6);
  std::ostringstream summary;
  summary << "CameraToHeadset from " << solution.image_names.size() << " photos: RPEE "
          << formatFixed(solution.rpee.mean_mm, 2) << " +- " << formatFixed(solution.rpee.std_mm, 2) << " mm ("
          << formatFixed(solution.rpee.mean_px, 2) << " px); the per-photo estimates spread "
          << formatFixed(he.rotation_rms_rad * kCameraRadToDeg, 2) << " deg, " << formatFixed(he.translation_rms_mm, 2)
          << " mm RMS; intrinsics from " << intrinsics_from;
  if (acquisition.value("headset_drops", 0) > 0) {
    summary << "; the headset left " << acquisition["headset_drops"].get<int>() << " time(s)";
  }
  result.summary = summary.str();
  return result;
}

}  // namespace mrsns::workflow::detail
