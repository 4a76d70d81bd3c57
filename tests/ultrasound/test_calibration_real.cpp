// Spatial calibration on PLUS's fCal 3-NWire recordings, against PLUS's own
// result on the same data (FreehandCalibration3NWires.results.xml).
#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/frame_poses.h"
#include "mrsns/io/device_set.h"
#include "mrsns/io/sequence_file.h"
#include "mrsns/ultrasound/probe_calibration.h"
#include "plus_reference.h"
#include "test_data.h"

namespace mrsns::ultrasound {
namespace {

struct RealData {
  io::DeviceSetConfiguration config;
  TrackedSequence calibration, validation;
  test::PlusReference reference;
};

const RealData& realData(const std::filesystem::path& config, const std::filesystem::path& calibration,
                         const std::filesystem::path& validation, const std::filesystem::path& results) {
  static const RealData data{io::readDeviceSet(config), io::readSequence(calibration), io::readSequence(validation),
                             test::readPlusReference(results)};
  return data;
}

#define MRSNS_REQUIRE_PLUS_DATA(var)                                                         \
  MRSNS_REQUIRE_DATA(config_path, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml"); \
  MRSNS_REQUIRE_DATA(calibration_path, "plus/fCal_Test_Calibration_3NWires.igs.mha");        \
  MRSNS_REQUIRE_DATA(validation_path, "plus/fCal_Test_Validation_3NWires.igs.mha");          \
  MRSNS_REQUIRE_DATA(results_path, "plus/FreehandCalibration3NWires.results.xml");           \
  const RealData& var = realData(config_path, calibration_path, validation_path, results_path)

std::array<Eigen::Vector2d, 4> imageCorners(const TrackedSequence& s) {
  const double w = static_cast<double>(s.geometry.size[0] - 1), h = static_cast<double>(s.geometry.size[1] - 1);
  return {Eigen::Vector2d(0, 0), Eigen::Vector2d(w, 0), Eigen::Vector2d(0, h), Eigen::Vector2d(w, h)};
}

double worstCornerDistance(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b, const TrackedSequence& s) {
  double worst = 0.0;
  for (const auto& c : imageCorners(s)) {
    const Eigen::Vector4d p(c.x(), c.y(), 0.0, 1.0);
    worst = std::max(worst, ((a * p) - (b * p)).head<3>().norm());
  }
  return worst;
}

struct Segmented {
  SequenceSegmentation calibration, validation;
  std::vector<NWirePattern> patterns;
  Eigen::Isometry3d reference_T_phantom;
  std::vector<std::string> names;
};

const Segmented& segmented(const RealData& data) {
  static const Segmented s = [&] {
    const auto& phantom = data.config.requirePhantom();
    const auto options = segmentationOptionsFrom(*data.config.segmentation);
    return Segmented{segmentCalibrationSequence(data.calibration, phantom, options),
                     segmentCalibrationSequence(data.validation, phantom, options), nwireGeometry(phantom),
                     phantomToReference(data.config), wireNames(phantom)};
  }();
  return s;
}

void printRun(const char* label, const SpatialCalibrationResult& r, const CalibrationErrorReport& validation,
              const RealData& data) {
  std::printf(
      "%s: %zu frames used, %zu rejected; 3D reprojection calibration %.3f +/- %.3f mm (PLUS %.3f +/- %.3f), "
      "validation %.3f +/- %.3f mm (PLUS %.3f +/- %.3f), all validation errors %.3f +/- %.3f; spacing %.5f "
      "%.5f mm/px; image corners vs PLUS's ImageToProbe %.3f mm\n",
      label, r.frames_used, r.rejected_frames.size(), r.calibration.reprojection_3d_mean_mm,
      r.calibration.reprojection_3d_std_mm, data.reference.calibration_mean_mm, data.reference.calibration_std_mm,
      validation.reprojection_3d_mean_mm, validation.reprojection_3d_std_mm, data.reference.validation_mean_mm,
      data.reference.validation_std_mm, validation.reprojection_3d_all_mean_mm, validation.reprojection_3d_all_std_mm,
      r.pixel_spacing_mm.x(), r.pixel_spacing_mm.y(),
      worstCornerDistance(r.probe_T_image, data.reference.image_to_probe, data.calibration));
}

// Our segmentation reproduces PLUS's dots (test_segmentation_real.cpp), so
// our error definition applied to PLUS's ImageToProbe reproduces PLUS's
// published validation figure; what remains is PLUS's 6-digit rounding of
// its matrix and points.
TEST(SpatialCalibrationReal, PlusMatrixOnOurSegmentationReproducesPlusFigure) {
  MRSNS_REQUIRE_PLUS_DATA(data);
  const auto& s = segmented(data);
  EXPECT_EQ(s.calibration.segmented_frames, s.calibration.total_frames);
  EXPECT_EQ(s.validation.segmented_frames, s.validation.total_frames);
  const auto plus_on_ours = evaluateSpatialCalibration(data.reference.image_to_probe, s.validation.frames, s.patterns,
                                                       s.reference_T_phantom, s.names);
  std::printf("PLUS's ImageToProbe on our validation segmentation: %.3f +/- %.3f mm (published %.3f +/- %.3f)\n",
              plus_on_ours.reprojection_3d_mean_mm, plus_on_ours.reprojection_3d_std_mm,
              data.reference.validation_mean_mm, data.reference.validation_std_mm);
  EXPECT_NEAR(plus_on_ours.reprojection_3d_mean_mm, data.reference.validation_mean_mm, 0.01);
  EXPECT_NEAR(plus_on_ours.reprojection_3d_std_mm, data.reference.validation_std_mm, 0.01);
}

// The default (both residual sets, no lag: PLUS's fCal workflow) meets the
// issue's two goals in one result: validation 3D reprojection <= 1.20 mm
// (PLUS 1.247) and the image corners within 1 mm of PLUS's ImageToProbe.
TEST(SpatialCalibrationReal, DefaultCalibrationBeatsPlusAndAgreesWithItsMatrix) {
  MRSNS_REQUIRE_PLUS_DATA(data);
  const auto run = calibrateProbe(data.config, data.calibration, data.validation);
  printRun("default (both, no lag)", run.result, run.validation_errors, data);
  EXPECT_EQ(run.tracker_lag.lag_s, 0.0);
  EXPECT_LE(run.validation_errors.reprojection_3d_mean_mm, 1.20);
  EXPECT_LT(run.validation_errors.reprojection_3d_mean_mm, data.reference.validation_mean_mm);
  EXPECT_LE(run.result.calibration.reprojection_3d_mean_mm, data.reference.calibration_mean_mm);
  EXPECT_LT(worstCornerDistance(run.result.probe_T_image, data.reference.image_to_probe, data.calibration), 1.0);
  EXPECT_GE(run.result.frames_used, 175u);
  EXPECT_EQ(run.validation_frames_paired, run.validation.frames.size());
}

// Without a lag, the distance of every dot to its wire beats PLUS's validation error.
TEST(SpatialCalibrationReal, DistanceToWiresBeatsPlusOnValidation) {
  MRSNS_REQUIRE_PLUS_DATA(data);
  const auto& s = segmented(data);
  SpatialCalibrationOptions options;
  options.objective = CalibrationObjective::DistanceToWires;
  const auto r = calibrateSpatial(s.calibration.frames, s.patterns, s.reference_T_phantom, options);
  const auto validation =
      evaluateSpatialCalibration(r.probe_T_image, s.validation.frames, s.patterns, s.reference_T_phantom, s.names);
  printRun("distance-to-wires", r, validation, data);
  for (const auto& w : validation.wires) {
    std::printf("  validation %s: %.2f %.2f px (std %.2f %.2f), %.3f mm\n", w.wire_name.c_str(), w.mean_px.x(),
                w.mean_px.y(), w.std_px.x(), w.std_px.y(), w.mean_distance_mm);
  }
  EXPECT_LE(validation.reprojection_3d_mean_mm, 1.20);
  EXPECT_LT(validation.reprojection_3d_mean_mm, data.reference.validation_mean_mm);
  EXPECT_LE(r.calibration.reprojection_3d_mean_mm, data.reference.calibration_mean_mm + 0.05);
  EXPECT_GE(r.frames_used, 160u);
  // Two least-squares criteria on the same frames: the corners differ by a
  // few mm (the recording does not pin the elevation tilt better).
  EXPECT_LT(worstCornerDistance(r.probe_T_image, data.reference.image_to_probe, data.calibration), 5.0);
}

// PLUS's own criterion (middle-wire points) on our segmentation lands on
// PLUS's ImageToProbe and its figures: PLUS fits a general affine map by
// linear least squares, we fit the 8 physical parameters, a few hundredths
// of a millimetre apart at the far corners.
TEST(SpatialCalibrationReal, MiddleWireObjectiveMatchesPlusMatrix) {
  MRSNS_REQUIRE_PLUS_DATA(data);
  const auto& s = segmented(data);
  SpatialCalibrationOptions options;
  options.objective = CalibrationObjective::MiddleWirePoints;
  const auto r = calibrateSpatial(s.calibration.frames, s.patterns, s.reference_T_phantom, options);
  const auto validation =
      evaluateSpatialCalibration(r.probe_T_image, s.validation.frames, s.patterns, s.reference_T_phantom, s.names);
  printRun("middle-wire", r, validation, data);
  EXPECT_LT(worstCornerDistance(r.probe_T_image, data.reference.image_to_probe, data.calibration), 0.2);
  EXPECT_NEAR(r.calibration.reprojection_3d_mean_mm, data.reference.calibration_mean_mm, 0.02);
  EXPECT_NEAR(validation.reprojection_3d_mean_mm, data.reference.validation_mean_mm, 0.02);
}

// The recording carries a tracker lag that neither PLUS's result nor the
// calibrations above model: estimated from the calibration sequence alone,
// it is about half a second, and applying it to the held-out validation
// sequence halves the validation error. The lag is pinned to within a frame
// period (79 ms) and the validation must beat PLUS's figure by more than
// its standard error (0.494 / sqrt(91) = 0.05 mm) many times over.
TEST(SpatialCalibrationReal, EstimatedTrackerLagHalvesTheValidationError) {
  MRSNS_REQUIRE_PLUS_DATA(data);
  SpatialCalibrationOptions options;
  options.objective = CalibrationObjective::MiddleWirePoints;
  TrackerLagOptions lag;
  lag.estimate = true;
  const auto run = calibrateProbe(data.config, data.calibration, data.validation, options, lag);
  printRun("middle-wire, estimated tracker lag", run.result, run.validation_errors, data);
  std::printf("  tracker lag %.1f ms, curvature %.2f mm/s^2, %zu/%zu validation frames paired\n",
              run.tracker_lag.lag_s * 1e3, run.tracker_lag.curvature_mm_per_s2, run.validation_frames_paired,
              run.validation.frames.size());
  ASSERT_TRUE(run.tracker_lag.estimated);
  EXPECT_NEAR(run.tracker_lag.lag_s, 0.49, 0.079);
  EXPECT_GT(run.tracker_lag.curvature_mm_per_s2, 0.0);
  EXPECT_LT(run.validation_errors.reprojection_3d_mean_mm, 0.5 * data.reference.validation_mean_mm + 0.1);
  EXPECT_LT(run.result.calibration.reprojection_3d_mean_mm, data.reference.calibration_mean_mm);
  EXPECT_GE(run.validation_frames_paired, 85u);
  // The lag-corrected ImageToProbe is the better calibration even where the
  // lag is not corrected: on the validation frames paired as recorded (as
  // PLUS evaluates) it beats PLUS's figure by more than the 0.05 mm
  // standard error too.
  const auto& s = segmented(data);
  const auto as_recorded = evaluateSpatialCalibration(run.result.probe_T_image, s.validation.frames, s.patterns,
                                                      s.reference_T_phantom, s.names);
  std::printf("  the lag-corrected ImageToProbe on the validation frames as recorded: %.3f +/- %.3f mm\n",
              as_recorded.reprojection_3d_mean_mm, as_recorded.reprojection_3d_std_mm);
  EXPECT_LT(as_recorded.reprojection_3d_mean_mm, data.reference.validation_mean_mm - 0.1);
}

// Calibrating without a lag (the default) still searches one and says when
// the sweep fits markedly better at another lag; at that lag it is quiet.
TEST(SpatialCalibrationReal, LagCheckReportsTheRecordingsLagWithoutApplyingIt) {
  MRSNS_REQUIRE_PLUS_DATA(data);
  TrackerLagOptions lag;
  lag.check = true;
  const auto run = calibrateProbe(data.config, data.calibration, data.validation, {}, lag);
  ASSERT_TRUE(run.tracker_lag_check.has_value());
  const auto& check = *run.tracker_lag_check;
  std::printf("lag check: %.1f ms, calibration error %.3f mm there, %.3f mm as applied; %s\n",
              check.estimate.lag_s * 1e3, check.error_at_estimate_mm, check.error_as_applied_mm, check.advice.c_str());
  EXPECT_EQ(run.tracker_lag.lag_s, 0.0);
  ASSERT_TRUE(check.estimate.estimated) << check.estimate.note;
  EXPECT_NEAR(check.estimate.lag_s, 0.49, 0.079);
  EXPECT_TRUE(check.significant);
  EXPECT_LT(check.error_at_estimate_mm, 0.5 * check.error_as_applied_mm);
  EXPECT_NE(check.advice.find("tracker lag"), std::string::npos);

  TrackerLagOptions at_estimate;
  at_estimate.check = true;
  at_estimate.lag_s = check.estimate.lag_s;
  const auto again = calibrateProbe(data.config, data.calibration, data.validation, {}, at_estimate);
  ASSERT_TRUE(again.tracker_lag_check.has_value());
  EXPECT_FALSE(again.tracker_lag_check->significant) << again.tracker_lag_check->advice;
  EXPECT_TRUE(again.tracker_lag_check->advice.empty());
  EXPECT_LT(again.validation_errors.reprojection_3d_mean_mm, 0.75);

  // An applied lag off the search grid is not judged against it.
  TrackerLagOptions outside;
  outside.check = true;
  outside.lag_s = 0.49;
  outside.search_half_range_s = 0.3;
  const auto unchecked = calibrateProbe(data.config, data.calibration, data.validation, {}, outside);
  ASSERT_TRUE(unchecked.tracker_lag_check.has_value());
  EXPECT_FALSE(unchecked.tracker_lag_check->estimate.estimated);
  EXPECT_FALSE(unchecked.tracker_lag_check->significant);
  EXPECT_NE(unchecked.tracker_lag_check->estimate.note.find("outside"), std::string::npos);
}

// On PLUS's own segmented points (its results file), PLUS's criterion
// reproduces PLUS's ImageToProbe.
TEST(SpatialCalibrationReal, MiddleWireOnPlusPointsReproducesPlusMatrix) {
  MRSNS_REQUIRE_PLUS_DATA(data);
  const auto& s = segmented(data);
  std::vector<CalibrationFrame> frames;
  for (auto f : s.calibration.frames) {
    const auto it = data.reference.calibration_points.find(static_cast<int>(f.frame_index));
    if (it == data.reference.calibration_points.end() || it->second.size() != 9) continue;
    f.wire_points_px = it->second;
    frames.push_back(f);
  }
  ASSERT_GE(frames.size(), 170u);
  SpatialCalibrationOptions options;
  options.objective = CalibrationObjective::MiddleWirePoints;
  const auto r = calibrateSpatial(frames, s.patterns, s.reference_T_phantom, options);
  const double corners = worstCornerDistance(r.probe_T_image, data.reference.image_to_probe, data.calibration);
  std::printf("middle-wire on PLUS's %zu calibration frames: corners %.3f mm from PLUS's ImageToProbe\n", frames.size(),
              corners);
  // PLUS rounds its matrix to 6 digits and refines differently: a tenth of
  // a millimetre at 60 mm from the transducer.
  EXPECT_LT(corners, 0.2);
  EXPECT_NEAR(r.calibration.reprojection_3d_mean_mm, data.reference.calibration_mean_mm, 0.02);
}

// Why the lag-corrected calibration sits ~2 mm from PLUS's matrix: frames
// rendered from the lag-corrected ImageToProbe along the recorded probe
// trajectory with a lag of the estimated size (noise model: 0.3 px Gaussian
// per dot coordinate, poses exact), then calibrated without the lag as
// PLUS does, land well over a millimetre from the truth and within a
// millimetre of PLUS's published matrix. PLUS's matrix is what the lag
// makes of the lag-free one; the corner goal "within 1 mm of PLUS" asks for
// that bias.
TEST(SpatialCalibrationReal, TheLagExplainsPlusMatrix) {
  MRSNS_REQUIRE_PLUS_DATA(data);
  const auto& s = segmented(data);
  std::vector<double> times;
  for (const auto& f : data.calibration.frames) times.push_back(f.timestamp);
  const auto poses = extractFramePoses(data.calibration.frames, "ProbeToReference").poses;
  TrackerLagOptions lag_options;
  lag_options.estimate = true;
  SpatialCalibrationOptions options;
  options.objective = CalibrationObjective::MiddleWirePoints;
  const auto lag =
      estimateTrackerLag(s.calibration.frames, times, poses, s.patterns, s.reference_T_phantom, options, lag_options);
  const auto lagged = pairWithTrackerLag(s.calibration.frames, times, poses, lag.lag_s);
  const Eigen::Matrix4d truth = calibrateSpatial(lagged, s.patterns, s.reference_T_phantom, options).probe_T_image;
  const Eigen::Matrix4d image_T_probe = truth.inverse();

  std::map<std::size_t, Eigen::Isometry3d> true_pose;
  for (const auto& f : lagged) true_pose[f.frame_index] = f.reference_T_probe;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.3);
  std::vector<CalibrationFrame> rendered;  // paired with the recorded (lagging) pose
  for (auto f : s.calibration.frames) {
    const auto it = true_pose.find(f.frame_index);
    if (it == true_pose.end()) continue;
    const Eigen::Matrix4d image_T_phantom = image_T_probe * (it->second.inverse() * s.reference_T_phantom).matrix();
    for (std::size_t k = 0; k < s.patterns.size(); ++k) {
      for (std::size_t j = 0; j < 3; ++j) {
        const Eigen::Vector3d a = (image_T_phantom * s.patterns[k].front[j].homogeneous()).head<3>();
        const Eigen::Vector3d b =
            (image_T_phantom * (s.patterns[k].front[j] + s.patterns[k].direction[j]).homogeneous()).head<3>();
        const Eigen::Vector3d hit = a - a.z() / (b.z() - a.z()) * (b - a);
        f.wire_points_px[3 * k + j] = hit.head<2>() + Eigen::Vector2d(noise(rng), noise(rng));
      }
    }
    rendered.push_back(f);
  }
  const Eigen::Matrix4d naive = calibrateSpatial(rendered, s.patterns, s.reference_T_phantom, options).probe_T_image;
  const double naive_to_truth = worstCornerDistance(naive, truth, data.calibration);
  const double naive_to_plus = worstCornerDistance(naive, data.reference.image_to_probe, data.calibration);
  const double truth_to_plus = worstCornerDistance(truth, data.reference.image_to_probe, data.calibration);
  std::printf(
      "lag %.1f ms: lag-naive calibration of rendered frames is %.2f mm from the truth and %.2f mm from "
      "PLUS's matrix (truth to PLUS %.2f mm)\n",
      lag.lag_s * 1e3, naive_to_truth, naive_to_plus, truth_to_plus);
  EXPECT_GT(naive_to_truth, 1.2);
  EXPECT_LT(naive_to_plus, 1.0);
  EXPECT_LT(naive_to_plus, 0.5 * truth_to_plus);
}

// A search range that does not contain the lag: refused, or (the CLI's
// default) calibrated without a lag and said so.
TEST(SpatialCalibrationReal, LagSearchThatFailsFallsBackToNoLagWhenAsked) {
  MRSNS_REQUIRE_PLUS_DATA(data);
  TrackerLagOptions lag;
  lag.estimate = true;
  lag.search_half_range_s = 0.2;  // the recording's lag is ~0.49 s
  EXPECT_THROW((void)calibrateProbe(data.config, data.calibration, data.validation, {}, lag), ComputationError);
  lag.fall_back_to_zero = true;
  const auto run = calibrateProbe(data.config, data.calibration, data.validation, {}, lag);
  EXPECT_FALSE(run.tracker_lag.estimated);
  EXPECT_EQ(run.tracker_lag.lag_s, 0.0);
  EXPECT_NE(run.tracker_lag.note.find("edge of the search range"), std::string::npos) << run.tracker_lag.note;
  EXPECT_EQ(run.validation_paired.size(), run.validation.frames.size());
}

}  // namespace
}  // namespace mrsns::ultrasound
