#include <gtest/gtest.h>

#include "mrsns/core/error.h"
#include "mrsns/core/frame_poses.h"
#include "mrsns/core/rigid.h"

namespace mrsns {
namespace {

Eigen::Matrix4d pose(const Eigen::Vector3d& phi, const Eigen::Vector3d& t) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = so3Exp(phi);
  m.topRightCorner<3, 1>() = t;
  return m;
}

TEST(FramePoses, ComposesStylusToReferencePerFrame) {
  std::vector<TrackedFrame> frames(3);
  for (int i = 0; i < 3; ++i) {
    frames[static_cast<std::size_t>(i)].timestamp = 10.0 + i;
    frames[static_cast<std::size_t>(i)].transforms["StylusToTracker"] = {
        pose(Eigen::Vector3d(0.1 * i, 0.2, 0.3), Eigen::Vector3d(i, 2, 3)), TransformStatus::Ok};
    frames[static_cast<std::size_t>(i)].transforms["ReferenceToTracker"] = {
        pose(Eigen::Vector3d(-0.3, 0.1, 0.05 * i), Eigen::Vector3d(100, 50, -20)), TransformStatus::Ok};
  }
  frames[1].transforms["ReferenceToTracker"].status = TransformStatus::Invalid;
  frames[2].transforms.erase("StylusToTracker");
  const auto extraction = extractFramePoses(frames, "StylusToReference");
  ASSERT_EQ(extraction.poses.size(), 1u);
  EXPECT_EQ(extraction.invalid_frames, 1u);
  EXPECT_EQ(extraction.missing_frames, 1u);
  const Eigen::Matrix4d expected =
      frames[0].transforms["ReferenceToTracker"].matrix.inverse() * frames[0].transforms["StylusToTracker"].matrix;
  EXPECT_LT((extraction.poses[0].to_T_from.matrix() - expected).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_DOUBLE_EQ(extraction.poses[0].timestamp, 10.0);
  const auto with_invalid = extractFramePoses(frames, "StylusToReference", true);
  EXPECT_EQ(with_invalid.poses.size(), 2u);
  EXPECT_EQ(with_invalid.poses[1].status, TransformStatus::Invalid);
}

TEST(FramePoses, RoundedMatricesAreOrthonormalisedAndCounted) {
  std::vector<TrackedFrame> frames(1);
  Eigen::Matrix4d m = pose(Eigen::Vector3d(0.5, -0.2, 0.1), Eigen::Vector3d(1, 2, 3));
  m(0, 0) += 1e-4;  // PLUS prints six significant digits
  frames[0].transforms["ProbeToTracker"] = {m, TransformStatus::Ok};
  const auto extraction = extractFramePoses(frames, "ProbeToTracker");
  ASSERT_EQ(extraction.poses.size(), 1u);
  EXPECT_EQ(extraction.orthonormalized_frames, 1u);
}

TEST(FramePoses, UnknownTransformNamesWhatTheFramesHave) {
  std::vector<TrackedFrame> frames(2);
  frames[0].transforms["ProbeToTracker"] = {Eigen::Matrix4d::Identity(), TransformStatus::Ok};
  try {
    (void)extractFramePoses(frames, "StylusToReference");
    FAIL() << "expected FrameError";
  } catch (const FrameError& e) {
    EXPECT_NE(std::string(e.what()).find("ProbeToTracker"), std::string::npos) << e.what();
  }
  EXPECT_THROW((void)extractFramePoses(frames, "Stylus"), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns
