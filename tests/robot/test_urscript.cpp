// URScript command generation (UR units: metres, radians) and the simulator's parser: golden lines, exact
// round trips, unit conversion, malformed lines.
#include <gtest/gtest.h>

#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/robot/urscript.h"

using namespace mrsns::robot;
using namespace mrsns::robot::urscript;

TEST(UrScript, GoldenLines) {
  Joints q;
  q << 0.5, -1.25, 1.5, -1.5, -1.5, 0;
  EXPECT_EQ(servoj(q), "servoj([0.5, -1.25, 1.5, -1.5, -1.5, 0], 0, 0, 0.008, 0.1, 300)");
  Twist v;
  v << 100, -50, 0, 0, 0, 0.25;  // mm/s, rad/s
  EXPECT_EQ(speedl(v, 500, 0.1), "speedl([0.1, -0.05, 0, 0, 0, 0.25], 0.5, 0.1)");
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() << 400, -100, 250;
  EXPECT_EQ(movel(T, 1200, 250), "movel(p[0.4, -0.1, 0.25, 0, 0, 0], a=1.2, v=0.25)");
  EXPECT_EQ(stopj(2), "stopj(2)");
  EXPECT_EQ(protectiveStop(), "protective_stop()");
  EXPECT_EQ(parseLine(protectiveStop()).kind, CommandKind::ProtectiveStop);
  EXPECT_THROW((void)parseLine("protective_stop(1)"), mrsns::FormatError);
  EXPECT_EQ(stopl(500), "stopl(0.5)");
  EXPECT_EQ(movej(q, 1.4, 1.05), "movej([0.5, -1.25, 1.5, -1.5, -1.5, 0], a=1.4, v=1.05)");
}

TEST(UrScript, RoundTripIsExact) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-3, 3);
  for (int i = 0; i < 200; ++i) {
    Joints q;
    for (int k = 0; k < 6; ++k) q[k] = u(rng);
    const auto c = parseLine(servoj(q, {0.002, 0.05, 500}));
    EXPECT_EQ(c.kind, CommandKind::ServoJ);
    EXPECT_EQ(c.q, q);  // shortest round-trip formatting: bit-exact
    EXPECT_EQ(c.time_s, 0.002);
    EXPECT_EQ(c.lookahead_time_s, 0.05);
    EXPECT_EQ(c.gain, 500);
    Twist v;
    for (int k = 0; k < 6; ++k) v[k] = u(rng) * (k < 3 ? 100 : 1);
    const auto s = parseLine(speedl(v, 800, 0.008));
    EXPECT_EQ(s.kind, CommandKind::SpeedL);
    // mm -> m -> mm: one rounding each way.
    EXPECT_LT((s.twist - v).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_NEAR(s.acceleration, 800, 1e-12);
  }
}

TEST(UrScript, PoseConversionMillimetresAndRotationVector) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = mrsns::so3Exp(Eigen::Vector3d(0.1, -2.0, 0.7));
  T.translation() << 123.4, -567.8, 910.1;
  const auto p = toUrPose(T);
  EXPECT_NEAR(p[0], 0.1234, 1e-15);
  EXPECT_NEAR(p[4], -2.0, 1e-12);
  const auto c = parseLine(movel(T, 1000, 100));
  EXPECT_EQ(c.kind, CommandKind::MoveL);
  EXPECT_LT((c.pose.matrix() - T.matrix()).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_NEAR(c.speed, 100, 1e-12);
  EXPECT_NEAR(c.acceleration, 1000, 1e-12);
  // Near pi the rotation vector is still a valid rotation.
  T.linear() = mrsns::so3Exp(Eigen::Vector3d(0, 0, M_PI - 1e-9));
  const auto back = fromUrPose(toUrPose(T));
  EXPECT_LT((back.linear() - T.linear()).cwiseAbs().maxCoeff(), 1e-8);
}

TEST(UrScript, KeywordsAndDefaults) {
  const auto c = parseLine("servoj([0,0,0,0,0,0], t=0.002, gain=1000)\n");
  EXPECT_EQ(c.time_s, 0.002);
  EXPECT_EQ(c.gain, 1000);
  EXPECT_EQ(c.lookahead_time_s, 0.1);
  EXPECT_EQ(parseLine("stopj(a=3)").acceleration, 3);
  EXPECT_NEAR(parseLine("movel(p[0.1,0,0,0,0,0])").speed, 250, 1e-12);
}

TEST(UrScript, MalformedLinesAreFormatErrors) {
  for (const char* line :
       {"", "servoj", "servoj([1,2,3])", "servoj([1,2,3,4,5,6]", "servoj(p[1,2,3,4,5,6])", "movel([0.1,0,0,0,0,0])",
        "speedl([0,0,0,0,0,0])", "stopj()", "stopj(nan)", "stopj(-1)", "popup(\"hi\")", "servoj([1,2,3,4,5,x])",
        "stopj(1, 2)", "stopj(b=1)", "servoj(t=1, [0,0,0,0,0,0])", "servoj([0,0,0,0,0,0]], 0)"}) {
    EXPECT_THROW((void)parseLine(line), mrsns::FormatError) << line;
  }
  Joints bad = Joints::Zero();
  bad[2] = std::nan("");
  EXPECT_THROW((void)servoj(bad), mrsns::InvalidArgumentError);
}
