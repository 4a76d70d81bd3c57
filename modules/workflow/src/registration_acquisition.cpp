// Landmark captures, their order-free matching to the CT's fiducials and the
// surface points of a registration recording (see registration_acquisition.h).
#include "registration_acquisition.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "mrsns/core/error.h"
#include "mrsns/core/frame_poses.h"

namespace mrsns::workflow::detail {

namespace {

struct TipSample {
  double t = 0.0;
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();
  Eigen::Vector3d marker = Eigen::Vector3d::Zero();
  Eigen::Vector3d shaft = Eigen::Vector3d::UnitZ();
};

/// Holds of the tip: windows of dwell_s without a gap where the tip and the
/// marker stay within the radius of their means (a pivot keeps the tip but
/// not the marker still), one capture per visit of a point.
std::vector<LandmarkCapture> findHolds(const std::vector<TipSample>& s, const RegistrationAcquisitionOptions& o) {
  std::vector<LandmarkCapture> out;
  bool armed = true;
  Eigen::Vector3d last = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  std::size_t begin = 0;
  for (std::size_t end = 0; end < s.size(); ++end) {
    if (!armed) {
      if ((s[end].tip - last).norm() > o.rearm_mm) armed = true;
      begin = end;
      continue;
    }
    if (end > 0 && s[end].t - s[end - 1].t > o.max_gap_s) begin = end;  // a gap breaks a hold
    while (begin < end && s[end].t - s[begin + 1].t >= o.dwell_s) ++begin;
    if (s[end].t - s[begin].t < o.dwell_s) continue;
    Eigen::Vector3d tip_mean = Eigen::Vector3d::Zero(), marker_mean = Eigen::Vector3d::Zero();
    for (std::size_t i = begin; i <= end; ++i) {
      tip_mean += s[i].tip;
      marker_mean += s[i].marker;
    }
    const double n = static_cast<double>(end - begin + 1);
    tip_mean /= n;
    marker_mean /= n;
    bool still = true;
    for (std::size_t i = begin; i <= end && still; ++i) {
      still = (s[i].tip - tip_mean).norm() <= o.dwell_radius_mm &&
              (s[i].marker - marker_mean).norm() <= 2.0 * o.dwell_radius_mm;
    }
    if (!still) continue;
    // The hold lasts while the tip stays: every sample of it goes into the point.
    std::size_t stop = end;
    while (stop + 1 < s.size() && s[stop + 1].t - s[stop].t <= o.max_gap_s &&
           (s[stop + 1].tip - tip_mean).norm() <= o.dwell_radius_mm) {
      ++stop;
    }
    LandmarkCapture c;
    c.start_s = s[begin].t;
    c.end_s = s[stop].t;
    Eigen::Vector3d shaft = Eigen::Vector3d::Zero();
    c.tip_patient.setZero();
    for (std::size_t i = begin; i <= stop; ++i) {
      c.tip_patient += s[i].tip;
      shaft += s[i].shaft;
    }
    c.samples = static_cast<int>(stop - begin + 1);
    c.tip_patient /= c.samples;
    c.shaft_patient = shaft.normalized();
    out.push_back(c);
    last = c.tip_patient;
    armed = false;
    end = stop;
    begin = stop + 1;
  }
  return out;
}

struct Match {
  std::vector<int> fiducial_of_capture;
  int count = 0;
  double rms = std::numeric_limits<double>::infinity();
};

/// Assigns every capture to the nearest fiducial under patient_T_ct (one
/// capture per fiducial: the closest; later re-touches replace earlier ones
/// afterwards), within the tolerance.
Match assign(const std::vector<LandmarkCapture>& captures, const RegistrationTargets& targets,
             const Eigen::Isometry3d& ct_T_patient, double tolerance) {
  Match m;
  m.fiducial_of_capture.assign(captures.size(), -1);
  double sum2 = 0.0;
  for (std::size_t c = 0; c < captures.size(); ++c) {
    const Eigen::Vector3d p = ct_T_patient * captures[c].tip_patient;
    double best = tolerance;
    for (std::size_t f = 0; f < targets.fiducials_ct.size(); ++f) {
      const double d = (p - targets.fiducials_ct[f]).norm();
      if (d < best) {
        best = d;
        m.fiducial_of_capture[c] = static_cast<int>(f);
      }
    }
    if (m.fiducial_of_capture[c] >= 0) sum2 += best * best;
  }
  std::vector<char> used(targets.fiducials_ct.size(), 0);
  for (int f : m.fiducial_of_capture) {
    if (f >= 0 && !used[static_cast<std::size_t>(f)]) {
      used[static_cast<std::size_t>(f)] = 1;
      ++m.count;
    }
  }
  m.rms = m.count > 0 ? std::sqrt(sum2 / m.count) : std::numeric_limits<double>::infinity();
  return m;
}

/// The pointer comes from outside the bone: its shaft and the fiducial's
/// outward axis agree. This tells a configuration from its 180-degree turn
/// when the fiducials lie nearly in a plane.
bool shaftsAgree(const std::vector<LandmarkCapture>& captures, const RegistrationTargets& targets,
                 const Match& m, const Eigen::Isometry3d& ct_T_patient) {
  if (targets.fiducial_axes_ct.size() != targets.fiducials_ct.size()) return true;
  double sum = 0.0;
  for (std::size_t c = 0; c < captures.size(); ++c) {
    const int f = m.fiducial_of_capture[c];
    if (f >= 0) sum += (ct_T_patient.linear() * captures[c].shaft_patient).dot(targets.fiducial_axes_ct[f]);
  }
  return sum > 0.0;
}

/// Order-free correspondence: every triple of captures against every triple
/// of fiducials with the same side lengths proposes a pose; the pose that
/// matches the most captures (then the smallest residual) wins.
Match matchCaptures(const std::vector<LandmarkCapture>& captures, const RegistrationTargets& targets,
                    double tolerance, Eigen::Isometry3d& best_ct_T_patient) {
  Match best;
  best.fiducial_of_capture.assign(captures.size(), -1);
  const auto& F = targets.fiducials_ct;
  const std::size_t nc = captures.size(), nf = F.size();
  if (nc < 3 || nf < 3) return best;
  const double side_tolerance = 0.6 * tolerance;
  const auto dist = [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return (a - b).norm(); };
  for (std::size_t a = 0; a < nc; ++a) {
    for (std::size_t b = a + 1; b < nc; ++b) {
      const double ab = dist(captures[a].tip_patient, captures[b].tip_patient);
      for (std::size_t c = b + 1; c < nc; ++c) {
        const double ac = dist(captures[a].tip_patient, captures[c].tip_patient);
        const double bc = dist(captures[b].tip_patient, captures[c].tip_patient);
        // A degenerate (nearly collinear) triple fixes no rotation.
        const Eigen::Vector3d normal = (captures[b].tip_patient - captures[a].tip_patient)
                                           .cross(captures[c].tip_patient - captures[a].tip_patient);
        if (normal.norm() < 20.0) continue;
        for (std::size_t i = 0; i < nf; ++i) {
          for (std::size_t j = 0; j < nf; ++j) {
            if (j == i || std::abs(dist(F[i], F[j]) - ab) > side_tolerance) continue;
            for (std::size_t k = 0; k < nf; ++k) {
              if (k == i || k == j || std::abs(dist(F[i], F[k]) - ac) > side_tolerance ||
                  std::abs(dist(F[j], F[k]) - bc) > side_tolerance) {
                continue;
              }
              Eigen::Matrix3d src, dst;
              src << captures[a].tip_patient, captures[b].tip_patient, captures[c].tip_patient;
              dst << F[i], F[j], F[k];
              Eigen::Isometry3d ct_T_patient(Eigen::umeyama(src, dst, false));
              Match m = assign(captures, targets, ct_T_patient, tolerance);
              if (m.count < 3 || !shaftsAgree(captures, targets, m, ct_T_patient)) continue;
              if (m.count > best.count || (m.count == best.count && m.rms < best.rms)) {
                best = std::move(m);
                best_ct_T_patient = ct_T_patient;
              }
            }
          }
        }
      }
    }
  }
  return best;
}

Eigen::Isometry3d isometryOf(const registration::PairedPointResult& r) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = r.rotation;
  t.translation() = r.translation;
  return t;
}

std::vector<TipSample> tipSamples(const std::vector<TrackedFrame>& frames, const RegistrationAcquisitionOptions& options,
                                  std::size_t* frames_without_pose) {
  const auto extraction = extractFramePoses(frames, options.transform);
  if (frames_without_pose != nullptr) *frames_without_pose = extraction.invalid_frames + extraction.missing_frames;
  std::vector<TipSample> samples;
  samples.reserve(extraction.poses.size());
  const double tip_length = options.tip_marker.norm();
  const Eigen::Vector3d up_marker =
      tip_length > 1e-9 ? Eigen::Vector3d(-options.tip_marker / tip_length) : Eigen::Vector3d::UnitZ();
  for (const auto& p : extraction.poses) {
    samples.push_back({p.timestamp, p.to_T_from * options.tip_marker, p.to_T_from.translation(),
                       p.to_T_from.linear() * up_marker});
  }
  return samples;
}

}  // namespace

