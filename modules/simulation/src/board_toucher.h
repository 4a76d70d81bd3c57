#pragma once
// The operator digitising the tracked checkerboard's corners with the stylus
// in the simulated room (BoardTouchSpec): asked for "corner K of N" by a prompt
// on the headset, brings the stylus's tip above corner K, down onto it (missed
// by the placement error), holds it there with tremor, and lifts it; asked
// anything else, puts the stylus back. Driven by the tracker loop; not
// thread-safe.
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "mrsns/simulation/scenario.h"

namespace mrsns::simulation {

class BoardToucher {
 public:
  /// `tip_tool`: the stylus's true tip in its marker's frame.
  BoardToucher(BoardTouchSpec spec, const HeadsetCameraSpec& board, Eigen::Vector3d tip_tool, std::uint64_t seed);

  /// A prompt at t. One asking for a corner starts the touch from where the stylus is (its orientation kept as
  /// it rests); any other sends the stylus back to `tracker_T_rest`.
  void onPrompt(double t, const std::string& prompt, const Eigen::Isometry3d& tracker_T_board,
                const Eigen::Isometry3d& tracker_T_rest);

  /// Where the operator holds the stylus's marker at t; absent: where the scenario puts it.
  [[nodiscard]] std::optional<Eigen::Isometry3d> pose(double t, const Eigen::Isometry3d& tracker_T_rest);

  /// One line per touch for the truth file: the corner and where the tip was put, in the board marker's frame.
  struct TouchTruth {
    int corner = 0;  ///< 1-based
    double prompt_t = 0.0;
    Eigen::Vector3d placement_error_mm = Eigen::Vector3d::Zero();
  };
  [[nodiscard]] const std::vector<TouchTruth>& touches() const { return touches_; }

 private:
  [[nodiscard]] Eigen::Isometry3d toolAtTip(const Eigen::Vector3d& tip_tracker) const;

  BoardTouchSpec spec_;
  HeadsetCameraSpec board_;
  Eigen::Vector3d tip_tool_;
  std::mt19937_64 rng_;
  Eigen::Vector3d tremor_hz_, tremor_phase_;
  Eigen::Matrix3d tracker_R_tool_ = Eigen::Matrix3d::Identity();  ///< the orientation it is held in
  std::optional<Eigen::Isometry3d> from_;
  Eigen::Vector3d target_ = Eigen::Vector3d::Zero();  ///< the tip's target (tracker)
  double start_t_ = 0.0;
  bool active_ = false, returning_ = false;
  std::optional<Eigen::Isometry3d> last_;
  std::vector<TouchTruth> touches_;
};

}  // namespace mrsns::simulation
