#pragma once
// The operator of the HMD calibration in the simulated room (CubeOperatorSpec):
// asked by a prompt on the headset, takes the tracked cube from where it rests,
// lines it up with the cube's hologram where the headset shows it (missed by
// the perception of a hologram), holds it with hand tremor, confirms on the
// headset and puts it back. Driven by the tracker loop; not thread-safe.
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "mrsns/simulation/scenario.h"

namespace mrsns::simulation {

class CubeOperator {
 public:
  CubeOperator(CubeOperatorSpec spec, std::uint64_t seed);

  /// A prompt the headset showed at t (s since the room started). A prompt that asks for the cube starts a
  /// match (the view named in it, else the next one), abandoning one under way.
  void onPrompt(double t, const std::string& prompt);

  /// Where the operator holds the cube at t, given where it rests (the scenario's motion) and where the
  /// headset shows the cube's hologram in the tracker frame (absent: not shown, so it cannot be matched).
  /// Absent: the cube is not in the operator's hand (it is where it rests).
  [[nodiscard]] std::optional<Eigen::Isometry3d> pose(double t, const Eigen::Isometry3d& tracker_T_rest,
                                                      const std::optional<Eigen::Isometry3d>& tracker_T_hologram);

  /// The confirmation the operator gives at t, once per match.
  [[nodiscard]] std::optional<std::string> confirmationDue(double t);

  /// One line per match for the truth file: view, when, the perception error it was matched with.
  struct MatchTruth {
    std::string view;
    double prompt_t = 0.0;
    double hold_t = 0.0;  ///< NaN until the hologram was seen and the cube reached it
    Eigen::Vector3d perception_error_mm = Eigen::Vector3d::Zero();  ///< tracker frame, at the cube's origin
    double depth_error_mm = 0.0;                                    ///< along the view (away from the eyes > 0)
    bool confirmed = false;
  };
  [[nodiscard]] const std::vector<MatchTruth>& matches() const { return matches_; }

 private:
  struct Match {
    std::size_t view = 0;
    double prompt_t = 0.0;
    std::optional<Eigen::Isometry3d> from;     ///< where the hand took the cube from
    std::optional<Eigen::Isometry3d> aligned;  ///< where the operator believes the hologram is
    double hold_t = 0.0;                       ///< when the cube reached it
    bool confirmed = false;
    // The hand during the hold.
    Eigen::Vector3d tremor_amplitude = Eigen::Vector3d::Zero(), tremor_hz = Eigen::Vector3d::Zero(),
                    tremor_phase = Eigen::Vector3d::Zero(), rotation_amplitude = Eigen::Vector3d::Zero(),
                    rotation_hz = Eigen::Vector3d::Zero(), rotation_phase = Eigen::Vector3d::Zero();
    Eigen::Vector3d drift_direction = Eigen::Vector3d::UnitX();
    std::vector<std::pair<double, Eigen::Vector3d>> jerks;  ///< start (s after hold_t), slip
  };
  Eigen::Isometry3d perceive(Match& m, const Eigen::Isometry3d& tracker_T_hologram);
  [[nodiscard]] Eigen::Isometry3d hand(const Match& m, double t) const;

  CubeOperatorSpec spec_;
  std::mt19937_64 rng_;
  std::optional<Match> match_;
  std::optional<Eigen::Isometry3d> release_from_;  ///< putting the cube back from here
  double release_t_ = 0.0;
  std::optional<Eigen::Isometry3d> last_rest_;  ///< where the cube rests, as last told
  std::size_t next_view_ = 0;
  std::vector<MatchTruth> matches_;
};

}  // namespace mrsns::simulation
