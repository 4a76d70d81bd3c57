#pragma once
// Poses as CSV, for tools that do not record PLUS sequences: one pose per
// line, either 16 numbers (a 4x4 matrix, row major) or 17 (a timestamp in
// seconds, then the 16), separated by commas, semicolons or whitespace.
// Lines starting with '#' and a first line of column names are skipped.
#include <Eigen/Geometry>
#include <filesystem>
#include <vector>

namespace mrsns::io {

struct PoseCsv {
  std::vector<Eigen::Isometry3d> poses;
  std::vector<double> timestamps;  ///< empty when the file has none
};

/// Throws FileError when unreadable, FormatError naming the file and line for
/// a malformed line or a matrix that is not rigid (within 1e-3 after
/// rounding; nearly rigid rows are orthonormalised).
PoseCsv readPoseCsv(const std::filesystem::path& path);

/// Writes poses (and timestamps, when given: same count) as 16 or 17 columns.
void writePoseCsv(const std::filesystem::path& path, const std::vector<Eigen::Isometry3d>& poses,
                  const std::vector<double>& timestamps = {});

}  // namespace mrsns::io
