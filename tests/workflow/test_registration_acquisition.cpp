// The registration acquisition's analysis on synthetic recordings with known
// ground truth: holds become landmark captures, touches in any order match
// the CT's fiducials by geometry (an extra hold elsewhere matches none), the
// pointer's shaft tells a planar configuration from its 180-degree turn, a
// tracking gap breaks a hold, and the moving tip near the bone gives the
// surface points.
//
// Noise model: the tip jitters with 0.1 mm RMS per axis (Gaussian, seeded)
// during holds and sweeps; the patient reference is still.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>

#include "mrsns/core/mesh_locator.h"
#include "registration_acquisition.h"

namespace mrsns::workflow::detail {
namespace {

// A bumpy posterior surface y = h(x, z) (CT mm), the side the pointer comes from at +y.
double height(double x, double z) {
  return 4.0 * std::sin(x / 12.0) * std::cos(z / 17.0);
}

TriangleMesh heightField() {
  TriangleMesh m;
  const int n = 61;
  m.vertices.resize(n * n, 3);
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      const double x = -60.0 + 2.0 * i, z = -60.0 + 2.0 * j;
      m.vertices.row(j * n + i) << x, height(x, z), z;
    }
  }
  m.faces.resize(2 * (n - 1) * (n - 1), 3);
  int f = 0;
  for (int j = 0; j + 1 < n; ++j) {
    for (int i = 0; i + 1 < n; ++i) {
      const int a = j * n + i;
      m.faces.row(f++) << a, a + n, a + 1;
      m.faces.row(f++) << a + 1, a + n, a + n + 1;
    }
  }
  m.frame = "CT";
  return m;
}

struct Recording {
  std::vector<TrackedFrame> frames;
  double t = 0.0;
};

constexpr double kRate = 60.0;
const Eigen::Vector3d kTip(0.0, 0.0, -150.0);

// One frame: the stylus marker placed so its tip is at tip_patient with its shaft along `up` (patient frame).
void addFrame(Recording& r, const Eigen::Isometry3d& tracker_T_patient, const Eigen::Vector3d& tip_patient,
              const Eigen::Vector3d& up_patient, bool visible = true) {
  Eigen::Isometry3d patient_T_stylus = Eigen::Isometry3d::Identity();
  patient_T_stylus.linear() = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), up_patient).toRotationMatrix();
  patient_T_stylus.translation() = tip_patient - patient_T_stylus.linear() * kTip;
  TrackedFrame f;
  f.timestamp = r.t;
  f.transforms["PatientToTracker"] = FrameTransform{tracker_T_patient.matrix(), TransformStatus::Ok};
  if (visible) {
    f.transforms["StylusToTracker"] =
        FrameTransform{(tracker_T_patient * patient_T_stylus).matrix(), TransformStatus::Ok};
  }
  r.frames.push_back(f);
  r.t += 1.0 / kRate;
}

struct Scene {
  std::vector<Eigen::Vector3d> fiducials_ct;
  TriangleMesh bone = heightField();
  Eigen::Isometry3d patient_T_ct = Eigen::Isometry3d::Identity();
  Eigen::Isometry3d tracker_T_patient = Eigen::Isometry3d::Identity();
  Eigen::Vector3d up_ct = Eigen::Vector3d(0.2, 1.0, 0.1).normalized();
};

Scene scene(const std::vector<Eigen::Vector2d>& xz) {
  Scene s;
  for (const auto& p : xz) s.fiducials_ct.emplace_back(p.x(), height(p.x(), p.y()), p.y());
  s.patient_T_ct.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  s.patient_T_ct.translation() = Eigen::Vector3d(12.0, -40.0, 25.0);
  s.tracker_T_patient.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()).toRotationMatrix();
  s.tracker_T_patient.translation() = Eigen::Vector3d(0, 50, -1400);
  return s;
}

