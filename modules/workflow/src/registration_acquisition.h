#pragma once
// What a patient registration's tracked stylus recording holds: the
// landmarks the operator touched (the tip held still), matched to the CT's
// fiducials without asking for an order, then the points swept over the bone
// (the tip moving within a few mm of the surface the landmarks place). The
// same analysis runs on the frames recorded so far while the operator works
// (the live feedback) and on a recording afterwards (the offline recompute).
#include <Eigen/Geometry>
#include <optional>
#include <string>
#include <vector>

#include "mrsns/core/mesh_locator.h"
#include "mrsns/core/tracked_frame.h"
#include "mrsns/registration/paired_point.h"

namespace mrsns::workflow::detail {

/// The CT side: where the fiducials are and the bone they sit on.
struct RegistrationTargets {
  std::vector<std::string> labels;                ///< "F-1", ...
  std::vector<Eigen::Vector3d> fiducials_ct;      ///< landmark positions (CT mm)
  std::vector<Eigen::Vector3d> fiducial_axes_ct;  ///< unit, out of the bone (the side a pointer comes from); may be empty
  const MeshLocator* bone = nullptr;              ///< the bone surface (CT mm)
};

struct RegistrationAcquisitionOptions {
  std::string transform = "StylusToPatient";  ///< the stylus marker in the patient reference's frame
  Eigen::Vector3d tip_marker = Eigen::Vector3d::Zero();
  double dwell_s = 1.0;          ///< a landmark is the tip held still this long
  double dwell_radius_mm = 1.0;  ///< ... every sample within this of the hold's mean (tremor is ~0.3 mm RMS)
  double rearm_mm = 5.0;         ///< the tip must leave a captured point by this much before the next capture
  double max_gap_s = 0.25;       ///< a hold is broken by a tracking gap longer than this (occlusion)
  double match_tolerance_mm = 5.0;  ///< a touched point farther than this from every fiducial matches none
  double surface_gate_mm = 2.0;     ///< a moving tip counts as on the bone within this of the surface
  double surface_spacing_mm = 1.0;  ///< surface points closer than this to the previous one are skipped
};

/// One held-still moment of the tip.
struct LandmarkCapture {
  double start_s = 0.0, end_s = 0.0;  ///< the hold's first and last sample (recording time)
  Eigen::Vector3d tip_patient = Eigen::Vector3d::Zero();
  Eigen::Vector3d shaft_patient = Eigen::Vector3d::UnitZ();  ///< unit, tip -> marker
  int samples = 0;
  int fiducial = -1;  ///< the CT fiducial it was matched to, or -1
};

struct RegistrationAcquisition {
  std::size_t frames = 0;
  std::size_t frames_without_pose = 0;  ///< the stylus or the reference not tracked (occlusion)
  std::vector<LandmarkCapture> captures;
  /// Per CT fiducial: the capture used for it (the latest one matched), or -1.
  std::vector<int> capture_of_fiducial;
  int matched = 0;
  /// Paired-point registration of the matched landmarks (3 or more).
  std::optional<registration::PairedPointResult> landmarks;
  Eigen::Isometry3d landmark_patient_T_ct = Eigen::Isometry3d::Identity();
  std::vector<Eigen::Vector3d> surface_patient;  ///< in time order
  double last_surface_time_s = 0.0;
  double last_time_s = 0.0;
};

/// The held-still moments of the tip (options.tip_marker through options.transform) in the frames, with the
/// same dwell detection as the registration's (dwell_s, dwell_radius_mm, rearm_mm, max_gap_s); `fiducial` is -1.
/// `frames_without_pose` (optional) counts the frames without the transform. Throws FrameError when no frame
/// holds the transform at all.
std::vector<LandmarkCapture> findTipHolds(const std::vector<TrackedFrame>& frames,
                                          const RegistrationAcquisitionOptions& options,
                                          std::size_t* frames_without_pose = nullptr);

/// Throws FrameError when no frame holds the transform at all.
RegistrationAcquisition analyseRegistrationFrames(const std::vector<TrackedFrame>& frames,
                                                  const RegistrationTargets& targets,
                                                  const RegistrationAcquisitionOptions& options);

}  // namespace mrsns::workflow::detail
