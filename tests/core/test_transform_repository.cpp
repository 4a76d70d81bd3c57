#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <atomic>
#include <chrono>
#include <cmath>
#include <random>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/core/transform_repository.h"

namespace mrsns {
namespace {

Eigen::Isometry3d randomPose(std::mt19937& rng, double max_translation_mm = 200.0) {
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(-max_translation_mm, max_translation_mm);
  Eigen::Quaterniond q(gauss(rng), gauss(rng), gauss(rng), gauss(rng));
  q.normalize();
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = q.toRotationMatrix();
  pose.translation() = Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng));
  return pose;
}

void expectPoseNear(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, double tol) {
  EXPECT_LE((a.matrix() - b.matrix()).cwiseAbs().maxCoeff(), tol) << "\n" << a.matrix() << "\nvs\n" << b.matrix();
}

TEST(TransformName, ParsesPlusStyleNames) {
  const auto name = TransformName::parse("ProbeToTracker");
  EXPECT_EQ(name.from, "Probe");
  EXPECT_EQ(name.to, "Tracker");
  EXPECT_EQ(name.str(), "ProbeToTracker");
  const auto image = TransformName::parse("ImageToTransducerOriginPixel");
  EXPECT_EQ(image.from, "Image");
  EXPECT_EQ(image.to, "TransducerOriginPixel");
}

TEST(TransformName, RejectsMalformedAndAmbiguousNames) {
  EXPECT_THROW(TransformName::parse("Probe"), InvalidArgumentError);
  EXPECT_THROW(TransformName::parse("ToTracker"), InvalidArgumentError);
  EXPECT_THROW(TransformName::parse("ProbeTotracker"), InvalidArgumentError);
  EXPECT_THROW(TransformName::parse("ToolToPatientToTracker"), InvalidArgumentError);
}

TEST(TransformRepository, ComposesThreeEdgePathLikeDirectProducts) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 50; ++trial) {
    TransformRepository repo;
    const auto probe_T_image = randomPose(rng);
    const auto tracker_T_probe = randomPose(rng);
    const auto tracker_T_reference = randomPose(rng);
    repo.setTransform("ImageToProbe", probe_T_image, TransformStatus::Ok, 1.0, true);
    repo.setTransform("ProbeToTracker", tracker_T_probe, TransformStatus::Ok, 2.0);
    repo.setTransform("ReferenceToTracker", tracker_T_reference, TransformStatus::Ok, 3.0);
    const Eigen::Isometry3d reference_T_image = tracker_T_reference.inverse() * tracker_T_probe * probe_T_image;
    const auto result = repo.getTransform("ImageToReference");
    EXPECT_TRUE(result.ok());
    expectPoseNear(result.to_T_from, reference_T_image, 1e-9);
    // The inverse query is the inverse transform.
    expectPoseNear(repo.getTransform("ReferenceToImage").to_T_from, reference_T_image.inverse(), 1e-9);
    // The oldest non-persistent timestamp is reported (the calibration does not age).
    EXPECT_DOUBLE_EQ(result.timestamp, 2.0);
  }
}

TEST(TransformRepository, IdentityForSameFrameAndDirectEdge) {
  TransformRepository repo;
  std::mt19937 rng(1);
  const auto tracker_T_probe = randomPose(rng);
  repo.setTransform("Probe", "Tracker", tracker_T_probe);
  expectPoseNear(repo.getTransform("Probe", "Probe").to_T_from, Eigen::Isometry3d::Identity(), 0.0);
  expectPoseNear(repo.getTransform("ProbeToTracker").to_T_from, tracker_T_probe, 0.0);
  EXPECT_TRUE(repo.getTransform("Tracker", "Tracker").ok());
}

TEST(TransformRepository, SettingTheInverseUpdatesTheSameEdge) {
  TransformRepository repo;
  std::mt19937 rng(2);
  repo.setTransform("ProbeToTracker", randomPose(rng));
  const auto probe_T_tracker = randomPose(rng);
  repo.setTransform("TrackerToProbe", probe_T_tracker);
  EXPECT_EQ(repo.edges().size(), 1u);
  expectPoseNear(repo.getTransform("ProbeToTracker").to_T_from, probe_T_tracker.inverse(), 1e-12);
}

