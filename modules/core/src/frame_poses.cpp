#include "mrsns/core/frame_poses.h"

#include <set>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/transform_repository.h"

namespace mrsns {

FramePoseExtraction extractFramePoses(const std::vector<TrackedFrame>& frames, const std::string& transform_name,
                                      bool include_invalid) {
  const auto name = TransformName::parse(transform_name);
  FramePoseExtraction extraction;
  std::set<std::string> available;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    TransformRepository repo;
    bool repaired = false;
    for (const auto& [edge_name, transform] : frames[i].transforms) {
      available.insert(edge_name);
      Eigen::Isometry3d pose;
      try {
        pose = isRigid(transform.matrix, 1e-6) ? Eigen::Isometry3d(transform.matrix) : orthonormalize(transform.matrix);
        repaired = repaired || !isRigid(transform.matrix, 1e-6);
        repo.setTransform(edge_name, pose, transform.status, frames[i].timestamp);
      } catch (const Error&) {
        // An unusable matrix (e.g. all zeros for a tool out of view) counts as invalid.
        continue;
      }
    }
    if (!repo.hasFrame(name.from) || !repo.hasFrame(name.to) || !repo.isConnected(name.from, name.to)) {
      ++extraction.missing_frames;
      continue;
    }
    const auto result = repo.getTransform(name.from, name.to);
    if (result.status != TransformStatus::Ok && !include_invalid) {
      ++extraction.invalid_frames;
      continue;
    }
    if (repaired) ++extraction.orthonormalized_frames;
    extraction.poses.push_back(FramePose{i, frames[i].timestamp, result.to_T_from, result.status});
  }
  if (extraction.poses.empty() && extraction.invalid_frames == 0) {
    std::string list;
    for (const auto& n : available) list += (list.empty() ? "" : ", ") + n;
    throw FrameError("no frame of the sequence can give '" + transform_name +
                     "' (the frames report: " + (list.empty() ? std::string("no transforms") : list) + ")");
  }
  return extraction;
}

}  // namespace mrsns
