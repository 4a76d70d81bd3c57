#pragma once
// Line markups files: 3D Slicer .mrk.json holding one markup of type "Line"
// per entry (two control points, start and end), the form planned screw
// paths are stored in (start = entry, end = target; the description carries
// the screw's vertebra, diameter and length, see
// mrsns/registration/screw_path.h). Positions are LPS mm in MR-SNS; RAS
// files are converted on reading.
#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

namespace mrsns::io {

struct MarkupsLine {
  std::string name;
  Eigen::Vector3d start = Eigen::Vector3d::Zero();  ///< LPS mm
  Eigen::Vector3d end = Eigen::Vector3d::Zero();    ///< LPS mm
  std::string description;
};

/// Reads every "Line" markup of a .mrk.json (other markup types are skipped
/// with a log message). Throws FileError when the file cannot be opened,
/// FormatError naming the file and the markup when it is malformed (not JSON,
/// a line without exactly two placed points, non-numeric positions) or holds
/// no line, UnsupportedError for units other than mm or an unknown
/// coordinate system.
std::vector<MarkupsLine> readMarkupsLines(const std::filesystem::path& path);

/// Writes one "Line" markup per entry (LPS, with a length measurement) into
/// one .mrk.json. Throws InvalidArgumentError for non-finite points,
/// FileError when the file cannot be written.
void writeMarkupsLines(const std::vector<MarkupsLine>& lines, const std::filesystem::path& path);

}  // namespace mrsns::io
