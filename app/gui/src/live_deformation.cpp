#include "live_deformation.h"

#include <cstring>
#include <exception>

#include "mrsns/core/log.h"
#include "mrsns/deformation/shape_model_ops.h"
#include "mrsns/deformation/shape_tracker.h"
#include "mrsns/deformation/simulated_sweep.h"

namespace mrsns::gui {

LiveDeformation::LiveDeformation(const LiveDeformationOptions& options) : options_(options) {
  builder_ = std::thread([this] {
    try {
      deformation::DeformationTrialOptions trial;
      trial.frames = options_.frames;
      auto sweep = std::make_unique<deformation::SimulatedSweep>(deformation::simulateSweep(trial, options_.seed));
      deformation::ShapeTrackerOptions tracker_options = trial.tracker;
      tracker_options.posterior.noise_sigma_mm = trial.noise_sigma_mm;
      tracker_ = std::make_unique<deformation::PosteriorShapeTracker>(sweep->model, tracker_options);
      truth_shape_ = deformation::shapeVector(sweep->truth.vertices);
      sweep_ = std::move(sweep);
      ready_.store(true);
    } catch (const std::exception& e) {
      std::lock_guard lock(mutex_);
      failure_ = e.what();
      logger()->warn("live deformation: the simulated sweep could not be built: {}", e.what());
    }
    built_.store(true);
  });
}

LiveDeformation::~LiveDeformation() {
  if (builder_.joinable()) builder_.join();
}

std::string LiveDeformation::failure() const {
  std::lock_guard lock(mutex_);
  return failure_;
}

void LiveDeformation::onBatch(double time_s) {
  if (!ready_.load()) return;
  if (batches_++ % static_cast<std::uint64_t>(std::max(1, options_.batches_per_frame)) != 0) return;
  try {
    const int frame = next_frame_;
    if (frame >= 0) {
      const TrackedFrame& tracked = sweep_->sequence.frames[static_cast<std::size_t>(frame)];
      // Navigation's chain: Image -> Probe (the believed calibration, pixel
      // scale removed: Algorithm 1 works in image mm) -> Tracker -> Reference (= model).
      Eigen::Matrix4d unscale = Eigen::Matrix4d::Identity();
      unscale.diagonal().head<3>().setConstant(1.0 / sweep_->pixel_spacing_mm);
      const Eigen::Isometry3d probe_T_image(sweep_->image_to_probe * unscale);
      const Eigen::Isometry3d tracker_T_probe(tracked.transforms.at("ProbeToTracker").matrix);
      const Eigen::Isometry3d tracker_T_reference(tracked.transforms.at("ReferenceToTracker").matrix);
      const Eigen::Isometry3d model_T_image = tracker_T_reference.inverse() * tracker_T_probe * probe_T_image;
      tracker_->update(model_T_image, sweep_->true_contours[static_cast<std::size_t>(frame)]);
      last_frame_.store(frame);
    }
    const double error = deformation::meanVertexDistance(tracker_->currentShape(), truth_shape_);
    {
      std::lock_guard lock(mutex_);
      samples_.push_back(DeformationSample{time_s, frame, error});
    }
    // The sweep repeats from the prior, as a new patient would.
    next_frame_ = frame + 1;
    if (next_frame_ >= static_cast<int>(sweep_->sequence.frames.size())) {
      tracker_->reset();
      next_frame_ = -1;
    }
  } catch (const std::exception& e) {
    // Real-time: report and carry on with the next frame.
    logger()->warn("live deformation: frame {}: {}", next_frame_, e.what());
    next_frame_ = -1;
    tracker_->reset();
  }
}

bool LiveDeformation::latestImage(ImageVolume& image, Eigen::Matrix4d& probe_T_pixel, int& frame) const {
  frame = last_frame_.load();
  if (!ready_.load() || frame < 0) return false;
  // The sweep is immutable once ready: safe to read beside the loop thread.
  const auto& sequence = sweep_->sequence;
  const auto& pixels = sequence.frames[static_cast<std::size_t>(frame)].pixels;
  image.size = {static_cast<int>(sequence.geometry.size[0]), static_cast<int>(sequence.geometry.size[1]), 1};
  image.spacing = Eigen::Vector3d::Ones();
  image.pixel_type = PixelType::UInt8;
  image.data.resize(pixels.size());
  std::memcpy(image.data.data(), pixels.data(), pixels.size());
  probe_T_pixel = sweep_->image_to_probe;
  return true;
}

std::vector<DeformationSample> LiveDeformation::takeSamples() {
  std::lock_guard lock(mutex_);
  std::vector<DeformationSample> out;
  out.swap(samples_);
  return out;
}

}  // namespace mrsns::gui
