// The simulated 10-pose protocol of paper 000 (checkerboard_trial.h has the noise model).
#include "mrsns/hmd/checkerboard_trial.h"

#include <cmath>
#include <random>
#include <utility>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/rotation_average.h"
#include "mrsns/core/units.h"

namespace mrsns::hmd {
namespace {

class Noise {
 public:
  explicit Noise(unsigned seed) : rng_(seed) {}
  double uniform(double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng_); }
  Eigen::Vector3d gauss3(double rms_3d) {
    std::normal_distribution<double> g(0.0, rms_3d / std::sqrt(3.0));
    return {g(rng_), g(rng_), g(rng_)};
  }
  unsigned next() { return static_cast<unsigned>(rng_()); }

 private:
  std::mt19937 rng_;
};

// One tracker sample of a rigid body at `truth`.
Eigen::Isometry3d trackerSample(const Eigen::Isometry3d& truth, Noise& noise, const CheckerboardTrialOptions& o) {
  Eigen::Isometry3d s = truth;
  s.linear() = so3Exp(noise.gauss3(o.tracker_rotation_rms_deg * kDeg)) * truth.linear();
  s.translation() += noise.gauss3(o.tracker_position_rms_mm);
  return s;
}

// The pose reported for an image: mean of the samples over the still period.
Eigen::Isometry3d trackedStill(const Eigen::Isometry3d& truth, Noise& noise, const CheckerboardTrialOptions& o) {
  std::vector<Eigen::Isometry3d> samples;
  for (int k = 0; k < std::max(o.tracker_samples_per_image, 1); ++k) samples.push_back(trackerSample(truth, noise, o));
  return averagePoses(samples).mean;
}

// A camera looking at the board centre from `distance`, up to `max_tilt` off the board normal
// (from the side the corners face), rolled up to +-20 deg.
Eigen::Isometry3d cameraLookingAt(const Eigen::Vector3d& centre, double distance, double max_tilt, Noise& noise) {
  const double theta = noise.uniform(0.0, max_tilt), phi = noise.uniform(-kPi, kPi);
  const Eigen::Vector3d dir(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), -std::cos(theta));
  const Eigen::Vector3d position = centre + distance * dir;
  const Eigen::Vector3d z = (centre - position).normalized();
  Eigen::Vector3d x = (Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitX().dot(z) * z).normalized();
  Eigen::Vector3d y = z.cross(x);
  Eigen::Isometry3d grid_T_camera = Eigen::Isometry3d::Identity();
  grid_T_camera.linear() << x, y, z;
  grid_T_camera.linear() = grid_T_camera.linear() * so3Exp(Eigen::Vector3d(0, 0, noise.uniform(-20, 20) * kDeg));
  grid_T_camera.translation() = position;
  return grid_T_camera;
}

// The whole board, border included, inside the image with a margin of `margin` pixels.
bool boardInView(const CheckerboardSpec& spec, const CameraIntrinsics& k, const Eigen::Isometry3d& camera_T_grid,
                 double margin) {
  std::vector<Eigen::Vector3d> outline;
  const double s = spec.square_mm;
  for (double u : {-2.0 * s, (spec.cols + 1.0) * s}) {
    for (double v : {-2.0 * s, (spec.rows + 1.0) * s}) outline.push_back(camera_T_grid * Eigen::Vector3d(u, v, 0));
  }
  for (const auto& p : outline) {
    if (p.z() < 100.0) return false;
  }
  for (const auto& px : projectPoints(outline, k)) {
    if (px.x() < margin || px.y() < margin || px.x() > k.width - margin || px.y() > k.height - margin) return false;
  }
  return true;
}

Eigen::Vector3d gridCentre(const CheckerboardSpec& spec) {
  return {0.5 * (spec.cols - 1) * spec.square_mm, 0.5 * (spec.rows - 1) * spec.square_mm, 0.0};
}

