// The pointer's registration motions (see registration_motion.h).
#include "registration_motion.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>

#include "mrsns/core/error.h"

namespace mrsns::simulation {

namespace {

MotionSegment tipSegment(MotionKind kind, double duration_s, PoseFrame frame, const Eigen::Matrix3d& frame_R_tool,
                         const Eigen::Vector3d& tip) {
  MotionSegment s;
  s.kind = kind;
  s.duration_s = duration_s;
  s.frame = frame;
  s.pose_of = PoseOf::Tip;
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = frame_R_tool;
  pose.translation() = tip;
  s.pose = pose;
  return s;
}

/// Along the pointer's shaft, from the tip towards the marker (the segment's frame).
Eigen::Vector3d shaftDirection(const PointerGeometry& pointer) {
  const double length = pointer.tip_tool.norm();
  const Eigen::Vector3d up_tool = length > 1e-9 ? Eigen::Vector3d(-pointer.tip_tool / length) : Eigen::Vector3d::UnitZ();
  return pointer.frame_R_tool * up_tool;
}

/// Where a column along -y first meets the bone, between y_top and y_bottom.
std::optional<Eigen::Vector3d> firstHit(double x, double z, double y_top, double y_bottom,
                                        const std::function<double(const Eigen::Vector3d&)>& distance) {
  constexpr double kStep = 0.5;
  double previous = y_top;
  if (distance(Eigen::Vector3d(x, previous, z)) <= 0.0) return std::nullopt;  // starts inside: no exposed surface
  for (double y = y_top - kStep; y >= y_bottom; y -= kStep) {
    if (distance(Eigen::Vector3d(x, y, z)) <= 0.0) {
      double outside = previous, inside = y;
      for (int i = 0; i < 12; ++i) {
        const double mid = 0.5 * (outside + inside);
        (distance(Eigen::Vector3d(x, mid, z)) <= 0.0 ? inside : outside) = mid;
      }
      return Eigen::Vector3d(x, 0.5 * (outside + inside), z);
    }
    previous = y;
  }
  return std::nullopt;
}

}  // namespace

std::vector<MotionSegment> touchLandmarkSegments(const MotionSegment& touch, const PointerGeometry& pointer,
                                                 const std::vector<Eigen::Vector3d>& landmarks) {
  const auto& points = touch.points.empty() ? landmarks : touch.points;
  if (points.empty()) {
    throw InvalidArgumentError(touch.frame == PoseFrame::Phantom
                                   ? "touch_landmarks: the N-wire phantom's definition has no Landmarks: give the "
                                     "segment's points_mm"
                                   : "touch_landmarks: the patient has no fiducials (a label map): give the "
                                     "segment's points_mm");
  }
  for (const auto& m : touch.misplaced) {
    if (m.landmark < 1 || m.landmark > static_cast<int>(points.size())) {
      throw InvalidArgumentError("touch_landmarks: misplaced landmark " + std::to_string(m.landmark) +
                                 " is not one of the " + std::to_string(points.size()) + " touched");
    }
  }
  constexpr double kDownUpS = 0.5;
  const Eigen::Vector3d up = shaftDirection(pointer);
  std::vector<MotionSegment> out;
  for (std::size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector3d p = points[i];
    for (const auto& m : touch.misplaced) {
      if (m.landmark == static_cast<int>(i) + 1) p += m.offset;
    }
    const Eigen::Vector3d above = p + touch.approach_mm * up;
    const auto at = [&](MotionKind kind, double duration_s, const Eigen::Vector3d& tip) {
      out.push_back(tipSegment(kind, duration_s, touch.frame, pointer.frame_R_tool, tip));
    };
    at(MotionKind::Move, touch.travel_s, above);
    at(MotionKind::Move, kDownUpS, p);
    at(MotionKind::Hold, touch.dwell_s, p);
    at(MotionKind::Move, kDownUpS, above);
  }
  return out;
}

std::vector<MotionSegment> traceBoneSegments(const MotionSegment& trace, const PointerGeometry& pointer,
                                             const std::vector<Eigen::Vector3d>& landmarks_ct,
                                             const std::function<double(const Eigen::Vector3d&)>& bone_distance_ct) {
  if (landmarks_ct.empty()) {
    throw InvalidArgumentError("trace_bone: the patient has no fiducials to say where the bone is exposed");
  }
  Eigen::AlignedBox3d box;
  for (const auto& p : landmarks_ct) box.extend(p);
  box.min() -= Eigen::Vector3d::Constant(trace.trace_margin_mm);
  box.max() += Eigen::Vector3d::Constant(trace.trace_margin_mm);
  const double width = std::max(box.sizes().x(), 1.0), height = std::max(box.sizes().z(), 1.0);
  // A grid of about trace_points columns with square cells.
  const double cell = std::sqrt(width * height / trace.trace_points);
  const int nx = std::max(2, static_cast<int>(std::lround(width / cell)));
  const int nz = std::max(2, static_cast<int>(std::lround(height / cell)));
  const double y_top = box.max().y() + 40.0, y_bottom = box.min().y() - 40.0;
  std::vector<Eigen::Vector3d> path;
  for (int iz = 0; iz < nz; ++iz) {
    for (int k = 0; k < nx; ++k) {
      const int ix = iz % 2 == 0 ? k : nx - 1 - k;  // serpentine: the tip never jumps back across the area
      const double x = box.min().x() + width * (ix + 0.5) / nx;
      const double z = box.min().z() + height * (iz + 0.5) / nz;
      if (auto hit = firstHit(x, z, y_top, y_bottom, bone_distance_ct)) path.push_back(*hit);
    }
  }
  if (path.size() < 2) {
    throw InvalidArgumentError("trace_bone: no exposed bone surface under the landmarks' extent");
  }
  constexpr double kApproachS = 1.0, kDownUpS = 0.5;
  const Eigen::Vector3d up = shaftDirection(pointer);
  const double step_s = std::max(0.02, (trace.duration_s - kApproachS - 2.0 * kDownUpS) / (path.size() - 1));
  std::vector<MotionSegment> out;
  out.push_back(tipSegment(MotionKind::Move, kApproachS, PoseFrame::CT, pointer.frame_R_tool, path.front() + 20.0 * up));
  out.push_back(tipSegment(MotionKind::Move, kDownUpS, PoseFrame::CT, pointer.frame_R_tool, path.front()));
  for (std::size_t i = 1; i < path.size(); ++i) {
    out.push_back(tipSegment(MotionKind::Move, step_s, PoseFrame::CT, pointer.frame_R_tool, path[i]));
  }
  out.push_back(tipSegment(MotionKind::Move, kDownUpS, PoseFrame::CT, pointer.frame_R_tool, path.back() + 20.0 * up));
  return out;
}

}  // namespace mrsns::simulation
