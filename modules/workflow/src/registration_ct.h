#pragma once
// The CT side of a patient registration: what the session's typed document
// holds (the bone models, the fiducials in the CT, the planned screws), read
// once for a registration acquired from the devices or the in-process
// simulated patient.
#include <string>
#include <vector>

#include "mrsns/core/mesh.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

/// The session's CT as a registration needs it.
struct SessionRegistrationTargets {
  std::string ct_name;
  TriangleMesh bone;  ///< every bone model of the session in one mesh (CT mm)
  std::vector<std::string> labels;
  std::vector<Eigen::Vector3d> fiducials_ct;
  /// Unit, out of the bone: the fiducial screw's axis when it was found, else the bone's outward normal there.
  std::vector<Eigen::Vector3d> fiducial_axes_ct;
  std::vector<double> confidences;  ///< of an automatic find; NaN for placed or imported fiducials
  std::vector<PlannedScrew> plans;
};

/// Reads the session's bone models, fiducials and plan. Throws
/// InvalidArgumentError naming the step to run when the session has no CT
/// (import-ct), no bone model (make-models) or fewer than 3 fiducials
/// (find-fiducials, place-fiducial).
SessionRegistrationTargets sessionRegistrationTargets(const Session& session, const std::string& step);

}  // namespace mrsns::workflow::detail