// Touches in `order`, each held 1.5 s with jitter, after a hold in a divot far away; then a sweep.
Recording record(const Scene& s, const std::vector<int>& order, std::uint64_t seed, double gap_in_touch_s = 0.0) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> jitter(0.0, 0.1);
  const auto noisy = [&](const Eigen::Vector3d& p) { return Eigen::Vector3d(p + Eigen::Vector3d(jitter(rng), jitter(rng), jitter(rng))); };
  const Eigen::Vector3d up = s.patient_T_ct.linear() * s.up_ct;
  Recording r;
  Eigen::Vector3d at = Eigen::Vector3d(150, 0, 0);
  for (int i = 0; i < 90; ++i) addFrame(r, s.tracker_T_patient, noisy(at), up);  // the divot
  for (std::size_t k = 0; k < order.size(); ++k) {
    const Eigen::Vector3d target = s.patient_T_ct * s.fiducials_ct[static_cast<std::size_t>(order[k])];
    for (int i = 1; i <= 60; ++i) {
      const double u = i / 60.0;
      addFrame(r, s.tracker_T_patient, at + (target - at) * u + up * 30.0 * std::sin(M_PI * u), up);
    }
    at = target;
    for (int i = 0; i < 90; ++i) {
      const bool hidden = k == 1 && gap_in_touch_s > 0.0 && i >= 30 && i < 30 + gap_in_touch_s * kRate;
      addFrame(r, s.tracker_T_patient, noisy(at), up, !hidden);
    }
  }
  // The sweep: a serpentine over the bone, then lifted off.
  for (int row = 0; row < 6; ++row) {
    for (int i = 0; i <= 60; ++i) {
      const double x = -40.0 + (row % 2 == 0 ? i : 60 - i) * 80.0 / 60.0, z = -40.0 + row * 16.0;
      addFrame(r, s.tracker_T_patient, noisy(s.patient_T_ct * Eigen::Vector3d(x, height(x, z), z)), up);
    }
  }
  for (int i = 0; i < 60; ++i) addFrame(r, s.tracker_T_patient, at + up * 50.0, up);
  return r;
}

RegistrationAcquisitionOptions options() {
  RegistrationAcquisitionOptions o;
  o.transform = "StylusToPatient";
  o.tip_marker = kTip;
  return o;
}

double errorAt(const Eigen::Isometry3d& estimate, const Eigen::Isometry3d& truth, const Eigen::Vector3d& p) {
  return (estimate * p - truth * p).norm();
}

const std::vector<Eigen::Vector2d> kAsymmetric = {{-35, -30}, {30, -28}, {-20, 5}, {25, 10}, {-30, 35}, {5, 40}};

TEST(RegistrationAcquisition, TouchesInAnyOrderMatchTheFiducialsAndAnExtraHoldMatchesNone) {
  const Scene s = scene(kAsymmetric);
  const MeshLocator bone(s.bone);
  RegistrationTargets t;
  for (std::size_t i = 0; i < s.fiducials_ct.size(); ++i) {
    t.labels.push_back("F-" + std::to_string(i + 1));
    t.fiducials_ct.push_back(s.fiducials_ct[i]);
    t.fiducial_axes_ct.push_back(Eigen::Vector3d::UnitY());
  }
  t.bone = &bone;
  Eigen::Isometry3d first;
  for (const std::vector<int>& order : {std::vector<int>{0, 1, 2, 3, 4, 5}, std::vector<int>{4, 2, 5, 0, 3, 1}}) {
    const auto a = analyseRegistrationFrames(record(s, order, 7).frames, t, options());
    ASSERT_EQ(a.captures.size(), 7U) << "the divot and six touches";
    EXPECT_EQ(a.captures.front().fiducial, -1) << "the divot is no fiducial";
    ASSERT_EQ(a.matched, 6);
    for (std::size_t k = 0; k < order.size(); ++k) {
      EXPECT_EQ(a.captures[k + 1].fiducial, order[k]) << "touch " << k;
    }
    // 0.1 mm per-axis jitter averaged over 90 samples: the landmarks land within a few hundredths of a mm.
    ASSERT_TRUE(a.landmarks.has_value());
    EXPECT_LT(a.landmarks->fre_rms_mm, 0.05);
    for (const auto& p : s.fiducials_ct) EXPECT_LT(errorAt(a.landmark_patient_T_ct, s.patient_T_ct, p), 0.05);
    // The sweep: 6 rows of 80 mm, a point per mm at the most, on the surface within the jitter; the approach
    // and lift of each touch also pass within the 2 mm gate for a few samples (as a real stylus's do).
    EXPECT_GT(a.surface_patient.size(), 300U);
    const Eigen::Isometry3d ct_T_patient = s.patient_T_ct.inverse();
    std::size_t within_jitter = 0;
    for (const auto& p : a.surface_patient) {
      const double d = bone.closestPoint(ct_T_patient * p).distance;
      EXPECT_LT(d, 2.0 + 0.05);
      within_jitter += d < 0.6 ? 1 : 0;
    }
    EXPECT_GT(within_jitter, a.surface_patient.size() * 95 / 100);
    if (order[0] == 0) {
      first = a.landmark_patient_T_ct;
    } else {
      EXPECT_TRUE(a.landmark_patient_T_ct.isApprox(first, 1e-3)) << "the order of the touches does not matter";
    }
  }
}

