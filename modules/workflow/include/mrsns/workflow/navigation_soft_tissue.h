#pragma once
// The live soft tissue of navigation (NavigationOptions::soft_tissue) from a session: what the navigation step
// and the GUI's live navigation both use.
#include <string>
#include <vector>

#include "mrsns/workflow/navigation.h"

namespace mrsns::workflow {

class Session;

/// Sets options.soft_tissue from the session: its shape model and placement (ct_T_model), the CT's extent, the
/// registration (CTToPatient), the probe's spatial calibration (ImageToProbe, with the frame size and the probe
/// it was made with) and the tracker lag it holds for. probe_transform and patient_transform are kept (set them
/// first). Returns what the session lacks, each naming the step that makes it; then options are not changed.
std::vector<std::string> applySessionSoftTissue(const Session& session, NavigationOptions& options);

}  // namespace mrsns::workflow
