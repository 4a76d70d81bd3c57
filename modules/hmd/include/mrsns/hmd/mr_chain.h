#pragma once
// The MR chain of paper 001 (Eq. 1): where the HMD must draw a pre-operative
// model, in its own hologram (world) frame,
//
//   T_Vir^Hol = (T_Hol^Tra)^-1 * T_Pat^Tra * T_Pre^Pat * T_Vir^Pre
//   hologram_T_virtual = inverse(tracker_T_hologram) * tracker_T_patient
//                        * patient_T_preop * preop_T_virtual
//
// answered by the transform repository (frames below), then converted to the
// Unity convention (left-handed, metres) by tracking/unity_convention.h for
// HoloLens clients. T_Vir^Pre is the handedness change between the mesh's
// virtual frame and the image frame: meshes exported in RAS for an LPS image
// need diag(-1, -1, 1), a rotation by pi about z (rigid, so it can live in
// the repository); the mirror to Unity's left-handed axes is applied last.
#include <Eigen/Geometry>
#include <span>
#include <string>

#include "mrsns/core/transform_repository.h"

namespace mrsns::hmd {

struct MrChainFrames {
  std::string hologram = "Hologram";
  std::string tracker = "Tracker";
  std::string patient = "Patient";
  std::string preop = "Preop";
  std::string virtual_model = "Virtual";
};

/// preop_T_virtual for a mesh in RAS and an image in LPS (or the reverse): diag(-1, -1, 1).
Eigen::Isometry3d preopFromVirtualRasLps();

/// Eq. 1 written out, for callers holding the four transforms.
Eigen::Isometry3d hologramFromVirtual(const Eigen::Isometry3d& tracker_T_hologram,
                                      const Eigen::Isometry3d& tracker_T_patient,
                                      const Eigen::Isometry3d& patient_T_preop,
                                      const Eigen::Isometry3d& preop_T_virtual);

/// Sets the four edges of Eq. 1 in the repository: the calibrations (hologram, registration,
/// handedness) as persistent, the patient reference as a tracked edge at `timestamp`.
void setMrChain(TransformRepository& repository, const Eigen::Isometry3d& tracker_T_hologram,
                const Eigen::Isometry3d& tracker_T_patient, const Eigen::Isometry3d& patient_T_preop,
                const Eigen::Isometry3d& preop_T_virtual, double timestamp = 0.0, const MrChainFrames& frames = {});

struct HologramPose {
  /// T_Vir^Hol in MR-SNS convention (right-handed, mm).
  Eigen::Isometry3d hologram_T_virtual = Eigen::Isometry3d::Identity();
  /// The same in the Unity convention (left-handed, metres), what a HoloLens app applies.
  Eigen::Matrix4d hologram_T_virtual_unity = Eigen::Matrix4d::Identity();
  TransformStatus status = TransformStatus::Missing;
  double timestamp = 0.0;
};

/// The hologram pose of the pre-operative model from the repository. Throws FrameError when
/// a frame is unknown or the chain is not connected (the message lists what each side reaches).
HologramPose hologramPose(const TransformRepository& repository, const MrChainFrames& frames = {});

/// Eq. 23: RMS distance (mm) between fiducials where they are (patient frame,
/// patient_T_virtual_true * P_i^v) and where the hologram shows them, given the true
/// calibration: inverse(tracker_T_patient) * tracker_T_hologram_true * hologram_T_virtual * P_i^v.
/// Throws InvalidArgumentError on no points.
double fusionRmsErrorMm(std::span<const Eigen::Vector3d> fiducial_virtual, const Eigen::Isometry3d& hologram_T_virtual,
                        const Eigen::Isometry3d& tracker_T_hologram_true, const Eigen::Isometry3d& tracker_T_patient,
                        const Eigen::Isometry3d& patient_T_virtual_true);

}  // namespace mrsns::hmd
