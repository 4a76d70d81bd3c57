#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "mesh_fixtures.h"
#include "mrsns/core/error.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/core/plane_intersection.h"

namespace mrsns {
namespace {

// Signed area of a planar polygon about `normal` (positive when counter-clockwise seen from its tip).
double signedArea(const Polyline3d& line, const Eigen::Vector3d& normal) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  const auto& p = line.points;
  for (std::size_t i = 0; i < p.size(); ++i) sum += p[i].cross(p[(i + 1) % p.size()]);
  return 0.5 * sum.dot(normal.normalized());
}

TEST(PlaneIntersection, CylinderCutAcrossAxisIsOneCircle) {
  const double r = 4.0;
  const int segments = 48;
  const TriangleMesh mesh = test::cylinder(r, 30.0, segments, 6, true);
  const Eigen::Vector3d normal(0, 0, 1);
  const auto contours = intersectMeshWithPlane(mesh, Eigen::Vector3d(0, 0, 1.234), normal);
  ASSERT_EQ(contours.size(), 1U);
  const Polyline3d& c = contours[0];
  EXPECT_TRUE(c.closed);
  // Points lie on vertical edges (radius r) or diagonals (chord, radius >= r cos(pi/N)).
  const double r_min = r * std::cos(std::numbers::pi / segments);
  for (const Eigen::Vector3d& p : c.points) {
    EXPECT_NEAR(p.z(), 1.234, 1e-12);
    EXPECT_LE(p.head<2>().norm(), r + 1e-12);
    EXPECT_GE(p.head<2>().norm(), r_min - 1e-12);
  }
  EXPECT_EQ(c.points.size(), 2U * segments);  // one point per vertical and per diagonal edge
  EXPECT_GT(signedArea(c, normal), 0.0);      // counter-clockwise about the normal
  EXPECT_LE(polylineLength(c), 2 * std::numbers::pi * r);
  EXPECT_GE(polylineLength(c), 2 * segments * r_min * std::sin(std::numbers::pi / segments));
  // Flipping the normal flips the orientation.
  const auto flipped = intersectMeshWithPlane(mesh, Eigen::Vector3d(0, 0, 1.234), -normal);
  ASSERT_EQ(flipped.size(), 1U);
  EXPECT_GT(signedArea(flipped[0], -normal), 0.0);
}

TEST(PlaneIntersection, TiltedPlaneThroughCylinderIsAnEllipse) {
  const double r = 5.0;
  const int segments = 64;
  const TriangleMesh mesh = test::cylinder(r, 60.0, segments, 12, false);
  const double tilt = 0.6;  // radians between plane normal and cylinder axis
  const Eigen::Vector3d normal(std::sin(tilt), 0.0, std::cos(tilt));
  const Eigen::Vector3d origin(0, 0, 2.0);
  const auto contours = intersectMeshWithPlane(mesh, origin, normal);
  ASSERT_EQ(contours.size(), 1U);
  ASSERT_TRUE(contours[0].closed);
  const double r_min = r * std::cos(std::numbers::pi / segments);
  double major = 0.0;
  for (const Eigen::Vector3d& p : contours[0].points) {
    EXPECT_NEAR(normal.dot(p - origin), 0.0, 1e-12);  // in the plane
    EXPECT_LE(p.head<2>().norm(), r + 1e-12);         // on the cylinder
    EXPECT_GE(p.head<2>().norm(), r_min - 1e-12);
    major = std::max(major, (p - origin).norm());
  }
  // Semi-major axis r / cos(tilt) along the tilt direction; vertices at angle 0 and pi are exact.
  EXPECT_NEAR(major, r / std::cos(tilt), 1e-9);
  EXPECT_GT(signedArea(contours[0], normal), 0.0);
}

TEST(PlaneIntersection, TwoSpheresGiveTwoContoursAndAMissGivesNone) {
  std::vector<TriangleMesh> parts = {test::icosphere(3.0, 3, Eigen::Vector3d(-10, 0, 0)),
                                     test::icosphere(2.0, 3, Eigen::Vector3d(10, 0, 0))};
  const TriangleMesh both = mergeMeshes(parts);
  const auto contours = intersectMeshWithPlane(both, Eigen::Vector3d(0, 0, 0.5), Eigen::Vector3d(0, 0, 1));
  ASSERT_EQ(contours.size(), 2U);
  for (const auto& c : contours) {
    EXPECT_TRUE(c.closed);
    const Eigen::Vector3d center =
        c.points.front().x() < 0 ? Eigen::Vector3d(-10, 0, 0.5) : Eigen::Vector3d(10, 0, 0.5);
    const double sphere_r = c.points.front().x() < 0 ? 3.0 : 2.0;
    for (const auto& p : c.points) EXPECT_LE((p - center).norm(), std::sqrt(sphere_r * sphere_r - 0.25) + 1e-12);
  }
  EXPECT_TRUE(intersectMeshWithPlane(both, Eigen::Vector3d(0, 0, 3.5), Eigen::Vector3d(0, 0, 1)).empty());
  EXPECT_TRUE(intersectMeshWithPlane(both, Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0)).empty());
}

