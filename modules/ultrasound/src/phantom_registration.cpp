#include "mrsns/ultrasound/phantom_registration.h"

#include "mrsns/core/error.h"
#include "mrsns/registration/paired_point.h"

namespace mrsns::ultrasound {

PhantomRegistrationResult registerPhantom(const io::PhantomDefinition& phantom,
                                          const std::vector<Eigen::Vector3d>& stylus_tips_reference) {
  if (phantom.landmarks.size() < 3) {
    throw InvalidArgumentError("phantom '" + phantom.name + "' defines " + std::to_string(phantom.landmarks.size()) +
                               " landmarks; at least 3 are needed for a registration");
  }
  if (stylus_tips_reference.size() != phantom.landmarks.size()) {
    throw InvalidArgumentError("phantom registration: " + std::to_string(stylus_tips_reference.size()) +
                               " stylus points for " + std::to_string(phantom.landmarks.size()) +
                               " phantom landmarks; touch every landmark once, in the definition's order");
  }
  std::vector<Eigen::Vector3d> moving;
  PhantomRegistrationResult result;
  for (const auto& l : phantom.landmarks) {
    moving.push_back(l.position_phantom);
    result.landmark_names.push_back(l.name);
  }
  const auto r = registration::registerPairedPoints(moving, stylus_tips_reference);
  result.reference_T_phantom.linear() = r.rotation;
  result.reference_T_phantom.translation() = r.translation;
  result.fre_rms_mm = r.fre_rms_mm;
  result.fre_mm = r.fre_mm;
  result.suspect_landmarks = r.suspect_points;
  return result;
}

}  // namespace mrsns::ultrasound
