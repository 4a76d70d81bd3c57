// CT slice views: planes through the cursor in the radiological layout, for
// straight and rotated volume directions; the ultrasound frame's cut of each
// plane (exact geometry); tool and frame overlays; window/level.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/rendering/slice_views.h"
#include "png_image.h"
#include "test_data.h"

using namespace mrsns;
using namespace mrsns::rendering;

namespace {

const Eigen::Vector3d kCentre(10.0, -20.0, 30.0);

// 81^3 voxels of 1 mm around kCentre: soft tissue (40 HU) with three bone
// cubes (1000 HU, 12 mm): A 20 mm to the patient's left (+x), B 20 mm
// anterior (-y), C 25 mm superior (+z). Filled by physical position so any
// direction matrix gives the same anatomy.
ImageVolume phantomCt(const Eigen::Matrix3d& direction) {
  ImageVolume ct;
  ct.size = {81, 81, 81};
  ct.spacing = Eigen::Vector3d::Ones();
  ct.direction = direction;
  ct.origin = kCentre - direction * Eigen::Vector3d(40, 40, 40);
  ct.pixel_type = PixelType::Int16;
  ct.data.resize(ct.byteCount());
  const Eigen::Vector3d cubes[3] = {kCentre + Eigen::Vector3d(20, 0, 0), kCentre + Eigen::Vector3d(0, -20, 0),
                                    kCentre + Eigen::Vector3d(0, 0, 25)};
  for (int k = 0; k < 81; ++k)
    for (int j = 0; j < 81; ++j)
      for (int i = 0; i < 81; ++i) {
        const Eigen::Vector3d p = ct.indexToPhysical(Eigen::Vector3d(i, j, k));
        std::int16_t v = 40;
        for (const auto& c : cubes) {
          if (((p - c).cwiseAbs().array() <= 6.0).all()) v = 1000;
        }
        std::memcpy(ct.data.data() + ct.linearIndex(i, j, k) * 2, &v, 2);
      }
  return ct;
}

}  // namespace

TEST(SliceViews, UltrasoundFrameCutsEachPlaneWhereGeometrySays) {
  SliceViews views;
  views.setVolume(phantomCt(Eigen::Matrix3d::Identity()));
  EXPECT_TRUE(views.cursor().isApprox(kCentre));
  // A 100 x 80 frame of 0.4 mm pixels in the sagittal plane x = centre + 5:
  // image x along +y (anterior to posterior), image y along -z (downwards).
  ImageVolume frame;
  frame.size = {100, 80, 1};
  frame.spacing = Eigen::Vector3d(0.4, 0.4, 1.0);
  frame.data.resize(frame.byteCount());
  Eigen::Isometry3d ct_T_image = Eigen::Isometry3d::Identity();
  ct_T_image.linear() << 0, 0, 1, 1, 0, 0, 0, -1, 0;
  ct_T_image.translation() = kCentre + Eigen::Vector3d(5, -20, 16);
  views.setUltrasoundFrame(frame, ct_T_image);
  // The frame covers pixels -0.5 .. n-0.5: y from centre-20.2 to -20 + 39.8,
  // z from centre+16.2 down to 16 - 31.8.
  Eigen::Vector3d a;
  Eigen::Vector3d b;
  ASSERT_TRUE(views.ultrasoundIntersection(SliceOrientation::Axial, a, b));
  EXPECT_NEAR(a.x(), kCentre.x() + 5, 1e-9);
  EXPECT_NEAR(b.x(), kCentre.x() + 5, 1e-9);
  EXPECT_NEAR(a.z(), kCentre.z(), 1e-9);
  EXPECT_NEAR(std::min(a.y(), b.y()), kCentre.y() - 20.2, 1e-9);
  EXPECT_NEAR(std::max(a.y(), b.y()), kCentre.y() + 19.8, 1e-9);
  ASSERT_TRUE(views.ultrasoundIntersection(SliceOrientation::Coronal, a, b));
  EXPECT_NEAR(a.y(), kCentre.y(), 1e-9);
  EXPECT_NEAR(std::min(a.z(), b.z()), kCentre.z() - 15.8, 1e-9);
  EXPECT_NEAR(std::max(a.z(), b.z()), kCentre.z() + 16.2, 1e-9);
  // Parallel to the sagittal plane and 5 mm off it: no cut.
  EXPECT_FALSE(views.ultrasoundIntersection(SliceOrientation::Sagittal, a, b));
  // Move the cursor above the frame: the axial plane misses it too.
  views.setCursor(kCentre + Eigen::Vector3d(0, 0, 20));
  EXPECT_FALSE(views.ultrasoundIntersection(SliceOrientation::Axial, a, b));
  views.clearUltrasoundFrame();
  EXPECT_FALSE(views.ultrasoundIntersection(SliceOrientation::Coronal, a, b));
}