TEST(PlaneIntersection, PlaneThroughVerticesAndAlongFacesOfBox) {
  const TriangleMesh mesh = test::box(Eigen::Vector3d(4, 6, 8), 4);  // lattice planes at z = 0, 2, 4, 6, 8
  // z = 4 passes exactly through a ring of vertices and edges.
  const auto contours = intersectMeshWithPlane(mesh, Eigen::Vector3d(0, 0, 4), Eigen::Vector3d(0, 0, 1));
  ASSERT_EQ(contours.size(), 1U);
  const Polyline3d& c = contours[0];
  EXPECT_TRUE(c.closed);
  EXPECT_NEAR(polylineLength(c), 2 * (4 + 6), 1e-12);
  EXPECT_NEAR(signedArea(c, Eigen::Vector3d(0, 0, 1)), 4 * 6, 1e-12);
  for (std::size_t i = 0; i < c.points.size(); ++i) {
    EXPECT_GT((c.points[i] - c.points[(i + 1) % c.points.size()]).norm(), 1e-9);  // no duplicates
  }
  // The top face lies in the plane z = 8: the mesh touches the plane along a
  // whole face, and the contour is its rim.
  const auto top = intersectMeshWithPlane(mesh, Eigen::Vector3d(0, 0, 8), Eigen::Vector3d(0, 0, 1));
  ASSERT_EQ(top.size(), 1U);
  EXPECT_TRUE(top[0].closed);
  EXPECT_NEAR(polylineLength(top[0]), 2 * (4 + 6), 1e-12);
}

TEST(PlaneIntersection, PlanesThroughSphereVerticesGiveOneClosedContour) {
  const double r = 10.0;
  const TriangleMesh mesh = test::icosphere(r, 3);
  const double r_in = test::inradius(mesh);
  // z = 0 contains a great circle of vertices and edges of the subdivided icosahedron.
  {
    const auto contours = intersectMeshWithPlane(mesh, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, 1));
    ASSERT_EQ(contours.size(), 1U);
    EXPECT_TRUE(contours[0].closed);
    for (const auto& p : contours[0].points) {
      EXPECT_EQ(p.z(), 0.0);
      EXPECT_LE(p.norm(), r + 1e-12);
      EXPECT_GE(p.norm(), r_in - 1e-12);
    }
  }
  // Random planes through a vertex, tilted at least 30 degrees from the radial direction.
  std::mt19937 rng(31);
  std::normal_distribution<double> g;
  for (int i = 0; i < 200; ++i) {
    const Eigen::Index v = std::uniform_int_distribution<Eigen::Index>(0, mesh.vertexCount() - 1)(rng);
    const Eigen::Vector3d point = mesh.vertices.row(v).transpose();
    Eigen::Vector3d normal;
    do {
      normal = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized();
    } while (std::abs(normal.dot(point.normalized())) > std::cos(std::numbers::pi / 6));
    const auto contours = intersectMeshWithPlane(mesh, point, normal);
    ASSERT_EQ(contours.size(), 1U) << "i=" << i;
    const Polyline3d& c = contours[0];
    EXPECT_TRUE(c.closed);
    EXPECT_GT(signedArea(c, normal), 0.0);
    bool passes_through_vertex = false;
    for (std::size_t k = 0; k < c.points.size(); ++k) {
      EXPECT_NEAR(normal.dot(c.points[k] - point), 0.0, 1e-9);
      EXPECT_GT((c.points[k] - c.points[(k + 1) % c.points.size()]).norm(), 1e-12);
      passes_through_vertex = passes_through_vertex || (c.points[k] - point).norm() < 1e-12;
    }
    EXPECT_TRUE(passes_through_vertex);
  }
}

TEST(PlaneIntersection, OpenTubeCutAlongItsAxisGivesTwoOpenLines) {
  const double h = 10.0;
  const TriangleMesh tube = test::cylinder(2.0, h, 16, 5, false);
  // The plane y = 0 passes through the vertices at angle 0 and pi.
  const auto contours = intersectMeshWithPlane(tube, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 1, 0));
  ASSERT_EQ(contours.size(), 2U);
  for (const auto& c : contours) {
    EXPECT_FALSE(c.closed);
    EXPECT_NEAR(polylineLength(c), h, 1e-12);
    EXPECT_NEAR(std::abs(c.points.front().z() - c.points.back().z()), h, 1e-12);
    EXPECT_NEAR(std::abs(c.points.front().x()), 2.0, 1e-12);
  }
}

