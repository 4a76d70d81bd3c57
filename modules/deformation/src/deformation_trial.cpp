#include "mrsns/deformation/deformation_trial.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numbers>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/surface_distance.h"
#include "mrsns/core/units.h"
#include "mrsns/deformation/model_building.h"
#include "mrsns/deformation/shape_model_ops.h"

namespace mrsns::deformation {
namespace {

Eigen::Isometry3d randomRigid(std::mt19937_64& rng, double translation_rms_mm, double rotation_deg) {
  std::normal_distribution<double> n(0.0, 1.0);
  const double s = translation_rms_mm / std::sqrt(3.0);
  Eigen::Vector3d axis(n(rng), n(rng), n(rng));
  axis.normalize();
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::AngleAxisd(rotation_deg * kDeg * n(rng), axis).toRotationMatrix();
  t.translation() = Eigen::Vector3d(s * n(rng), s * n(rng), s * n(rng));
  return t;
}

Summary summarise(const std::vector<double>& v) {
  Summary s;
  if (v.empty()) return s;
  for (double x : v) s.mean += x;
  s.mean /= static_cast<double>(v.size());
  for (double x : v) s.sd += (x - s.mean) * (x - s.mean);
  s.sd = v.size() > 1 ? std::sqrt(s.sd / static_cast<double>(v.size() - 1)) : 0.0;
  s.max = *std::max_element(v.begin(), v.end());
  return s;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const auto idx = static_cast<std::size_t>(
      std::clamp(q * static_cast<double>(v.size() - 1), 0.0, static_cast<double>(v.size() - 1)));
  return v[idx];
}

double fiducialError(const Eigen::VectorXd& a, const Eigen::VectorXd& b, const std::vector<int>& ids) {
  double sum = 0.0;
  for (int v : ids) sum += (a.segment<3>(3 * v) - b.segment<3>(3 * v)).norm();
  return sum / static_cast<double>(ids.size());
}

}  // namespace

DeformationTrialResult runDeformationTrial(const DeformationTrialOptions& o) {
  if (o.cases < 1 || o.training_shapes < 3 || o.frames < 1) {
    throw InvalidArgumentError("runDeformationTrial: need >= 1 case, >= 3 training shapes and >= 1 frame");
  }
  DeformationTrialResult result;
  std::mt19937_64 rng(o.seed);
  const std::vector<int> fiducials = phantomFiducialVertices(o.phantom);
  std::vector<double> all_update, all_seg;
  for (int case_index = 0; case_index < o.cases; ++case_index) {
    // Model from training shapes in the phantom frame (the phantom base is
    // fixed, so no Procrustes: rigid motion is the registration's business).
    std::vector<TriangleMesh> training;
    for (int i = 0; i < o.training_shapes; ++i) {
      training.push_back(makeVesselPhantom(randomVesselDeformation(rng, 4, o.stretch_mm), o.phantom));
    }
    ShapeModelBuildOptions build;
    build.align = false;
    const ShapeModel model = buildShapeModel(training, build).model;
    result.model_modes = static_cast<int>(model.modeCount());
    result.model_points = static_cast<int>(model.pointCount());
    const TriangleMesh truth = makeVesselPhantom(randomVesselDeformation(rng, 4, o.stretch_mm), o.phantom);
    const Eigen::VectorXd truth_shape = shapeVector(truth.vertices);

    ShapeTrackerOptions tracker_options = o.tracker;
    tracker_options.posterior.noise_sigma_mm = o.noise_sigma_mm;
    PosteriorShapeTracker tracker(model, tracker_options);
    const Eigen::Isometry3d calibration_error = randomRigid(rng, o.calibration_error_mm, o.calibration_rotation_deg);
    TrialCase tc;
    tc.frames = o.frames;
    std::uniform_real_distribution<double> phase(0.0, 2.0 * std::numbers::pi);
    const double ph1 = phase(rng), ph2 = phase(rng), ph3 = phase(rng);
    const double z0 = -o.phantom.cca_length_mm + 2.0;
    const double z1 = o.phantom.branch_length_mm - 2.0;
    const double width = o.bmode.width * o.bmode.spacing_mm;
    for (int f = 0; f < o.frames; ++f) {
      const double s = o.frames > 1 ? static_cast<double>(f) / (o.frames - 1) : 0.5;
      // Freehand sweep along the vessel: transverse slices, slow tilts and
      // lateral wander; the transducer face 12 mm above the vessel.
      const double z = z0 + s * (z1 - z0);
      const double tilt_x = o.sweep_tilt_deg * kDeg * std::sin(2.0 * std::numbers::pi * 1.3 * s + ph1);
      const double tilt_y = o.sweep_tilt_deg * kDeg * std::sin(2.0 * std::numbers::pi * 0.9 * s + ph2);
      const double wander = 1.5 * std::sin(2.0 * std::numbers::pi * 0.7 * s + ph3);
      Eigen::Isometry3d model_T_probe = Eigen::Isometry3d::Identity();
      model_T_probe.linear() =
          (Eigen::AngleAxisd(tilt_y, Eigen::Vector3d::UnitY()) * Eigen::AngleAxisd(tilt_x, Eigen::Vector3d::UnitX()))
              .toRotationMatrix();
      model_T_probe.translation() = Eigen::Vector3d(wander, 0.0, z);
      // Image frame: origin at the top-left pixel, x lateral, y depth.
      Eigen::Isometry3d probe_T_image = Eigen::Isometry3d::Identity();
      probe_T_image.translation() = Eigen::Vector3d(-0.5 * width, -12.0, 0.0);
      const Eigen::Isometry3d true_model_T_image = model_T_probe * probe_T_image;
      const BModeImage image = renderBMode(truth, true_model_T_image, o.bmode, rng);
      // What navigation believes: tracking noise on the probe pose and a
      // fixed calibration error on the image-to-probe transform.
      const Eigen::Isometry3d measured = model_T_probe *
                                         randomRigid(rng, o.tracking_noise_mm, o.tracking_rotation_deg) *
                                         probe_T_image * calibration_error;
      const auto t0 = std::chrono::steady_clock::now();
      const std::vector<Polyline3d> seeds = tracker.predictedContours(measured);
      const std::vector<LumenContour> lumens = segmentLumens(image, seeds, o.segmentation);
      std::vector<Polyline3d> features;
      for (const auto& l : lumens) {
        if (l.ok) {
          features.push_back(l.contour);
          ++tc.contours_segmented;
          if (l.split) ++tc.contours_split;
        } else {
          ++tc.contours_refused;
          logger()->debug("deform-trial case {} frame {}: lumen refused: {}", case_index, f, l.status);
        }
      }
      const double seg_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      tc.segmentation_ms.push_back(seg_ms);
      const FrameUpdate u = tracker.update(measured, features);
      if (u.updated) {
        ++tc.frames_updated;
        tc.update_ms.push_back(u.elapsed_ms);
      }
    }
    const Eigen::VectorXd& post = tracker.currentShape();
    const SymmetricSurfaceDistance sd_post = surfaceDistance(shapeMesh(model, post), truth);
    const SymmetricSurfaceDistance sd_prior = surfaceDistance(shapeMesh(model, model.mean), truth);
    tc.posterior_sd_mean_mm = sd_post.mean;
    tc.posterior_sd_max_mm = sd_post.hausdorff;
    tc.prior_sd_mean_mm = sd_prior.mean;
    tc.prior_sd_max_mm = sd_prior.hausdorff;
    tc.posterior_fp_mm = fiducialError(post, truth_shape, fiducials);
    tc.prior_fp_mm = fiducialError(model.mean, truth_shape, fiducials);
    tc.observations = static_cast<int>(tracker.observations().size());
    tc.excluded = static_cast<int>(tracker.posterior().excluded.size());
    tc.posterior_mahalanobis = tracker.posterior().mahalanobis;
    all_update.insert(all_update.end(), tc.update_ms.begin(), tc.update_ms.end());
    all_seg.insert(all_seg.end(), tc.segmentation_ms.begin(), tc.segmentation_ms.end());
    result.cases.push_back(std::move(tc));
  }
  auto collect = [&](auto member) {
    std::vector<double> v;
    for (const auto& c : result.cases) v.push_back(c.*member);
    return summarise(v);
  };
  result.posterior_sd_mean_mm = collect(&TrialCase::posterior_sd_mean_mm);
  result.posterior_sd_max_mm = collect(&TrialCase::posterior_sd_max_mm);
  result.posterior_fp_mm = collect(&TrialCase::posterior_fp_mm);
  result.prior_sd_mean_mm = collect(&TrialCase::prior_sd_mean_mm);
  result.prior_sd_max_mm = collect(&TrialCase::prior_sd_max_mm);
  result.prior_fp_mm = collect(&TrialCase::prior_fp_mm);
  result.update_ms_p50 = percentile(all_update, 0.5);
  result.update_ms_p99 = percentile(all_update, 0.99);
  result.segmentation_ms_p50 = percentile(all_seg, 0.5);
  return result;
}

}  // namespace mrsns::deformation
