// The simulated world's truth: tool timelines with the operator's hand, the
// patient (and its faults), visibility from the camera, the echo scene.
#include "mrsns/simulation/world.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "mrsns/core/error.h"
#include "mrsns/core/minimum_jerk.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/units.h"
#include "mrsns/io/device_set.h"
#include "mrsns/io/image_io.h"
#include "mrsns/io/statismo_io.h"
#include "mrsns/registration/phantom_cervical.h"
#include "mrsns/simulation/soft_tissue.h"
#include "registration_motion.h"

namespace mrsns::simulation {

namespace {

nlohmann::json poseJson(const Eigen::Isometry3d& a_T_b) {
  nlohmann::json m = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m.push_back(a_T_b.matrix()(r, c));
  }
  return m;
}

}  // namespace

const char* toString(Visibility v) {
  switch (v) {
    case Visibility::Visible: return "visible";
    case Visibility::OutOfVolume: return "out_of_volume";
    case Visibility::LineOfSightBlocked: return "line_of_sight_blocked";
    case Visibility::OccludedByFault: return "occluded_by_fault";
  }
  return "?";
}

// One tool's timeline: segment start times and the seeded hand.
struct World::ToolTimeline {
  std::vector<double> starts;        // start time of each segment
  std::vector<double> durations;     // each segment's duration, with the hand's dwell jitter
  std::vector<double> depth_offset;  // the depth misperceived at each segment's target (mm, tool z)
  Eigen::Vector3d tremor_hz = Eigen::Vector3d::Zero();
  Eigen::Vector3d tremor_phase = Eigen::Vector3d::Zero();
  Eigen::Vector3d rot_tremor_phase = Eigen::Vector3d::Zero();
  Eigen::Vector3d drift_direction = Eigen::Vector3d::UnitX();
  double drift_phase = 0.0;
  struct Slip {
    double at_s;
    Eigen::Vector3d offset;
  };
  std::vector<Slip> slips;
};

// The patient's geometry in its CT frame, for the echo scene.
struct World::Patient {
  std::optional<registration::CervicalPhantom> phantom;
  ImageVolume labels;
  Eigen::Matrix4d lps_to_ijk = Eigen::Matrix4d::Identity();
  std::vector<int> vessel_labels, ignored_labels;
  std::unique_ptr<DeformingSoftTissue> soft_tissue;

  // Signed distance (mm) to the bone or the vessel: exact for the generated
  // phantom; for a label map, +/- half a voxel from the label lookup (its sign
  // is all the beam needs to find the surface).
  [[nodiscard]] int labelAt(const Eigen::Vector3d& p_ct) const {
    const Eigen::Vector4d ijk = lps_to_ijk * p_ct.homogeneous();
    const int i = static_cast<int>(std::lround(ijk.x())), j = static_cast<int>(std::lround(ijk.y())),
              k = static_cast<int>(std::lround(ijk.z()));
    if (!labels.contains(i, j, k)) return 0;
    return static_cast<int>(labels.value(i, j, k));
  }
  [[nodiscard]] bool isVessel(int label) const {
    return std::find(vessel_labels.begin(), vessel_labels.end(), label) != vessel_labels.end();
  }
  [[nodiscard]] bool isIgnored(int label) const {
    return std::find(ignored_labels.begin(), ignored_labels.end(), label) != ignored_labels.end();
  }
  [[nodiscard]] double boneDistance(const Eigen::Vector3d& p_ct) const {
    if (phantom) return registration::phantomBoneDistance(*phantom, p_ct);
    const int l = labelAt(p_ct);
    const double half = 0.5 * labels.spacing.minCoeff();
    return (l != 0 && !isVessel(l) && !isIgnored(l)) ? -half : half;
  }
  [[nodiscard]] double vesselDistance(const Eigen::Vector3d& p_ct) const {
    if (phantom) {
      // The phantom's vessel is a straight tube along the CT's z axis.
      const Eigen::Vector2d d = (p_ct - phantom->vessel_center).head<2>();
      return d.norm() - phantom->vessel_lumen_radius_mm;
    }
    const double half = 0.5 * labels.spacing.minCoeff();
    return isVessel(labelAt(p_ct)) ? -half : half;
  }
};

