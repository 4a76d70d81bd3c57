#pragma once
// The wearer of the headset during paper 000's checkerboard hand-eye
// calibration in the simulated room (HeadsetCameraSpec): asked for "view K of
// N" of the checkerboard by a prompt on the headset, walks to a view of the
// tracked board (nearer views first, as the paper's 0.5-1.5 m), holds the head
// still with a slow sway, and the headset takes a photo; asked anything else,
// goes back to where the headset rests. Driven by the tracker loop; not
// thread-safe.
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "mrsns/hmd/camera_calibration.h"
#include "mrsns/hmd/checkerboard_grid.h"
#include "mrsns/simulation/scenario.h"

namespace mrsns::simulation {

class CameraOperator {
 public:
  CameraOperator(HeadsetCameraSpec spec, MeasurementVolume volume, std::uint64_t seed);

  /// A prompt the headset showed at t. One that asks for a checkerboard view starts the walk to it (from
  /// where the headset is); any other sends the wearer back to `tracker_T_rest`.
  void onPrompt(double t, const std::string& prompt, const Eigen::Isometry3d& tracker_T_board,
                const Eigen::Isometry3d& tracker_T_rest);

  /// Where the wearer holds the headset's marker at t; absent: where the scenario puts it (at rest).
  [[nodiscard]] std::optional<Eigen::Isometry3d> pose(double t, const Eigen::Isometry3d& tracker_T_rest);

  /// The photo due at t (once per view): the camera's true pose relative to the printed grid, given where
  /// the headset's marker and the board truly are.
  struct Photo {
    int view = 0;
    Eigen::Isometry3d camera_T_grid = Eigen::Isometry3d::Identity();
  };
  [[nodiscard]] std::optional<Photo> photoDue(double t, const Eigen::Isometry3d& tracker_T_headset,
                                              const Eigen::Isometry3d& tracker_T_board);

  [[nodiscard]] hmd::CheckerboardSpec board() const { return {spec_.rows, spec_.cols, spec_.square_mm}; }
  [[nodiscard]] const hmd::CameraIntrinsics& trueIntrinsics() const { return true_; }
  /// What the device reports (its factory calibration, off the truth by the spec's error).
  [[nodiscard]] const hmd::CameraIntrinsics& reportedIntrinsics() const { return reported_; }

  /// One line per view for the truth file.
  struct ViewTruth {
    int view = 0;
    double prompt_t = 0.0;
    double photo_t = -1.0;  ///< < 0: not taken
    double distance_mm = 0.0, tilt_deg = 0.0;
    bool reachable = true;  ///< false: no view with the board whole in the image and the headset tracked
  };
  [[nodiscard]] const std::vector<ViewTruth>& views() const { return views_; }

 private:
  [[nodiscard]] std::optional<Eigen::Isometry3d> chooseView(int view, int of, const Eigen::Isometry3d& tracker_T_board,
                                                            double& distance, double& tilt);
  [[nodiscard]] Eigen::Vector3d sway(double t) const;

  HeadsetCameraSpec spec_;
  MeasurementVolume volume_;
  std::mt19937_64 rng_;
  hmd::CameraIntrinsics true_, reported_;
  Eigen::Vector3d sway_hz_, sway_phase_;
  // The walk under way: from `from_` at `start_t_` to `to_` (a view, or the rest when returning).
  std::optional<Eigen::Isometry3d> from_, to_;
  double start_t_ = 0.0;
  bool returning_ = false;
  bool photo_pending_ = false;
  std::optional<Eigen::Isometry3d> last_;  ///< where the wearer held it at the last pose()
  std::vector<ViewTruth> views_;
};

}  // namespace mrsns::simulation
