#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "mesh_fixtures.h"
#include "mrsns/core/error.h"
#include "mrsns/core/mesh_locator.h"

namespace mrsns {
namespace {

Eigen::Vector3d randomPoint(std::mt19937& rng, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  return lo + Eigen::Vector3d(u(rng), u(rng), u(rng)).cwiseProduct(hi - lo);
}

// Exact signed distance to the axis-aligned box [lo, hi].
double boxSignedDistance(const Eigen::Vector3d& q, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  const Eigen::Vector3d outside = (lo - q).cwiseMax(q - hi).cwiseMax(0.0);
  if (outside.squaredNorm() > 0.0) return outside.norm();
  return -std::min((q - lo).minCoeff(), (hi - q).minCoeff());
}

void expectMatchesBruteForce(const TriangleMesh& mesh, int queries, unsigned seed) {
  const MeshLocator locator(mesh);
  std::mt19937 rng(seed);
  const Eigen::Vector3d lo = mesh.vertices.colwise().minCoeff().transpose();
  const Eigen::Vector3d hi = mesh.vertices.colwise().maxCoeff().transpose();
  const Eigen::Vector3d margin = 0.5 * (hi - lo);
  for (int i = 0; i < queries; ++i) {
    const Eigen::Vector3d q = randomPoint(rng, lo - margin, hi + margin);
    const SurfacePoint fast = locator.closestPoint(q);
    const SurfacePoint slow = locator.closestPointBruteForce(q);
    ASSERT_NEAR(fast.distance, slow.distance, 1e-9) << mesh.name << " query " << q.transpose();
    EXPECT_NEAR((fast.point - q).norm(), fast.distance, 1e-12);
    ASSERT_GE(fast.face, 0);
    // The barycentric weights reproduce the point on the reported face.
    Eigen::Vector3d from_bary = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k)
      from_bary += fast.barycentric[k] * mesh.vertices.row(mesh.faces(fast.face, k)).transpose();
    EXPECT_LT((from_bary - fast.point).norm(), 1e-9);
    EXPECT_GE(fast.barycentric.minCoeff(), -1e-12);
    EXPECT_NEAR(fast.barycentric.sum(), 1.0, 1e-12);
  }
}

TEST(MeshLocator, ClosestPointMatchesBruteForceOnSphereBoxAndTube) {
  expectMatchesBruteForce(test::icosphere(10.0, 3, Eigen::Vector3d(5, -2, 1)), 400, 1);
  expectMatchesBruteForce(test::box(Eigen::Vector3d(4, 8, 16), 5), 400, 2);
  expectMatchesBruteForce(test::cylinder(3.0, 20.0, 32, 10, false), 400, 3);
  expectMatchesBruteForce(test::planeGrid(50.0, 10), 200, 4);
}

TEST(MeshLocator, ClosestPointOnTriangleRegions) {
  const Eigen::Vector3d a(0, 0, 0), b(2, 0, 0), c(0, 2, 0);
  Eigen::Vector3d w;
  // Interior: projection onto the plane.
  EXPECT_TRUE(closestPointOnTriangle({0.5, 0.5, 3}, a, b, c, &w).isApprox(Eigen::Vector3d(0.5, 0.5, 0)));
  EXPECT_TRUE(w.isApprox(Eigen::Vector3d(0.5, 0.25, 0.25)));
  // Vertex regions return exact unit weights.
  EXPECT_EQ(closestPointOnTriangle({-1, -1, 1}, a, b, c, &w), a);
  EXPECT_EQ(w, Eigen::Vector3d(1, 0, 0));
  EXPECT_EQ(closestPointOnTriangle({5, -1, 0}, a, b, c, &w), b);
  EXPECT_EQ(w, Eigen::Vector3d(0, 1, 0));
  // Edge region (b-c): exact zero on the opposite corner's weight.
  EXPECT_TRUE(closestPointOnTriangle({2, 2, 0}, a, b, c, &w).isApprox(Eigen::Vector3d(1, 1, 0)));
  EXPECT_EQ(w[0], 0.0);
  // A degenerate (collinear) triangle falls back to its edges.
  const Eigen::Vector3d p = closestPointOnTriangle({1, 1, 0}, a, b, Eigen::Vector3d(4, 0, 0), &w);
  EXPECT_TRUE(p.allFinite());
  EXPECT_TRUE(p.isApprox(Eigen::Vector3d(1, 0, 0)));
}

TEST(MeshLocator, SignedDistanceToBoxIsExact) {
  const Eigen::Vector3d lo(-3, 1, 2);
  const Eigen::Vector3d size(6, 4, 10);
  const TriangleMesh mesh = test::box(size, 3, lo);
  const MeshLocator locator(mesh);
  ASSERT_TRUE(locator.closed());
  std::mt19937 rng(21);
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Vector3d q = randomPoint(rng, lo - size, lo + 2 * size);
    EXPECT_NEAR(locator.signedClosestPoint(q).signed_distance, boxSignedDistance(q, lo, lo + size), 1e-9)
        << q.transpose();
  }
  // Corner (vertex pseudo-normal) and edge (edge pseudo-normal) regions, outside and inside.
  const Eigen::Vector3d hi = lo + size;
  EXPECT_NEAR(locator.signedClosestPoint(hi + Eigen::Vector3d(0.5, 0.5, 0.5)).signed_distance, std::sqrt(0.75), 1e-12);
  EXPECT_NEAR(locator.signedClosestPoint(hi + Eigen::Vector3d(0.3, 0.4, -5)).signed_distance, 0.5, 1e-12);
  EXPECT_NEAR(locator.signedClosestPoint(hi - Eigen::Vector3d(0.1, 0.1, 0.1)).signed_distance, -0.1, 1e-12);
  EXPECT_NEAR(locator.signedClosestPoint(lo + Eigen::Vector3d(1e-3, 2, 5)).signed_distance, -1e-3, 1e-12);
}

