#pragma once
// Calibration results in PLUS's files: the ImageToProbe written into a
// device-set configuration's CoordinateDefinitions (as fCal saves it), and
// the ImageToProbe of a PLUS ProbeCalibration result file.
#include <Eigen/Core>
#include <filesystem>
#include <string>

namespace mrsns::ultrasound {

/// Copies the configuration `input` to `output` with `to_T_from` stored as
/// <Transform From=FROM To=TO Matrix=... Error=... Date=...> in
/// CoordinateDefinitions (replacing one already there). Throws FileError /
/// FormatError naming the file.
void writeCoordinateDefinition(const std::filesystem::path& input, const std::filesystem::path& output,
                               const std::string& from, const std::string& to, const Eigen::Matrix4d& to_T_from,
                               double error_mm);

/// The ImageToProbe of a PLUS ProbeCalibrationResult file
/// (CalibrationResults/Transform From="Image" To="Probe"). Throws FileError /
/// FormatError naming the file.
Eigen::Matrix4d readPlusImageToProbe(const std::filesystem::path& results);

}  // namespace mrsns::ultrasound