TEST(SliceViews, BadInputIsRefused) {
  SliceViews views;
  EXPECT_THROW(views.setVolume(ImageVolume{}), InvalidArgumentError);
  ImageVolume wrong = phantomCt(Eigen::Matrix3d::Identity());
  wrong.data.resize(10);
  EXPECT_THROW(views.setVolume(wrong), InvalidArgumentError);
  EXPECT_THROW(views.setWindowLevel(0.0, 40.0), InvalidArgumentError);
  EXPECT_THROW(views.setWindowLevel(400.0, std::nan("")), InvalidArgumentError);
  EXPECT_THROW(views.setTool(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 50.0), InvalidArgumentError);
  EXPECT_THROW(views.setCursor(Eigen::Vector3d(std::nan(""), 0, 0)), InvalidArgumentError);
}

// Radiological layout, checked in each 200 x 200 panel around its centre:
// 81 mm across the vertical gives 100 / (1.05 * 40) = 2.38 px/mm, so a cube
// 20 mm off the cursor is centred 48 px off the panel centre, 14 px wide.
TEST(SliceViews, PlanesShowTheAnatomyInTheRadiologicalLayoutForAnyDirectionMatrix) {
  MRSNS_REQUIRE_DISPLAY();
  const double quarter = std::numbers::pi / 2.0;
  const Eigen::Matrix3d rotated =
      (Eigen::AngleAxisd(quarter, Eigen::Vector3d::UnitZ()) * Eigen::AngleAxisd(quarter, Eigen::Vector3d::UnitX()))
          .toRotationMatrix();
  const std::vector<Eigen::Matrix3d> directions = {Eigen::Matrix3d::Identity(), rotated};
  for (const Eigen::Matrix3d& direction : directions) {
    SCOPED_TRACE(direction.isIdentity() ? "identity direction" : "rotated direction");
    SliceViews views;
    views.setVolume(phantomCt(direction));
    const auto png = mrsns::test::scratchDirectory("slices") / "views.png";
    snapshotSlicesPng(views, png, 600, 200);
    const auto image = mrsns::test::readPng(png);
    ASSERT_EQ(image.width, 600);
    ASSERT_EQ(image.height, 200);
    const int off = 48;
    auto bright = [&](int x, int y) { return mrsns::test::isBright(image.rgb(x, y)); };
    auto grey = [&](int x, int y) {
      const auto c = image.rgb(x, y);
      return c[0] > 60 && c[0] < 200 && std::abs(c[0] - c[1]) < 10;
    };
    // Axial (0..200): left cube A right of centre, anterior cube B above it.
    EXPECT_TRUE(bright(100 + off, 100)) << "axial: A (patient's left) on the right";
    EXPECT_TRUE(grey(100 - off, 100));
    EXPECT_TRUE(bright(100, 100 - off)) << "axial: B (anterior) at the top";
    EXPECT_TRUE(grey(100, 100 + off));
    // Sagittal (200..400): anterior B on the left, superior C on top.
    EXPECT_TRUE(bright(300 - off, 100)) << "sagittal: B (anterior) on the left";
    EXPECT_TRUE(grey(300 + off, 100));
    EXPECT_TRUE(bright(300, 100 - 60)) << "sagittal: C (superior) at the top";
    // Coronal (400..600): left A on the right, superior C on top.
    EXPECT_TRUE(bright(500 + off, 100)) << "coronal: A (patient's left) on the right";
    EXPECT_TRUE(grey(500 - off, 100));
    EXPECT_TRUE(bright(500, 100 - 60)) << "coronal: C (superior) at the top";
    EXPECT_TRUE(grey(500, 100 + 60));
  }
}

