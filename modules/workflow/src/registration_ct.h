#pragma once
// The CT side of a patient registration: the patient's CT (the generated
// cervical phantom the session names as its input), its bone surface, the
// fiducial screws found in the CT image (metal threshold, one cluster per
// screw, where its axis meets the bone), the planned screw paths, and the
// context models the session shows.
#include <string>
#include <vector>

#include "mrsns/core/mesh.h"
#include "mrsns/registration/fiducials_from_mesh.h"
#include "mrsns/registration/label_meshing.h"
#include "mrsns/registration/phantom_cervical.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

struct PreparedCt {
  registration::CervicalPhantom phantom;
  registration::LabelMeshingResult bone_meshes;
  TriangleMesh bone;  ///< every vertebra in one mesh (CT mm)
  /// The fiducial screws found in the CT image, not the generator's list.
  std::vector<registration::DetectedFiducial> fiducials;
  int metal_components = 0;  ///< connected metal regions (the number of screws looked for)
};

/// Generates the CT, meshes the vertebrae and finds the fiducials; progress
/// between `from` and `to`. Throws ComputationError when the CT holds fewer
/// than 3 metal screws.
PreparedCt prepareCt(const registration::PhantomOptions& options, const StepContext& context, double from,
                     double to);

/// Writes the models (vertebrae, vessel, neck outline) in CT mm into
/// registration/models and returns their list for figures.models.
Json writePhantomModels(Session& session, const PreparedCt& ct, std::vector<std::string>& outputs);

/// figures.paths: the planned screws (CT mm).
Json screwPathsJson(const registration::CervicalPhantom& phantom);

}  // namespace mrsns::workflow::detail
