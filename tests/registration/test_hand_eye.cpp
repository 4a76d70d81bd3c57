// AX = XB and AX = YB solvers (registration/hand_eye.h).
// Synthetic scenes: a target fixed in the base frame, a camera rigidly on the
// hand at a known X = hand_T_eye, stations with the hand rotated up to +-40 deg
// about random axes and moved in a 400 mm box, target 500-900 mm from the camera.
// Noise model (when on): hand poses 0.1 deg RMS per axis in rotation and 0.2 mm
// per axis in translation (a robot or an optical tracker), camera poses
// 0.1 deg per axis and 0.5 mm per axis (solvePnP of a board at ~0.7 m).
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/registration/hand_eye.h"

namespace mrsns {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;
const HandEyeMethod kAllMethods[] = {HandEyeMethod::TsaiLenz, HandEyeMethod::ParkMartin, HandEyeMethod::Daniilidis,
                                     HandEyeMethod::Refined};

struct Noise {
  double hand_rot = 0, hand_trans = 0, eye_rot = 0, eye_trans = 0;
};

Eigen::Vector3d gaussVec(std::mt19937& rng, double sigma) {
  std::normal_distribution<double> g(0.0, sigma);
  return {g(rng), g(rng), g(rng)};
}

Eigen::Isometry3d randomPose(std::mt19937& rng, double max_angle, double box_mm) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  Eigen::Vector3d axis(u(rng), u(rng), u(rng));
  T.linear() = so3Exp(axis.normalized() * max_angle * std::abs(u(rng)));
  T.translation() = box_mm * Eigen::Vector3d(u(rng), u(rng), u(rng));
  return T;
}

Eigen::Isometry3d noisy(const Eigen::Isometry3d& T, std::mt19937& rng, double rot, double trans) {
  Eigen::Isometry3d out = T;
  if (rot > 0) out.linear() = so3Exp(gaussVec(rng, rot)) * T.linear();
  if (trans > 0) out.translation() += gaussVec(rng, trans);
  return out;
}

struct Scene {
  Eigen::Isometry3d X, base_T_target;
  std::vector<Eigen::Isometry3d> base_T_hand, eye_T_target;
};

// Camera looking at the target: the hand is placed so the eye sits 500-900 mm from the target.
Scene makeScene(std::mt19937& rng, int stations, const Eigen::Isometry3d& X, const Noise& noise,
                double max_angle = 40 * kDeg) {
  Scene s;
  s.X = X;
  s.base_T_target = Eigen::Isometry3d::Identity();
  s.base_T_target.translation() = Eigen::Vector3d(100, -50, 1500);
  std::uniform_real_distribution<double> dist(500.0, 900.0);
  for (int i = 0; i < stations; ++i) {
    const Eigen::Isometry3d wiggle = randomPose(rng, max_angle, 0.0);
    Eigen::Isometry3d eye_T_target = Eigen::Isometry3d::Identity();
    eye_T_target.linear() = wiggle.linear();
    eye_T_target.translation() = Eigen::Vector3d(0, 0, dist(rng)) + randomPose(rng, 0, 200).translation();
    const Eigen::Isometry3d base_T_hand = s.base_T_target * eye_T_target.inverse() * X.inverse();
    s.base_T_hand.push_back(noisy(base_T_hand, rng, noise.hand_rot, noise.hand_trans));
    s.eye_T_target.push_back(noisy(eye_T_target, rng, noise.eye_rot, noise.eye_trans));
  }
  return s;
}

double rotError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return rotationAngleBetween(a.linear(), b.linear());
}
double transError(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return (a.translation() - b.translation()).norm();
}

Eigen::Isometry3d fixedX() {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = so3Exp(Eigen::Vector3d(0.3, -1.1, 0.7));
  X.translation() = Eigen::Vector3d(35.0, -80.0, 120.0);
  return X;
}

TEST(HandEye, ExactDataEveryMethodRecoversX) {
  std::mt19937 rng(1);
  const Scene s = makeScene(rng, 8, fixedX(), {});
  for (HandEyeMethod m : kAllMethods) {
    HandEyeOptions options;
    options.method = m;
    const HandEyeResult r = calibrateHandEye(s.base_T_hand, s.eye_T_target, options);
    EXPECT_LT(rotError(r.hand_T_eye, s.X), 1e-9) << handEyeMethodName(m);
    EXPECT_LT(transError(r.hand_T_eye, s.X), 1e-9 * 1000) << handEyeMethodName(m);  // 1e-9 relative to ~1 m
    EXPECT_LT(r.rotation_rms_rad, 1e-9) << handEyeMethodName(m);
    EXPECT_LT(r.translation_rms_mm, 1e-6) << handEyeMethodName(m);
    EXPECT_EQ(r.motion_pairs_used, 28) << handEyeMethodName(m);
    EXPECT_EQ(r.pair_rotation_residual_rad.size(), 28u);
    EXPECT_GT(r.axis_spread_rad, 0.3);
  }
}

