#pragma once
// Soft-tissue tracking during live navigation (paper 001 Algorithm 1): the
// simulated carotid protocol's freehand sweep (deformation::simulateSweep,
// with its tracking noise and calibration error) replayed frame by frame
// from the navigation loop's deformation hook, the posterior shape updated
// from each frame's contours, and its error against the held-out ground
// truth (mean vertex distance, mm) per frame: the curve of the output
// area's deformation plot. The simulation is built on its own thread so
// navigation starts at once; frames are skipped until it is ready.
#include <Eigen/Core>
#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "mrsns/core/image.h"

namespace mrsns::deformation {
struct SimulatedSweep;
class PosteriorShapeTracker;
}  // namespace mrsns::deformation

namespace mrsns::gui {

struct LiveDeformationOptions {
  std::uint64_t seed = 1;
  int frames = 60;
  /// One ultrasound frame every this many tracking batches (60 Hz tracker:
  /// 20 frames a second, a 3 s sweep).
  int batches_per_frame = 3;
};

struct DeformationSample {
  double time_s = 0.0;  ///< navigation clock (since start)
  int frame = -1;       ///< sweep frame; -1 for the prior before the first frame
  double error_mm = 0.0;
};

class LiveDeformation {
 public:
  /// Starts building the simulation on a worker thread.
  explicit LiveDeformation(const LiveDeformationOptions& options = {});
  ~LiveDeformation();
  LiveDeformation(const LiveDeformation&) = delete;
  LiveDeformation& operator=(const LiveDeformation&) = delete;

  /// The navigation loop's deformation hook (loop thread). Never throws.
  void onBatch(double time_s);
  /// Samples since the last call (GUI thread).
  std::vector<DeformationSample> takeSamples();
  [[nodiscard]] bool ready() const { return ready_.load(); }
  /// The sweep is built or has failed: destroying this no longer waits.
  [[nodiscard]] bool built() const { return built_.load(); }
  /// The B-mode frame last used (GUI thread): an 8-bit slice with pixel
  /// spacing 1 and probe_T_pixel, the believed calibration mapping pixel
  /// (i, j, 0, 1) to probe mm. False before the first frame; `frame` says
  /// which one it is, so a caller can skip a frame it has shown already.
  bool latestImage(ImageVolume& image, Eigen::Matrix4d& probe_T_pixel, int& frame) const;
  /// Why the simulation could not be built (empty when fine).
  [[nodiscard]] std::string failure() const;

 private:
  LiveDeformationOptions options_;
  std::thread builder_;
  std::atomic<bool> ready_{false};
  std::atomic<bool> built_{false};
  std::unique_ptr<deformation::SimulatedSweep> sweep_;
  std::unique_ptr<deformation::PosteriorShapeTracker> tracker_;
  Eigen::VectorXd truth_shape_;
  std::uint64_t batches_ = 0;
  int next_frame_ = -1;  // -1: the prior is sampled first
  std::atomic<int> last_frame_{-1};
  mutable std::mutex mutex_;
  std::vector<DeformationSample> samples_;
  std::string failure_;
};

}  // namespace mrsns::gui
