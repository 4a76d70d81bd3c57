// Phantom registration from stylus landmarks and the image-to-reference
// chain with the temporal offset.
#include <gtest/gtest.h>

#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/io/device_set.h"
#include "mrsns/ultrasound/image_chain.h"
#include "mrsns/ultrasound/phantom_registration.h"
#include "mrsns/ultrasound/spatial_calibration.h"
#include "test_data.h"

namespace mrsns::ultrasound {
namespace {

TEST(PhantomRegistration, RecoversPhantomToReferenceFromNoisyStylusPoints) {
  MRSNS_REQUIRE_DATA(config_path, "plus/PlusDeviceSet_fCal_Sim_SpatialCalibration_1.2.xml");
  const auto config = io::readDeviceSet(config_path);
  const auto& phantom = config.requirePhantom();
  const Eigen::Isometry3d truth = orthonormalize(config.findTransform("Phantom", "Reference")->to_T_from);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.3);  // stylus tip error, mm per axis
  std::vector<Eigen::Vector3d> tips;
  for (const auto& l : phantom.landmarks) {
    tips.push_back(truth * l.position_phantom + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
  }
  const auto r = registerPhantom(phantom, tips);
  // 8 landmarks over 120 x 40 x 15 mm with 0.5 mm RMS FLE: the pose is good
  // to a few tenths of a mm inside the phantom.
  for (const auto& l : phantom.landmarks) {
    EXPECT_LT((r.reference_T_phantom * l.position_phantom - truth * l.position_phantom).norm(), 0.6);
  }
  EXPECT_GT(r.fre_rms_mm, 0.1);
  EXPECT_LT(r.fre_rms_mm, 1.0);
  EXPECT_EQ(r.landmark_names.size(), 8u);
  tips.pop_back();
  EXPECT_THROW((void)registerPhantom(phantom, tips), InvalidArgumentError);
}

TEST(ImageChain, ProbePoseUsesTheTrackerLag) {
  // The probe moves along x at 100 mm/s; the tracker stamps each instant 50 ms late.
  std::vector<FramePose> poses;
  for (int i = 0; i <= 100; ++i) {
    FramePose p;
    p.timestamp = i * 0.01;
    p.to_T_from.translation() = Eigen::Vector3d(100.0 * (p.timestamp - 0.05), 0, 0);
    poses.push_back(p);
  }
  const auto at = probePoseAtVideoTime(poses, 0.5, 0.05);
  EXPECT_NEAR(at.translation().x(), 50.0, 1e-9);  // the true position at video time 0.5 s
  EXPECT_THROW((void)probePoseAtVideoTime(poses, 0.99, 0.05), InvalidArgumentError);
}

TEST(ImageChain, CornersReachCtThroughTheRepository) {
  TransformRepository repository;
  Eigen::Isometry3d ct_T_reference = Eigen::Isometry3d::Identity();
  ct_T_reference.linear() = so3Exp(Eigen::Vector3d(0.2, -0.1, 0.3));
  ct_T_reference.translation() = Eigen::Vector3d(10, -20, 30);
  repository.setTransform("Reference", "CT", ct_T_reference);
  Eigen::Isometry3d reference_T_probe = Eigen::Isometry3d::Identity();
  reference_T_probe.linear() = so3Exp(Eigen::Vector3d(-0.4, 0.1, 1.0));
  reference_T_probe.translation() = Eigen::Vector3d(100, 50, -20);
  const Eigen::Matrix4d probe_T_image =
      imageToProbeMatrix(so3Exp(Eigen::Vector3d(0.0, -1.5, 0.0)), Eigen::Vector3d(11, 46, -7), {0.08, 0.075});
  const auto placed = placeImage(repository, reference_T_probe, probe_T_image, 820, 616, "CT");
  const Eigen::Vector4d corner(819, 615, 0, 1);
  const Eigen::Vector3d expected =
      (ct_T_reference.matrix() * reference_T_probe.matrix() * probe_T_image * corner).head<3>();
  EXPECT_LT((placed.corners_mm[3] - expected).norm(), 1e-9);
  // The image diagonal keeps its physical length.
  EXPECT_NEAR((placed.corners_mm[3] - placed.corners_mm[0]).norm(), std::hypot(819 * 0.08, 615 * 0.075), 1e-9);
  EXPECT_THROW((void)placeImage(repository, reference_T_probe, probe_T_image, 820, 616, "Nowhere"), FrameError);
}

}  // namespace
}  // namespace mrsns::ultrasound