TEST(RegistrationAcquisition, ThePointersShaftRulesOutTheTurnedOverMatchOfAPlanarSymmetricSet) {
  // Fiducials in the plane y = 0, mirror-symmetric in x: turned 180 degrees about z they land on each other, so
  // geometry alone cannot choose; the shaft coming from +y can.
  Scene s;
  s.bone = heightField();
  for (const auto& [x, z] : std::vector<std::pair<double, double>>{{-20, -30}, {20, -30}, {-25, 0}, {25, 0}, {-15, 28}, {15, 28}}) {
    s.fiducials_ct.emplace_back(x, 0.0, z);
  }
  s.patient_T_ct.translation() = Eigen::Vector3d(5, 5, 5);
  s.tracker_T_patient.translation() = Eigen::Vector3d(0, 0, -1400);
  s.up_ct = Eigen::Vector3d::UnitY();
  RegistrationTargets t;
  for (std::size_t i = 0; i < s.fiducials_ct.size(); ++i) {
    t.labels.push_back("F-" + std::to_string(i + 1));
    t.fiducials_ct.push_back(s.fiducials_ct[i]);
    t.fiducial_axes_ct.push_back(Eigen::Vector3d::UnitY());
  }
  const auto a = analyseRegistrationFrames(record(s, {0, 1, 2, 3, 4, 5}, 3).frames, t, options());
  ASSERT_EQ(a.matched, 6);
  for (std::size_t k = 0; k < 6; ++k) EXPECT_EQ(a.captures[k + 1].fiducial, static_cast<int>(k));
  EXPECT_LT(errorAt(a.landmark_patient_T_ct, s.patient_T_ct, Eigen::Vector3d(0, -60, 0)), 0.1)
      << "not the turned-over pose, which is 120 mm off at the vertebral body";
}

TEST(RegistrationAcquisition, ATrackingGapBreaksAHoldAndIsCounted) {
  const Scene s = scene(kAsymmetric);
  RegistrationTargets t;
  for (const auto& p : s.fiducials_ct) {
    t.labels.push_back("F");
    t.fiducials_ct.push_back(p);
  }
  // A 0.6 s occlusion 0.5 s into a 1.5 s hold leaves 0.5 s and 0.4 s of stillness: no capture there at 1 s.
  const auto a = analyseRegistrationFrames(record(s, {0, 1, 2, 3, 4, 5}, 5, 0.6).frames, t, options());
  EXPECT_EQ(a.frames_without_pose, 36U);
  EXPECT_EQ(a.matched, 5);
  EXPECT_EQ(a.capture_of_fiducial[1], -1);
  // With a shorter dwell the rest of the hold is enough.
  auto o = options();
  o.dwell_s = 0.3;
  EXPECT_EQ(analyseRegistrationFrames(record(s, {0, 1, 2, 3, 4, 5}, 5, 0.6).frames, t, o).matched, 6);
}

TEST(RegistrationAcquisition, FewerThanThreeTouchesRegisterNothing) {
  const Scene s = scene(kAsymmetric);
  RegistrationTargets t;
  for (const auto& p : s.fiducials_ct) {
    t.labels.push_back("F");
    t.fiducials_ct.push_back(p);
  }
  const auto a = analyseRegistrationFrames(record(s, {2, 4}, 9).frames, t, options());
  EXPECT_EQ(a.matched, 0);
  EXPECT_FALSE(a.landmarks.has_value());
  EXPECT_TRUE(analyseRegistrationFrames({}, t, options()).captures.empty());
}

}  // namespace
}  // namespace mrsns::workflow::detail