TEST(TransformRepository, WorstStatusAlongPathIsReported) {
  TransformRepository repo;
  repo.setTransform("ImageToProbe", Eigen::Isometry3d::Identity(), TransformStatus::Ok, 0.0, true);
  repo.setTransform("ProbeToTracker", Eigen::Isometry3d::Identity(), TransformStatus::Ok, 1.0);
  repo.setTransform("ReferenceToTracker", Eigen::Isometry3d::Identity(), TransformStatus::Ok, 1.0);
  EXPECT_EQ(repo.getTransform("ImageToReference").status, TransformStatus::Ok);
  repo.setStatus("Probe", "Tracker", TransformStatus::Invalid, 1.5);
  EXPECT_EQ(repo.getTransform("ImageToReference").status, TransformStatus::Invalid);
  repo.setStatus("Reference", "Tracker", TransformStatus::Missing, 1.6);
  EXPECT_EQ(repo.getTransform("ImageToReference").status, TransformStatus::Missing);
  // Only the edges on the path count.
  EXPECT_EQ(repo.getTransform("ImageToProbe").status, TransformStatus::Ok);
}

TEST(TransformRepository, UnknownFrameNamesKnownFrames) {
  TransformRepository repo;
  repo.setTransform("ProbeToTracker", Eigen::Isometry3d::Identity());
  try {
    (void)repo.getTransform("StylusToTracker");
    FAIL() << "expected FrameError";
  } catch (const FrameError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("Stylus"), std::string::npos);
    EXPECT_NE(message.find("Probe, Tracker"), std::string::npos);
  }
}

TEST(TransformRepository, DisconnectedGraphGivesFrameErrorWithBothGroups) {
  TransformRepository repo;
  repo.setTransform("ProbeToTracker", Eigen::Isometry3d::Identity());
  repo.setTransform("ImageToCT", Eigen::Isometry3d::Identity());
  EXPECT_FALSE(repo.isConnected("Probe", "CT"));
  try {
    (void)repo.getTransform("ProbeToCT");
    FAIL() << "expected FrameError";
  } catch (const FrameError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("{Probe, Tracker}"), std::string::npos) << message;
    EXPECT_NE(message.find("{CT, Image}"), std::string::npos) << message;
  }
}

TEST(TransformRepository, RefusesContradictoryEdgesAndSelfLoops) {
  TransformRepository repo;
  repo.setTransform("ProbeToTracker", Eigen::Isometry3d::Identity());
  repo.setTransform("ReferenceToTracker", Eigen::Isometry3d::Identity());
  EXPECT_THROW(repo.setTransform("ProbeToReference", Eigen::Isometry3d::Identity()), FrameError);
  EXPECT_THROW(repo.setTransform("Probe", "Probe", Eigen::Isometry3d::Identity()), InvalidArgumentError);
  EXPECT_THROW(repo.setTransform("", "Probe", Eigen::Isometry3d::Identity()), InvalidArgumentError);
  // After removing one edge the new one is accepted.
  EXPECT_TRUE(repo.removeTransform("Tracker", "Reference"));
  EXPECT_NO_THROW(repo.setTransform("ProbeToReference", Eigen::Isometry3d::Identity()));
  EXPECT_FALSE(repo.removeTransform("Nothing", "Here"));
}

TEST(TransformRepository, RefusesNonRigidAndNaNMatrices) {
  TransformRepository repo;
  Eigen::Isometry3d scaled = Eigen::Isometry3d::Identity();
  scaled.linear() *= 1.1;
  EXPECT_THROW(repo.setTransform("ProbeToTracker", scaled), InvalidArgumentError);
  Eigen::Isometry3d nan = Eigen::Isometry3d::Identity();
  nan.translation().x() = std::nan("");
  EXPECT_THROW(repo.setTransform("ProbeToTracker", nan), InvalidArgumentError);
  Eigen::Isometry3d mirrored = Eigen::Isometry3d::Identity();
  mirrored.linear()(0, 0) = -1.0;
  EXPECT_THROW(repo.setTransform("ProbeToTracker", mirrored), InvalidArgumentError);
  EXPECT_FALSE(repo.hasFrame("Probe"));
}

TEST(TransformRepository, SetStatusOfUnknownEdgeThrows) {
  TransformRepository repo;
  EXPECT_THROW(repo.setStatus("Probe", "Tracker", TransformStatus::Invalid), FrameError);
}

