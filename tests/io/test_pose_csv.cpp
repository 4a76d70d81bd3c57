#include <gtest/gtest.h>

#include <fstream>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/io/pose_csv.h"
#include "test_data.h"

namespace mrsns::io {
namespace {

TEST(PoseCsv, RoundTripWithAndWithoutTimestamps) {
  const auto dir = test::scratchDirectory("pose_csv");
  std::vector<Eigen::Isometry3d> poses;
  std::vector<double> times;
  for (int i = 0; i < 5; ++i) {
    Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
    p.linear() = so3Exp(Eigen::Vector3d(0.1 * i, -0.2, 0.3 + i));
    p.translation() = Eigen::Vector3d(i * 10.5, -3.25, 1e3 / 7.0);
    poses.push_back(p);
    times.push_back(100.0 + i * 0.02);
  }
  writePoseCsv(dir / "timed.csv", poses, times);
  writePoseCsv(dir / "plain.csv", poses);
  const auto timed = readPoseCsv(dir / "timed.csv");
  const auto plain = readPoseCsv(dir / "plain.csv");
  ASSERT_EQ(timed.poses.size(), 5u);
  ASSERT_EQ(timed.timestamps.size(), 5u);
  EXPECT_TRUE(plain.timestamps.empty());
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_LT((timed.poses[i].matrix() - poses[i].matrix()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_LT((plain.poses[i].matrix() - poses[i].matrix()).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_DOUBLE_EQ(timed.timestamps[i], times[i]);
  }
}

TEST(PoseCsv, AcceptsHeaderCommentsAndWhitespaceSeparators) {
  const auto dir = test::scratchDirectory("pose_csv");
  std::ofstream(dir / "p.csv") << "m00 m01 m02 m03 m10 m11 m12 m13 m20 m21 m22 m23 m30 m31 m32 m33\n"
                                  "# a comment\n\n"
                                  "1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1\r\n";
  const auto csv = readPoseCsv(dir / "p.csv");
  ASSERT_EQ(csv.poses.size(), 1u);
  EXPECT_TRUE(csv.poses[0].translation().isApprox(Eigen::Vector3d(5, 6, 7)));
}

TEST(PoseCsv, RejectsMalformedLinesWithFileAndLine) {
  const auto dir = test::scratchDirectory("pose_csv");
  std::ofstream(dir / "short.csv") << "1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1\n1,2,3\n";
  try {
    (void)readPoseCsv(dir / "short.csv");
    FAIL() << "expected FormatError";
  } catch (const FormatError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("short.csv"), std::string::npos);
    EXPECT_NE(message.find("line 2"), std::string::npos);
  }
  std::ofstream(dir / "scaled.csv") << "2,0,0,0,0,2,0,0,0,0,2,0,0,0,0,1\n";
  EXPECT_THROW((void)readPoseCsv(dir / "scaled.csv"), FormatError);
  std::ofstream(dir / "nan.csv") << "nan,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1\n";
  EXPECT_THROW((void)readPoseCsv(dir / "nan.csv"), FormatError);
  std::ofstream(dir / "empty.csv") << "# nothing\n";
  EXPECT_THROW((void)readPoseCsv(dir / "empty.csv"), FormatError);
  EXPECT_THROW((void)readPoseCsv(dir / "absent.csv"), FileError);
}

}  // namespace
}  // namespace mrsns::io
