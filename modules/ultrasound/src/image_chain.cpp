#include "mrsns/ultrasound/image_chain.h"

#include <algorithm>
#include <string>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"

namespace mrsns::ultrasound {

Eigen::Isometry3d probePoseAtVideoTime(const std::vector<FramePose>& poses, double frame_time_s, double tracker_lag_s) {
  if (poses.empty()) throw InvalidArgumentError("probePoseAtVideoTime: no probe pose");
  const double t = frame_time_s + tracker_lag_s;
  for (std::size_t i = 1; i < poses.size(); ++i) {
    if (poses[i].timestamp < poses[i - 1].timestamp) {
      throw InvalidArgumentError("probePoseAtVideoTime: the probe poses are not in time order (sample " +
                                 std::to_string(i) + ")");
    }
  }
  if (t < poses.front().timestamp || t > poses.back().timestamp) {
    throw InvalidArgumentError("probePoseAtVideoTime: time " + std::to_string(t) +
                               " s (frame time + tracker lag) is outside the tracker stream [" +
                               std::to_string(poses.front().timestamp) + ", " + std::to_string(poses.back().timestamp) +
                               "] s");
  }
  const auto it = std::lower_bound(poses.begin(), poses.end(), t,
                                   [](const FramePose& p, double time) { return p.timestamp < time; });
  if (it == poses.begin()) return it->to_T_from;
  const auto& b = *it;
  const auto& a = *(it - 1);
  const double span = b.timestamp - a.timestamp;
  return interpolatePose(a.to_T_from, b.to_T_from, span > 0.0 ? (t - a.timestamp) / span : 0.0);
}

ImagePlacement placeImage(TransformRepository& repository, const Eigen::Isometry3d& reference_T_probe,
                          const Eigen::Matrix4d& probe_T_image, int width, int height, std::string_view target_frame) {
  if (width <= 0 || height <= 0) throw InvalidArgumentError("placeImage: the image size must be positive");
  repository.setTransform("Probe", "Reference", reference_T_probe);
  const auto target_T_probe = repository.getTransform("Probe", target_frame);
  ImagePlacement out;
  out.target_T_image = target_T_probe.to_T_from.matrix() * probe_T_image;
  const double w = width - 1, h = height - 1;
  const std::array<Eigen::Vector2d, 4> px{Eigen::Vector2d(0, 0), Eigen::Vector2d(w, 0), Eigen::Vector2d(0, h),
                                          Eigen::Vector2d(w, h)};
  for (std::size_t i = 0; i < 4; ++i) {
    out.corners_mm[i] = (out.target_T_image * Eigen::Vector4d(px[i].x(), px[i].y(), 0.0, 1.0)).head<3>();
  }
  return out;
}

}  // namespace mrsns::ultrasound