CameraCalibrationResult calibrateIntrinsics(const CheckerboardTrialOptions& o, Noise& noise,
                                            std::vector<GrayImage>* kept) {
  std::vector<std::vector<Eigen::Vector2d>> corners;
  int attempts = 0;
  while (static_cast<int>(corners.size()) < o.intrinsics_images && attempts++ < 50 * o.intrinsics_images) {
    const Eigen::Isometry3d grid_T_camera =
        cameraLookingAt(gridCentre(o.intrinsics_board), noise.uniform(300.0, 600.0), 40 * kDeg, noise);
    Eigen::Isometry3d camera_T_grid = grid_T_camera.inverse();
    // Shift the board across the image so the distortion is seen away from the centre.
    camera_T_grid.translation() += Eigen::Vector3d(noise.uniform(-120, 120), noise.uniform(-60, 60), 0.0);
    if (!boardInView(o.intrinsics_board, o.camera, camera_T_grid, 10.0)) continue;
    BoardRenderOptions render = o.render;
    render.seed = noise.next();
    GrayImage image = renderCheckerboard(o.intrinsics_board, o.camera, camera_T_grid, render);
    const auto found = detectCheckerboard(image, o.intrinsics_board);
    if (found) {
      corners.push_back(*found);
      if (kept != nullptr) kept->push_back(std::move(image));
    }
  }
  return calibrateCamera(corners, o.intrinsics_board, o.camera.width, o.camera.height);
}

}  // namespace