TEST(MeshLocator, SignedDistanceToSphereWithinTessellationBounds) {
  const double r = 20.0;
  const TriangleMesh mesh = test::icosphere(r, 4);
  const double r_in = test::inradius(mesh);
  const MeshLocator locator(mesh);
  std::mt19937 rng(5);
  std::normal_distribution<double> g;
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector3d dir = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    const double rho = 2.0 * r * (i + 0.5) / 500.0;
    const double sd = locator.signedClosestPoint(rho * dir).signed_distance;
    // The surface lies between the spheres of radius r_in and r.
    EXPECT_GE(sd, rho - r - 1e-9) << rho;
    EXPECT_LE(sd, rho - r_in + 1e-9) << rho;
    if (rho < r_in) {
      EXPECT_LT(sd, 0.0);
    }
    if (rho > r) {
      EXPECT_GT(sd, 0.0);
    }
  }
}

TEST(MeshLocator, SignOnNonConvexMeshAgreesWithRayParity) {
  // A bumpy sphere: alternate vertices pulled in, so it has concave edges and
  // vertices where a plain face normal gives the wrong sign.
  TriangleMesh mesh = test::icosphere(10.0, 2);
  for (Eigen::Index v = 0; v < mesh.vertexCount(); v += 2) mesh.vertices.row(v) *= 0.6;
  const MeshLocator locator(mesh);
  ASSERT_TRUE(locator.closed());
  std::mt19937 rng(17);
  std::normal_distribution<double> g;
  int inside_count = 0;
  for (int i = 0; i < 3000; ++i) {
    // Near a random vertex, where closest points fall on vertices and edges.
    const Eigen::Index v = std::uniform_int_distribution<Eigen::Index>(0, mesh.vertexCount() - 1)(rng);
    const Eigen::Vector3d q = mesh.vertices.row(v).transpose() + 0.8 * Eigen::Vector3d(g(rng), g(rng), g(rng));
    const SignedSurfacePoint sp = locator.signedClosestPoint(q);
    if (sp.distance < 1e-6) continue;
    // Independent inside test: a ray from an inside point crosses the surface an odd number of times.
    const auto hits = locator.intersectRay(q, Eigen::Vector3d(g(rng), g(rng), g(rng)));
    const bool inside = hits.size() % 2 == 1;
    inside_count += inside ? 1 : 0;
    EXPECT_EQ(sp.signed_distance < 0.0, inside) << q.transpose() << " sd " << sp.signed_distance;
    EXPECT_NEAR(std::abs(sp.signed_distance), sp.distance, 0.0);
  }
  EXPECT_GT(inside_count, 300);  // both sides were exercised
}

