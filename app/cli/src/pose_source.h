#pragma once
// Tool poses for calibration verbs: from a PLUS sequence file and a
// transform name (computed per frame through the transform repository), or
// from a pose CSV.
#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <vector>

#include "cli_context.h"

namespace mrsns::cli {

struct PoseSourceOptions {
  std::string sequence;
  std::string transform;
  std::string csv;
  /// Only frames first_frame..last_frame (0-based, inclusive; -1: to the end): the part of a recording an
  /// acquisition used.
  int first_frame = 0;
  int last_frame = -1;
};

struct LoadedPoses {
  std::vector<Eigen::Isometry3d> poses;
  /// {"file", "transform", "frames", "used", "skipped_invalid", "skipped_missing"}.
  Json summary = Json::object();
};

/// Adds --sequence/--transform/--csv/--first-frame/--last-frame to a subcommand.
void addPoseSourceOptions(CLI::App& sub, PoseSourceOptions& options, const std::string& default_transform);

/// Throws InvalidArgumentError when neither or both sources are given.
LoadedPoses loadPoses(const PoseSourceOptions& options);

/// "[x, y, z]" with 3 decimals, for text reports.
std::string formatVector(const Eigen::Vector3d& v, int decimals = 3);

}  // namespace mrsns::cli
