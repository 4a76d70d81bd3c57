#pragma once
// Transform files: ITK/Slicer transform files (.tfm and ITK .txt text,
// .h5/.hdf5, .mat) and plain 4x4 text matrices (.txt: 4 lines of 4 numbers).
//
// Conventions (read this before using a matrix from a file):
// - An ITK transform file stores T in ITK's *resampling* direction: T maps a
//   point of the fixed (reference, parent) space to the moving (child) space,
//   in LPS millimetres. readTransformFile() returns exactly that T (composed
//   over all components of a composite transform, first applied on the right).
// - 3D Slicer saves a transform node by writing the inverse of its ToParent
//   matrix, converted from RAS to LPS. So for a Slicer node "ProbeToTracker"
//   (ToParent maps probe -> tracker, i.e. tracker_T_probe in RAS), the file
//   holds T = probe_T_tracker in LPS. parentFromChildLps(T) = T^-1 gives
//   tracker_T_probe in LPS; slicerToParentRas(T) gives the matrix Slicer shows.
// - A plain 4x4 text matrix carries no convention: it is returned as written
//   (mrsns writes T itself, so .tfm -> .txt -> .tfm keeps the numbers).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <filesystem>
#include <string>
#include <vector>

namespace mrsns::io {

struct TransformFile {
  std::string format;  ///< "itk-text", "itk-hdf5", "itk-matlab" or "matrix-text"
  /// ITK class names in the order they are applied (e.g. "Euler3DTransform_double_3_3"); empty for matrix-text.
  std::vector<std::string> components;
  /// True when every component is linear (matrix + offset), so `matrix` describes the whole transform.
  bool linear = false;
  /// The file's transform T as a homogeneous matrix (see the conventions above); identity when not linear.
  Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();
  /// || R^T R - I ||_F of the 3x3 part (0 for a rotation; larger with scaling or shear).
  double orthonormality_error = 0.0;
  /// Linear, orthonormal within 1e-5, det(R) > 0 and last row (0, 0, 0, 1).
  bool rigid = false;
};

/// Reads a transform file; the format follows from its extension (.tfm,
/// .h5/.hdf5, .mat) and, for .txt, from its content ("#Insight Transform
/// File" header or 16 numbers). Non-linear content (B-spline, displacement
/// field) is read with linear = false. Throws FileError when the file cannot
/// be opened, FormatError naming the file when it is malformed.
TransformFile readTransformFile(const std::filesystem::path& path);

/// The file's T as a 4x4 matrix; throws UnsupportedError (naming the file and
/// the non-linear component) when the transform is not linear.
Eigen::Matrix4d readLinearTransform(const std::filesystem::path& path);

/// The file's T as a rigid transform; throws UnsupportedError when it is not
/// linear or not rigid within `tolerance` (|| R^T R - I ||_F, e.g. scaling),
/// naming the file and the measured error. Tiny round-off is projected away.
Eigen::Isometry3d readRigidTransform(const std::filesystem::path& path, double tolerance = 1e-5);

/// Writes T (a linear transform; see the conventions above) by extension:
/// .tfm (ITK text), .h5/.hdf5 (ITK HDF5), .mat (ITK Matlab) as
/// AffineTransform_double_3_3, or .txt as a plain 4x4 matrix. Throws
/// InvalidArgumentError for a non-finite or non-affine matrix.
void writeTransformFile(const Eigen::Matrix4d& transform, const std::filesystem::path& path);

/// parent_T_child in LPS from a file's T (its inverse).
Eigen::Matrix4d parentFromChildLps(const Eigen::Matrix4d& file_transform);

/// The ToParent matrix 3D Slicer shows (RAS) for a file holding T.
Eigen::Matrix4d slicerToParentRas(const Eigen::Matrix4d& file_transform);

/// The T to write so that 3D Slicer shows ToParent matrix `to_parent_ras`.
Eigen::Matrix4d fileTransformFromSlicerToParentRas(const Eigen::Matrix4d& to_parent_ras);

/// The same transform expressed in the other of RAS/LPS (the flip is its own inverse).
Eigen::Matrix4d flipRasLps(const Eigen::Matrix4d& transform);

}  // namespace mrsns::io