World::World(const Scenario& scenario) : scenario_(scenario) {
  if (scenario_.patient) {
    patient_ = std::make_unique<Patient>();
    const auto& spec = *scenario_.patient;
    if (spec.generated) {
      registration::PhantomOptions options;
      options.spacing_mm = spec.phantom_spacing_mm;
      options.seed = scenario_.seed;
      patient_->phantom = registration::generateCervicalPhantom(options);
    } else {
      patient_->labels = io::readImage(spec.labels);
      if (patient_->labels.empty()) throw FormatError("the label map " + spec.labels.string() + " is empty");
      patient_->lps_to_ijk = patient_->labels.ijkToLps().inverse();
      patient_->vessel_labels = spec.vessel_labels;
      patient_->ignored_labels = spec.ignored_labels;
    }
    if (spec.soft_tissue) {
      patient_->soft_tissue = std::make_unique<DeformingSoftTissue>(
          io::readStatismoModel(spec.soft_tissue->shape_model), *spec.soft_tissue, scenario_.seed);
    }
  }
  expandRegistrationMotions();
  std::mt19937_64 rng(scenario_.seed * 7919ULL + 17ULL);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (std::size_t i = 0; i < scenario_.tools.size(); ++i) {
    const auto& tool = scenario_.tools[i];
    auto tl = std::make_unique<ToolTimeline>();
    const auto& h = tool.hand;
    std::normal_distribution<double> gauss(0.0, 1.0);
    double t = 0.0;
    for (const auto& seg : tool.motion) {
      double duration = seg.duration_s;
      if (seg.kind == MotionKind::Hold && h.dwell_jitter_s > 0.0) {
        duration = std::max(0.2 * duration, duration + h.dwell_jitter_s * gauss(rng));
      }
      // One misperceived depth per target: a hold at the pose a move just reached keeps that move's error.
      const std::size_t k = tl->depth_offset.size();
      const MotionSegment* before = k > 0 ? &tool.motion[k - 1] : nullptr;
      const bool same_target = before != nullptr && before->pose && seg.pose && before->frame == seg.frame &&
                               before->pose_of == seg.pose_of && before->pose->isApprox(*seg.pose, 1e-9);
      const double drawn = h.depth_misperception_mm > 0.0 ? h.depth_misperception_mm * gauss(rng) : 0.0;
      tl->depth_offset.push_back(!seg.pose ? 0.0 : same_target ? tl->depth_offset[k - 1] : drawn);
      tl->starts.push_back(t);
      tl->durations.push_back(duration);
      t += duration;
    }
    for (int a = 0; a < 3; ++a) {
      tl->tremor_hz[a] = h.tremor_min_hz + (h.tremor_max_hz - h.tremor_min_hz) * uniform(rng);
      tl->tremor_phase[a] = kTwoPi * uniform(rng);
      tl->rot_tremor_phase[a] = kTwoPi * uniform(rng);
    }
    tl->drift_direction = Eigen::Vector3d(uniform(rng) - 0.5, uniform(rng) - 0.5, uniform(rng) - 0.5).normalized();
    tl->drift_phase = kTwoPi * uniform(rng);
    if (h.slips_per_min > 0.0) {
      // Poisson events over the scenario (or two hours when it runs until stopped).
      const double horizon = scenario_.duration_s > 0.0 ? scenario_.duration_s : 7200.0;
      std::exponential_distribution<double> gap(h.slips_per_min / 60.0);
      std::normal_distribution<double> normal(0.0, 1.0);
      for (double at = gap(rng); at < horizon; at += gap(rng)) {
        tl->slips.push_back({at, Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized() * h.slip_mm});
      }
    }
    timelines_.push_back(std::move(tl));
    if (scenario_.patient && tool.name == scenario_.patient->reference_tool) reference_index_ = i;
    if (scenario_.nwire_phantom && tool.name == scenario_.nwire_phantom->reference_tool) phantom_reference_index_ = i;
    if (scenario_.ultrasound.enabled && tool.name == scenario_.ultrasound.probe_tool) probe_index_ = i;
  }

  if (scenario_.nwire_phantom) {
    const auto config = io::readDeviceSet(scenario_.nwire_phantom->config);
    if (!config.phantom || config.phantom->patterns.empty()) {
      throw FormatError(scenario_.nwire_phantom->config.string() + " has no PhantomDefinition with wire patterns");
    }
    Eigen::AlignedBox3d box;
    for (const auto& pattern : config.phantom->patterns) {
      for (const auto& wire : pattern.wires) {
        wires_phantom_.push_back({wire.end_point_front, wire.end_point_back, scenario_.nwire_phantom->wire_radius_mm});
        box.extend(wire.end_point_front);
        box.extend(wire.end_point_back);
      }
    }
    EchoBox bath;
    bath.scene_T_box.translation() = box.center();
    bath.half_extent_mm = 0.5 * box.sizes() + Eigen::Vector3d::Constant(scenario_.nwire_phantom->bath_margin_mm);
    bath_phantom_ = bath;
  }
}