// Property: random X (tiny, moderate, large rotation) on exact data. Tsai-Lenz parametrises X
// by tan(theta/2) and is only tested below 2.8 rad (its documented limit).
TEST(HandEye, RandomXPropertyExact) {
  std::mt19937 rng(7);
  std::vector<Eigen::Isometry3d> xs;
  Eigen::Isometry3d tiny = Eigen::Isometry3d::Identity();
  tiny.linear() = so3Exp(Eigen::Vector3d(1e-9, -2e-9, 0.5e-9));
  tiny.translation() = Eigen::Vector3d(0.0, 0.0, 1e-6);
  xs.push_back(tiny);
  xs.push_back(Eigen::Isometry3d::Identity());
  for (int k = 0; k < 10; ++k) xs.push_back(randomPose(rng, 2.8, 300.0));
  for (const auto& X : xs) {
    const Scene s = makeScene(rng, 6, X, {});
    for (HandEyeMethod m : kAllMethods) {
      HandEyeOptions options;
      options.method = m;
      const HandEyeResult r = calibrateHandEye(s.base_T_hand, s.eye_T_target, options);
      EXPECT_LT(rotError(r.hand_T_eye, X), 1e-9) << handEyeMethodName(m) << " X angle " << rotationAngle(X.linear());
      EXPECT_LT(transError(r.hand_T_eye, X), 1e-6) << handEyeMethodName(m);
    }
  }
}

TEST(HandEye, NearPiXExactForParkMartinDaniilidisRefined) {
  std::mt19937 rng(11);
  for (double eps : {1e-3, 1e-6, 0.0}) {
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.linear() = so3Exp((kPi - eps) * Eigen::Vector3d(0.2, 0.9, -0.4).normalized());
    X.translation() = Eigen::Vector3d(-20, 10, 60);
    const Scene s = makeScene(rng, 6, X, {});
    for (HandEyeMethod m : {HandEyeMethod::ParkMartin, HandEyeMethod::Daniilidis, HandEyeMethod::Refined}) {
      HandEyeOptions options;
      options.method = m;
      const HandEyeResult r = calibrateHandEye(s.base_T_hand, s.eye_T_target, options);
      EXPECT_LT(rotError(r.hand_T_eye, X), 1e-9) << handEyeMethodName(m) << " eps " << eps;
      EXPECT_LT(transError(r.hand_T_eye, X), 1e-6) << handEyeMethodName(m) << " eps " << eps;
    }
  }
}

// Relative motions of angle pi - eps about two different axes (the quaternion scalar part is
// ~0, the case where dual-quaternion signs and log maps break in naive code).
TEST(HandEye, NearPiMotionsExact) {
  const Eigen::Isometry3d X = fixedX();
  for (double eps : {1e-2, 1e-5, 1e-8}) {
    std::vector<Eigen::Isometry3d> A, B;
    const Eigen::Vector3d axes[] = {{1, 0, 0}, {0, 1, 0.3}, {0.5, -0.2, 1}};
    for (int k = 0; k < 3; ++k) {
      Eigen::Isometry3d a = Eigen::Isometry3d::Identity();
      a.linear() = so3Exp((kPi - eps) * axes[k].normalized());
      a.translation() = Eigen::Vector3d(10.0 * k, -40, 25);
      A.push_back(a);
      B.push_back(X.inverse() * a * X);
    }
    for (HandEyeMethod m : kAllMethods) {
      HandEyeOptions options;
      options.method = m;
      const HandEyeResult r = solveAXXB(A, B, options);
      EXPECT_LT(rotError(r.hand_T_eye, X), 1e-9) << handEyeMethodName(m) << " eps " << eps;
      EXPECT_LT(transError(r.hand_T_eye, X), 1e-6) << handEyeMethodName(m) << " eps " << eps;
    }
  }
}

