// Offscreen snapshots: the PNG has the asked size and the objects show up in
// their expected colours in their expected regions (not pixel-exact: Mesa
// versions shade differently). Run under xvfb-run -a.
#include <gtest/gtest.h>

#include <filesystem>

#include "mrsns/core/error.h"
#include "mrsns/rendering/scene.h"
#include "mrsns/rendering/tool_models.h"
#include "png_image.h"
#include "test_data.h"

using namespace mrsns;
using namespace mrsns::rendering;
using mrsns::test::isBluish;
using mrsns::test::isGreenish;
using mrsns::test::isReddish;

namespace {

// Camera looking from anterior (-y) at the origin, superior up: patient's
// left (+x) appears on the right of the image.
void frontCamera(Scene& scene, double distance = 300.0) {
  scene.setCamera(Eigen::Vector3d(0, -distance, 0), Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
}

}  // namespace

TEST(Snapshot, WritesAPngOfTheAskedSizeWithObjectsWhereTheyAre) {
  MRSNS_REQUIRE_DISPLAY();
  Scene scene;
  scene.setBackground(Eigen::Vector3d::Zero());
  scene.setMesh("red ball", sphereMesh(Eigen::Vector3d(-40, 0, 0), 15.0, 32, 16), Eigen::Vector3d(1, 0, 0));
  scene.setMesh("green box", boxMesh(Eigen::Vector3d(25, -15, -15), Eigen::Vector3d(55, 15, 15)),
                Eigen::Vector3d(0, 1, 0));
  frontCamera(scene);
  const auto png = mrsns::test::scratchDirectory("snapshot") / "two.png";
  snapshotPng(scene, png, 320, 200);
  ASSERT_TRUE(std::filesystem::exists(png));
  const auto image = mrsns::test::readPng(png);
  EXPECT_EQ(image.width, 320);
  EXPECT_EQ(image.height, 200);
  EXPECT_EQ(image.components, 3);
  const int w = image.width;
  const int h = image.height;
  // The ball (patient's right, -x) on the image's left, the box on its right.
  const int red_left = image.count(0, 0, w / 2, h, isReddish);
  const int red_right = image.count(w / 2, 0, w, h, isReddish);
  const int green_left = image.count(0, 0, w / 2, h, isGreenish);
  const int green_right = image.count(w / 2, 0, w, h, isGreenish);
  EXPECT_GT(red_left, 200);
  EXPECT_EQ(red_right, 0);
  EXPECT_GT(green_right, 200);
  EXPECT_EQ(green_left, 0);
  // Both at mid height: nothing coloured in the top and bottom quarters.
  EXPECT_EQ(image.count(0, 0, w, h / 5, [](auto c) { return isReddish(c) || isGreenish(c); }), 0);

  // Moving an object is a pose change: the ball crosses to the right.
  Eigen::Isometry3d move = Eigen::Isometry3d::Identity();
  move.translation() = Eigen::Vector3d(80, 0, 0);
  scene.setPose("red ball", move);
  scene.setVisible("green box", false);
  snapshotPng(scene, png, 320, 200);
  const auto moved = mrsns::test::readPng(png);
  EXPECT_EQ(moved.count(0, 0, w / 2, h, isReddish), 0);
  EXPECT_GT(moved.count(w / 2, 0, w, h, isReddish), 200);
  EXPECT_EQ(moved.count(0, 0, w, h, isGreenish), 0);
}

TEST(Snapshot, UncertaintyScalarsColourLowBlueAndHighRed) {
  MRSNS_REQUIRE_DISPLAY();
  Scene scene;
  scene.setBackground(Eigen::Vector3d::Zero());
  // A flattened ellipsoid facing the camera; low scalars on one side, high on the other.
  TriangleMesh tissue = sphereMesh(Eigen::Vector3d::Zero(), 1.0, 64, 32);
  for (Eigen::Index i = 0; i < tissue.vertexCount(); ++i) {
    tissue.vertices.row(i) =
        Eigen::RowVector3d(60.0 * tissue.vertices(i, 0), 5.0 * tissue.vertices(i, 1), 30.0 * tissue.vertices(i, 2));
  }
  tissue.normals.resize(0, 3);
  scene.setMesh("tissue", tissue, Eigen::Vector3d(1, 1, 1));
  std::vector<double> sigma(static_cast<std::size_t>(tissue.vertexCount()));
  for (Eigen::Index i = 0; i < tissue.vertexCount(); ++i) {
    sigma[static_cast<std::size_t>(i)] = tissue.vertices(i, 0) < 0.0 ? 0.2 : 1.8;
  }
  scene.setMeshScalars("tissue", sigma, 0.0, 2.0, "Posterior SD (mm)");
  frontCamera(scene);
  const auto png = mrsns::test::scratchDirectory("snapshot") / "uncertainty.png";
  snapshotPng(scene, png, 400, 240);
  const auto image = mrsns::test::readPng(png);
  const int w = image.width;
  const int h = image.height;
  // Low uncertainty on the patient's right (image left) is blue, high red;
  // the scalar bar sits at the far right (x > 0.88 w), so stop before it.
  const int right_edge = static_cast<int>(0.85 * w);
  EXPECT_GT(image.count(0, 0, w / 2, h, isBluish), 500);
  EXPECT_EQ(image.count(0, 0, w / 2 - 10, h, isReddish), 0);
  EXPECT_GT(image.count(w / 2, 0, right_edge, h, isReddish), 500);
  EXPECT_EQ(image.count(w / 2 + 10, 0, right_edge, h, isBluish), 0);
  // The scalar bar holds both ends of the table.
  const int bar_x0 = static_cast<int>(0.88 * w);
  EXPECT_GT(image.count(bar_x0, 0, w, h, isReddish), 20);
  EXPECT_GT(image.count(bar_x0, 0, w, h, isBluish), 20);
}

TEST(Snapshot, UltrasoundSliceShowsItsPixelsWhereItIsPlaced) {
  MRSNS_REQUIRE_DISPLAY();
  Scene scene;
  scene.setBackground(Eigen::Vector3d(0, 0, 0.6));
  // 64 x 48 frame, 0.5 mm pixels: the left half white, the right half black.
  ImageVolume frame;
  frame.size = {64, 48, 1};
  frame.spacing = Eigen::Vector3d(0.5, 0.5, 1.0);
  frame.pixel_type = PixelType::UInt8;
  frame.data.assign(frame.byteCount(), std::byte{0});
  for (int j = 0; j < 48; ++j)
    for (int i = 0; i < 32; ++i) frame.data[frame.linearIndex(i, j, 0)] = std::byte{255};
  // Image x along world +x, image y (down the frame, away from the probe)
  // along world -z, the plane facing the camera at -y.
  Eigen::Isometry3d world_T_image = Eigen::Isometry3d::Identity();
  world_T_image.linear() << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  world_T_image.translation() = Eigen::Vector3d(-16, 0, 12);
  scene.setUltrasoundSlice("us", frame, world_T_image);
  scene.setCamera(Eigen::Vector3d(0, -100, 0), Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
  const auto png = mrsns::test::scratchDirectory("snapshot") / "us.png";
  snapshotPng(scene, png, 300, 300);
  const auto image = mrsns::test::readPng(png);
  // The frame spans x in [-16, 16], z in [-12, 12] around the centre: bright
  // left of centre, black right of it, background blue outside.
  const int c = 150;
  EXPECT_TRUE(mrsns::test::isBright(image.rgb(c - 20, c))) << "left half of the frame should be white";
  EXPECT_TRUE(mrsns::test::isDark(image.rgb(c + 20, c))) << "right half of the frame should be black";
  EXPECT_TRUE(isBluish(image.rgb(10, 10))) << "outside the frame the background shows";

  // A new frame of the same size reuses the texture: now all black.
  std::fill(frame.data.begin(), frame.data.end(), std::byte{0});
  scene.setUltrasoundSlice("us", frame, world_T_image);
  snapshotPng(scene, png, 300, 300);
  EXPECT_TRUE(mrsns::test::isDark(mrsns::test::readPng(png).rgb(c - 20, c)));
}

TEST(Snapshot, BadSizeOrPathIsRefused) {
  MRSNS_REQUIRE_DISPLAY();
  Scene scene;
  const auto dir = mrsns::test::scratchDirectory("snapshot");
  EXPECT_THROW(snapshotPng(scene, dir / "x.png", 0, 100), InvalidArgumentError);
  EXPECT_THROW(snapshotPng(scene, dir / "x.png", 100, 100000), InvalidArgumentError);
  EXPECT_THROW(snapshotPng(scene, dir / "no such folder" / "x.png", 100, 100), FileError);
}

TEST(Snapshot, ManySnapshotsInOneProcess) {
  // The trial report and the GUI take many snapshots in one process: each
  // must release its window and X connection.
  MRSNS_REQUIRE_DISPLAY();
  Scene scene;
  scene.setMesh("ball", sphereMesh(Eigen::Vector3d::Zero(), 10.0), Eigen::Vector3d(1, 0, 0));
  scene.resetCamera();
  const auto dir = mrsns::test::scratchDirectory("snapshot");
  for (int i = 0; i < 12; ++i) {
    snapshotPng(scene, dir / "many.png", 64, 48);
    ASSERT_GT(mrsns::test::readPng(dir / "many.png").count(0, 0, 64, 48, isReddish), 100) << "snapshot " << i;
  }
}