TEST(TransformRepository, PreparedQueryFollowsTopologyChangesAndNeverThrows) {
  TransformRepository repo;
  auto query = repo.prepare("Image", "Reference");
  EXPECT_EQ(repo.evaluate(query).status, TransformStatus::Missing);  // frames unknown yet
  repo.setTransform("ImageToProbe", Eigen::Isometry3d(Eigen::Translation3d(1, 0, 0)));
  repo.setTransform("ProbeToTracker", Eigen::Isometry3d(Eigen::Translation3d(0, 2, 0)));
  EXPECT_EQ(repo.evaluate(query).status, TransformStatus::Missing);  // no path yet
  repo.setTransform("ReferenceToTracker", Eigen::Isometry3d(Eigen::Translation3d(0, 0, 3)));
  auto result = repo.evaluate(query);
  EXPECT_TRUE(result.ok());
  EXPECT_TRUE(result.to_T_from.translation().isApprox(Eigen::Vector3d(1, 2, -3)));
  // Re-route through another edge after a removal.
  repo.removeTransform("Reference", "Tracker");
  EXPECT_EQ(repo.evaluate(query).status, TransformStatus::Missing);
  repo.setTransform("ReferenceToProbe", Eigen::Isometry3d(Eigen::Translation3d(0, 0, 5)));
  result = repo.evaluate(query);
  EXPECT_TRUE(result.ok());
  EXPECT_TRUE(result.to_T_from.translation().isApprox(Eigen::Vector3d(1, 0, -5)));
}

TEST(TransformRepository, PathListsFramesInOrder) {
  TransformRepository repo;
  repo.setTransform("ImageToProbe", Eigen::Isometry3d::Identity());
  repo.setTransform("ProbeToTracker", Eigen::Isometry3d::Identity());
  repo.setTransform("ReferenceToTracker", Eigen::Isometry3d::Identity());
  const std::vector<std::string> expected{"Image", "Probe", "Tracker", "Reference"};
  EXPECT_EQ(repo.path("Image", "Reference"), expected);
  const std::vector<std::string> frames{"Image", "Probe", "Reference", "Tracker"};
  EXPECT_EQ(repo.frames(), frames);
}

TEST(TransformRepository, ConcurrentReadersNeverSeeTornMatrices) {
  // The writer keeps a fixed relation between rotation and translation
  // (translation.x = 100 * angle); a torn read would break it.
  TransformRepository repo;
  auto pose = [](double angle) {
    Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
    p.linear() = Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    p.translation() = Eigen::Vector3d(100.0 * angle, -100.0 * angle, 0.0);
    return p;
  };
  repo.setTransform("ProbeToTracker", pose(0.0), TransformStatus::Ok, 0.0);
  repo.setTransform("ImageToProbe", Eigen::Isometry3d::Identity(), TransformStatus::Ok, 0.0, true);
  std::atomic<bool> stop{false};
  std::atomic<int> bad{0};
  std::atomic<long> reads{0};
  std::vector<std::thread> readers;
  for (int r = 0; r < 3; ++r) {
    readers.emplace_back([&] {
      auto query = repo.prepare("Image", "Tracker");
      while (!stop.load()) {
        const auto result = repo.evaluate(query);
        const double angle = std::atan2(result.to_T_from.linear()(1, 0), result.to_T_from.linear()(0, 0));
        if (std::abs(result.to_T_from.translation().x() - 100.0 * angle) > 1e-9 ||
            std::abs(result.to_T_from.translation().y() + 100.0 * angle) > 1e-9) {
          bad.fetch_add(1);
        }
        reads.fetch_add(1);
      }
    });
  }
  // Keep writing until the readers have overlapped with many writes (on a
  // loaded machine they may start late); bounded so the test always ends.
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  for (int i = 0; i < 20000 || (reads.load() < 3000 && std::chrono::steady_clock::now() < give_up); ++i) {
    const double angle = 0.0001 * (i % 30000);
    repo.setTransform("ProbeToTracker", pose(angle), TransformStatus::Ok, i * 1e-3);
  }
  stop = true;
  for (auto& t : readers) t.join();
  EXPECT_EQ(bad.load(), 0);
  EXPECT_GE(reads.load(), 3000);
}

}  // namespace
}  // namespace mrsns