TEST(MeshLocator, SignedDistanceOnOpenMeshNeedsOptIn) {
  const MeshLocator locator(test::planeGrid(10.0, 4));
  EXPECT_FALSE(locator.closed());
  EXPECT_THROW((void)locator.signedClosestPoint(Eigen::Vector3d(1, 1, 1)), ComputationError);
  EXPECT_NEAR(locator.signedClosestPoint(Eigen::Vector3d(2.5, 5, 1.5), true).signed_distance, 1.5, 1e-12);
  EXPECT_NEAR(locator.signedClosestPoint(Eigen::Vector3d(2.5, 5, -0.5), true).signed_distance, -0.5, 1e-12);
}

TEST(MeshLocator, RayThroughSphereCentreHitsTwiceAtKnownParameters) {
  const double r = 10.0;
  const Eigen::Vector3d c(1, 2, 3);
  const TriangleMesh mesh = test::icosphere(r, 3, c);
  const MeshLocator locator(mesh);
  // The subdivided icosahedron has vertices at c +- r e_x: this ray passes
  // exactly through two vertices shared by 5-6 faces each.
  const auto hits = locator.intersectRay(c - Eigen::Vector3d(3 * r, 0, 0), Eigen::Vector3d(1, 0, 0));
  ASSERT_EQ(hits.size(), 2U);
  EXPECT_NEAR(hits[0].t, 2 * r, 1e-9);
  EXPECT_NEAR(hits[1].t, 4 * r, 1e-9);
  EXPECT_TRUE(hits[0].entering);
  EXPECT_FALSE(hits[1].entering);

  // Random directions through the centre: hits symmetric, between r_in and r.
  const double r_in = test::inradius(mesh, c);
  std::mt19937 rng(9);
  std::normal_distribution<double> g;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d dir = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    const auto line = locator.intersectLine(c, 2.5 * dir);  // non-unit direction: t scales
    ASSERT_EQ(line.size(), 2U) << dir.transpose();
    EXPECT_LT(line[0].t, 0.0);
    EXPECT_GT(line[1].t, 0.0);
    for (const RayHit& h : line) {
      const double rho = (h.point - c).norm();
      EXPECT_GE(rho, r_in - 1e-9);
      EXPECT_LE(rho, r + 1e-9);
      EXPECT_NEAR(std::abs(h.t) * 2.5, rho, 1e-9);
    }
    // From the centre, a ray leaves once.
    const auto ray = locator.intersectRay(c, dir);
    ASSERT_EQ(ray.size(), 1U);
    EXPECT_FALSE(ray[0].entering);
  }
}