// First-order error of X from the noise model (Park & Martin's analysis, simplified): a motion
// pair carries two hand and two eye poses, so its rotation vectors have 2 sigma_rot per axis
// of noise; fitting R_X to N - 1 independent motions of RMS angle theta gives an axis error of
// ~2 sigma_rot / (theta sqrt(2/3 (N-1))) per axis. The translation solve divides the motion
// translation noise (eye translation plus eye rotation times the ~700 mm board distance, and
// the R_X error times the motion translations) by the chord |R_A - I| ~ theta.
struct Predicted {
  double rot_rad = 0, trans_mm = 0;
};
Predicted predictedError(const Scene& s, const Noise& n) {
  double theta2 = 0, tb2 = 0;
  const auto N = s.base_T_hand.size();
  for (size_t i = 1; i < N; ++i) {
    const Eigen::Isometry3d A = s.base_T_hand[0].inverse() * s.base_T_hand[i];
    const Eigen::Isometry3d B = s.eye_T_target[0] * s.eye_T_target[i].inverse();
    theta2 += std::pow(rotationAngle(A.linear()), 2) / static_cast<double>(N - 1);
    tb2 += B.translation().squaredNorm() / static_cast<double>(N - 1);
  }
  const double theta = std::sqrt(theta2), dof = std::sqrt(static_cast<double>(N - 1));
  const double rot_axis = 2.0 * std::max(n.hand_rot, n.eye_rot) / (theta * std::sqrt(2.0 / 3.0) * dof);
  const double trans_motion = 2.0 * std::hypot(std::hypot(n.eye_trans, n.hand_trans), n.eye_rot * 700.0);
  Predicted p;
  p.rot_rad = std::sqrt(3.0) * rot_axis;
  p.trans_mm = std::sqrt(3.0) * (trans_motion + rot_axis * std::sqrt(tb2)) / (theta * dof);
  return p;
}

// Noisy stations, 40 scenes of 15 stations: every method within 3x the first-order prediction in
// every scene, and the methods agree with each other within 3x of it.
TEST(HandEye, NoisyStationsRecoverXWithinNoise) {
  std::mt19937 rng(3);
  const Noise noise{0.1 * kDeg, 0.2, 0.1 * kDeg, 0.5};
  double mean_rot[4] = {0, 0, 0, 0}, mean_trans[4] = {0, 0, 0, 0};
  constexpr int kScenes = 40;
  for (int scene = 0; scene < kScenes; ++scene) {
    const Scene s = makeScene(rng, 15, fixedX(), noise);
    const Predicted pred = predictedError(s, noise);
    std::vector<Eigen::Isometry3d> estimates;
    for (int k = 0; k < 4; ++k) {
      HandEyeOptions options;
      options.method = kAllMethods[k];
      const HandEyeResult r = calibrateHandEye(s.base_T_hand, s.eye_T_target, options);
      estimates.push_back(r.hand_T_eye);
      const double re = rotError(r.hand_T_eye, s.X), te = transError(r.hand_T_eye, s.X);
      EXPECT_LT(re, 3.0 * pred.rot_rad) << handEyeMethodName(kAllMethods[k]) << " scene " << scene;
      EXPECT_LT(te, 3.0 * pred.trans_mm) << handEyeMethodName(kAllMethods[k]) << " scene " << scene;
      mean_rot[k] += re / kScenes;
      mean_trans[k] += te / kScenes;
      // Residuals reflect the noise: a motion pair carries ~4 noisy poses.
      EXPECT_GT(r.rotation_rms_rad, 0.05 * kDeg);
      EXPECT_LT(r.rotation_rms_rad, 0.6 * kDeg);
    }
    for (int k = 1; k < 4; ++k) {
      EXPECT_LT(rotError(estimates[static_cast<size_t>(k)], estimates[0]), 3.0 * pred.rot_rad);
      EXPECT_LT(transError(estimates[static_cast<size_t>(k)], estimates[0]), 3.0 * pred.trans_mm);
    }
  }
  // The refinement weighs rotation and translation by their noise: no worse than its start.
  EXPECT_LE(mean_trans[3], 1.05 * mean_trans[1]);
  for (int k = 0; k < 4; ++k) {
    RecordProperty(std::string(handEyeMethodName(kAllMethods[k])) + "_mean_rot_deg",
                   std::to_string(mean_rot[k] / kDeg));
    RecordProperty(std::string(handEyeMethodName(kAllMethods[k])) + "_mean_trans_mm", std::to_string(mean_trans[k]));
  }
}

TEST(HandEye, RotationAboutOneAxisIsRefused) {
  std::mt19937 rng(5);
  // Hand rotates only about its z axis (plus the stated noise): translation along z undetermined.
  const Eigen::Isometry3d X = fixedX();
  std::vector<Eigen::Isometry3d> H, E;
  const Eigen::Isometry3d base_T_target = Eigen::Isometry3d(Eigen::Translation3d(0, 0, 1500));
  for (int i = 0; i < 10; ++i) {
    Eigen::Isometry3d h = Eigen::Isometry3d::Identity();
    h.linear() = so3Exp(Eigen::Vector3d(0, 0, -1.0 + 0.2 * i));
    h.translation() = Eigen::Vector3d(30.0 * i, -10.0 * i, 5.0 * i);
    H.push_back(noisy(h, rng, 0.1 * kDeg, 0.2));
    E.push_back(noisy(X.inverse() * h.inverse() * base_T_target, rng, 0.1 * kDeg, 0.5));
  }
  for (HandEyeMethod m : kAllMethods) {
    HandEyeOptions options;
    options.method = m;
    try {
      calibrateHandEye(H, E, options);
      ADD_FAILURE() << "one-axis motion accepted by " << handEyeMethodName(m);
    } catch (const InvalidArgumentError& e) {
      EXPECT_NE(std::string(e.what()).find("second, different axis"), std::string::npos) << e.what();
    }
    EXPECT_THROW(calibrateRobotWorldHandEye(H, E, options), InvalidArgumentError);
  }
}