World::~World() = default;

void World::expandRegistrationMotions() {
  std::vector<Eigen::Vector3d> fiducials_ct;
  if (patient_ && patient_->phantom) {
    for (const auto& l : patient_->phantom->fiducials_truth.points) fiducials_ct.push_back(l.position);
  }
  // The frames as they lie when the room starts: a reference where it starts, then the CT or phantom in it.
  const auto startOf = [this](const std::string& reference_tool, const Eigen::Isometry3d& reference_T_frame) {
    Eigen::Isometry3d tracker_T_reference = Eigen::Isometry3d::Identity();
    for (const auto& tool : scenario_.tools) {
      if (tool.name == reference_tool) tracker_T_reference = tool.start;
    }
    return tracker_T_reference * reference_T_frame;
  };
  const Eigen::Isometry3d tracker_T_ct = scenario_.patient
                                             ? startOf(scenario_.patient->reference_tool, scenario_.patient->reference_T_ct)
                                             : Eigen::Isometry3d::Identity();
  std::optional<Eigen::Isometry3d> tracker_T_phantom;
  std::vector<Eigen::Vector3d> phantom_landmarks;
  if (scenario_.nwire_phantom) {
    tracker_T_phantom =
        startOf(scenario_.nwire_phantom->reference_tool, scenario_.nwire_phantom->reference_T_phantom);
    const auto config = io::readDeviceSet(scenario_.nwire_phantom->config);
    if (config.phantom) {
      for (const auto& l : config.phantom->landmarks) phantom_landmarks.push_back(l.position_phantom);
    }
  }
  for (auto& tool : scenario_.tools) {
    std::vector<MotionSegment> expanded;
    for (const auto& seg : tool.motion) {
      if (seg.kind != MotionKind::TouchLandmarks && seg.kind != MotionKind::TraceBone) {
        expanded.push_back(seg);
        continue;
      }
      const bool on_phantom = seg.kind == MotionKind::TouchLandmarks && seg.frame == PoseFrame::Phantom;
      if (on_phantom && !tracker_T_phantom) {
        throw InvalidArgumentError(tool.name + ": touch_landmarks in frame Phantom needs an 'nwire_phantom'");
      }
      if (!on_phantom && !patient_) {
        throw InvalidArgumentError(tool.name + ": touch_landmarks and trace_bone need a 'patient'");
      }
      const Eigen::Isometry3d& tracker_T_frame = on_phantom ? *tracker_T_phantom : tracker_T_ct;
      PointerGeometry pointer;
      pointer.tip_tool = tool.tip_tool.value_or(Eigen::Vector3d::Zero());
      // The pointer keeps the orientation it starts with in the room (held as it was picked up), its start pose
      // given in its start frame as the room stands at the start.
      Eigen::Isometry3d tracker_T_start = Eigen::Isometry3d::Identity();
      switch (tool.start_frame) {
        case PoseFrame::Tracker: break;
        case PoseFrame::CT: tracker_T_start = tracker_T_ct; break;
        case PoseFrame::Phantom: tracker_T_start = tracker_T_phantom.value_or(Eigen::Isometry3d::Identity()); break;
        case PoseFrame::Reference:
          if (scenario_.patient) tracker_T_start = startOf(scenario_.patient->reference_tool, Eigen::Isometry3d::Identity());
          break;
        case PoseFrame::RobotBase: tracker_T_start = scenario_.robot.tracker_T_base; break;
      }
      const Eigen::Matrix3d tracker_R_tool = tracker_T_start.linear() * tool.start.linear();
      pointer.frame_R_tool = tracker_T_frame.linear().transpose() * tracker_R_tool;
      const Patient* patient = patient_.get();
      const auto more =
          seg.kind == MotionKind::TouchLandmarks
              ? touchLandmarkSegments(seg, pointer, on_phantom ? phantom_landmarks : fiducials_ct)
              : traceBoneSegments(seg, pointer, fiducials_ct,
                                  [patient](const Eigen::Vector3d& p) { return patient->boneDistance(p); });
      expanded.insert(expanded.end(), more.begin(), more.end());
    }
    tool.motion = std::move(expanded);
  }
}

