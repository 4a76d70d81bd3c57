#pragma once
// What a surgeon does with a pointer for a patient registration, as motion
// segments of the tip: touching landmarks one after the other (approach,
// down, hold, up), and tracing the exposed bone surface. The world expands
// the scenario's touch_landmarks and trace_bone segments with these once it
// has built the patient.
#include <Eigen/Geometry>
#include <functional>
#include <vector>

#include "mrsns/simulation/scenario.h"

namespace mrsns::simulation {

struct PointerGeometry {
  Eigen::Vector3d tip_tool = Eigen::Vector3d::Zero();  ///< the tip in the marker frame
  /// The pointer's orientation while it works, in the frame of the segment (CT or Phantom).
  Eigen::Matrix3d frame_R_tool = Eigen::Matrix3d::Identity();
};

/// Holds and moves (in the segment's frame, pose_of tip) that touch
/// `landmarks` (that frame) in order, or the segment's own points when given,
/// with its misplaced touches. Throws InvalidArgumentError when there is
/// nothing to touch or a misplaced touch names a landmark that is not touched.
std::vector<MotionSegment> touchLandmarkSegments(const MotionSegment& touch, const PointerGeometry& pointer,
                                                 const std::vector<Eigen::Vector3d>& landmarks);

/// Moves of the tip over the bone surface seen from +y of the CT (posterior
/// in LPS: the exposed surface of a posterior approach), over the extent of
/// `landmarks_ct` in x and z widened by the segment's margin, in a
/// serpentine. `bone_distance_ct` is the signed distance to the bone (mm,
/// negative inside). Throws InvalidArgumentError when the area holds no bone.
std::vector<MotionSegment> traceBoneSegments(const MotionSegment& trace, const PointerGeometry& pointer,
                                             const std::vector<Eigen::Vector3d>& landmarks_ct,
                                             const std::function<double(const Eigen::Vector3d&)>& bone_distance_ct);

}  // namespace mrsns::simulation