TEST(HandEye, BadInputIsRefusedWithClearErrors) {
  std::mt19937 rng(9);
  const Scene s = makeScene(rng, 6, fixedX(), {});
  const std::vector<Eigen::Isometry3d> two(s.base_T_hand.begin(), s.base_T_hand.begin() + 2);
  const std::vector<Eigen::Isometry3d> two_e(s.eye_T_target.begin(), s.eye_T_target.begin() + 2);
  EXPECT_THROW(calibrateHandEye(two, two_e), InvalidArgumentError);
  std::vector<Eigen::Isometry3d> fewer = s.eye_T_target;
  fewer.pop_back();
  EXPECT_THROW(calibrateHandEye(s.base_T_hand, fewer), InvalidArgumentError);
  std::vector<Eigen::Isometry3d> nan = s.eye_T_target;
  nan[2].translation().x() = std::nan("");
  EXPECT_THROW(calibrateHandEye(s.base_T_hand, nan), InvalidArgumentError);
  // All stations at one orientation: no motion carries rotation.
  std::vector<Eigen::Isometry3d> H, E;
  for (int i = 0; i < 5; ++i) {
    H.push_back(Eigen::Isometry3d(Eigen::Translation3d(10.0 * i, 0, 0)));
    E.push_back(fixedX().inverse() * H.back().inverse());
  }
  try {
    calibrateHandEye(H, E);
    ADD_FAILURE() << "translation-only motion accepted";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("min_rotation_angle_rad"), std::string::npos) << e.what();
  }
}

TEST(RobotWorldHandEye, ExactAndNoisyRecovery) {
  std::mt19937 rng(13);
  const Eigen::Isometry3d X = fixedX();
  Eigen::Isometry3d Y = Eigen::Isometry3d::Identity();
  Y.linear() = so3Exp(Eigen::Vector3d(-0.4, 0.2, 2.0));
  Y.translation() = Eigen::Vector3d(900, -300, 200);
  for (bool with_noise : {false, true}) {
    std::vector<Eigen::Isometry3d> H, W;
    for (int i = 0; i < 12; ++i) {
      const Eigen::Isometry3d h = randomPose(rng, 50 * kDeg, 300.0);
      const Eigen::Isometry3d w = Y.inverse() * h * X;
      H.push_back(with_noise ? noisy(h, rng, 0.1 * kDeg, 0.2) : h);
      W.push_back(with_noise ? noisy(w, rng, 0.1 * kDeg, 0.5) : w);
    }
    // Same first-order prediction as above, B_i = W_0^-1 W_i (eye_T_target = W^-1).
    Scene as_scene;
    as_scene.base_T_hand = H;
    for (const auto& w : W) as_scene.eye_T_target.push_back(w.inverse());
    const Predicted pred = predictedError(as_scene, {0.1 * kDeg, 0.2, 0.1 * kDeg, 0.5});
    for (HandEyeMethod m : kAllMethods) {
      HandEyeOptions options;
      options.method = m;
      const RobotWorldHandEyeResult r = calibrateRobotWorldHandEye(H, W, options);
      const double rot_tol = with_noise ? 3.0 * pred.rot_rad : 1e-9,
                   trans_tol = with_noise ? 3.0 * pred.trans_mm : 1e-6;
      EXPECT_LT(rotError(r.hand_T_eye, X), rot_tol) << handEyeMethodName(m);
      EXPECT_LT(transError(r.hand_T_eye, X), trans_tol) << handEyeMethodName(m);
      EXPECT_LT(rotError(r.base_T_world, Y), rot_tol) << handEyeMethodName(m);
      EXPECT_LT(transError(r.base_T_world, Y), trans_tol) << handEyeMethodName(m);
      EXPECT_EQ(r.pose_translation_residual_mm.size(), 12u);
      if (with_noise) {
        EXPECT_GT(r.translation_rms_mm, 0.1);
      }
    }
  }
}

}  // namespace
}  // namespace mrsns