Eigen::Isometry3d World::patientShift(double t, bool relative) const {
  Eigen::Isometry3d shift = Eigen::Isometry3d::Identity();
  for (const auto& f : scenario_.faults) {
    if (f.kind == FaultKind::PatientShift && f.relative_to_reference == relative && t >= f.at_s)
      shift = shift * f.shift;
  }
  return shift;
}

Eigen::Isometry3d World::trackerTReference(double t) const {
  if (!reference_index_) return Eigen::Isometry3d::Identity();
  return toolPose(*reference_index_, t);
}

Eigen::Isometry3d World::trackerTCt(double t) const {
  const Eigen::Isometry3d reference_T_ct =
      scenario_.patient ? scenario_.patient->reference_T_ct : Eigen::Isometry3d::Identity();
  // A shift relative to the reference moves the anatomy under a marker that stays put: the registration is
  // then wrong, which navigation must detect; the whole-patient shift is already in the reference's pose.
  return trackerTReference(t) * patientShift(t, true) * reference_T_ct;
}

Eigen::Isometry3d World::trackerTPhantom(double t) const {
  const Eigen::Isometry3d reference_T_phantom =
      scenario_.nwire_phantom ? scenario_.nwire_phantom->reference_T_phantom : Eigen::Isometry3d::Identity();
  const Eigen::Isometry3d tracker_T_reference =
      phantom_reference_index_ ? toolPose(*phantom_reference_index_, t) : Eigen::Isometry3d::Identity();
  return tracker_T_reference * reference_T_phantom;
}

bool World::isReference(std::size_t index) const {
  return (reference_index_ && index == *reference_index_) ||
         (phantom_reference_index_ && index == *phantom_reference_index_);
}

Eigen::Isometry3d World::frameInTracker(PoseFrame frame, double t) const {
  switch (frame) {
    case PoseFrame::Tracker: return Eigen::Isometry3d::Identity();
    case PoseFrame::Reference: return trackerTReference(t);
    case PoseFrame::Phantom: return trackerTPhantom(t);
    case PoseFrame::CT: return trackerTCt(t);
    case PoseFrame::RobotBase: return scenario_.robot.tracker_T_base;
  }
  return Eigen::Isometry3d::Identity();
}

