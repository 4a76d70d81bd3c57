// Camera side of the checkerboard hand-eye: rendered images, corner
// detection, calibrateCamera, solvePnP, the chain T_c^h and the RPEE.
// Image noise model where stated: 0.7 px Gaussian blur, 2 grey levels of
// additive noise on a 200-level contrast, 2x2 supersampled edges.
#include <gtest/gtest.h>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/hmd/board_renderer.h"
#include "mrsns/hmd/camera_calibration.h"
#include "mrsns/hmd/checkerboard_hand_eye.h"
#include "mrsns/hmd/retro_projection.h"

namespace mrsns::hmd {
namespace {

const CameraIntrinsics kCamera{1000.0, 1000.0, 640.0, 360.0, {-0.05, 0.02, 0.0, 0.0, 0.0}, 1280, 720};
const CheckerboardSpec kBoard{3, 5, 40.0};

Eigen::Isometry3d cameraTGrid(double distance, const Eigen::Vector3d& tilt) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = so3Exp(tilt);
  T.translation() = Eigen::Vector3d(-80.0, -40.0, distance);
  return T;
}

std::vector<Eigen::Vector2d> trueCorners(const Eigen::Isometry3d& camera_T_grid, const CameraIntrinsics& k) {
  std::vector<Eigen::Vector3d> pts;
  for (const auto& g : idealGridCorners(kBoard)) pts.push_back(camera_T_grid * g);
  return projectPoints(pts, k);
}

// Detected corners of a rendered board against the true projections: sub-pixel corner
// localisation under this noise is ~0.05-0.1 px; 0.3 px allows the worst of 15 corners.
TEST(CameraCalibration, RenderedBoardCornersFoundWithinNoise) {
  for (double distance : {500.0, 1000.0, 1500.0}) {
    const Eigen::Isometry3d T = cameraTGrid(distance, Eigen::Vector3d(0.3, -0.2, 0.1));
    const GrayImage image = renderCheckerboard(kBoard, kCamera, T);
    ASSERT_EQ(image.width, 1280);
    const auto found = detectCheckerboard(image, kBoard);
    ASSERT_TRUE(found.has_value()) << distance;
    auto truth = trueCorners(T, kCamera);
    // OpenCV may number a 180-deg symmetric board from either end.
    if ((found->front() - truth.front()).norm() > (found->front() - truth.back()).norm()) {
      std::reverse(truth.begin(), truth.end());
    }
    for (size_t i = 0; i < truth.size(); ++i) EXPECT_LT(((*found)[i] - truth[i]).norm(), 0.3) << distance << " " << i;
  }
}

TEST(CameraCalibration, BoardNotFoundNamesTheImage) {
  GrayImage blank{640, 480, std::vector<std::uint8_t>(640 * 480, 128)};
  EXPECT_FALSE(detectCheckerboard(blank, kBoard).has_value());
  try {
    detectCheckerboardOrThrow(blank, kBoard, "img_007.png");
    ADD_FAILURE() << "blank image accepted";
  } catch (const ComputationError& e) {
    EXPECT_NE(std::string(e.what()).find("img_007.png"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not found"), std::string::npos) << e.what();
  }
  // Board half out of the image.
  const GrayImage cut = renderCheckerboard(
      kBoard, kCamera, cameraTGrid(500.0, Eigen::Vector3d(0, 0.0, 0)) * Eigen::Translation3d(-500.0, 0.0, 0.0));
  EXPECT_FALSE(detectCheckerboard(cut, kBoard).has_value());
  EXPECT_THROW(readGrayImage("/nonexistent/img.png"), FileError);
}

// Exact projections (no image): calibrateCamera and solvePnP recover the camera to rounding
// (corners are passed as float to OpenCV: ~1e-4 px).
TEST(CameraCalibration, ExactCornersRecoverIntrinsicsAndPose) {
  const CheckerboardSpec big{6, 9, 25.0};
  std::vector<std::vector<Eigen::Vector2d>> views;
  const Eigen::Vector3d tilts[] = {{0.4, 0.1, 0},    {-0.4, 0.2, 0.3},  {0.1, 0.5, -0.2},
                                   {0.2, -0.5, 0.1}, {-0.3, -0.3, 0.5}, {0.5, 0.4, -0.4}};
  for (const auto& t : tilts) {
    Eigen::Isometry3d T = cameraTGrid(450.0, t);
    std::vector<Eigen::Vector3d> pts;
    for (const auto& g : idealGridCorners(big)) pts.push_back(T * g);
    views.push_back(projectPoints(pts, kCamera));
  }
  const auto cal = calibrateCamera(views, big, 1280, 720);
  EXPECT_LT(cal.rms_reprojection_px, 1e-3);
  EXPECT_NEAR(cal.intrinsics.fx, kCamera.fx, 0.05);
  EXPECT_NEAR(cal.intrinsics.cy, kCamera.cy, 0.05);
  EXPECT_NEAR(cal.intrinsics.distortion[0], kCamera.distortion[0], 1e-3);
  EXPECT_THROW(calibrateCamera({views[0]}, big, 1280, 720), InvalidArgumentError);

  const Eigen::Isometry3d T = cameraTGrid(1200.0, Eigen::Vector3d(0.2, 0.3, -0.1));
  const BoardPose pose = estimateBoardPose(trueCorners(T, kCamera), kBoard, kCamera);
  EXPECT_LT(rotationAngleBetween(pose.camera_T_grid.linear(), T.linear()), 1e-5);
  EXPECT_LT((pose.camera_T_grid.translation() - T.translation()).norm(), 0.05);
  EXPECT_LT(pose.rms_reprojection_px, 1e-3);
}

// The chain T_c^h on exact corners: every view gives the true hmd_T_camera, whichever end the
// corners are numbered from, and the retro-projection error is ~0.
TEST(CheckerboardHandEye, ExactViewsRecoverChainAndReversedOrder) {
  Eigen::Isometry3d hmd_T_camera = Eigen::Isometry3d::Identity();
  hmd_T_camera.linear() = so3Exp(Eigen::Vector3d(1.5, 0.1, -0.05));
  hmd_T_camera.translation() = Eigen::Vector3d(35, -60, 25);
  Eigen::Isometry3d tracker_T_board = Eigen::Isometry3d::Identity();
  tracker_T_board.linear() = so3Exp(Eigen::Vector3d(0.1, 2.9, -0.2));
  tracker_T_board.translation() = Eigen::Vector3d(150, -80, -1900);
  Eigen::Isometry3d board_T_grid = Eigen::Isometry3d::Identity();
  board_T_grid.translation() = Eigen::Vector3d(-60, 40, 3);
  std::vector<CheckerboardView> views;
  const Eigen::Vector3d tilts[] = {{0.2, 0.1, 0}, {-0.3, 0.2, 0.3}, {0.1, -0.4, -0.2}, {0.3, 0.3, 0.1}};
  for (int i = 0; i < 4; ++i) {
    const Eigen::Isometry3d camera_T_grid = cameraTGrid(600.0 + 250.0 * i, tilts[i]);
    CheckerboardView v;
    v.name = "view" + std::to_string(i);
    v.corners_px = trueCorners(camera_T_grid, kCamera);
    if (i % 2 == 1) std::reverse(v.corners_px.begin(), v.corners_px.end());
    v.tracker_T_board = tracker_T_board;
    v.tracker_T_hmd = tracker_T_board * board_T_grid * camera_T_grid.inverse() * hmd_T_camera.inverse();
    views.push_back(v);
  }
  const auto r = calibrateCheckerboardHandEye(views, board_T_grid, kBoard, kCamera);
  EXPECT_LT(rotationAngleBetween(r.hmd_T_camera.linear(), hmd_T_camera.linear()), 1e-5);
  EXPECT_LT((r.hmd_T_camera.translation() - hmd_T_camera.translation()).norm(), 0.1);
  EXPECT_EQ(r.corners_reversed, (std::vector<bool>{false, true, false, true}));
  for (const auto& axis : r.dispersion.axes) EXPECT_LT(axis.circular_variance, 1e-10);
  const auto rpee = retroProjectionError(views, r.hmd_T_camera, board_T_grid, kBoard, kCamera, r.corners_reversed);
  EXPECT_EQ(rpee.corner_error_mm.size(), 60u);
  EXPECT_LT(rpee.mean_px, 0.01);
  EXPECT_LT(rpee.mean_mm, 0.01);
  // A wrong calibration shows: 2 mm off along x moves every corner by ~2 mm at the board.
  Eigen::Isometry3d off = r.hmd_T_camera;
  off.translation().x() += 2.0;
  const auto bad = retroProjectionError(views, off, board_T_grid, kBoard, kCamera, r.corners_reversed);
  EXPECT_GT(bad.mean_mm, 1.0);
  EXPECT_LT(bad.mean_mm, 2.5);
  EXPECT_THROW(calibrateCheckerboardHandEye({views[0], views[1]}, board_T_grid, kBoard, kCamera), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::hmd
