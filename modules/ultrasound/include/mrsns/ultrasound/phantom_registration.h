#pragma once
// PhantomToReference from the phantom's landmarks (PLUS configuration
// Landmarks) touched with a tracked stylus, by paired-point registration.
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "mrsns/io/device_set.h"

namespace mrsns::ultrasound {

struct PhantomRegistrationResult {
  Eigen::Isometry3d reference_T_phantom = Eigen::Isometry3d::Identity();
  double fre_rms_mm = 0.0;
  std::vector<double> fre_mm;  ///< per landmark, in the phantom's landmark order
  std::vector<std::string> landmark_names;
  std::vector<int> suspect_landmarks;  ///< leave-one-out outliers, worst first
};

/// `stylus_tips_reference[i]` is the stylus tip (Reference frame, mm) on
/// landmark i of the phantom definition. Throws InvalidArgumentError when
/// the counts differ or the phantom has fewer than 3 landmarks.
PhantomRegistrationResult registerPhantom(const io::PhantomDefinition& phantom,
                                          const std::vector<Eigen::Vector3d>& stylus_tips_reference);

}  // namespace mrsns::ultrasound