Eigen::Isometry3d World::toolPose(std::size_t index, double t) const {
  const ToolSpec& tool = scenario_.tools[index];
  const ToolTimeline& tl = *timelines_[index];
  const Eigen::Isometry3d image_T_probe = scenario_.ultrasound.probe_T_image.inverse();
  // A key pose (frame, pose, what it places) resolved to the tool in the tracker frame at time t.
  struct Key {
    PoseFrame frame;
    Eigen::Isometry3d pose;
    PoseOf of;
  };
  const auto resolve = [&](const Key& k) -> Eigen::Isometry3d {
    // The reference itself cannot be posed relative to frames that follow it.
    const PoseFrame frame = isReference(index) ? PoseFrame::Tracker : k.frame;
    Eigen::Isometry3d p = frameInTracker(frame, t) * k.pose;
    if (k.of == PoseOf::Image) p = p * image_T_probe;
    if (k.of == PoseOf::Tip) p = p * Eigen::Translation3d(-tool.tip_tool.value_or(Eigen::Vector3d::Zero()));
    return p;
  };

  Key previous{tool.start_frame, tool.start, PoseOf::Tool};
  Eigen::Isometry3d pose = resolve(previous);
  for (std::size_t s = 0; s < tool.motion.size(); ++s) {
    const MotionSegment& seg = tool.motion[s];
    Key target = seg.pose ? Key{seg.frame, *seg.pose, seg.pose_of} : previous;
    if (tl.depth_offset[s] != 0.0) target.pose = target.pose * Eigen::Translation3d(0.0, 0.0, tl.depth_offset[s]);
    const double duration = tl.durations[s];
    const double local = t - tl.starts[s];
    if (local >= duration) {
      // Finished: the segment's end pose is the next one's start.
      if (seg.kind == MotionKind::Hold || seg.kind == MotionKind::Move) previous = target;
      pose = resolve(previous);
      continue;
    }
    if (local < 0.0) break;
    const double u = local / duration;
    const Eigen::Isometry3d from = resolve(previous);
    switch (seg.kind) {
      case MotionKind::TouchLandmarks:
      case MotionKind::TraceBone: break;  // replaced by holds and moves when the world was built
      case MotionKind::Hold: pose = resolve(target); break;
      case MotionKind::Move: pose = interpolatePose(from, resolve(target), minimumJerk(u)); break;
      case MotionKind::Sweep: {
        // Back and forth `cycles` times, slowing at each end as a hand does.
        const double w = 0.5 - 0.5 * std::cos(kTwoPi * seg.cycles * u);
        pose = interpolatePose(from, resolve(target), w);
        break;
      }
      case MotionKind::Pivot: {
        const double a = seg.amplitude_deg * kDeg;
        const double ax = a * std::sin(kTwoPi * seg.frequency_hz * local);
        const double ay = seg.one_axis ? 0.0 : a * std::sin(kTwoPi * 1.5 * seg.frequency_hz * local + 0.7);
        const Eigen::Vector3d tip_tool = seg.tip_tool.value_or(tool.tip_tool.value_or(Eigen::Vector3d::Zero()));
        const Eigen::Vector3d tip_tracker = from * tip_tool;
        Eigen::Isometry3d p = from;
        p.linear() = from.linear() * so3Exp(Eigen::Vector3d(ax, ay, 0.0));
        p.translation() = tip_tracker - p.linear() * tip_tool;
        pose = p;
        break;
      }
      case MotionKind::Spin: {
        // About the shaft's line through the tip: the tip stays in the divot, the shaft keeps its direction.
        const Eigen::Vector3d tip_tracker = from * tool.tip_tool.value_or(Eigen::Vector3d::Zero());
        const Eigen::Vector3d axis_tracker = from.linear() * tool.shaft();
        const double angle = seg.amplitude_deg * kDeg * std::sin(kTwoPi * seg.frequency_hz * local);
        const Eigen::Matrix3d turn = Eigen::AngleAxisd(angle, axis_tracker).toRotationMatrix();
        Eigen::Isometry3d p = from;
        p.linear() = turn * from.linear();
        p.translation() = tip_tracker + turn * (from.translation() - tip_tracker);
        pose = p;
        break;
      }
      case MotionKind::UpDown: {
        Eigen::Isometry3d p = from;
        // The axis in the tool's frame, or in the segment's frame when one is named (up and down over a target).
        const Eigen::Vector3d axis_tracker = seg.frame == PoseFrame::Tracker
                                                 ? Eigen::Vector3d(from.linear() * seg.axis_tool)
                                                 : Eigen::Vector3d(frameInTracker(seg.frame, t).linear() * seg.axis_tool);
        p.translation() += axis_tracker * seg.amplitude_mm * std::sin(kTwoPi * seg.frequency_hz * local);
        pose = p;
        break;
      }
    }
    break;
  }
  // The hand, on top of the intended motion (the reference is clamped to the patient: no hand).
  const HandModel& h = tool.hand;
  Eigen::Isometry3d out = pose;
  if (h.tremor_rms_mm > 0.0 || h.drift_mm > 0.0 || !tl.slips.empty() || h.tremor_rotation_rms_deg > 0.0) {
    Eigen::Vector3d offset = Eigen::Vector3d::Zero();
    // Per-axis sinusoids of RMS rms/sqrt(3) each give a 3D RMS of rms: amplitude sqrt(2/3) rms.
    const double amp = h.tremor_rms_mm * std::sqrt(2.0 / 3.0);
    Eigen::Vector3d rot = Eigen::Vector3d::Zero();
    const double ramp = h.tremor_rotation_rms_deg * kDeg * std::sqrt(2.0 / 3.0);
    for (int k = 0; k < 3; ++k) {
      offset[k] += amp * std::sin(kTwoPi * tl.tremor_hz[k] * t + tl.tremor_phase[k]);
      rot[k] = ramp * std::sin(kTwoPi * tl.tremor_hz[(k + 1) % 3] * t + tl.rot_tremor_phase[k]);
    }
    offset += tl.drift_direction * h.drift_mm * std::sin(kTwoPi * h.drift_hz * t + tl.drift_phase);
    for (const auto& slip : tl.slips) {
      // A slip, then the hand corrects it over about half a second.
      if (t >= slip.at_s) offset += slip.offset * std::exp(-(t - slip.at_s) / 0.15);
    }
    out.translation() += offset;
    out.linear() = out.linear() * so3Exp(rot);
  }
  // The whole patient moved (bumped table): its reference marker moves with it.
  if (reference_index_ && index == *reference_index_) out = out * patientShift(t, false);
  return out;
}

