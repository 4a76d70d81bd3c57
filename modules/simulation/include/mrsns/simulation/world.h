#pragma once
// The simulated world: where every tool, the patient, the N-wire phantom and
// the robot truly are at time t (seconds since the scenario started), what
// the camera can see, and what the ultrasound beam meets. This is the truth:
// it never leaves mrsns-sim except through the truth file.
#include <Eigen/Geometry>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "mrsns/simulation/bmode_renderer.h"
#include "mrsns/simulation/scenario.h"

namespace mrsns::simulation {

/// Why a tool cannot be measured at an instant (None: it can).
enum class Visibility { Visible, OutOfVolume, LineOfSightBlocked, OccludedByFault };
[[nodiscard]] const char* toString(Visibility v);

struct ToolTruth {
  std::string name;
  Eigen::Isometry3d tracker_T_tool = Eigen::Isometry3d::Identity();
  Visibility visibility = Visibility::Visible;
};

class World {
 public:
  /// Builds the patient (generates the phantom or reads the label map) and
  /// the N-wire phantom. Throws FileError/FormatError for unreadable inputs.
  explicit World(const Scenario& scenario);
  ~World();
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  [[nodiscard]] const Scenario& scenario() const { return scenario_; }

  /// A tool in the operator's hand where the script does not say (the cube of the HMD calibration, lined up
  /// with what the headset shows): its pose replaces the scripted one.
  struct HeldTool {
    std::string name;
    Eigen::Isometry3d tracker_T_tool;
  };

  /// True pose of every scripted tool at t (motion + the operator's hand), with
  /// visibility. `robot_base_T_flange` places the robot's marker (absent: no robot).
  [[nodiscard]] std::vector<ToolTruth> tools(double t, const std::optional<Eigen::Isometry3d>& robot_base_T_flange,
                                             const std::vector<HeldTool>& held = {}) const;

  /// The patient's reference marker, CT and N-wire phantom in the tracker frame at t (faults applied).
  [[nodiscard]] Eigen::Isometry3d trackerTReference(double t) const;
  [[nodiscard]] Eigen::Isometry3d trackerTCt(double t) const;
  [[nodiscard]] Eigen::Isometry3d trackerTPhantom(double t) const;

  /// The true image plane (tracker frame) of the probe at t (no hand noise
  /// differs from the tool's: the image is rigidly attached to the probe).
  [[nodiscard]] Eigen::Isometry3d trackerTImage(double t) const;

  /// What the beam meets at t, in the tracker frame.
  [[nodiscard]] EchoScene echoScene(double t) const;

  /// Truth summary for the truth file: static transforms of the scenario and
  /// of the patient (fiducials in CT, planned screws, ...).
  [[nodiscard]] std::string staticTruthJson() const;

 private:
  struct Patient;
  struct ToolTimeline;
  /// Replaces touch_landmarks and trace_bone segments by the holds and moves of the tip they stand for.
  void expandRegistrationMotions();
  [[nodiscard]] Eigen::Isometry3d toolPose(std::size_t index, double t) const;
  [[nodiscard]] bool isReference(std::size_t index) const;
  [[nodiscard]] Eigen::Isometry3d frameInTracker(PoseFrame frame, double t) const;
  [[nodiscard]] Visibility visibility(const ToolSpec& tool, const Eigen::Isometry3d& tracker_T_tool, double t,
                                      const std::vector<Eigen::Isometry3d>& poses) const;
  [[nodiscard]] Eigen::Isometry3d patientShift(double t, bool relative) const;

  Scenario scenario_;
  std::vector<std::unique_ptr<ToolTimeline>> timelines_;
  std::unique_ptr<Patient> patient_;
  std::vector<EchoWire> wires_phantom_;  ///< N-wire phantom frame
  std::optional<EchoBox> bath_phantom_;
  std::optional<std::size_t> reference_index_;
  std::optional<std::size_t> phantom_reference_index_;
  std::optional<std::size_t> probe_index_;
};

}  // namespace mrsns::simulation
