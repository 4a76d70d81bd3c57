#pragma once
// The live soft tissue of the navigation loop (paper 001 Algorithm 1 on the source's ultrasound): frames from
// the source's thread, probe and patient poses from the loop thread, the posterior on a worker of its own so
// neither waits. Only the latest frame is kept: a frame that comes while another is processed replaces the
// waiting one (counted as skipped). The posterior near the planned paths, with each face's standard deviation,
// goes to a sink (the robot's supervisor) after every update.
#include <Eigen/Geometry>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "mrsns/core/frame_poses.h"
#include "mrsns/core/plane_intersection.h"
#include "mrsns/registration/screw_path.h"
#include "mrsns/tracking/tracking_source.h"
#include "mrsns/workflow/navigation.h"

namespace mrsns {
class MeshLocator;
}
namespace mrsns::robot {
struct SoftTissueSurface;
}
namespace mrsns::deformation {
class PosteriorShapeTracker;
}

namespace mrsns::workflow::detail {

class LiveSoftTissue {
 public:
  using SurfaceSink = std::function<void(std::shared_ptr<const robot::SoftTissueSurface>, double frame_arrival_s)>;
  using EventSink = std::function<void(const std::string& kind, const std::string& message)>;
  /// The whole posterior mean mesh (CT frame), at most every 0.2 s and at the end: the headset's hologram.
  using MeshSink = std::function<void(const std::shared_ptr<const TriangleMesh>&)>;

  /// Loads and checks the model (a refusal is kept as the status, never thrown). `paths_ct`: the planned
  /// paths in the CT frame, whose neighbourhood the supervisor gets. `clock`: the loop clock.
  LiveSoftTissue(SoftTissueOptions options, std::vector<registration::ScrewPath> paths_ct, std::function<double()> clock,
                 EventSink events);
  ~LiveSoftTissue();
  LiveSoftTissue(const LiveSoftTissue&) = delete;
  LiveSoftTissue& operator=(const LiveSoftTissue&) = delete;

  /// Set before start().
  void setSurfaceSink(SurfaceSink sink);
  void setMeshSink(MeshSink sink);
  void start();
  void stop();

  /// Loop thread: the poses of one tracking batch.
  void observe(std::span<const tracking::ToolUpdate> batch);
  /// Source thread: a frame (copied; never blocks for long).
  void push(const tracking::TrackedImage& image);

  /// Fills the soft-tissue fields of `status`.
  void fillStatus(NavigationStatus& status) const;
  [[nodiscard]] std::vector<SoftTissueSample> samples() const;
  [[nodiscard]] std::optional<LiveUltrasoundFrame> latestFrame() const;
  /// The posterior mean mesh in the CT frame (null before the model is loaded or when refused).
  [[nodiscard]] std::shared_ptr<const TriangleMesh> currentMeshCt() const;
  [[nodiscard]] bool active() const;

 private:
  void run();
  void process(tracking::TrackedImage image, double arrived_s);
  void refuse(const std::string& why);
  void prepareSupervisorRegion(const std::vector<registration::ScrewPath>& paths_ct);
  std::shared_ptr<const robot::SoftTissueSurface> supervisorSurface() const;

  SoftTissueOptions options_;
  std::function<double()> clock_;
  EventSink events_;
  SurfaceSink sink_;
  MeshSink mesh_sink_;
  std::unique_ptr<deformation::PosteriorShapeTracker> tracker_;  // worker thread only once started
  Eigen::Isometry3d model_T_ct_ = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d probe_T_image_ = Eigen::Isometry3d::Identity();  // image mm (x = i sx, y = j sy)
  Eigen::Vector2d pixel_spacing_ = Eigen::Vector2d::Ones();
  // The supervisor's region: model vertices near the planned paths, the faces among them (re-indexed), and
  // the rows of Q = U diag(sqrt(lambda)) and the mean for those vertices.
  std::vector<Eigen::Index> region_vertices_;
  Eigen::MatrixX3i region_faces_;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> region_q_;  // blocks of rows contiguous
  Eigen::VectorXd region_mean_;
  // The region's surface at the prior mean: every posterior's is this tree refitted (its vertices moved).
  std::shared_ptr<const MeshLocator> region_locator_;
  double last_mesh_s_ = -1e9;  // worker thread

  mutable std::mutex pose_mutex_;  // guards the two histories
  std::condition_variable pose_arrived_;
  std::deque<FramePose> tracker_T_probe_;
  std::deque<FramePose> tracker_T_patient_;

  mutable std::mutex mutex_;  // guards everything below
  std::condition_variable wake_;
  std::optional<std::pair<tracking::TrackedImage, double>> pending_;
  bool quit_ = false;
  std::string state_ = "off";
  std::string refusal_;
  NavigationStatus counts_;
  std::vector<SoftTissueSample> samples_;
  std::optional<LiveUltrasoundFrame> latest_;
  std::shared_ptr<const TriangleMesh> mesh_ct_;
  std::atomic<bool> running_{false};
  std::thread thread_;
};

}  // namespace mrsns::workflow::detail