Visibility World::visibility(const ToolSpec& tool, const Eigen::Isometry3d& tracker_T_tool, double t,
                             const std::vector<Eigen::Isometry3d>& poses) const {
  for (const auto& f : scenario_.faults) {
    if (f.kind == FaultKind::Occlusion && f.tool == tool.name && t >= f.at_s && t < f.at_s + f.duration_s) {
      return Visibility::OccludedByFault;
    }
  }
  const Eigen::Vector3d p = tracker_T_tool.translation();
  const auto& v = scenario_.tracker.volume;
  const double depth = -p.z();
  if (depth < v.near_mm || depth > v.far_mm || std::abs(p.x()) > depth * std::tan(v.half_angle_x_deg * kDeg) ||
      std::abs(p.y()) > depth * std::tan(v.half_angle_y_deg * kDeg)) {
    return Visibility::OutOfVolume;
  }
  // Line of sight from the camera (the tracker frame's origin) to the marker.
  const double length = p.norm();
  const Eigen::Vector3d ray = p / length;
  for (const auto& occ : scenario_.tracker.occluders) {
    if (occ.attached_to == tool.name) continue;
    Eigen::Vector3d c = occ.center;
    if (!occ.attached_to.empty()) {
      const auto it = std::find_if(scenario_.tools.begin(), scenario_.tools.end(),
                                   [&](const ToolSpec& s) { return s.name == occ.attached_to; });
      if (it == scenario_.tools.end()) continue;
      c = poses[static_cast<std::size_t>(it - scenario_.tools.begin())] * occ.center;
    }
    const double along = std::clamp(c.dot(ray), 0.0, length);
    if ((c - along * ray).norm() < occ.radius_mm + 0.5 * tool.marker_radius_mm) {
      return Visibility::LineOfSightBlocked;
    }
  }
  return Visibility::Visible;
}

std::vector<ToolTruth> World::tools(double t, const std::optional<Eigen::Isometry3d>& robot_base_T_flange,
                                    const std::vector<HeldTool>& held) const {
  std::vector<Eigen::Isometry3d> poses;
  poses.reserve(scenario_.tools.size());
  for (std::size_t i = 0; i < scenario_.tools.size(); ++i) {
    poses.push_back(toolPose(i, t));
    for (const auto& h : held) {
      if (h.name == scenario_.tools[i].name) poses.back() = h.tracker_T_tool;
    }
  }
  std::vector<ToolTruth> out;
  out.reserve(poses.size() + 1);
  for (std::size_t i = 0; i < poses.size(); ++i) {
    out.push_back({scenario_.tools[i].name, poses[i], visibility(scenario_.tools[i], poses[i], t, poses)});
  }
  if (robot_base_T_flange) {
    ToolSpec marker;
    marker.name = scenario_.robot.marker_tool;
    const Eigen::Isometry3d pose =
        scenario_.robot.tracker_T_base * *robot_base_T_flange * scenario_.robot.flange_T_marker;
    out.push_back({marker.name, pose, visibility(marker, pose, t, poses)});
  }
  return out;
}

Eigen::Isometry3d World::trackerTImage(double t) const {
  if (!probe_index_) throw InvalidArgumentError("the scenario has no ultrasound probe");
  return toolPose(*probe_index_, t) * scenario_.ultrasound.probe_T_image;
}