TEST(PlaneIntersection, FacesCutFromSidesGiveTheMeshCutAndBadIndicesAreRefused) {
  const TriangleMesh box = test::box(Eigen::Vector3d(10, 10, 10), 1, Eigen::Vector3d(-5, -5, -5));
  const Eigen::Vector3d point(0.0, 0.0, 1.5), normal(0.2, 0.1, 1.0);
  const Eigen::VectorXd d = (box.vertices.rowwise() - point.transpose()) * normal.normalized();
  std::vector<char> positive(static_cast<std::size_t>(d.size()));
  for (Eigen::Index v = 0; v < d.size(); ++v) positive[static_cast<std::size_t>(v)] = d(v) >= 0.0 ? 1 : 0;
  int asked = 0;
  const auto vertex = [&](std::int32_t v, Eigen::Vector3d& x, double& distance) {
    ++asked;
    x = box.vertices.row(v).transpose();
    distance = d(v);
  };
  const auto cut = cutFacesWithPlane(box.faces, positive, vertex);
  const auto reference = cutMeshWithPlane(box, point, normal);
  ASSERT_EQ(cut.size(), 1U);
  ASSERT_EQ(reference.size(), 1U);
  ASSERT_EQ(cut[0].polyline.points.size(), reference[0].polyline.points.size());
  for (std::size_t i = 0; i < cut[0].polyline.points.size(); ++i) {
    EXPECT_LT((cut[0].polyline.points[i] - reference[0].polyline.points[i]).norm(), 1e-12);
  }
  // Only the endpoints of crossed edges are asked for, once per edge (the box's four vertical edges and the
  // four side faces' diagonals).
  EXPECT_EQ(cut[0].edges.size(), 8U);
  EXPECT_EQ(asked, 16);
  // A face beyond the sides given, or a negative index: refused, naming the vertex.
  auto bad = box.faces;
  bad(3, 1) = static_cast<std::int32_t>(positive.size());
  try {
    (void)cutFacesWithPlane(bad, positive, vertex);
    FAIL() << "a face beyond the vertices was accepted";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("vertex 8 of 8"), std::string::npos) << e.what();
  }
  bad(3, 1) = -2;
  EXPECT_THROW((void)cutFacesWithPlane(bad, positive, vertex), InvalidArgumentError);
}

TEST(PlaneIntersection, ResampleClosedContourAtUniformArcLength) {
  Polyline3d square;
  square.closed = true;
  square.points = {{0, 0, 0}, {4, 0, 0}, {4, 4, 0}, {0, 4, 0}};
  EXPECT_DOUBLE_EQ(polylineLength(square), 16.0);
  const Polyline3d resampled = resamplePolyline(square, 8);
  ASSERT_EQ(resampled.points.size(), 8U);
  EXPECT_TRUE(resampled.closed);
  const std::vector<Eigen::Vector3d> expected = {{0, 0, 0}, {2, 0, 0}, {4, 0, 0}, {4, 2, 0},
                                                 {4, 4, 0}, {2, 4, 0}, {0, 4, 0}, {0, 2, 0}};
  for (std::size_t i = 0; i < expected.size(); ++i) EXPECT_LT((resampled.points[i] - expected[i]).norm(), 1e-12);

  // A circle-like contour from a cut: equal chords after resampling.
  const auto cut = intersectMeshWithPlane(test::cylinder(3.0, 10.0, 40, 3, false), Eigen::Vector3d(0, 0, 0.3),
                                          Eigen::Vector3d(0, 0, 1));
  ASSERT_EQ(cut.size(), 1U);
  const Polyline3d k = resamplePolyline(cut[0], 25);
  ASSERT_EQ(k.points.size(), 25U);
  const double spacing = polylineLength(cut[0]) / 25;
  for (std::size_t i = 0; i < k.points.size(); ++i) {
    // Chords never exceed the arc spacing; on a near-circle they are close to it.
    const double chord = (k.points[(i + 1) % k.points.size()] - k.points[i]).norm();
    EXPECT_LE(chord, spacing + 1e-12);
    EXPECT_GT(chord, 0.99 * spacing);
  }
}

TEST(PlaneIntersection, ResampleOpenPolylineKeepsEndsAndRejectsBadInput) {
  Polyline3d line;
  line.points = {{0, 0, 0}, {1, 0, 0}, {1, 3, 0}};
  const Polyline3d r = resamplePolyline(line, 5);
  ASSERT_EQ(r.points.size(), 5U);
  EXPECT_FALSE(r.closed);
  EXPECT_LT((r.points.front() - line.points.front()).norm(), 1e-15);
  EXPECT_LT((r.points.back() - line.points.back()).norm(), 1e-15);
  EXPECT_LT((r.points[1] - Eigen::Vector3d(1, 0, 0)).norm(), 1e-12);
  EXPECT_LT((r.points[2] - Eigen::Vector3d(1, 1, 0)).norm(), 1e-12);
  EXPECT_THROW((void)resamplePolyline(line, 1), InvalidArgumentError);
  Polyline3d point;
  point.points = {{1, 1, 1}, {1, 1, 1}};
  EXPECT_THROW((void)resamplePolyline(point, 4), InvalidArgumentError);
  EXPECT_THROW((void)intersectMeshWithPlane(test::box(Eigen::Vector3d(1, 1, 1)), Eigen::Vector3d::Zero(),
                                            Eigen::Vector3d::Zero()),
               InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns
