#include "mrsns/hmd/cube_calibration.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <string>

#include "mrsns/core/dense_solvers.h"
#include "mrsns/core/error.h"
#include "mrsns/registration/paired_point.h"

namespace mrsns::hmd {
namespace {

void requireFinite(std::span<const Eigen::Vector3d> points, const char* name) {
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!points[i].allFinite()) {
      throw InvalidArgumentError(std::string(name) + ": point " + std::to_string(i) +
                                 " is not finite; remove or re-collect it");
    }
  }
}

void requireSpread(std::span<const Eigen::Vector3d> points, const char* name, const CubeCalibrationOptions& options) {
  const Eigen::Vector3d extents = principalExtents(points);
  if (extents(0) <= 0.0 || extents(1) < options.min_collinearity_ratio * extents(0)) {
    throw InvalidArgumentError(std::string(name) +
                               ": the points are (nearly) collinear; the cube calibration needs at least 4 "
                               "fiducials spanning 3D (use vertices on different faces of the cube)");
  }
  if (extents(2) < options.min_planarity_ratio * extents(0)) {
    throw InvalidArgumentError(std::string(name) +
                               ": the points are (nearly) coplanar; the cube calibration needs at least 4 "
                               "fiducials spanning 3D (use vertices on different faces of the cube)");
  }
}

// Hartley normalisation: centroid to the origin, mean distance sqrt(3), so the DLT's design
// matrix is well scaled whatever the units and position of the data.
Eigen::Matrix4d normalisingTransform(std::span<const Eigen::Vector3d> points) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  double mean_distance = 0.0;
  for (const auto& p : points) mean_distance += (p - centroid).norm();
  mean_distance /= static_cast<double>(points.size());
  const double s = std::sqrt(3.0) / mean_distance;
  Eigen::Matrix4d N = Eigen::Matrix4d::Identity();
  N.topLeftCorner<3, 3>() *= s;
  N.topRightCorner<3, 1>() = -s * centroid;
  return N;
}

double rms(const std::vector<double>& values) {
  double sum = 0.0;
  for (double v : values) sum += v * v;
  return values.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(values.size()));
}

}  // namespace

Eigen::Vector3d principalExtents(std::span<const Eigen::Vector3d> points) {
  if (points.empty()) return Eigen::Vector3d::Zero();
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : points) centroid += p;
  centroid /= static_cast<double>(points.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : points) cov += (p - centroid) * (p - centroid).transpose();
  cov /= static_cast<double>(points.size());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  const Eigen::Vector3d ev = eig.eigenvalues().cwiseMax(0.0);  // ascending
  return {std::sqrt(ev(2)), std::sqrt(ev(1)), std::sqrt(ev(0))};
}

std::vector<Eigen::Vector3d> cubeFiducialsInTracker(const Eigen::Isometry3d& tracker_T_cube,
                                                    std::span<const Eigen::Vector3d> vertex_cube) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(vertex_cube.size());
  for (const auto& v : vertex_cube) out.push_back(tracker_T_cube * v);
  return out;
}

std::vector<Eigen::Vector3d> cubeVerticesFromDigitisation(std::span<const Eigen::Vector3d> tip_tracker,
                                                          std::span<const Eigen::Isometry3d> tracker_T_cube) {
  if (tracker_T_cube.size() != 1 && tracker_T_cube.size() != tip_tracker.size()) {
    throw InvalidArgumentError("cubeVerticesFromDigitisation: " + std::to_string(tip_tracker.size()) +
                               " tip positions but " + std::to_string(tracker_T_cube.size()) +
                               " cube poses; give one cube pose per tip or a single pose");
  }
  requireFinite(tip_tracker, "cubeVerticesFromDigitisation tip_tracker");
  std::vector<Eigen::Vector3d> out;
  out.reserve(tip_tracker.size());
  for (std::size_t i = 0; i < tip_tracker.size(); ++i) {
    const auto& pose = tracker_T_cube[tracker_T_cube.size() == 1 ? 0 : i];
    if (!pose.matrix().allFinite()) {
      throw InvalidArgumentError("cubeVerticesFromDigitisation: cube pose " + std::to_string(i) + " is not finite");
    }
    out.push_back(pose.inverse() * tip_tracker[i]);
  }
  return out;
}

