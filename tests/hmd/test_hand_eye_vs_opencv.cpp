// registration/hand_eye.h against cv::calibrateHandEye (Tsai, Park, Horaud,
// Andreff, Daniilidis) on the same data. Scene and noise model as in
// tests/registration/test_hand_eye.cpp: 15 stations, hand rotated up to
// +-40 deg about random axes, camera 500-900 mm from the target; hand poses
// 0.1 deg / 0.2 mm per axis, camera poses 0.1 deg / 0.5 mm per axis.
#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <random>

#include "mrsns/core/rigid.h"
#include "mrsns/registration/hand_eye.h"

namespace mrsns {
namespace {

constexpr double kDeg = 3.14159265358979323846 / 180.0;

Eigen::Vector3d gauss(std::mt19937& rng, double s) {
  std::normal_distribution<double> g(0.0, s);
  return {g(rng), g(rng), g(rng)};
}

Eigen::Isometry3d noisy(const Eigen::Isometry3d& T, std::mt19937& rng, double rot, double trans) {
  Eigen::Isometry3d out = T;
  out.linear() = so3Exp(gauss(rng, rot)) * T.linear();
  out.translation() += gauss(rng, trans);
  return out;
}

struct Data {
  Eigen::Isometry3d X;
  std::vector<Eigen::Isometry3d> base_T_hand, eye_T_target;
};

Data makeData(std::mt19937& rng, bool with_noise) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Data d;
  d.X = Eigen::Isometry3d::Identity();
  d.X.linear() = so3Exp(Eigen::Vector3d(0.3, -1.1, 0.7));
  d.X.translation() = Eigen::Vector3d(35.0, -80.0, 120.0);
  const Eigen::Isometry3d base_T_target(Eigen::Translation3d(100, -50, 1500));
  for (int i = 0; i < 15; ++i) {
    Eigen::Isometry3d e = Eigen::Isometry3d::Identity();
    e.linear() = so3Exp(Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized() * 40 * kDeg * std::abs(u(rng)));
    e.translation() = Eigen::Vector3d(200 * u(rng), 200 * u(rng), 700 + 200 * u(rng));
    const Eigen::Isometry3d h = base_T_target * e.inverse() * d.X.inverse();
    d.base_T_hand.push_back(with_noise ? noisy(h, rng, 0.1 * kDeg, 0.2) : h);
    d.eye_T_target.push_back(with_noise ? noisy(e, rng, 0.1 * kDeg, 0.5) : e);
  }
  return d;
}

Eigen::Isometry3d openCv(const Data& d, cv::HandEyeCalibrationMethod method) {
  std::vector<cv::Mat> R_g2b, t_g2b, R_t2c, t_t2c;
  auto split = [](const Eigen::Isometry3d& T, std::vector<cv::Mat>& R, std::vector<cv::Mat>& t) {
    cv::Mat r(3, 3, CV_64F), v(3, 1, CV_64F);
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) r.at<double>(i, j) = T.linear()(i, j);
      v.at<double>(i) = T.translation()(i);
    }
    R.push_back(r);
    t.push_back(v);
  };
  for (size_t i = 0; i < d.base_T_hand.size(); ++i) {
    split(d.base_T_hand[i], R_g2b, t_g2b);
    split(d.eye_T_target[i], R_t2c, t_t2c);
  }
  cv::Mat R, t;
  cv::calibrateHandEye(R_g2b, t_g2b, R_t2c, t_t2c, R, t, method);
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) X.linear()(i, j) = R.at<double>(i, j);
    X.translation()(i) = t.at<double>(i);
  }
  X.linear() = nearestRotation(X.linear());
  return X;
}

const cv::HandEyeCalibrationMethod kOpenCv[] = {cv::CALIB_HAND_EYE_TSAI, cv::CALIB_HAND_EYE_PARK,
                                                cv::CALIB_HAND_EYE_HORAUD, cv::CALIB_HAND_EYE_ANDREFF,
                                                cv::CALIB_HAND_EYE_DANIILIDIS};
const char* kOpenCvNames[] = {"Tsai", "Park", "Horaud", "Andreff", "Daniilidis"};
const HandEyeMethod kOurs[] = {HandEyeMethod::TsaiLenz, HandEyeMethod::ParkMartin, HandEyeMethod::Daniilidis,
                               HandEyeMethod::Refined};

// Exact data: every solver, ours and OpenCV's, gives X; they agree to OpenCV's precision.
TEST(HandEyeVsOpenCv, ExactDataAllAgree) {
  std::mt19937 rng(21);
  const Data d = makeData(rng, false);
  for (size_t k = 0; k < 5; ++k) {
    const Eigen::Isometry3d cvX = openCv(d, kOpenCv[k]);
    EXPECT_LT(rotationAngleBetween(cvX.linear(), d.X.linear()), 1e-6) << kOpenCvNames[k];
    EXPECT_LT((cvX.translation() - d.X.translation()).norm(), 1e-3) << kOpenCvNames[k];
  }
  for (HandEyeMethod m : kOurs) {
    HandEyeOptions o;
    o.method = m;
    const auto r = calibrateHandEye(d.base_T_hand, d.eye_T_target, o);
    EXPECT_LT(rotationAngleBetween(r.hand_T_eye.linear(), d.X.linear()), 1e-9) << handEyeMethodName(m);
  }
}

// Noisy data: every one of our four solvers agrees with every one of OpenCV's five within the
// noise. The first-order error of X for this scene (see test_hand_eye.cpp) is ~0.15 deg and
// ~2.5 mm; two estimates from the same data differ by less than 3x that.
TEST(HandEyeVsOpenCv, NoisyDataAgreeWithinNoise) {
  std::mt19937 rng(22);
  for (int scene = 0; scene < 10; ++scene) {
    const Data d = makeData(rng, true);
    std::vector<Eigen::Isometry3d> cvX;
    for (auto m : kOpenCv) cvX.push_back(openCv(d, m));
    for (HandEyeMethod m : kOurs) {
      HandEyeOptions o;
      o.method = m;
      const auto r = calibrateHandEye(d.base_T_hand, d.eye_T_target, o);
      for (size_t k = 0; k < cvX.size(); ++k) {
        EXPECT_LT(rotationAngleBetween(r.hand_T_eye.linear(), cvX[k].linear()), 0.45 * kDeg)
            << handEyeMethodName(m) << " vs " << kOpenCvNames[k] << " scene " << scene;
        EXPECT_LT((r.hand_T_eye.translation() - cvX[k].translation()).norm(), 7.5)
            << handEyeMethodName(m) << " vs " << kOpenCvNames[k] << " scene " << scene;
      }
      // Same-named methods implement the same equations: much closer than the noise.
      if (m == HandEyeMethod::ParkMartin) {
        EXPECT_LT(rotationAngleBetween(r.hand_T_eye.linear(), cvX[1].linear()), 0.02 * kDeg) << scene;
      }
    }
  }
}

}  // namespace
}  // namespace mrsns
