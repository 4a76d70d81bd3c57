#include "mrsns/deformation/simulated_sweep.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "mrsns/core/error.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/deformation/model_building.h"
#include "trial_random.h"

namespace mrsns::deformation {

SweepPose sweepPose(const DeformationTrialOptions& o, int frame, const Eigen::Vector3d& phases) {
  using detail::kDeg;
  const double s = o.frames > 1 ? static_cast<double>(frame) / (o.frames - 1) : 0.5;
  // Freehand sweep along the vessel: transverse slices, slow tilts and
  // lateral wander; the transducer face 12 mm above the vessel.
  const double z0 = -o.phantom.cca_length_mm + 2.0;
  const double z1 = o.phantom.branch_length_mm - 2.0;
  const double z = z0 + s * (z1 - z0);
  const double tilt_x = o.sweep_tilt_deg * kDeg * std::sin(2.0 * std::numbers::pi * 1.3 * s + phases[0]);
  const double tilt_y = o.sweep_tilt_deg * kDeg * std::sin(2.0 * std::numbers::pi * 0.9 * s + phases[1]);
  const double wander = 1.5 * std::sin(2.0 * std::numbers::pi * 0.7 * s + phases[2]);
  SweepPose p;
  p.model_T_probe.linear() =
      (Eigen::AngleAxisd(tilt_y, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(tilt_x, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  p.model_T_probe.translation() = Eigen::Vector3d(wander, 0.0, z);
  // Image frame: origin at the top-left pixel, x lateral, y depth.
  const double width = o.bmode.width * o.bmode.spacing_mm;
  p.probe_T_image.translation() = Eigen::Vector3d(-0.5 * width, -12.0, 0.0);
  return p;
}

SimulatedSweep simulateSweep(const DeformationTrialOptions& o, std::uint64_t seed) {
  if (o.training_shapes < 3 || o.frames < 1) {
    throw InvalidArgumentError("simulateSweep: need >= 3 training shapes and >= 1 frame");
  }
  std::mt19937_64 rng(seed);
  SimulatedSweep out;
  std::vector<TriangleMesh> training;
  for (int i = 0; i < o.training_shapes; ++i) {
    training.push_back(makeVesselPhantom(randomVesselDeformation(rng, 4, o.stretch_mm), o.phantom));
  }
  ShapeModelBuildOptions build;
  build.align = false;
  out.model = buildShapeModel(training, build).model;
  out.truth = makeVesselPhantom(randomVesselDeformation(rng, 4, o.stretch_mm), o.phantom);
  out.fiducial_vertices = phantomFiducialVertices(o.phantom);
  const Eigen::Isometry3d calibration_error =
      detail::randomRigid(rng, o.calibration_error_mm, o.calibration_rotation_deg);
  std::uniform_real_distribution<double> phase(0.0, 2.0 * std::numbers::pi);
  const Eigen::Vector3d phases(phase(rng), phase(rng), phase(rng));
  // A reference marker somewhere in the tracker's volume.
  Eigen::Isometry3d tracker_T_reference = Eigen::Isometry3d::Identity();
  tracker_T_reference.linear() = Eigen::AngleAxisd(0.5, Eigen::Vector3d(0.2, 1.0, 0.3).normalized()).toRotationMatrix();
  tracker_T_reference.translation() = Eigen::Vector3d(120.0, -40.0, -900.0);

  const double s = o.bmode.spacing_mm;
  out.pixel_spacing_mm = s;
  auto& seq = out.sequence;
  seq.geometry.dimensions = 2;
  seq.geometry.size = {o.bmode.width, o.bmode.height, 1};
  seq.geometry.spacing = {s, s, 1.0};
  seq.pixel_format = {PixelType::UInt8, 1};
  Eigen::Isometry3d believed_probe_T_image = Eigen::Isometry3d::Identity();
  for (int f = 0; f < o.frames; ++f) {
    const SweepPose pose = sweepPose(o, f, phases);
    const Eigen::Isometry3d true_model_T_image = pose.model_T_probe * pose.probe_T_image;
    const BModeImage image = renderBMode(out.truth, true_model_T_image, o.bmode, rng);
    const Eigen::Isometry3d measured_model_T_probe =
        pose.model_T_probe * detail::randomRigid(rng, o.tracking_noise_mm, o.tracking_rotation_deg);
    believed_probe_T_image = pose.probe_T_image * calibration_error;
    TrackedFrame frame;
    frame.timestamp = 10.0 + 0.05 * f;
    frame.transforms["ProbeToTracker"].matrix = (tracker_T_reference * measured_model_T_probe).matrix();
    frame.transforms["ReferenceToTracker"].matrix = tracker_T_reference.matrix();
    frame.pixels.resize(image.pixels.size());
    // 8 bits as a scanner exports them: 128 grey levels per unit of echo.
    std::transform(image.pixels.begin(), image.pixels.end(), frame.pixels.begin(),
                   [](float v) { return static_cast<std::uint8_t>(std::clamp(std::lround(128.0 * v), 0L, 255L)); });
    seq.frames.push_back(std::move(frame));
    const TriangleMesh in_image = transformMesh(out.truth, true_model_T_image.inverse());
    std::vector<Polyline3d> cut = intersectMeshWithPlane(in_image, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
    std::erase_if(cut, [](const Polyline3d& c) { return !c.closed || c.points.size() < 5; });
    out.true_contours.push_back(std::move(cut));
  }
  Eigen::Matrix4d scale = Eigen::Matrix4d::Identity();
  scale.diagonal().head<3>().setConstant(s);
  out.image_to_probe = believed_probe_T_image.matrix() * scale;
  return out;
}

}  // namespace mrsns::deformation