TEST(SliceViews, WindowLevelToolAndFrameOverlaysShow) {
  MRSNS_REQUIRE_DISPLAY();
  SliceViews views;
  views.setVolume(phantomCt(Eigen::Matrix3d::Identity()));
  const auto dir = mrsns::test::scratchDirectory("slices");
  // A bone window above every value: the whole image black.
  views.setWindowLevel(10.0, 3000.0);
  snapshotSlicesPng(views, dir / "dark.png", 600, 200);
  const auto dark = mrsns::test::readPng(dir / "dark.png");
  EXPECT_EQ(dark.count(0, 0, 600, 200, [](auto c) { return !mrsns::test::isDark(c); }), 0);
  EXPECT_EQ(views.windowLevel(), Eigen::Vector2d(10.0, 3000.0));
  // The crosshair on that black: each view shows the other two planes through the cursor, and nothing else.
  views.setCrosshairVisible(true);
  snapshotSlicesPng(views, dir / "crosshair.png", 600, 200);
  const auto crosshair = mrsns::test::readPng(dir / "crosshair.png");
  for (int panel = 0; panel < 3; ++panel) {
    const int cx = 200 * panel + 100;
    const auto lit = [](auto c) { return !mrsns::test::isDark(c); };
    EXPECT_GT(crosshair.count(cx - 2, 20, cx + 3, 80, lit), 20) << "vertical line, panel " << panel;
    EXPECT_GT(crosshair.count(cx - 80, 98, cx - 20, 103, lit), 20) << "horizontal line, panel " << panel;
    EXPECT_EQ(crosshair.count(cx - 80, 20, cx - 20, 80, lit), 0) << "nothing beside the lines, panel " << panel;
  }
  views.setCrosshairVisible(false);

  views.setWindowLevel(400.0, 40.0);
  // Tool tip at the centre pointing superior-left; the cursor follows it.
  views.setTool(kCentre, Eigen::Vector3d(1, 0, 1).normalized(), 30.0);
  ImageVolume frame;
  frame.size = {100, 80, 1};
  frame.spacing = Eigen::Vector3d(0.4, 0.4, 1.0);
  frame.data.resize(frame.byteCount());
  Eigen::Isometry3d ct_T_image = Eigen::Isometry3d::Identity();
  ct_T_image.linear() << 0, 0, 1, 1, 0, 0, 0, -1, 0;
  ct_T_image.translation() = kCentre + Eigen::Vector3d(5, -20, 16);
  views.setUltrasoundFrame(frame, ct_T_image);
  snapshotSlicesPng(views, dir / "overlays.png", 600, 200);
  const auto image = mrsns::test::readPng(dir / "overlays.png");
  auto yellow = [](std::array<int, 3> c) { return c[0] > 150 && c[1] > 120 && c[2] < 80; };
  for (int panel = 0; panel < 3; ++panel) {
    const int x0 = 200 * panel;
    EXPECT_GT(image.count(x0, 0, x0 + 200, 200, mrsns::test::isGreenish), 20) << "tool overlay in panel " << panel;
    // The frame stands in a sagittal plane: a yellow line in axial and coronal only.
    const int frame_pixels = image.count(x0, 0, x0 + 200, 200, yellow);
    if (panel == 1) {
      EXPECT_EQ(frame_pixels, 0);
    } else {
      EXPECT_GT(frame_pixels, 40) << "frame overlay in panel " << panel;
    }
  }
}
