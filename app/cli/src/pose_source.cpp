#include "pose_source.h"

#include <cstdio>

#include "mrsns/core/error.h"
#include "mrsns/core/frame_poses.h"
#include "mrsns/io/pose_csv.h"
#include "mrsns/io/sequence_file.h"

namespace mrsns::cli {

void addPoseSourceOptions(CLI::App& sub, PoseSourceOptions& options, const std::string& default_transform) {
  options.transform = default_transform;
  sub.add_option("--sequence", options.sequence,
                 "PLUS sequence file (.igs.mha, .seq.mha, .mhd, .seq.nrrd) with the poses");
  sub.add_option("--transform", options.transform,
                 "transform to take from each frame, PLUS style (computed through the frame's transforms, e.g. "
                 "StylusToReference from StylusToTracker and ReferenceToTracker)")
      ->capture_default_str();
  sub.add_option("--csv", options.csv, "pose CSV instead of a sequence: 16 (or timestamp + 16) numbers per line");
}

LoadedPoses loadPoses(const PoseSourceOptions& options) {
  if (options.sequence.empty() == options.csv.empty()) {
    throw InvalidArgumentError("give the poses either with --sequence FILE (and --transform NAME) or with --csv FILE");
  }
  LoadedPoses loaded;
  if (!options.csv.empty()) {
    auto csv = io::readPoseCsv(options.csv);
    loaded.poses = std::move(csv.poses);
    loaded.summary = Json{{"file", options.csv}, {"frames", loaded.poses.size()}, {"used", loaded.poses.size()}};
    return loaded;
  }
  io::SequenceReadOptions read_options;
  const auto sequence = io::readSequenceHeader(options.sequence, read_options);
  const auto extraction = extractFramePoses(sequence.frames, options.transform);
  for (const auto& p : extraction.poses) loaded.poses.push_back(p.to_T_from);
  loaded.summary = Json{{"file", options.sequence},
                        {"transform", options.transform},
                        {"frames", sequence.frames.size()},
                        {"used", extraction.poses.size()},
                        {"skipped_invalid", extraction.invalid_frames},
                        {"skipped_missing", extraction.missing_frames}};
  return loaded;
}

std::string formatVector(const Eigen::Vector3d& v, int decimals) {
  char buffer[128];
  std::snprintf(buffer, sizeof buffer, "[%.*f, %.*f, %.*f]", decimals, v.x(), decimals, v.y(), decimals, v.z());
  return buffer;
}

}  // namespace mrsns::cli
