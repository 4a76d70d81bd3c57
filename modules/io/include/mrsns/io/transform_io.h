#pragma once
// Transform files: ITK/Slicer transform files (.tfm and ITK .txt text,
// .h5/.hdf5, .mat) and plain 4x4 text matrices (.txt: 4 lines of 4 numbers).
//
// THE CONVENTION (what every MR-SNS writer and reader of a transform follows)
// A file is named after the 3D Slicer transform node it holds, "ChildToParent"
// (StylusTipToStylus.tfm, ImageToProbe.tfm, MovingToFixed.txt): the node's
// ToParent maps child points to the parent, i.e. parent_T_child
// (p_parent = parent_T_child * p_child), and the file stores it so that
// 3D Slicer loads exactly that node:
// - ITK formats (.tfm, a .txt starting "#Insight Transform File", .h5/.hdf5,
//   .mat) store ITK's *resampling* direction, the inverse:
//   file T = inverse(parent_T_child) in LPS, written as an
//   AffineTransform_double_3_3 (Parameters: the 3x3 of T row by row, then its
//   translation; FixedParameters: 0 0 0). Slicer shows ToParent in RAS as
//   flipRasLps(inverse(T)) = diag(-1,-1,1,1) * parent_T_child * diag(-1,-1,1,1).
// - A plain 4x4 text .txt holds parent_T_child itself in LPS, row by row
//   (p_parent = M p_child, as a PLUS device set's matrices are written).
// writeChildToParent() and readChildToParent() apply this whatever the
// extension, so `.tfm -> .txt -> .tfm` keeps the meaning, and work for affine
// transforms (an ImageToProbe with mm/pixel scaling) as well as rigid ones.
//
// The low-level API (readTransformFile, readLinearTransform,
// readRigidTransform, writeTransformFile) reads and writes the file's raw T
// as stored, with no convention applied: for `info` and for inspecting files.
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
  /// The file's raw T as a homogeneous matrix, as stored (for ITK formats the inverse of the node's
  /// ToParent, for matrix-text the numbers as written; see above); identity when not linear.
  Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();
  /// || R^T R - I ||_F of the 3x3 part (0 for a rotation; larger with scaling or shear).
  double orthonormality_error = 0.0;
  /// Linear, orthonormal within 1e-5, det(R) > 0 and last row (0, 0, 0, 1).
  bool rigid = false;
};

/// Low-level: reads a transform file's raw T (no convention applied; use
/// readChildToParent for what the file means). The format follows from its
/// extension (.tfm, .h5/.hdf5, .mat) and, for .txt, from its content
/// ("#Insight Transform File" header or 16 numbers). Non-linear content (B-spline, displacement
/// field) is read with linear = false. Throws FileError when the file cannot
/// be opened, FormatError naming the file when it is malformed.
TransformFile readTransformFile(const std::filesystem::path& path);

/// Low-level: the file's raw T as a 4x4 matrix; throws UnsupportedError
/// (naming the file and the non-linear component) when it is not linear.
Eigen::Matrix4d readLinearTransform(const std::filesystem::path& path);

/// Low-level: the file's raw T as a rigid transform; throws UnsupportedError
/// when it is not linear or not rigid within `tolerance` (|| R^T R - I ||_F,
/// e.g. scaling), naming the file and the measured error. Tiny round-off is projected away.
Eigen::Isometry3d readRigidTransform(const std::filesystem::path& path, double tolerance = 1e-5);

/// Low-level: writes `transform` as the file's raw T, as given, by extension:
/// .tfm (ITK text), .h5/.hdf5 (ITK HDF5), .mat (ITK Matlab) as
/// AffineTransform_double_3_3, or .txt as a plain 4x4 matrix. A file named
/// after a node must be written with writeChildToParent instead. Throws
/// InvalidArgumentError for a non-finite or non-affine matrix.
void writeTransformFile(const Eigen::Matrix4d& transform, const std::filesystem::path& path);

/// Writes the node ChildToParent, `parent_T_child` in LPS (rigid or affine),
/// by the convention above: .tfm/.h5/.hdf5/.mat hold its inverse, a .txt the
/// plain matrix itself. Throws InvalidArgumentError for a non-finite, non-affine
/// or singular matrix (an ITK file needs its inverse), UnsupportedError for
/// another extension, FileError when the file cannot be written.
void writeChildToParent(const Eigen::Matrix4d& parent_T_child, const std::filesystem::path& path);

/// Reads the node ChildToParent a file holds, parent_T_child in LPS, by the
/// convention above: the inverse of an ITK file's (linear, possibly composite)
/// T, or a plain .txt matrix as written. Throws as readTransformFile, plus
/// UnsupportedError for a non-linear transform and FormatError for a singular
/// matrix, naming the file.
Eigen::Matrix4d readChildToParent(const std::filesystem::path& path);

/// readChildToParent as a rigid transform: throws UnsupportedError when it is
/// not rigid within `tolerance` (|| R^T R - I ||_F, e.g. an image calibration's
/// pixel scaling), naming the file and the measured error. Tiny round-off is
/// projected away.
Eigen::Isometry3d readChildToParentRigid(const std::filesystem::path& path, double tolerance = 1e-5);

/// parent_T_child in LPS from an ITK file's raw T (its inverse). Not for a
/// plain .txt matrix, which holds parent_T_child itself: readChildToParent
/// knows the difference.
Eigen::Matrix4d parentFromChildLps(const Eigen::Matrix4d& file_transform);

/// The ToParent matrix 3D Slicer shows (RAS) for an ITK file holding raw T.
Eigen::Matrix4d slicerToParentRas(const Eigen::Matrix4d& file_transform);

/// The raw T of an ITK file for which 3D Slicer shows ToParent matrix `to_parent_ras`.
Eigen::Matrix4d fileTransformFromSlicerToParentRas(const Eigen::Matrix4d& to_parent_ras);

/// The same transform expressed in the other of RAS/LPS (the flip is its own inverse).
Eigen::Matrix4d flipRasLps(const Eigen::Matrix4d& transform);

}  // namespace mrsns::io
