// Screw paths and their clearance to a surface, against analytic distances
// to a plane and a sphere-like surface.
#include <gtest/gtest.h>

#include "mrsns/core/error.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/registration/screw_path.h"
#include "surface_fixtures.h"

namespace mrsns::registration {
namespace {

// The square [-100, 100]^2 in the plane z = 0.
TriangleMesh planeMesh() {
  TriangleMesh m;
  m.vertices.resize(4, 3);
  m.vertices << -100, -100, 0, 100, -100, 0, 100, 100, 0, -100, 100, 0;
  m.faces.resize(2, 3);
  m.faces << 0, 1, 2, 0, 2, 3;
  return m;
}

ScrewPath path(const Eigen::Vector3d& entry, const Eigen::Vector3d& target, double diameter, double length = 0.0) {
  ScrewPath p;
  p.name = "test";
  p.vertebra = "C5";
  p.entry = entry;
  p.target = target;
  p.diameter_mm = diameter;
  p.length_mm = length;
  return p;
}

TEST(ScrewPath, DirectionLengthAndTip) {
  const auto p = path({1, 2, 3}, {1, 2, 13}, 3.5, 40.0);
  EXPECT_TRUE(p.direction().isApprox(Eigen::Vector3d::UnitZ()));
  EXPECT_DOUBLE_EQ(p.effectiveLength(), 40.0);
  EXPECT_TRUE(p.tip().isApprox(Eigen::Vector3d(1, 2, 43)));
  EXPECT_DOUBLE_EQ(path({0, 0, 0}, {3, 4, 0}, 3.5).effectiveLength(), 5.0);
}

TEST(ScrewPath, ClearanceParallelToAPlaneIsHeightMinusRadiusEverywhere) {
  const MeshLocator plane(planeMesh());
  const auto c = screwPathClearance(path({0, 0, 5}, {20, 0, 5}, 3.0), plane);
  ASSERT_EQ(c.profile.size(), 21u);  // every mm from 0 to 20
  for (std::size_t i = 0; i < c.profile.size(); ++i) {
    EXPECT_DOUBLE_EQ(c.profile[i].depth_mm, static_cast<double>(i));
    EXPECT_NEAR(c.profile[i].clearance_mm, 5.0 - 1.5, 1e-9);
  }
  EXPECT_NEAR(c.min_clearance_mm, 3.5, 1e-9);
  EXPECT_FALSE(c.cuts_surface);
  EXPECT_TRUE(c.crossings_mm.empty());
}

TEST(ScrewPath, ObliquePathIsClosestAtItsTip) {
  // Descends from z = 20 to z = 5 over 20.5 mm of length (slope known).
  const Eigen::Vector3d entry(0, 0, 20);
  const Eigen::Vector3d dir = Eigen::Vector3d(4, 0, -3).normalized();
  const auto c = screwPathClearance(path(entry, entry + 10 * dir, 2.0, 20.5), MeshLocator(planeMesh()));
  ASSERT_EQ(c.profile.size(), 22u);  // 0..20 and the tip at 20.5
  EXPECT_DOUBLE_EQ(c.profile.back().depth_mm, 20.5);
  EXPECT_NEAR(c.min_clearance_mm, 20.0 - 0.6 * 20.5 - 1.0, 1e-6);
  EXPECT_NEAR(c.min_depth_mm, 20.5, 1e-6);
  EXPECT_NEAR(c.profile[10].clearance_mm, 20.0 - 0.6 * 10 - 1.0, 1e-9);
}

TEST(ScrewPath, PathThroughTheSurfaceCutsItWhereItCrosses) {
  const auto c = screwPathClearance(path({0, 0, 10}, {0, 0, -10}, 4.0), MeshLocator(planeMesh()));
  EXPECT_TRUE(c.cuts_surface);
  ASSERT_EQ(c.crossings_mm.size(), 1u);
  EXPECT_NEAR(c.crossings_mm[0], 10.0, 1e-9);
  EXPECT_NEAR(c.min_clearance_mm, -2.0, 1e-9);
  EXPECT_NEAR(c.min_depth_mm, 10.0, 1e-6);
}

TEST(ScrewPath, MinimumBetweenSamplesIsFoundByRefinement) {
  // A path passing over a surface's extreme point between two samples: the
  // vertebra-like shape's top, approached tangentially.
  const auto mesh = test::vertebraLikeMesh(61, 80);
  const MeshLocator surface(mesh);
  const auto top = surface.intersectRay(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ()).back().point;
  const Eigen::Vector3d entry = top + Eigen::Vector3d(-10.5, 0, 3);
  const auto c = screwPathClearance(path(entry, entry + Eigen::Vector3d(21, 0, 0), 1.0), surface);
  double sampled_min = 1e9;
  for (const auto& s : c.profile) sampled_min = std::min(sampled_min, s.clearance_mm);
  EXPECT_LE(c.min_clearance_mm, sampled_min);
  // Brute-force check of the refined minimum over a 0.01 mm sampling.
  double fine = 1e9;
  for (int i = 0; i <= 2100; ++i) {
    fine = std::min(fine, surface.closestPoint(entry + Eigen::Vector3d(0.01 * i, 0, 0)).distance - 0.5);
  }
  EXPECT_NEAR(c.min_clearance_mm, fine, 1e-3);
}

TEST(ScrewPath, DescriptionRoundTrip) {
  auto p = path({1, 2, 3}, {4, 5, 6}, 3.5, 42.0);
  p.vertebra = "T12";
  const auto q = screwPathFromLine("T12 left", p.entry, p.target, screwPathDescription(p));
  EXPECT_EQ(q.name, "T12 left");
  EXPECT_EQ(q.vertebra, "T12");
  EXPECT_DOUBLE_EQ(q.diameter_mm, 3.5);
  EXPECT_DOUBLE_EQ(q.length_mm, 42.0);
  // A description written by hand in Slicer: spaces, other keys, missing length.
  const auto r = screwPathFromLine("x", p.entry, p.target, " vertebra = C3 ;diameter_mm=4; surgeon=AB");
  EXPECT_EQ(r.vertebra, "C3");
  EXPECT_DOUBLE_EQ(r.diameter_mm, 4.0);
  EXPECT_DOUBLE_EQ(r.length_mm, 0.0);
}

TEST(ScrewPathBadInput, DegenerateOrMalformedPathsAreRefused) {
  const MeshLocator plane(planeMesh());
  EXPECT_THROW(screwPathClearance(path({1, 1, 1}, {1, 1, 1}, 3.5), plane), InvalidArgumentError);
  EXPECT_THROW(screwPathClearance(path({0, 0, 1}, {0, 0, 5}, 0.0), plane), InvalidArgumentError);
  EXPECT_THROW(screwPathClearance(path({0, 0, std::nan("")}, {0, 0, 5}, 3.0), plane), InvalidArgumentError);
  ClearanceOptions o;
  o.step_mm = 0.0;
  EXPECT_THROW(screwPathClearance(path({0, 0, 1}, {0, 0, 5}, 3.0), plane, o), InvalidArgumentError);
  EXPECT_THROW(screwPathFromLine("bad", {0, 0, 0}, {0, 0, 1}, "diameter_mm=3.5mm"), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::registration
