// The CT side of a patient registration (see registration_ct.h).
#include "registration_ct.h"

#include "mrsns/core/error.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/io/mesh_io.h"

namespace mrsns::workflow::detail {

SessionRegistrationTargets sessionRegistrationTargets(const Session& session, const std::string& step) {
  SessionRegistrationTargets t;
  const auto ct = session.ct();
  if (!ct) {
    throw InvalidArgumentError(step + ": the session has no CT to register: import the patient's CT (import-ct), "
                                      "make its bone models (make-models) and find its fiducials (find-fiducials)");
  }
  t.ct_name = ct->name;
  std::vector<TriangleMesh> bones;
  for (const auto& m : session.models(ModelRole::Bone)) bones.push_back(io::readMesh(session.resolve(m.file)));
  if (bones.empty()) {
    throw InvalidArgumentError(step + ": the session's CT has no bone model: make them first (make-models): the "
                                      "surface registration fits the swept points to the bone");
  }
  t.bone = mergeMeshes(bones);
  t.bone.frame = "CT";
  const auto fiducials = session.fiducials();
  if (!fiducials || fiducials->points.size() < 3) {
    throw InvalidArgumentError(step + ": the session's CT has " +
                               std::to_string(fiducials ? fiducials->points.size() : 0) +
                               " fiducial(s): a landmark registration needs at least 3; find them in the CT "
                               "(find-fiducials) or place them (place-fiducial)");
  }
  const MeshLocator locator(t.bone);
  const PointsN3 normals = faceNormals(t.bone);
  for (const auto& f : fiducials->points) {
    t.labels.push_back(f.label);
    t.fiducials_ct.push_back(f.position_ct);
    t.confidences.push_back(f.confidence);
    Eigen::Vector3d axis = f.axis_ct;
    if (!(axis.norm() > 0.5)) {
      // Where the pointer comes from: out of the bone at the fiducial.
      const auto closest = locator.closestPoint(f.position_ct);
      axis = normals.row(closest.face).transpose();
    }
    t.fiducial_axes_ct.push_back(axis.normalized());
  }
  t.plans = session.plans();
  return t;
}

}  // namespace mrsns::workflow::detail
