#pragma once
// What the preparation steps on the patient's data share: the session's CT
// and label maps read back from the session folder, models written with
// their headset copy, provenance, and the planned screws' figures kept up to
// date whenever the anatomy or the plan changes.
#include <string>
#include <vector>

#include "mrsns/core/image.h"
#include "mrsns/core/mesh.h"
#include "mrsns/workflow/session.h"
#include "step_internal.h"

namespace mrsns::workflow::detail {

/// Provenance of something `step` made now (source "step", or "file" with the user's `file`).
Provenance madeBy(const std::string& step, const std::string& file = {});

/// The session's CT, read from its file. Throws InvalidArgumentError naming
/// import-ct when the session has none, FileError when its file is gone.
ImageVolume loadSessionCt(const Session& session, const std::string& step);

/// A label map of the session (on the CT's grid), read from its file.
ImageVolume loadSessionLabelMap(const Session& session, const LabelMapEntry& labels);

/// The label map `id`, or the session's latest one when `id` is empty.
/// Throws InvalidArgumentError naming import-label-map when there is none,
/// or listing the ids when `id` names none.
LabelMapEntry sessionLabelMap(const Session& session, const std::string& id, const std::string& step);

/// Writes `mesh` as models/<id>.vtp (and a copy decimated to at most
/// `hmd_triangles` as models/hmd/<id>.vtp when hmd_triangles > 0 and the
/// mesh is larger), fills the entry's files, triangle counts and enclosed
/// volume, and lists the files in `outputs`. Does not store the entry.
ModelEntry writeModelFiles(const Session& session, const TriangleMesh& mesh, ModelEntry entry,
                           std::size_t hmd_triangles, std::vector<std::string>& outputs);

/// The screws' figures (clearance to the soft tissue, vessels and neural
/// structures, cortical breach, angles to the vertebra's axes) recomputed on
/// the session's models for every planned screw, and the plan's Slicer
/// markups copy (plans/Plan.mrk.json) rewritten. Saves. Returns the figures
/// by screw name.
Json refreshPlanFigures(Session& session);

/// Throws InvalidArgumentError naming `step` and the screw when it cannot be
/// placed: no name, non-finite or coincident ends, a diameter outside (0, 15]
/// mm, a length outside [0, 200] mm, a side other than left/right, an end or
/// the tip outside the CT.
void checkScrew(const PlannedScrew& screw, const ImageEntry& ct, const std::string& step);

/// The plan's Slicer markups copy, plans/Plan.mrk.json (removed when the plan is empty).
void writePlanFile(Session& session, const std::vector<PlannedScrew>& plans);

/// "x,y,z" (or "x y z", or a JSON array of 3 numbers) as a point; throws
/// InvalidArgumentError naming the step and parameter otherwise.
Eigen::Vector3d pointParam(const Json& params, const std::string& key, const std::string& step);

/// The bounds of the session's CT in LPS mm (its voxel centres' box grown by half a voxel).
Eigen::AlignedBox3d ctBounds(const ImageEntry& ct);

}  // namespace mrsns::workflow::detail
