#include "mrsns/hmd/mr_chain.h"

#include <cmath>

#include "mrsns/core/error.h"
#include "mrsns/tracking/unity_convention.h"

namespace mrsns::hmd {

Eigen::Isometry3d preopFromVirtualRasLps() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::Vector3d(-1.0, -1.0, 1.0).asDiagonal();
  return T;
}

Eigen::Isometry3d hologramFromVirtual(const Eigen::Isometry3d& tracker_T_hologram,
                                      const Eigen::Isometry3d& tracker_T_patient,
                                      const Eigen::Isometry3d& patient_T_preop,
                                      const Eigen::Isometry3d& preop_T_virtual) {
  return tracker_T_hologram.inverse() * tracker_T_patient * patient_T_preop * preop_T_virtual;
}

void setMrChain(TransformRepository& repository, const Eigen::Isometry3d& tracker_T_hologram,
                const Eigen::Isometry3d& tracker_T_patient, const Eigen::Isometry3d& patient_T_preop,
                const Eigen::Isometry3d& preop_T_virtual, double timestamp, const MrChainFrames& frames) {
  const double persistent_time = std::numeric_limits<double>::quiet_NaN();
  repository.setTransform(frames.hologram, frames.tracker, tracker_T_hologram, TransformStatus::Ok, persistent_time,
                          true);
  repository.setTransform(frames.patient, frames.tracker, tracker_T_patient, TransformStatus::Ok, timestamp, false);
  repository.setTransform(frames.preop, frames.patient, patient_T_preop, TransformStatus::Ok, persistent_time, true);
  repository.setTransform(frames.virtual_model, frames.preop, preop_T_virtual, TransformStatus::Ok, persistent_time,
                          true);
}

HologramPose hologramPose(const TransformRepository& repository, const MrChainFrames& frames) {
  const TransformResult r = repository.getTransform(frames.virtual_model, frames.hologram);
  HologramPose pose;
  pose.hologram_T_virtual = r.to_T_from;
  pose.hologram_T_virtual_unity = tracking::transformToUnity(r.to_T_from.matrix());
  pose.status = r.status;
  pose.timestamp = r.timestamp;
  return pose;
}

double fusionRmsErrorMm(std::span<const Eigen::Vector3d> fiducial_virtual, const Eigen::Isometry3d& hologram_T_virtual,
                        const Eigen::Isometry3d& tracker_T_hologram_true, const Eigen::Isometry3d& tracker_T_patient,
                        const Eigen::Isometry3d& patient_T_virtual_true) {
  if (fiducial_virtual.empty()) {
    throw InvalidArgumentError("fusionRmsErrorMm: no fiducials; give the virtual fiducials of Eq. 23 (6 in the paper)");
  }
  const Eigen::Isometry3d patient_T_shown = tracker_T_patient.inverse() * tracker_T_hologram_true * hologram_T_virtual;
  double sum = 0.0;
  for (const auto& p : fiducial_virtual) sum += (patient_T_virtual_true * p - patient_T_shown * p).squaredNorm();
  return std::sqrt(sum / static_cast<double>(fiducial_virtual.size()));
}

}  // namespace mrsns::hmd
