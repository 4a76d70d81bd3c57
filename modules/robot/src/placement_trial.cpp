#include "mrsns/robot/placement_trial.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <memory>
#include <numbers>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/mesh.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/rotation_average.h"
#include "mrsns/core/units.h"
#include "mrsns/registration/paired_point.h"
#include "mrsns/registration/phantom_cervical.h"
#include "mrsns/robot/control_loop.h"
#include "mrsns/robot/robot_tracker_calibration.h"
#include "mrsns/robot/simulated_arm.h"

namespace mrsns::robot {
namespace {

class Noise {
 public:
  explicit Noise(std::uint64_t seed) : gen_(seed) {}
  Eigen::Vector3d vec() { return {n_(gen_), n_(gen_), n_(gen_)}; }
  /// A pose perturbed as one tracker frame: position sigma per axis, orientation sigma per axis.
  Eigen::Isometry3d pose(const Eigen::Isometry3d& T, double sigma_mm, double sigma_rad) {
    Eigen::Isometry3d N = T;
    N.translation() += sigma_mm * vec();
    N.linear() = T.linear() * so3Exp(sigma_rad * vec());
    return N;
  }

 private:
  std::mt19937_64 gen_;
  std::normal_distribution<double> n_{0.0, 1.0};
};

// The vessel wall as a tube along the phantom's vessel centre line, displaced radially by a pressure
// bump that breathes with time (the soft tissue the drill must keep away from).
TriangleMesh vesselSurface(const registration::CervicalPhantom& phantom, double amplitude_mm, double phase) {
  constexpr int kSegments = 48, kRings = 61;
  const double z0 = -60, z1 = 60;
  TriangleMesh m;
  m.frame = "CT";
  m.name = "vessel";
  m.vertices.resize(kSegments * kRings + 2, 3);
  const Eigen::Vector3d c = phantom.vessel_center;
  // The bump pushes the wall toward the spine (medial-posterior), strongest at the C5/C6 level.
  const double toward_spine = std::atan2(-c.y(), -c.x());
  for (int r = 0; r < kRings; ++r) {
    const double z = z0 + (z1 - z0) * r / (kRings - 1);
    for (int s = 0; s < kSegments; ++s) {
      const double th = 2 * kPi * s / kSegments;
      const double bump = amplitude_mm * std::sin(phase) * std::exp(-z * z / (2 * 20.0 * 20.0)) *
                          std::max(0.0, std::cos(th - toward_spine));
      const double rad = phantom.vessel_outer_radius_mm + bump;
      m.vertices.row(r * kSegments + s) << c.x() + rad * std::cos(th), c.y() + rad * std::sin(th), z;
    }
  }
  const int bottom = kSegments * kRings, top = bottom + 1;
  m.vertices.row(bottom) << c.x(), c.y(), z0;
  m.vertices.row(top) << c.x(), c.y(), z1;
  std::vector<Eigen::Vector3i> faces;
  for (int r = 0; r + 1 < kRings; ++r) {
    for (int s = 0; s < kSegments; ++s) {
      const int a = r * kSegments + s, b = r * kSegments + (s + 1) % kSegments;
      const int a2 = a + kSegments, b2 = b + kSegments;
      faces.emplace_back(a, b, b2);
      faces.emplace_back(a, b2, a2);
    }
  }
  for (int s = 0; s < kSegments; ++s) {
    faces.emplace_back(bottom, (s + 1) % kSegments, s);
    const int off = (kRings - 1) * kSegments;
    faces.emplace_back(top, off + s, off + (s + 1) % kSegments);
  }
  m.faces.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (std::size_t i = 0; i < faces.size(); ++i) m.faces.row(static_cast<Eigen::Index>(i)) = faces[i].transpose();
  return m;
}

DeviationSummary summarize(const std::vector<double>& v) {
  DeviationSummary s;
  if (v.empty()) return s;
  for (double x : v) {
    s.mean += x;
    s.max = std::max(s.max, x);
  }
  s.mean /= static_cast<double>(v.size());
  if (v.size() > 1) {
    for (double x : v) s.std += (x - s.mean) * (x - s.mean);
    s.std = std::sqrt(s.std / static_cast<double>(v.size() - 1));
  }
  return s;
}

struct World {
  Eigen::Isometry3d base_T_ct = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d base_T_tracker = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d flange_T_marker = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d flange_T_tip = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d ct_T_ref = Eigen::Isometry3d::Identity();
  Joints q_start = Joints::Zero();
};

World makeWorld(const Ur5Kinematics& kin) {
  World w;
  // Patient prone in front of the robot: CT posterior (+y) is up (+z base), CT superior (+z) is -y base.
  w.base_T_ct.linear() << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  w.base_T_ct.translation() << -420, -200, 0;
  w.base_T_tracker.linear() = so3Exp(Eigen::Vector3d(0.4, -0.3, 2.6));
  w.base_T_tracker.translation() << -600, 1100, 900;
  w.flange_T_marker.linear() = so3Exp(Eigen::Vector3d(0.2, 0.4, 0.1));
  w.flange_T_marker.translation() << 60, 20, 60;
  w.flange_T_tip.translation() << 0, 0, 150;
  w.ct_T_ref.linear() = so3Exp(Eigen::Vector3d(0.1, 0.0, 0.2));
  w.ct_T_ref.translation() << 0, 70, 45;
  // Start: drill pointing down, 90 mm above the neck.
  Eigen::Isometry3d tip = Eigen::Isometry3d::Identity();
  tip.linear() << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  tip.translation() = w.base_T_ct * Eigen::Vector3d(0, 90, 0);
  const Joints q_ref = (Joints() << 0.0, -1.5708, 1.5708, -1.5708, -1.5708, 0.0).finished();
  const auto q = kin.inverseNearest(tip * w.flange_T_tip.inverse(), q_ref, nullptr);
  if (!q) throw ComputationError("runPlacementTrial: the start pose of the trial is out of the UR5's reach");
  w.q_start = *q;
  return w;
}

}  // namespace

PlacementTrialResult runPlacementTrial(const PlacementTrialOptions& o) {
  if (o.trials < 1 || !(o.tracking_noise_mm >= 0) || !(o.tracking_rotation_deg >= 0) || !(o.registration_fle_mm >= 0) ||
      !(o.deformation_amplitude_mm >= 0) || !(o.tracker_rate_hz > 0) || o.calibration_stations < 6 ||
      o.calibration_frames_per_station < 1 || !(o.advance_speed_mm_s > 0)) {
    throw InvalidArgumentError(
        "runPlacementTrial: trials >= 1, non-negative noise, tracker rate > 0, >= 6 calibration stations and a "
        "positive advance speed are required");
  }
  registration::PhantomOptions po;
  po.spacing_mm = o.phantom_spacing_mm;
  po.seed = o.seed;
  const auto phantom = registration::generateCervicalPhantom(po);
  const Ur5Kinematics kin;
  const World w = makeWorld(kin);
  Noise noise(o.seed * 7919 + 17);
  const double sigma_axis = o.tracking_noise_mm / std::sqrt(3.0);
  const double sigma_rot = o.tracking_rotation_deg * kDeg;
  PlacementTrialResult result;

  // Robot-tracker calibration: static stations, each averaged over several tracker frames.
  CalibrationPoseOptions cpo;
  cpo.count = o.calibration_stations;
  cpo.seed = o.seed;
  const auto stations = generateCalibrationPoses(kin, w.q_start, cpo);
  std::vector<Eigen::Isometry3d> markers;
  for (const auto& b : stations.base_T_flange) {
    const Eigen::Isometry3d truth = w.base_T_tracker.inverse() * b * w.flange_T_marker;
    std::vector<Eigen::Isometry3d> frames;
    for (int f = 0; f < o.calibration_frames_per_station; ++f)
      frames.push_back(noise.pose(truth, sigma_axis, sigma_rot));
    markers.push_back(averagePoses(frames).mean);
  }
  const auto cal = calibrateRobotTracker(stations.base_T_flange, markers);
  result.calibration_flange_marker_error_mm =
      (cal.flange_T_marker.translation() - w.flange_T_marker.translation()).norm();
  result.calibration_flange_marker_error_deg =
      rotationAngleBetween(cal.flange_T_marker.linear(), w.flange_T_marker.linear()) / kDeg;
  result.calibration_residual_rms_mm = cal.translation_rms_mm;

  // Landmark registration of the CT to the patient reference (pointer on the fiducial screws).
  std::vector<Eigen::Vector3d> in_ct, in_ref;
  for (const auto& lm : phantom.fiducials_truth.points) {
    in_ct.push_back(lm.position);
    in_ref.push_back(w.ct_T_ref.inverse() * lm.position + (o.registration_fle_mm / std::sqrt(3.0)) * noise.vec());
  }
  const auto reg = registration::registerPairedPoints(in_ct, in_ref);
  Eigen::Isometry3d ref_T_ct_est = Eigen::Isometry3d::Identity();
  ref_T_ct_est.linear() = reg.rotation;
  ref_T_ct_est.translation() = reg.translation;
  result.registration_fre_mm = reg.fre_rms_mm;

  // C5 and C6 paths, one per vertebra per trial, sides alternating.
  std::vector<const registration::ScrewPath*> c5, c6;
  for (const auto& p : phantom.screw_paths) (p.vertebra == "C5" ? c5 : c6).push_back(&p);
  if (c5.empty() || c6.empty()) throw ComputationError("runPlacementTrial: the phantom has no C5/C6 screw paths");
  double tre_sum = 0;
  int tre_n = 0;
  for (const auto& p : phantom.screw_paths) {
    const Eigen::Vector3d err = w.ct_T_ref * (ref_T_ct_est * p.entry) - p.entry;
    tre_sum += err.squaredNorm();
    ++tre_n;
  }
  result.registration_tre_at_entries_mm = std::sqrt(tre_sum / tre_n);

  std::vector<double> dist, angle, tipdev;
  const Eigen::Isometry3d ct_T_base = w.base_T_ct.inverse();
  const Eigen::Isometry3d tracker_T_ref = w.base_T_tracker.inverse() * w.base_T_ct * w.ct_T_ref;
  for (int trial = 0; trial < o.trials; ++trial) {
    for (int level = 0; level < 2; ++level) {
      const auto& list = level == 0 ? c5 : c6;
      const registration::ScrewPath& plan = *list[static_cast<std::size_t>(trial) % list.size()];
      SimulatedArmOptions ao;
      ao.q0 = w.q_start;
      auto arm = std::make_shared<SimulatedArm>(ao);
      ControlLoopSetup setup;
      setup.flange_T_marker = cal.flange_T_marker;
      setup.base_T_tracker = cal.base_T_tracker;
      setup.flange_T_tip = w.flange_T_tip;
      setup.patient_T_plan = ref_T_ct_est;
      setup.plan = plan;
      ControlLoopOptions lo;
      lo.guidance.advance_speed_mm_s = o.advance_speed_mm_s;
      lo.guidance.align_settle_cycles = 250;
      lo.measurement_time_constant_s = o.measurement_filter_s;
      ControlLoop loop(arm, kin, setup, lo);
      loop.enable();
      loop.startPlacement();

      PlacementResult pr;
      pr.trial = trial + 1;
      pr.path = plan.name;
      pr.min_soft_tissue_distance_mm = std::numeric_limits<double>::infinity();
      std::vector<Eigen::Vector3d> achieved;
      TrackingSnapshot snap;
      double next_frame = 0, next_shape = 0;
      std::shared_ptr<const MeshLocator> tissue;
      int restarts = 0;
      const int max_cycles = 40000;
      int k = 0;
      for (; k < max_cycles; ++k) {
        const double t = k * arm->controlPeriodS();
        const ArmState truth = arm->state();
        if (t >= next_frame) {
          snap.drill_tracked = snap.patient_tracked = true;
          snap.drill_timestamp_s = snap.patient_timestamp_s = t;
          snap.tracker_T_drill =
              noise.pose(w.base_T_tracker.inverse() * truth.base_T_flange * w.flange_T_marker, sigma_axis, sigma_rot);
          snap.tracker_T_patient = noise.pose(tracker_T_ref, sigma_axis, sigma_rot);
          next_frame += 1.0 / o.tracker_rate_hz;
        }
        snap.time_s = t;
        if (t >= next_shape) {
          const double phase = 2 * kPi * (t / o.deformation_period_s + 0.37 * (trial * 2 + level));
          tissue = std::make_shared<MeshLocator>(vesselSurface(phantom, o.deformation_amplitude_mm, phase));
          loop.setSoftTissue(tissue);
          next_shape += o.deformation_update_s;
        }
        const CycleReport r = loop.tick(snap);
        arm->step();
        const Eigen::Vector3d tip_ct = ct_T_base * (truth.base_T_flange * w.flange_T_tip).translation();
        if (k % 10 == 0)
          pr.min_soft_tissue_distance_mm =
              std::min(pr.min_soft_tissue_distance_mm, tissue->closestPoint(tip_ct).distance);
        if (r.guidance.phase == GuidancePhase::Advance && r.guidance.depth_mm >= 0) achieved.push_back(tip_ct);
        const auto state = loop.supervisor().state();
        if (state == SupervisorState::Stopped || state == SupervisorState::Fault) {
          if (r.stop_sent != StopCommand::None && !r.decision.stop_repeated) ++pr.stops;
          // The surgeon waits for the arm to rest, acknowledges, and starts the path again.
          if (arm->state().qd.isZero(0.0) && restarts < 3 && loop.acknowledge()) {
            ++restarts;
            achieved.clear();
            loop.startPlacement();
          }
          if (restarts >= 3) break;
        }
        if (loop.guidance().phase() == GuidancePhase::Done) {
          pr.completed = true;
          break;
        }
      }
      pr.duration_s = k * arm->controlPeriodS();
      result.cycles += static_cast<std::uint64_t>(k);
      for (const auto& tr : loop.supervisor().transitions()) {
        if (tr.to == SupervisorState::Stopped || tr.to == SupervisorState::Fault) {
          ++result.stops[toString(tr.reason)];
          ++result.total_stops;
        }
      }
      if (pr.completed && achieved.size() >= 10) {
        Eigen::Vector3d mean = Eigen::Vector3d::Zero();
        for (const auto& p : achieved) mean += p;
        mean /= static_cast<double>(achieved.size());
        Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
        for (const auto& p : achieved) cov += (p - mean) * (p - mean).transpose();
        Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
        Eigen::Vector3d dir = es.eigenvectors().col(2);
        const Eigen::Vector3d planned = plan.direction();
        if (dir.dot(planned) < 0) dir = -dir;
        const Eigen::Vector3d rel = plan.entry - mean;
        pr.distance_deviation_mm = (rel - rel.dot(dir) * dir).norm();
        pr.angle_deviation_deg = std::atan2(dir.cross(planned).norm(), dir.dot(planned)) / kDeg;
        Eigen::Vector3d deepest = achieved.front();
        for (const auto& p : achieved) {
          if ((p - plan.entry).dot(planned) > (deepest - plan.entry).dot(planned)) deepest = p;
        }
        pr.tip_deviation_mm = (deepest - plan.tip()).norm();
        dist.push_back(pr.distance_deviation_mm);
        angle.push_back(pr.angle_deviation_deg);
        tipdev.push_back(pr.tip_deviation_mm);
        ++result.completed;
      }
      result.placements.push_back(pr);
    }
  }
  result.distance_deviation_mm = summarize(dist);
  result.angle_deviation_deg = summarize(angle);
  result.tip_deviation_mm = summarize(tipdev);
  return result;
}

}  // namespace mrsns::robot
