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
  sub.add_option("--first-frame", options.first_frame,
                 "use frames from this one on (0-based index in the file: a sequence's frame or a CSV's pose line)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  sub.add_option("--last-frame", options.last_frame, "use frames up to this one, inclusive (-1: to the end)")
      ->capture_default_str()
      ->check(CLI::Range(-1, 1 << 30));
}

namespace {

bool inRange(const PoseSourceOptions& options, std::size_t index) {
  return index >= static_cast<std::size_t>(options.first_frame) &&
         (options.last_frame < 0 || index <= static_cast<std::size_t>(options.last_frame));
}

}  // namespace

LoadedPoses loadPoses(const PoseSourceOptions& options) {
  if (options.sequence.empty() == options.csv.empty()) {
    throw InvalidArgumentError("give the poses either with --sequence FILE (and --transform NAME) or with --csv FILE");
  }
  if (options.last_frame >= 0 && options.last_frame < options.first_frame) {
    throw InvalidArgumentError("--last-frame " + std::to_string(options.last_frame) + " is before --first-frame " +
                               std::to_string(options.first_frame));
  }
  LoadedPoses loaded;
  if (!options.csv.empty()) {
    auto csv = io::readPoseCsv(options.csv);
    for (std::size_t i = 0; i < csv.poses.size(); ++i) {
      if (inRange(options, i)) loaded.poses.push_back(csv.poses[i]);
    }
    loaded.summary = Json{{"file", options.csv}, {"frames", csv.poses.size()}, {"used", loaded.poses.size()}};
    return loaded;
  }
  io::SequenceReadOptions read_options;
  const auto sequence = io::readSequenceHeader(options.sequence, read_options);
  if (static_cast<std::size_t>(options.first_frame) >= sequence.frames.size()) {
    throw InvalidArgumentError("--first-frame " + std::to_string(options.first_frame) + ": '" + options.sequence +
                               "' has " + std::to_string(sequence.frames.size()) + " frames");
  }
  const auto extraction = extractFramePoses(sequence.frames, options.transform);
  for (const auto& p : extraction.poses) {
    if (inRange(options, p.frame_index)) loaded.poses.push_back(p.to_T_from);
  }
  loaded.summary = Json{{"file", options.sequence},
                        {"transform", options.transform},
                        {"frames", sequence.frames.size()},
                        {"used", loaded.poses.size()},
                        {"first_frame", options.first_frame},
                        {"last_frame", options.last_frame},
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
