// Generated tool glyphs: closed, outward, tip at the origin, volumes of the
// primitives against their analytic polygonal values.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "mrsns/core/error.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/rendering/tool_models.h"

using namespace mrsns;
using namespace mrsns::rendering;

TEST(ToolModels, CylinderIsClosedOutwardWithThePolygonVolume) {
  const int sides = 24;
  const double r = 3.0;
  const double length = 40.0;
  const TriangleMesh m = cylinderMesh(
      Eigen::Vector3d(1, 2, 3), Eigen::Vector3d(1, 2, 3) + length * Eigen::Vector3d(1, 1, 1).normalized(), r, sides);
  EXPECT_TRUE(isClosed(m));
  // A regular n-gon of circumradius r has area n r^2 sin(2 pi / n) / 2.
  const double polygon = 0.5 * sides * r * r * std::sin(2.0 * std::numbers::pi / sides);
  EXPECT_NEAR(signedVolume(m), polygon * length, 1e-9 * polygon * length);
}

TEST(ToolModels, ConeAndSphereVolumes) {
  const int sides = 32;
  const TriangleMesh cone = coneMesh(Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, 30), 0.0, 5.0, sides);
  EXPECT_TRUE(isClosed(cone));
  const double base = 0.5 * sides * 25.0 * std::sin(2.0 * std::numbers::pi / sides);
  EXPECT_NEAR(signedVolume(cone), base * 30.0 / 3.0, 1e-9 * base * 10.0);
  const TriangleMesh sphere = sphereMesh(Eigen::Vector3d(5, 5, 5), 10.0, 48, 24);
  EXPECT_TRUE(isClosed(sphere));
  // An inscribed polyhedron: a little under 4/3 pi r^3 (about 1% at 48 x 24).
  const double ball = 4.0 / 3.0 * std::numbers::pi * 1000.0;
  EXPECT_LT(signedVolume(sphere), ball);
  EXPECT_GT(signedVolume(sphere), 0.97 * ball);
}

TEST(ToolModels, BoxVolumeAndOrientation) {
  const TriangleMesh box = boxMesh(Eigen::Vector3d(-1, -2, -3), Eigen::Vector3d(1, 2, 3));
  EXPECT_TRUE(isClosed(box));
  EXPECT_NEAR(signedVolume(box), 2.0 * 4.0 * 6.0, 1e-12);
}

TEST(ToolModels, EveryToolHasItsTipAtTheOriginAndItsBodyAlongPlusZ) {
  for (ToolKind kind : {ToolKind::Stylus, ToolKind::Drill, ToolKind::EndEffector}) {
    const TriangleMesh m = toolModel(kind);
    ASSERT_FALSE(m.empty());
    validateMesh(m, "tool");
    EXPECT_EQ(m.normals.rows(), m.vertexCount());
    const Eigen::AlignedBox3d box = boundingBox(m);
    EXPECT_NEAR(box.min().z(), 0.0, 1e-12);
    EXPECT_GT(box.max().z(), 100.0);
    // Every part is closed and outward, so the whole has positive volume.
    EXPECT_GT(signedVolume(m), 0.0);
    EXPECT_TRUE(isClosed(m));
  }
  // The stylus and drill end in a point on the axis.
  for (ToolKind kind : {ToolKind::Stylus, ToolKind::Drill}) {
    const TriangleMesh m = toolModel(kind);
    double nearest = 1e9;
    for (Eigen::Index i = 0; i < m.vertexCount(); ++i) nearest = std::min(nearest, m.vertices.row(i).norm());
    EXPECT_LT(nearest, 1e-12);
  }
}

TEST(ToolModels, DegenerateInputIsRefused) {
  EXPECT_THROW((void)cylinderMesh(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 1.0), InvalidArgumentError);
  EXPECT_THROW((void)cylinderMesh(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 0.0), InvalidArgumentError);
  EXPECT_THROW((void)cylinderMesh(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), 1.0, 2), InvalidArgumentError);
  EXPECT_THROW((void)boxMesh(Eigen::Vector3d::Zero(), Eigen::Vector3d(1, 0, 1)), InvalidArgumentError);
  EXPECT_THROW((void)sphereMesh(Eigen::Vector3d::Zero(), -1.0), InvalidArgumentError);
}