CheckerboardTrialResult runCheckerboardTrial(const CheckerboardTrialOptions& o) {
  if (o.poses < 3 || !(o.min_distance_mm > 0) || !(o.max_distance_mm >= o.min_distance_mm)) {
    throw InvalidArgumentError("checkerboard trial: give at least 3 poses and 0 < min distance <= max distance");
  }
  Noise noise(o.seed);
  CheckerboardTrialResult result;
  result.options = o;

  // Ground truth of the scene.
  Eigen::Isometry3d hmd_T_camera = Eigen::Isometry3d::Identity();
  hmd_T_camera.linear() = so3Exp(Eigen::Vector3d(0.05, -0.08, 0.03)) * so3Exp(Eigen::Vector3d(kPi / 2, 0, 0));
  hmd_T_camera.translation() = Eigen::Vector3d(35.0, -60.0, 25.0);
  result.true_hmd_T_camera = hmd_T_camera;
  Eigen::Isometry3d tracker_T_board = Eigen::Isometry3d::Identity();
  tracker_T_board.linear() = so3Exp(Eigen::Vector3d(0.1, 2.9, -0.2));
  tracker_T_board.translation() = Eigen::Vector3d(150.0, -80.0, -1900.0);
  Eigen::Isometry3d board_T_grid = Eigen::Isometry3d::Identity();
  board_T_grid.linear() = so3Exp(Eigen::Vector3d(0.0, 0.0, 0.03));
  board_T_grid.translation() = Eigen::Vector3d(-60.0, 40.0, 3.0);

  // 1. Camera intrinsics from close views of the printed board.
  result.camera = calibrateIntrinsics(o, noise, o.keep_inputs ? &result.intrinsics_images : nullptr);

  // 2. Pointer pivot calibration.
  const Eigen::Vector3d tip(2.0, -1.5, 150.0);
  std::vector<Eigen::Isometry3d> pivot;
  const Eigen::Vector3d divot(0.0, 100.0, -1700.0);
  for (int i = 0; i < 60; ++i) {
    Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
    p.linear() = so3Exp(
        Eigen::Vector3d(noise.uniform(-25, 25) * kDeg, noise.uniform(-25, 25) * kDeg, noise.uniform(-60, 60) * kDeg));
    p.translation() = divot - p.linear() * tip;
    pivot.push_back(trackerSample(p, noise, o));
  }
  const Eigen::Vector3d tip_estimate = calibratePointerTip(pivot, {}, &result.pointer_pivot_rms_mm);
  result.pointer_tip_error_mm = (tip_estimate - tip).norm();

  // 3. Digitise every corner, fit the ideal grid.
  const auto grid_corners = idealGridCorners(o.board);
  std::vector<Eigen::Isometry3d> pointer_samples, board_samples;
  for (const auto& g : grid_corners) {
    const Eigen::Vector3d corner_tracker = tracker_T_board * board_T_grid * g + noise.gauss3(o.digitisation_rms_mm);
    Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
    p.linear() =
        tracker_T_board.linear() * so3Exp(Eigen::Vector3d(kPi + noise.uniform(-0.3, 0.3), noise.uniform(-0.3, 0.3), 0));
    p.translation() = corner_tracker - p.linear() * tip;
    // The tip rests still on each corner (paper 000 §2.3): the poses are averaged like an image's.
    pointer_samples.push_back(trackedStill(p, noise, o));
    board_samples.push_back(trackedStill(tracker_T_board, noise, o));
  }
  const auto digitised = digitiseInBoard(pointer_samples, board_samples, tip_estimate);
  result.grid = fitCheckerboardGrid(digitised, o.board);
  for (const auto& g : grid_corners) {
    result.grid_error_mm = std::max(result.grid_error_mm, (result.grid.board_T_grid * g - board_T_grid * g).norm());
  }

  // 4. The protocol: poses at min..max distance, one image each.
  std::vector<CheckerboardView> views;
  int attempts = 0;
  while (static_cast<int>(views.size()) < o.poses && attempts++ < 100 * o.poses) {
    const double distance = o.poses == 1 ? o.min_distance_mm
                                         : o.min_distance_mm + (o.max_distance_mm - o.min_distance_mm) *
                                                                   static_cast<double>(views.size()) / (o.poses - 1);
    const Eigen::Isometry3d grid_T_camera = cameraLookingAt(gridCentre(o.board), distance, 35 * kDeg, noise);
    const Eigen::Isometry3d camera_T_grid = grid_T_camera.inverse();
    if (!boardInView(o.board, o.camera, camera_T_grid, 10.0)) continue;
    BoardRenderOptions render = o.render;
    render.seed = noise.next();
    const GrayImage image = renderCheckerboard(o.board, o.camera, camera_T_grid, render);
    CheckerboardView view;
    view.name = "pose " + std::to_string(views.size() + 1);
    view.corners_px = detectCheckerboardOrThrow(image, o.board, view.name);
    const Eigen::Isometry3d tracker_T_hmd = tracker_T_board * board_T_grid * grid_T_camera * hmd_T_camera.inverse();
    view.tracker_T_hmd = trackedStill(tracker_T_hmd, noise, o);
    view.tracker_T_board = trackedStill(tracker_T_board, noise, o);
    views.push_back(view);
    if (o.keep_inputs) result.images.push_back(image);
    result.distances_mm.push_back((camera_T_grid * gridCentre(o.board)).norm());
  }
  if (static_cast<int>(views.size()) < o.poses) {
    throw ComputationError("checkerboard trial: could not place " + std::to_string(o.poses) +
                           " camera poses with the whole board in view; reduce the distance range");
  }

  // 5. Hand-eye chain, averaging, Tables 1-2, retro-projection error.
  result.hand_eye = calibrateCheckerboardHandEye(views, result.grid.board_T_grid, o.board, result.camera.intrinsics);
  result.rpee = retroProjectionError(views, result.hand_eye.hmd_T_camera, result.grid.board_T_grid, o.board,
                                     result.camera.intrinsics, result.hand_eye.corners_reversed);
  result.rotation_error_deg = rotationAngleBetween(result.hand_eye.hmd_T_camera.linear(), hmd_T_camera.linear()) / kDeg;
  result.translation_error_mm = (result.hand_eye.hmd_T_camera.translation() - hmd_T_camera.translation()).norm();
  if (o.keep_inputs) {
    result.views = views;
    result.digitised_corners = digitised;
  }
  return result;
}

}  // namespace mrsns::hmd