EchoScene World::echoScene(double t) const {
  EchoScene scene;
  if (!wires_phantom_.empty()) {
    const Eigen::Isometry3d tracker_T_phantom = trackerTPhantom(t);
    for (const auto& w : wires_phantom_)
      scene.wires.push_back({tracker_T_phantom * w.a, tracker_T_phantom * w.b, w.radius_mm});
    if (bath_phantom_)
      scene.water_bath = EchoBox{tracker_T_phantom * bath_phantom_->scene_T_box, bath_phantom_->half_extent_mm};
  }
  if (scenario_.flat_target) {
    // A plate at the bottom of a water tank: a strong flat reflector under water, as the temporal calibration
    // uses. Its signed distance is exact (a box), so the renderer's distance lattice may rely on it.
    const auto& f = *scenario_.flat_target;
    const Eigen::Isometry3d target_T_tracker = (frameInTracker(f.frame, t) * f.pose).inverse();
    const Eigen::Vector3d half(f.half_size_mm.x(), f.half_size_mm.y(), 5.0);
    scene.bone_distance_mm = [target_T_tracker, half](const Eigen::Vector3d& p) {
      const Eigen::Vector3d q = (target_T_tracker * p - Eigen::Vector3d(0, 0, -5.0)).cwiseAbs() - half;
      return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    };
    if (!scene.water_bath) {
      EchoBox tank;
      tank.scene_T_box = frameInTracker(f.frame, t) * f.pose;
      tank.scene_T_box.translation() += tank.scene_T_box.linear() * Eigen::Vector3d(0, 0, 0.5 * f.water_depth_mm);
      tank.half_extent_mm = Eigen::Vector3d(f.half_size_mm.x(), f.half_size_mm.y(), 0.5 * f.water_depth_mm);
      scene.water_bath = tank;
    }
  }
  if (patient_) {
    const Eigen::Isometry3d ct_T_tracker = trackerTCt(t).inverse();
    const Patient* patient = patient_.get();
    auto target = scene.bone_distance_mm;  // a flat target, if any: the union of both reflectors
    scene.bone_distance_mm = [patient, ct_T_tracker, target](const Eigen::Vector3d& p) {
      const double bone = patient->boneDistance(ct_T_tracker * p);
      return target ? std::min(bone, target(p)) : bone;
    };
    if (patient->soft_tissue) {
      // The deforming vessel of the shape model, as it is at this instant.
      const auto surface = patient->soft_tissue->surfaceAt(t);
      const Eigen::Isometry3d model_T_tracker = patient->soft_tissue->ctTModel().inverse() * ct_T_tracker;
      scene.vessel_distance_mm = [surface, model_T_tracker](const Eigen::Vector3d& p) {
        return surface->signedClosestPoint(model_T_tracker * p, true).signed_distance;
      };
    } else if (patient->phantom || !patient->vessel_labels.empty()) {
      scene.vessel_distance_mm = [patient, ct_T_tracker](const Eigen::Vector3d& p) {
        return patient->vesselDistance(ct_T_tracker * p);
      };
    }
  }
  return scene;
}