TEST(MeshLocator, RayThroughSharedEdgesAndVerticesOfBoxIsReportedOnce) {
  const TriangleMesh mesh = test::box(Eigen::Vector3d(10, 10, 10), 5);  // lattice spacing 2
  const MeshLocator locator(mesh);
  // (y, z) = (3, 7) lies on a quad diagonal; (4, 6) on a lattice vertex; (3.3, 7.9) inside a triangle.
  for (const Eigen::Vector2d& yz : {Eigen::Vector2d(3, 7), Eigen::Vector2d(4, 6), Eigen::Vector2d(3.3, 7.9)}) {
    const auto hits = locator.intersectLine(Eigen::Vector3d(-5, yz[0], yz[1]), Eigen::Vector3d(1, 0, 0));
    ASSERT_EQ(hits.size(), 2U) << yz.transpose();
    EXPECT_NEAR(hits[0].t, 5.0, 1e-12);
    EXPECT_NEAR(hits[1].t, 15.0, 1e-12);
    EXPECT_TRUE(hits[0].entering);
    EXPECT_FALSE(hits[1].entering);
    EXPECT_TRUE(hits[1].point.isApprox(Eigen::Vector3d(10, yz[0], yz[1])));
  }
  // A screw path as a segment: only the entry lies between its ends.
  const auto entry = locator.intersectSegment(Eigen::Vector3d(5, 5, -4), Eigen::Vector3d(5, 5, 4));
  ASSERT_EQ(entry.size(), 1U);
  EXPECT_NEAR(entry[0].t, 0.5, 1e-12);
  EXPECT_TRUE(entry[0].entering);
  // Missing the box, and a ray pointing away from it.
  EXPECT_TRUE(locator.intersectLine(Eigen::Vector3d(-5, 11, 5), Eigen::Vector3d(1, 0, 0)).empty());
  EXPECT_TRUE(locator.intersectRay(Eigen::Vector3d(-5, 5, 5), Eigen::Vector3d(-1, 0, 0)).empty());
  // Diagonal through two opposite corners of the cube.
  const auto diagonal = locator.intersectLine(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1, 1, 1));
  ASSERT_EQ(diagonal.size(), 2U);
  EXPECT_NEAR(diagonal[0].t, 1.0, 1e-12);
  EXPECT_NEAR(diagonal[1].t, 11.0, 1e-12);
}

TEST(MeshLocator, LinesThroughVerticesAndEdgeMidpointsCrossTwice) {
  // The subdivided icosahedron is centrally symmetric: a line through the
  // centre and a vertex (or an edge midpoint) leaves through the antipodal
  // vertex (edge), so every hit lands on a feature shared by several faces.
  const Eigen::Vector3d c(-3, 7, 11);
  const TriangleMesh mesh = test::icosphere(15.0, 3, c);
  const MeshLocator locator(mesh);
  std::mt19937 rng(23);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Index f = std::uniform_int_distribution<Eigen::Index>(0, mesh.faceCount() - 1)(rng);
    const int k = i % 3;
    const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, k)).transpose();
    const Eigen::Vector3d b = mesh.vertices.row(mesh.faces(f, (k + 1) % 3)).transpose();
    const Eigen::Vector3d target = (i % 2 == 0) ? a : Eigen::Vector3d(0.5 * (a + b));
    const auto hits = locator.intersectLine(c, target - c);
    ASSERT_EQ(hits.size(), 2U) << "i=" << i;
    EXPECT_NEAR(hits[0].t, -1.0, 1e-9);
    EXPECT_NEAR(hits[1].t, 1.0, 1e-9);
    EXPECT_TRUE(hits[0].entering);
    EXPECT_FALSE(hits[1].entering);
  }
}

TEST(MeshLocator, ClosestPointWithinRespectsTheBound) {
  const MeshLocator locator(test::box(Eigen::Vector3d(2, 2, 2), 2));
  const Eigen::Vector3d q(1, 1, 5);  // 3 above the top face
  EXPECT_EQ(locator.closestPointWithin(q, 2.9).face, -1);
  EXPECT_TRUE(std::isinf(locator.closestPointWithin(q, 2.9).distance));
  const SurfacePoint at_bound = locator.closestPointWithin(q, 3.0);
  ASSERT_GE(at_bound.face, 0);
  EXPECT_NEAR(at_bound.distance, 3.0, 1e-15);
  EXPECT_EQ(locator.closestPointWithin(q, 10.0).distance, locator.closestPoint(q).distance);
  EXPECT_THROW((void)locator.closestPointWithin(q, -1.0), InvalidArgumentError);
}

