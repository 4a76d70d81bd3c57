// Fiducial screws found in meshes: synthetic titanium screws (a shaft and a
// wider head, as closed cylinders) inserted into a vertebra-like bone
// surface at known points with known axes.
#include <gtest/gtest.h>

#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/registration/fiducials_from_mesh.h"
#include "surface_fixtures.h"

namespace mrsns::registration {
namespace {

using test::Screw;
using test::screwMesh;

struct Phantom {
  TriangleMesh bone = test::vertebraLikeMesh(91, 120);
  std::vector<Screw> screws;
  TriangleMesh screw_mesh;
};

const Phantom& phantom() {
  static const Phantom p = [] {
    Phantom ph;
    const MeshLocator bone(ph.bone);
    const auto normals = faceNormals(ph.bone);
    std::mt19937_64 rng(31);
    std::normal_distribution<double> g(0.0, 1.0);
    const Eigen::Vector3d directions[8] = {{1, 0, 0.2},   {-1, 0.1, 0},  {0, 1, 0.3},      {0.2, -1, -0.4},
                                           {0.3, 0.2, 1}, {-0.2, 0, -1}, {0.7, 0.7, -0.5}, {-0.6, -0.6, 0.6}};
    std::vector<TriangleMesh> meshes;
    for (const auto& d : directions) {
      const auto hits = bone.intersectRay(Eigen::Vector3d::Zero(), d.normalized());
      Screw s;
      s.entry = hits.back().point;
      // Screws are not placed exactly along the normal: tilt by ~10 degrees.
      const Eigen::Vector3d n = normals.row(hits.back().face).transpose();
      const Eigen::Vector3d tilt = Eigen::Vector3d(g(rng), g(rng), g(rng)).cross(n).normalized();
      s.axis = (n + std::tan(10.0 * test::kDegree) * tilt).normalized();
      ph.screws.push_back(s);
      meshes.push_back(screwMesh(s));
    }
    ph.screw_mesh = mergeMeshes(meshes);
    return ph;
  }();
  return p;
}

TEST(FiducialsFromMesh, EightScrewsAreFoundWithinHalfAMillimetreOfTheirEntryPoints) {
  const auto& ph = phantom();
  const auto result = findFiducialsFromMeshes(ph.screw_mesh, ph.bone, 8);
  ASSERT_EQ(result.fiducials.size(), 8u);
  std::vector<bool> matched(8, false);
  for (const auto& f : result.fiducials) {
    // Each detection matches exactly one screw.
    int best = -1;
    double best_d = 1e9;
    for (int k = 0; k < 8; ++k) {
      const double d = (f.position - ph.screws[static_cast<std::size_t>(k)].entry).norm();
      if (d < best_d) {
        best_d = d;
        best = k;
      }
    }
    ASSERT_GE(best, 0);
    EXPECT_FALSE(matched[static_cast<std::size_t>(best)]) << "screw " << best << " found twice";
    matched[static_cast<std::size_t>(best)] = true;
    EXPECT_LT(best_d, 0.5) << f.label;
    EXPECT_TRUE(f.axis_hits_bone) << f.label;
    // Axis orientation: out of the bone, towards the head.
    EXPECT_GT(f.axis.dot(ph.screws[static_cast<std::size_t>(best)].axis), std::cos(1.0 * test::kDegree));
    EXPECT_GT(f.elongation, 1.5);
    EXPECT_NEAR(f.size_balance, 1.0, 1e-9);  // identical screws: equal clusters
    EXPECT_GT(f.confidence, 0.5);
  }
}

TEST(FiducialsFromMesh, LandmarkSetCarriesLabelsAndConfidence) {
  const auto& ph = phantom();
  const auto result = findFiducialsFromMeshes(ph.screw_mesh, ph.bone, 8);
  const auto set = fiducialLandmarks(result, "CT");
  ASSERT_EQ(set.size(), 8u);
  EXPECT_EQ(set.frame, "CT");
  EXPECT_EQ(set.points[0].label, "F-1");
  EXPECT_NE(set.points[0].description.find("confidence="), std::string::npos);
  EXPECT_TRUE(set.points[3].position.isApprox(result.fiducials[3].position));
}

TEST(FiducialsFromMesh, ScrewAwayFromTheBoneFallsBackToItsHeadWithLowConfidence) {
  const auto& ph = phantom();
  // A loose screw 100 mm from the bone, axis parallel to z: the axis misses the bone.
  Screw loose{Eigen::Vector3d(100, 0, 0), Eigen::Vector3d::UnitZ()};
  const TriangleMesh meshes[2] = {screwMesh(ph.screws[0]), screwMesh(loose)};
  const auto result = findFiducialsFromMeshes(mergeMeshes(meshes), ph.bone, 2);
  ASSERT_EQ(result.fiducials.size(), 2u);
  // Clusters are ordered by x: the loose screw (x = 100) is last.
  const auto& f = result.fiducials[1];
  EXPECT_FALSE(f.axis_hits_bone);
  // The head end is the end farther from the bone; both ends are outside, so
  // the result is one of the two cluster ends along z.
  EXPECT_NEAR(f.position.x(), 100.0, 1e-6);
  EXPECT_NEAR(std::abs(f.position.z()), f.position.z() > 0 ? 5.0 : 8.0, 1e-6);
  EXPECT_LT(f.confidence, result.fiducials[0].confidence);
  EXPECT_TRUE(result.fiducials[0].axis_hits_bone);
}

TEST(KMeans, SeparatesWellSeparatedBlobsAndIsDeterministic) {
  std::mt19937_64 rng(4);
  std::normal_distribution<double> g(0.0, 1.0);
  const Eigen::Vector3d centres[3] = {{-30, 0, 0}, {0, 25, 5}, {40, -10, 0}};
  PointsN3 x(300, 3);
  for (int i = 0; i < 300; ++i) x.row(i) = (centres[i % 3] + Eigen::Vector3d(g(rng), g(rng), g(rng))).transpose();
  const auto a = kMeans(x, 3);
  const auto b = kMeans(x, 3);
  EXPECT_EQ(a.labels, b.labels);
  EXPECT_EQ(a.sizes, (std::vector<int>{100, 100, 100}));
  // Ordered by x: cluster 0 is the blob at x = -30, and so on.
  for (int i = 0; i < 300; ++i) EXPECT_EQ(a.labels[static_cast<std::size_t>(i)], i % 3 == 0 ? 0 : (i % 3 == 1 ? 1 : 2));
  // Within-cluster scatter of unit Gaussians: inertia ~ 3 * 300 (chi-square, 900 dof: +-15%).
  EXPECT_NEAR(a.inertia, 900.0, 135.0);
}

TEST(FiducialsBadInput, CountLargerThanTheVertexCountIsRefused) {
  const auto& ph = phantom();
  EXPECT_THROW(findFiducialsFromMeshes(ph.screw_mesh, ph.bone, static_cast<int>(ph.screw_mesh.vertexCount()) + 1),
               InvalidArgumentError);
  EXPECT_THROW(findFiducialsFromMeshes(ph.screw_mesh, ph.bone, 0), InvalidArgumentError);
  EXPECT_THROW(kMeans(PointsN3::Zero(2, 3), 3), InvalidArgumentError);
}

TEST(FiducialsBadInput, EmptyMeshesAreRefused) {
  const auto& ph = phantom();
  TriangleMesh empty;
  EXPECT_THROW(findFiducialsFromMeshes(empty, ph.bone, 1), InvalidArgumentError);
  EXPECT_THROW(findFiducialsFromMeshes(ph.screw_mesh, empty, 1), InvalidArgumentError);
  PointsN3 nan = PointsN3::Zero(5, 3);
  nan(2, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(kMeans(nan, 2), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::registration