std::string World::staticTruthJson() const {
  nlohmann::json j;
  j["scenario"] = scenario_.name;
  j["seed"] = scenario_.seed;
  if (scenario_.ultrasound.enabled) {
    j["ImageToProbe"] = poseJson(scenario_.ultrasound.probe_T_image);
    j["image_spacing_mm"] = {scenario_.ultrasound.spacing_x_mm, scenario_.ultrasound.spacing_y_mm};
    j["image_size_px"] = {scenario_.ultrasound.width, scenario_.ultrasound.height};
    j["video_lag_s"] = scenario_.ultrasound.video_lag_s;
  }
  if (scenario_.patient) {
    j["CTToReference"] = poseJson(scenario_.patient->reference_T_ct);
    j["patient_reference_tool"] = scenario_.patient->reference_tool;
  }
  if (scenario_.nwire_phantom) {
    j["PhantomToReference"] = poseJson(scenario_.nwire_phantom->reference_T_phantom);
    nlohmann::json ends = nlohmann::json::array();
    for (const auto& w : wires_phantom_) {
      for (const Eigen::Vector3d& p : {w.a, w.b}) ends.push_back({p.x(), p.y(), p.z()});
    }
    j["phantom_wires_mm"] = ends;
  }
  if (scenario_.robot.enabled) {
    j["RobotBaseToTracker"] = poseJson(scenario_.robot.tracker_T_base);
    j["MarkerToFlange"] = poseJson(scenario_.robot.flange_T_marker);
    j["drill_tip_flange_mm"] = {scenario_.robot.drill_tip_flange.x(), scenario_.robot.drill_tip_flange.y(),
                                scenario_.robot.drill_tip_flange.z()};
    j["robot_marker_tool"] = scenario_.robot.marker_tool;
  }
  nlohmann::json tips = nlohmann::json::object();
  nlohmann::json shafts = nlohmann::json::object();
  for (const auto& tool : scenario_.tools) {
    if (!tool.tip_tool) continue;
    tips[tool.name] = {tool.tip_tool->x(), tool.tip_tool->y(), tool.tip_tool->z()};
    const Eigen::Vector3d shaft = tool.shaft();
    shafts[tool.name] = {shaft.x(), shaft.y(), shaft.z()};
  }
  if (scenario_.robot.enabled) {
    // The drill's tip in its marker's frame: what pivoting the drill calibrates; its axis (from the flange to
    // the tip): what spinning it calibrates.
    const Eigen::Isometry3d marker_T_flange = scenario_.robot.flange_T_marker.inverse();
    const Eigen::Vector3d tip = marker_T_flange * scenario_.robot.drill_tip_flange;
    tips[scenario_.robot.marker_tool] = {tip.x(), tip.y(), tip.z()};
    const Eigen::Vector3d axis = marker_T_flange.linear() * scenario_.robot.drill_tip_flange.normalized();
    shafts[scenario_.robot.marker_tool] = {axis.x(), axis.y(), axis.z()};
  }
  j["tool_tips_mm"] = tips;
  j["tool_shafts"] = shafts;
  if (scenario_.hmd.cube.enabled) {
    const auto& c = scenario_.hmd.cube;
    j["hmd_cube_operator"] = {{"depth_bias_mm", c.depth_bias_mm},
                              {"depth_error_sd_mm", c.depth_error_mm},
                              {"lateral_error_sd_mm", c.lateral_error_mm},
                              {"rotation_sd_deg", c.rotation_deg},
                              {"tremor_amplitude_mm", c.tremor_mm},
                              {"tremor_hz", {c.tremor_min_hz, c.tremor_max_hz}},
                              {"drift_mm_per_s", c.drift_mm_per_s},
                              {"jerks_per_s", c.jerks_per_s},
                              {"jerk_mm", {c.jerk_min_mm, c.jerk_max_mm}},
                              {"headset_jitter_mm", scenario_.hmd.jitter_mm},
                              {"headset_drift_mm_per_min", scenario_.hmd.drift_mm_per_min},
                              {"tracker_position_rms_mm", scenario_.tracker.noise.position_rms_mm}};
  }
  if (scenario_.hmd.camera.enabled && !scenario_.hmd.marker_tool.empty()) {
    // What the checkerboard hand-eye calibration estimates (paper 000's T_c^h), and what the photos are made of.
    const auto& c = scenario_.hmd.camera;
    nlohmann::json m = nlohmann::json::array();
    for (int r = 0; r < 4; ++r) {
      for (int k = 0; k < 4; ++k) m.push_back(c.marker_T_camera.matrix()(r, k));
    }
    nlohmann::json g = nlohmann::json::array();
    for (int r = 0; r < 4; ++r) {
      for (int k = 0; k < 4; ++k) g.push_back(c.board_T_grid.matrix()(r, k));
    }
    j["hmd_camera"] = {{"headset_tool", scenario_.hmd.marker_tool},
                       {"board_tool", c.board_tool},
                       {"board", {{"rows", c.rows}, {"cols", c.cols}, {"square_mm", c.square_mm}}},
                       {"GridToBoardMarker", g},
                       {"board_touch_placement_error_mm", scenario_.hmd.board_touch.placement_error_mm},
                       {"CameraToHeadsetMarker", m},
                       {"noise_model",
                        {{"image_blur_sigma_px", c.blur_sigma_px},
                         {"image_noise_grey_levels", c.noise_sigma},
                         {"head_sway_mm", c.head_sway_mm},
                         {"reported_intrinsics_focal_error_percent", c.intrinsics_focal_error_percent},
                         {"reported_intrinsics_principal_error_px", c.intrinsics_principal_error_px},
                         {"tracker_position_rms_mm", scenario_.tracker.noise.position_rms_mm},
                         {"tracker_orientation_rms_deg", scenario_.tracker.noise.orientation_rms_deg}}}};
  }
  if (patient_ && patient_->soft_tissue) j["soft_tissue"] = nlohmann::json::parse(patient_->soft_tissue->truthJson());
  if (patient_ && patient_->phantom) {
    nlohmann::json fiducials = nlohmann::json::array();
    for (const auto& s : patient_->phantom->screws) {
      fiducials.push_back({{"label", s.label}, {"ct_mm", {s.bone_entry.x(), s.bone_entry.y(), s.bone_entry.z()}}});
    }
    j["fiducials_ct"] = fiducials;
    nlohmann::json paths = nlohmann::json::array();
    for (const auto& path : patient_->phantom->screw_paths) {
      paths.push_back({{"name", path.name},
                       {"entry_ct_mm", {path.entry.x(), path.entry.y(), path.entry.z()}},
                       {"target_ct_mm", {path.target.x(), path.target.y(), path.target.z()}}});
    }
    j["screw_paths_ct"] = paths;
  }
  nlohmann::json faults = nlohmann::json::array();
  for (const auto& f : scenario_.faults) {
    faults.push_back({{"kind", toString(f.kind)}, {"at_s", f.at_s}, {"duration_s", f.duration_s}, {"tool", f.tool}});
  }
  j["faults"] = faults;
  return j.dump();
}

}  // namespace mrsns::simulation