CubeCalibrationResult calibrateCube(std::span<const Eigen::Vector3d> fiducial_tracker,
                                    std::span<const Eigen::Vector3d> fiducial_hololens,
                                    const CubeCalibrationOptions& options) {
  if (fiducial_tracker.size() != fiducial_hololens.size()) {
    throw InvalidArgumentError("calibrateCube: " + std::to_string(fiducial_tracker.size()) + " tracker points but " +
                               std::to_string(fiducial_hololens.size()) +
                               " hologram points; give one tracker point per hologram fiducial");
  }
  const std::size_t n = fiducial_tracker.size();
  if (n < 4) {
    throw InvalidArgumentError("calibrateCube: " + std::to_string(n) +
                               " fiducial pairs; the cube calibration needs at least 4 non-coplanar pairs");
  }
  requireFinite(fiducial_tracker, "calibrateCube fiducial_tracker");
  requireFinite(fiducial_hololens, "calibrateCube fiducial_hololens");
  requireSpread(fiducial_hololens, "calibrateCube fiducial_hololens", options);
  requireSpread(fiducial_tracker, "calibrateCube fiducial_tracker", options);

  CubeCalibrationResult result;
  result.principal_rms_mm = principalExtents(fiducial_hololens);

  // Rigid map.
  registration::PairedPointOptions pp;
  pp.leave_one_out = false;
  const auto rigid = registration::registerPairedPoints(fiducial_hololens, fiducial_tracker, pp);
  result.tracker_T_hololens.linear() = rigid.rotation;
  result.tracker_T_hololens.translation() = rigid.translation;
  result.rigid_residuals_mm = rigid.fre_mm;
  result.rigid_rms_mm = rigid.fre_rms_mm;

  // Affine map by the normalised DLT: x_tra' = M x_hol' with M 3x4 in normalised coordinates.
  const Eigen::Matrix4d Nh = normalisingTransform(fiducial_hololens);
  const Eigen::Matrix4d Nt = normalisingTransform(fiducial_tracker);
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3 * static_cast<Eigen::Index>(n), 12);
  Eigen::VectorXd b(3 * static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector4d h = Nh * fiducial_hololens[i].homogeneous();
    const Eigen::Vector4d t = Nt * fiducial_tracker[i].homogeneous();
    for (int r = 0; r < 3; ++r) {
      const auto row = static_cast<Eigen::Index>(3 * i) + r;
      A.block<1, 4>(row, 4 * r) = h.transpose();
      b(row) = t(r);
    }
  }
  Eigen::VectorXd sv;
  const Eigen::VectorXd m = svdLeastSquares(A, b, &sv);
  result.dlt_condition_number = sv(sv.size() - 1) > 0.0 ? sv(0) / sv(sv.size() - 1) : INFINITY;
  Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
  for (int r = 0; r < 3; ++r) M.block<1, 4>(r, 0) = m.segment<4>(4 * r).transpose();
  result.tracker_A_hololens = Nt.inverse() * M * Nh;
  result.tracker_A_hololens.row(3) << 0.0, 0.0, 0.0, 1.0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d mapped = (result.tracker_A_hololens * fiducial_hololens[i].homogeneous()).head<3>();
    result.affine_residuals_mm.push_back((mapped - fiducial_tracker[i]).norm());
  }
  result.affine_rms_mm = rms(result.affine_residuals_mm);
  // Singular values from the eigenvalues of L^T L (GCC 12 warns spuriously inside a 3x3 JacobiSVD).
  const Eigen::Matrix3d L = result.tracker_A_hololens.topLeftCorner<3, 3>();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> gram(L.transpose() * L);
  const Eigen::Vector3d ev = gram.eigenvalues().cwiseMax(0.0);
  result.affine_singular_values = Eigen::Vector3d(std::sqrt(ev(2)), std::sqrt(ev(1)), std::sqrt(ev(0)));
  result.affine_rigidity_deviation = (result.affine_singular_values.array() - 1.0).abs().maxCoeff();
  return result;
}

}  // namespace mrsns::hmd