std::vector<LandmarkCapture> findTipHolds(const std::vector<TrackedFrame>& frames,
                                          const RegistrationAcquisitionOptions& options,
                                          std::size_t* frames_without_pose) {
  if (frames.empty()) return {};
  return findHolds(tipSamples(frames, options, frames_without_pose), options);
}

RegistrationAcquisition analyseRegistrationFrames(const std::vector<TrackedFrame>& frames,
                                                  const RegistrationTargets& targets,
                                                  const RegistrationAcquisitionOptions& options) {
  RegistrationAcquisition out;
  out.frames = frames.size();
  out.capture_of_fiducial.assign(targets.fiducials_ct.size(), -1);
  if (frames.empty()) return out;
  const auto samples = tipSamples(frames, options, &out.frames_without_pose);
  if (!samples.empty()) out.last_time_s = samples.back().t;
  out.captures = findHolds(samples, options);

  Eigen::Isometry3d ct_T_patient = Eigen::Isometry3d::Identity();
  const Match m = matchCaptures(out.captures, targets, options.match_tolerance_mm, ct_T_patient);
  for (std::size_t c = 0; c < out.captures.size(); ++c) {
    const int f = m.fiducial_of_capture[c];
    out.captures[c].fiducial = f;
    if (f >= 0) out.capture_of_fiducial[static_cast<std::size_t>(f)] = static_cast<int>(c);  // the latest touch
  }
  std::vector<Eigen::Vector3d> ct, patient;
  for (std::size_t f = 0; f < out.capture_of_fiducial.size(); ++f) {
    const int c = out.capture_of_fiducial[f];
    if (c < 0) continue;
    ct.push_back(targets.fiducials_ct[f]);
    patient.push_back(out.captures[static_cast<std::size_t>(c)].tip_patient);
  }
  out.matched = static_cast<int>(ct.size());
  if (out.matched < 3) return out;
  registration::PairedPointOptions pp;
  pp.leave_one_out = out.matched >= 4;
  out.landmarks = registration::registerPairedPoints(ct, patient, pp);
  out.landmark_patient_T_ct = isometryOf(*out.landmarks);

  // The sweep over the bone: moving samples (not a landmark's hold) near the surface the landmarks place.
  if (targets.bone == nullptr) return out;
  const Eigen::Isometry3d landmark_ct_T_patient = out.landmark_patient_T_ct.inverse();
  std::size_t next_capture = 0;
  Eigen::Vector3d previous = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  for (const auto& s : samples) {
    while (next_capture < out.captures.size() && out.captures[next_capture].end_s < s.t) ++next_capture;
    if (next_capture < out.captures.size() && s.t >= out.captures[next_capture].start_s) continue;
    if ((s.tip - previous).norm() < options.surface_spacing_mm) continue;
    const auto hit = targets.bone->closestPointWithin(landmark_ct_T_patient * s.tip, options.surface_gate_mm);
    if (!(hit.distance <= options.surface_gate_mm)) continue;
    out.surface_patient.push_back(s.tip);
    out.last_surface_time_s = s.t;
    previous = s.tip;
  }
  return out;
}

}  // namespace mrsns::workflow::detail
