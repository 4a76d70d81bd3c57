#include <gtest/gtest.h>

#include <cmath>

#include "mesh_fixtures.h"
#include "mrsns/core/error.h"
#include "mrsns/core/surface_distance.h"

namespace mrsns {
namespace {

TEST(SurfaceDistance, MeshToItselfIsZero) {
  const TriangleMesh mesh = test::icosphere(8.0, 3);
  const SymmetricSurfaceDistance d = surfaceDistance(mesh, mesh);
  EXPECT_EQ(d.hausdorff, 0.0);
  EXPECT_EQ(d.mean, 0.0);
  EXPECT_EQ(d.a_to_b.rms, 0.0);
  EXPECT_EQ(d.a_to_b.distances.size(), mesh.vertexCount());
}

TEST(SurfaceDistance, TranslatedPlaneAlongNormalGivesTheTranslation) {
  const TriangleMesh plane = test::planeGrid(20.0, 8);
  Eigen::Isometry3d shift = Eigen::Isometry3d::Identity();
  shift.translation() = Eigen::Vector3d(0, 0, 0.25);
  const TriangleMesh moved = transformMesh(plane, shift);
  const SymmetricSurfaceDistance d = surfaceDistance(plane, moved);
  EXPECT_NEAR(d.hausdorff, 0.25, 1e-12);
  EXPECT_NEAR(d.a_to_b.mean, 0.25, 1e-12);
  EXPECT_NEAR(d.b_to_a.rms, 0.25, 1e-12);
  EXPECT_NEAR(d.mean, 0.25, 1e-12);
}

TEST(SurfaceDistance, ConcentricSpheresBoundedByRadiiAndTessellation) {
  const TriangleMesh inner = test::icosphere(10.0, 3);
  const TriangleMesh outer = test::icosphere(12.0, 3);
  const double inner_in = test::inradius(inner);
  const SurfaceDistanceResult out_to_in = pointsToSurfaceDistance(outer.vertices, inner);
  // Outer vertices at radius 12; the inner surface lies between radii inner_in and 10.
  EXPECT_GE(out_to_in.distances.minCoeff(), 2.0 - 1e-9);
  EXPECT_LE(out_to_in.max, 12.0 - inner_in + 1e-9);
  EXPECT_NEAR(out_to_in.distances(out_to_in.max_index), out_to_in.max, 0.0);
  EXPECT_LE(out_to_in.mean, out_to_in.rms + 1e-15);
  EXPECT_LE(out_to_in.rms, out_to_in.max + 1e-15);
  const SymmetricSurfaceDistance sym = surfaceDistance(inner, outer);
  EXPECT_GE(sym.hausdorff, 2.0 - 1e-9);
  EXPECT_EQ(sym.hausdorff, std::max(sym.a_to_b.max, sym.b_to_a.max));
}

TEST(SurfaceDistance, ExplicitPointsAndInvalidInput) {
  const MeshLocator box(test::box(Eigen::Vector3d(2, 2, 2)));
  PointsN3 points(3, 3);
  points << 1, 1, 3,  // 1 above the top face
      1, 1, 1,        // centre: 1 from every face
      4, 1, 1;        // 2 beyond the +x face
  const SurfaceDistanceResult r = pointsToSurfaceDistance(points, box);
  EXPECT_NEAR(r.distances(0), 1.0, 1e-12);
  EXPECT_NEAR(r.distances(1), 1.0, 1e-12);
  EXPECT_NEAR(r.distances(2), 2.0, 1e-12);
  EXPECT_EQ(r.max_index, 2);
  EXPECT_NEAR(r.mean, 4.0 / 3.0, 1e-12);
  EXPECT_NEAR(r.rms, std::sqrt(6.0 / 3.0), 1e-12);
  EXPECT_THROW((void)pointsToSurfaceDistance(PointsN3(0, 3), box), InvalidArgumentError);

  TriangleMesh a = test::box(Eigen::Vector3d(1, 1, 1));
  TriangleMesh b = a;
  a.frame = "CT";
  b.frame = "Reference";
  EXPECT_THROW((void)surfaceDistance(a, b), FrameError);
}

}  // namespace
}  // namespace mrsns