TEST(MeshLocator, RejectsInvalidMeshesAndQueries) {
  TriangleMesh bad = test::box(Eigen::Vector3d(1, 1, 1));
  bad.faces(0, 2) = 1000;
  EXPECT_THROW(MeshLocator{bad}, InvalidArgumentError);
  TriangleMesh no_faces;
  no_faces.vertices = PointsN3::Zero(3, 3);
  EXPECT_THROW(MeshLocator{no_faces}, InvalidArgumentError);
  const MeshLocator locator(test::box(Eigen::Vector3d(1, 1, 1)));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW((void)locator.closestPoint(Eigen::Vector3d(nan, 0, 0)), InvalidArgumentError);
  EXPECT_THROW((void)locator.intersectLine(Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()), InvalidArgumentError);
}

TEST(MeshLocator, LeafSizeDoesNotChangeAnswers) {
  const TriangleMesh mesh = test::icosphere(5.0, 3);
  const MeshLocator one(mesh, {.max_leaf_faces = 1});
  const MeshLocator many(mesh, {.max_leaf_faces = 64});
  std::mt19937 rng(13);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d q = randomPoint(rng, Eigen::Vector3d::Constant(-8), Eigen::Vector3d::Constant(8));
    EXPECT_NEAR(one.closestPoint(q).distance, many.closestPoint(q).distance, 1e-12);
  }
}

// A deforming surface (the live soft tissue): the refitted locator answers exactly as a fresh one on the moved
// vertices (closest point, within-bound, signed distance), with a tree grouped for the old shape, for small
// and large deformations (an 8192-face tube: the tree's top levels were built on several threads).
TEST(MeshLocator, RefittedAnswersAsAFreshBuildOnTheMovedVertices) {
  const TriangleMesh rest = test::cylinder(3.0, 40.0, 64, 64, true);
  ASSERT_GE(rest.faceCount(), 8192);
  const MeshLocator locator(rest);
  std::mt19937 rng(5);
  for (const double amplitude : {0.3, 6.0}) {
    TriangleMesh moved = rest;
    for (Eigen::Index i = 0; i < moved.vertices.rows(); ++i) {
      const double z = moved.vertices(i, 2);
      moved.vertices(i, 0) += amplitude * std::sin(0.2 * z);  // the tube bent sideways
      moved.vertices(i, 1) += 0.5 * amplitude * std::cos(0.15 * z);
    }
    const MeshLocator refit = locator.refitted(moved.vertices);
    const MeshLocator fresh(moved);
    const Eigen::Vector3d lo = moved.vertices.colwise().minCoeff().transpose() - Eigen::Vector3d::Constant(5);
    const Eigen::Vector3d hi = moved.vertices.colwise().maxCoeff().transpose() + Eigen::Vector3d::Constant(5);
    for (int i = 0; i < 300; ++i) {
      const Eigen::Vector3d q = randomPoint(rng, lo, hi);
      const SurfacePoint a = refit.closestPoint(q), b = fresh.closestPoint(q);
      ASSERT_NEAR(a.distance, b.distance, 1e-9) << "amplitude " << amplitude << " query " << q.transpose();
      EXPECT_NEAR(a.distance, refit.closestPointBruteForce(q).distance, 1e-9);
      EXPECT_EQ(refit.closestPointWithin(q, 1.0).face >= 0, fresh.closestPointWithin(q, 1.0).face >= 0);
      EXPECT_NEAR(refit.signedClosestPoint(q).signed_distance, fresh.signedClosestPoint(q).signed_distance, 1e-9);
    }
    EXPECT_TRUE(refit.faceNormals().isApprox(fresh.faceNormals(), 1e-12));
  }
  // The original is untouched.
  EXPECT_NEAR(locator.closestPoint(Eigen::Vector3d(10, 0, 0)).distance, 7.0, 1e-9);
  EXPECT_THROW((void)locator.refitted(rest.vertices.topRows(10)), InvalidArgumentError);
  PointsN3 bad = rest.vertices;
  bad(3, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW((void)locator.refitted(bad), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns
