// UR5 kinematics: FK against the published zero pose and against Universal Robots' own kinematics file
// (the URDF joint chain of ur_description), IK round trips, Jacobian against finite differences,
// singularity measure against the closed-form determinant.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <random>
#include <sstream>
#include <string>

#include "../support/test_data.h"
#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/robot/ur5_kinematics.h"

namespace mrsns::robot {
namespace {

constexpr double kPi = std::numbers::pi;

Joints randomJoints(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-kPi, kPi);
  Joints q;
  for (int i = 0; i < 6; ++i) q[i] = u(rng);
  return q;
}

double poseDistance(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return std::max((a.translation() - b.translation()).norm(), rotationAngleBetween(a.linear(), b.linear()));
}

// The six link entries (x y z roll pitch yaw, metres/radians) of a ur_description kinematics yaml.
std::map<std::string, std::array<double, 6>> readUrdfKinematics(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::map<std::string, std::array<double, 6>> links;
  std::string line, current;
  const std::map<std::string, int> keys{{"x", 0}, {"y", 1}, {"z", 2}, {"roll", 3}, {"pitch", 4}, {"yaw", 5}};
  while (std::getline(in, line)) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const auto indent = line.find_first_not_of(' ');
    const std::string key = line.substr(indent, colon - indent);
    const std::string value = line.substr(colon + 1);
    if (indent == 2 && value.find_first_not_of(' ') == std::string::npos) {
      current = key;
    } else if (indent == 4 && keys.count(key) != 0 && !current.empty()) {
      links[current][keys.at(key)] = std::stod(value);
    }
  }
  return links;
}

Eigen::Isometry3d urdfJoint(const std::array<double, 6>& e, double q) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = 1000.0 * Eigen::Vector3d(e[0], e[1], e[2]);
  T.linear() = (Eigen::AngleAxisd(e[5], Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(e[4], Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(e[3], Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  return T * Eigen::AngleAxisd(q, Eigen::Vector3d::UnitZ());
}

TEST(Ur5Kinematics, ZeroPoseMatchesPublishedFlangePose) {
  // All joints zero: the arm lies stretched along -x; the flange is at (a2 + a3, -(d4 + d6), d1 - d5)
  // and the tool axis points along -y (Rx(pi/2) from the alternating link twists).
  const Ur5Kinematics kin;
  const auto T = kin.forward(Joints::Zero());
  EXPECT_NEAR(T.translation().x(), -817.25, 1e-9);
  EXPECT_NEAR(T.translation().y(), -191.45, 1e-9);
  EXPECT_NEAR(T.translation().z(), -5.491, 1e-9);
  EXPECT_NEAR(rotationAngleBetween(T.linear(), Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitX()).toRotationMatrix()),
              0.0, 1e-12);
  // Base rotation by +90 deg turns the same point about z.
  Joints q = Joints::Zero();
  q[0] = kPi / 2;
  EXPECT_LT((kin.forward(q).translation() - Eigen::Vector3d(191.45, -817.25, -5.491)).norm(), 1e-9);
  // Upper arm and forearm vertical (q2 = -pi/2): the wrist-1 frame is d1 + |a2| + |a3| above the base.
  q = Joints::Zero();
  q[1] = -kPi / 2;
  EXPECT_NEAR(kin.forwardFrames(q)[3].translation().z(), 89.159 + 817.25, 1e-9);
}

TEST(Ur5Kinematics, MatchesUniversalRobotsKinematicsFile) {
  MRSNS_REQUIRE_DATA(yaml, "robot/ur5_default_kinematics.yaml");
  const auto links = readUrdfKinematics(yaml);
  ASSERT_EQ(links.size(), 6u);
  // DH lengths read off the URDF chain.
  const auto& L = links;
  const auto dh = urDhParameters(1000 * L.at("shoulder")[2], 1000 * L.at("forearm")[0], 1000 * L.at("wrist_1")[0],
                                 1000 * L.at("wrist_1")[2], -1000 * L.at("wrist_2")[1], 1000 * L.at("wrist_3")[1]);
  const auto nominal = ur5DhParameters();
  for (int i = 0; i < 6; ++i) {
    EXPECT_NEAR(dh.d[i], nominal.d[i], 1e-9) << "d" << i + 1;
    EXPECT_NEAR(dh.a[i], nominal.a[i], 1e-9) << "a" << i + 1;
  }
  // The URDF chain and the DH chain differ by one constant flange rotation; after removing it they agree
  // at any joint vector. The file rounds pi/2 to 1.570796327 (3e-10 rad over < 1 m: < 1e-6 mm).
  const Ur5Kinematics kin(dh);
  const char* names[6] = {"shoulder", "upper_arm", "forearm", "wrist_1", "wrist_2", "wrist_3"};
  auto urdf = [&](const Joints& q) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    for (int i = 0; i < 6; ++i) T = T * urdfJoint(links.at(names[i]), q[i]);
    return T;
  };
  const Eigen::Isometry3d C = kin.forward(Joints::Zero()).inverse() * urdf(Joints::Zero());
  EXPECT_LT(C.translation().norm(), 1e-6);
  std::mt19937_64 rng(7);
  for (int k = 0; k < 50; ++k) {
    const Joints q = randomJoints(rng);
    EXPECT_LT(poseDistance(kin.forward(q) * C, urdf(q)), 1e-6) << q.transpose();
  }
}

TEST(Ur5Kinematics, InverseRoundTripsOverRandomPoses) {
  const Ur5Kinematics kin;
  std::mt19937_64 rng(11);
  int checked = 0, eight = 0;
  for (int k = 0; k < 500; ++k) {
    const Joints q = randomJoints(rng);
    const auto T = kin.forward(q);
    const auto sols = kin.inverse(T);
    const auto sing = kin.singularity(q);
    if (sing.any()) continue;  // near singularities some branches merge; covered below
    ++checked;
    // Up to 8: a shoulder branch can leave the elbow out of reach for some poses.
    ASSERT_GE(sols.size(), 2u) << q.transpose();
    ASSERT_LE(sols.size(), 8u);
    eight += sols.size() == 8u ? 1 : 0;
    bool found = false;
    for (const auto& s : sols) {
      EXPECT_LT(poseDistance(kin.forward(s), T), 1e-9) << s.transpose();
      Joints d = s - q;
      for (int i = 0; i < 6; ++i) d[i] = std::remainder(d[i], 2 * kPi);
      found = found || d.cwiseAbs().maxCoeff() < 1e-7;
    }
    EXPECT_TRUE(found) << "the generating joints are not among the 8 solutions: " << q.transpose();
  }
  EXPECT_GT(checked, 300);
  EXPECT_GT(eight, checked / 4);
}

TEST(Ur5Kinematics, InverseAtWristSingularityKeepsHint) {
  const Ur5Kinematics kin;
  Joints q;
  q << 0.3, -1.2, 1.4, -0.7, 0.0, 0.9;  // q5 = 0: q4 and q6 share one axis
  const auto sols = kin.inverse(kin.forward(q), 0.9);
  ASSERT_FALSE(sols.empty());
  // acos at +-1 turns rounding of 1e-16 into 1e-8 rad of q5: the singular pose round-trips to ~1e-5 mm.
  for (const auto& s : sols) EXPECT_LT(poseDistance(kin.forward(s), kin.forward(q)), 1e-5);
  EXPECT_TRUE(kin.singularity(q).wrist);
}

TEST(Ur5Kinematics, InverseNearestPicksCurrentBranchAndRespectsLimits) {
  const Ur5Kinematics kin;
  Joints q;
  q << 0.4, -1.1, 1.3, -1.7, -1.5, 0.2;
  Joints current = q + Joints::Constant(0.02);
  auto best = kin.inverseNearest(kin.forward(q), current);
  ASSERT_TRUE(best.has_value());
  EXPECT_LT((*best - q).cwiseAbs().maxCoeff(), 1e-8);
  // The base has turned a full revolution: the nearest solution keeps that turn.
  current[0] += 2 * kPi;
  best = kin.inverseNearest(kin.forward(q), current);
  ASSERT_TRUE(best.has_value());
  EXPECT_NEAR((*best)[0], q[0] + 2 * kPi, 1e-8);
  // Out of reach: nothing.
  Eigen::Isometry3d far = Eigen::Isometry3d::Identity();
  far.translation() << 2000, 0, 0;
  EXPECT_FALSE(kin.inverseNearest(far, q).has_value());
  // Limits: an elbow beyond pi is refused.
  JointLimits limits = ur5JointLimits();
  EXPECT_FALSE(withinLimits((Joints() << 0, 0, 3.5, 0, 0, 0).finished(), limits));
  EXPECT_EQ(firstJointOutsideLimits((Joints() << 0, 0, 3.5, 0, 0, 0).finished(), limits), 2);
  limits.max_q[0] = 0.3;  // the generating solution's base angle is now outside
  best = kin.inverseNearest(kin.forward(q), q, &limits);
  if (best) {
    EXPECT_LE((*best)[0], 0.3);
  }
}

TEST(Ur5Kinematics, JacobianMatchesFiniteDifferences) {
  const Ur5Kinematics kin;
  std::mt19937_64 rng(3);
  const double h = 1e-6;
  for (int k = 0; k < 30; ++k) {
    const Joints q = randomJoints(rng);
    const auto J = kin.jacobian(q);
    for (int i = 0; i < 6; ++i) {
      Joints qp = q, qm = q;
      qp[i] += h;
      qm[i] -= h;
      const auto Tp = kin.forward(qp), Tm = kin.forward(qm);
      const Eigen::Vector3d v = (Tp.translation() - Tm.translation()) / (2 * h);
      const Eigen::Vector3d w = so3Log(Tp.linear() * Tm.linear().transpose()) / (2 * h);
      // Central differences: O(h^2 * 1000 mm) truncation, O(1e-13 mm / h) rounding.
      EXPECT_LT((J.block<3, 1>(0, i) - v).norm(), 1e-5) << "joint " << i;
      EXPECT_LT((J.block<3, 1>(3, i) - w).norm(), 1e-8) << "joint " << i;
    }
  }
}

TEST(Ur5Kinematics, SingularityMeasureIsTheJacobianDeterminant) {
  // det J = a2 a3 sin q3 sin q5 (a2 cos q2 + a3 cos(q2 + q3) + d5 sin(q2 + q3 + q4)) for every UR arm.
  const Ur5Kinematics kin;
  std::mt19937_64 rng(5);
  for (int k = 0; k < 50; ++k) {
    const Joints q = randomJoints(rng);
    const auto s = kin.singularity(q);
    const double expected = -425.0 * -392.25 * s.elbow_sin * s.wrist_sin * s.shoulder_mm;
    EXPECT_NEAR(std::abs(kin.jacobian(q).determinant()), std::abs(expected), 1e-6 * (1 + std::abs(expected)));
  }
  Joints q;
  q << 0.2, -1.0, 0.0, -1.0, 1.0, 0.0;  // stretched elbow
  EXPECT_TRUE(kin.singularity(q).elbow);
  EXPECT_LT(kin.singularity(q).min_singular_value, 1e-9);
  q << 0.2, -1.0, 1.2, -1.0, 1.0, 0.0;
  EXPECT_FALSE(kin.singularity(q).any());
}

TEST(Ur5Kinematics, RefusesBadParameters) {
  EXPECT_THROW(urDhParameters(std::nan(""), -425, -392.25, 109.15, 94.65, 82.3), InvalidArgumentError);
  EXPECT_THROW(urDhParameters(89.159, 425, -392.25, 109.15, 94.65, 82.3), InvalidArgumentError);
  EXPECT_THROW(urDhParameters(89.159, -425, -392.25, -109.15, 94.65, 82.3), InvalidArgumentError);
  Eigen::Isometry3d nan_pose = Eigen::Isometry3d::Identity();
  nan_pose.translation().x() = std::nan("");
  EXPECT_TRUE(Ur5Kinematics().inverse(nan_pose).empty());
}

}  // namespace
}  // namespace mrsns::robot
