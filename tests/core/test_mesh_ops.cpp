#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "mesh_fixtures.h"
#include "mrsns/core/error.h"
#include "mrsns/core/mesh_ops.h"

namespace mrsns {
namespace {

TEST(MeshOps, BoxAreaVolumeAndBoundsAreExact) {
  const Eigen::Vector3d size(10.0, 20.0, 30.0);
  const Eigen::Vector3d lo(-100.0, 250.0, 40.0);  // far from the origin, like CT coordinates
  const TriangleMesh mesh = test::box(size, 4, lo);
  ASSERT_NO_THROW(validateMesh(mesh));
  EXPECT_TRUE(isClosed(mesh));
  EXPECT_NEAR(surfaceArea(mesh), 2.0 * (10 * 20 + 20 * 30 + 10 * 30), 1e-9);
  EXPECT_NEAR(signedVolume(mesh), 10.0 * 20.0 * 30.0, 1e-8);
  const Eigen::AlignedBox3d bounds = boundingBox(mesh);
  EXPECT_TRUE(bounds.min().isApprox(lo, 1e-12));
  EXPECT_TRUE(bounds.max().isApprox(lo + size, 1e-12));
  EXPECT_TRUE(surfaceCentroid(mesh).isApprox(lo + size / 2, 1e-12));
}

TEST(MeshOps, InsideOutMeshHasNegativeVolume) {
  TriangleMesh mesh = test::box(Eigen::Vector3d(1, 2, 3), 2);
  mesh.faces.col(1).swap(mesh.faces.col(2));
  EXPECT_NEAR(signedVolume(mesh), -6.0, 1e-12);
  EXPECT_TRUE(isClosed(mesh));  // still consistently oriented, just inward
}

TEST(MeshOps, IcosphereAreaAndVolumeBetweenInscribedAndCircumscribedBalls) {
  const double r = 12.5;
  const Eigen::Vector3d c(3, -4, 5);
  for (int s = 2; s <= 4; ++s) {
    const TriangleMesh mesh = test::icosphere(r, s, c);
    ASSERT_TRUE(isClosed(mesh));
    // A convex polyhedron inscribed in the sphere contains the ball of its
    // inradius, so area and volume are bounded by those of the two balls.
    const double r_in = test::inradius(mesh, c);
    const double volume = signedVolume(mesh);
    const double area = surfaceArea(mesh);
    EXPECT_GT(volume, 4.0 / 3.0 * std::numbers::pi * std::pow(r_in, 3)) << "s=" << s;
    EXPECT_LT(volume, 4.0 / 3.0 * std::numbers::pi * std::pow(r, 3)) << "s=" << s;
    EXPECT_GT(area, 4.0 * std::numbers::pi * r_in * r_in) << "s=" << s;
    EXPECT_LT(area, 4.0 * std::numbers::pi * r * r) << "s=" << s;
    EXPECT_LT((surfaceCentroid(mesh) - c).norm(), 1e-9);
  }
}

TEST(MeshOps, FaceAndVertexNormalsPointOutward) {
  const TriangleMesh cube = test::box(Eigen::Vector3d(2, 2, 2), 3, Eigen::Vector3d(-1, -1, -1));
  const PointsN3 fn = faceNormals(cube);
  for (Eigen::Index f = 0; f < cube.faceCount(); ++f) {
    EXPECT_NEAR(fn.row(f).norm(), 1.0, 1e-12);
    // Axis aligned and pointing away from the centre.
    EXPECT_NEAR(fn.row(f).cwiseAbs().maxCoeff(), 1.0, 1e-12);
    const Eigen::Vector3d center = (cube.vertices.row(cube.faces(f, 0)) + cube.vertices.row(cube.faces(f, 1)) +
                                    cube.vertices.row(cube.faces(f, 2)))
                                       .transpose() /
                                   3.0;
    EXPECT_GT(fn.row(f).dot(center.transpose()), 0.0);
  }
  const double r = 5.0;
  const TriangleMesh sphere = test::icosphere(r, 3);
  const PointsN3 vn = vertexNormals(sphere);
  // A symmetric fan of faces around a sphere vertex averages to the radial
  // direction; the fan is near-symmetric, so allow a fraction of the facet angle.
  const double facet_angle = std::acos(test::inradius(sphere) / r);
  for (Eigen::Index v = 0; v < sphere.vertexCount(); ++v) {
    const Eigen::Vector3d radial = sphere.vertices.row(v).transpose() / r;
    EXPECT_NEAR(vn.row(v).norm(), 1.0, 1e-12);
    EXPECT_LT(std::acos(std::min(1.0, vn.row(v).dot(radial.transpose()))), facet_angle);
  }
}

TEST(MeshOps, DegenerateFaceHasZeroNormalAndArea) {
  TriangleMesh mesh;
  mesh.vertices.resize(3, 3);
  mesh.vertices << 0, 0, 0, 1, 1, 1, 2, 2, 2;  // collinear
  mesh.faces.resize(1, 3);
  mesh.faces << 0, 1, 2;
  EXPECT_EQ(faceNormals(mesh).row(0).norm(), 0.0);
  EXPECT_EQ(faceAreas(mesh)(0), 0.0);
  EXPECT_EQ(vertexNormals(mesh).norm(), 0.0);
  EXPECT_THROW((void)surfaceCentroid(mesh), InvalidArgumentError);
}

TEST(MeshOps, TransformPreservesAreaVolumeAndMovesCentroid) {
  const TriangleMesh mesh = test::icosphere(7.0, 2, Eigen::Vector3d(1, 2, 3));
  TriangleMesh with_normals = mesh;
  with_normals.normals = vertexNormals(mesh);
  with_normals.frame = "Model";
  Eigen::Isometry3d ct_T_model = Eigen::Isometry3d::Identity();
  ct_T_model.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  ct_T_model.translation() = Eigen::Vector3d(-40, 15, 300);
  const TriangleMesh moved = transformMesh(with_normals, ct_T_model, "CT");
  EXPECT_EQ(moved.frame, "CT");
  EXPECT_NEAR(surfaceArea(moved), surfaceArea(mesh), 1e-9);
  EXPECT_NEAR(signedVolume(moved), signedVolume(mesh), 1e-8);
  EXPECT_LT((surfaceCentroid(moved) - ct_T_model * surfaceCentroid(mesh)).norm(), 1e-9);
  // Rotated normals equal the normals recomputed from the moved vertices.
  EXPECT_LT((moved.normals - vertexNormals(moved)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(transformMesh(mesh, Eigen::Isometry3d::Identity()).vertices, mesh.vertices);
}

TEST(MeshOps, MergeConcatenatesAndShiftsIndices) {
  std::vector<TriangleMesh> parts = {test::box(Eigen::Vector3d(1, 1, 1)),
                                     test::box(Eigen::Vector3d(2, 2, 2), 1, Eigen::Vector3d(5, 0, 0))};
  const TriangleMesh merged = mergeMeshes(parts);
  EXPECT_EQ(merged.vertexCount(), parts[0].vertexCount() + parts[1].vertexCount());
  EXPECT_EQ(merged.faceCount(), parts[0].faceCount() + parts[1].faceCount());
  ASSERT_NO_THROW(validateMesh(merged));
  EXPECT_TRUE(isClosed(merged));
  EXPECT_NEAR(signedVolume(merged), 1.0 + 8.0, 1e-12);
  EXPECT_EQ(merged.normals.rows(), 0);

  parts[0].frame = "CT";
  parts[1].frame = "Reference";
  EXPECT_THROW((void)mergeMeshes(parts), FrameError);
}

TEST(MeshOps, CleanRemovesDegenerateFacesAndUnreferencedVertices) {
  TriangleMesh mesh = test::box(Eigen::Vector3d(1, 1, 1));
  const Eigen::Index nv = mesh.vertexCount();
  const Eigen::Index nf = mesh.faceCount();
  // Append an unreferenced vertex, a face repeating a vertex, and a sliver
  // whose three vertices are collinear (zero area).
  mesh.vertices.conservativeResize(nv + 4, 3);
  mesh.vertices.row(nv) << 9, 9, 9;
  mesh.vertices.row(nv + 1) << 20, 0, 0;
  mesh.vertices.row(nv + 2) << 21, 0, 0;
  mesh.vertices.row(nv + 3) << 22, 0, 0;
  mesh.faces.conservativeResize(nf + 2, 3);
  mesh.faces.row(nf) << 0, 0, 1;
  mesh.faces.row(nf + 1) << static_cast<int>(nv + 1), static_cast<int>(nv + 2), static_cast<int>(nv + 3);
  const CleanMeshResult result = cleanMesh(mesh);
  EXPECT_EQ(result.removed_faces, 2);
  EXPECT_EQ(result.removed_vertices, 4);
  EXPECT_EQ(result.mesh.vertexCount(), nv);
  EXPECT_EQ(result.mesh.faceCount(), nf);
  EXPECT_TRUE(isClosed(result.mesh));
  EXPECT_NEAR(signedVolume(result.mesh), 1.0, 1e-12);
  EXPECT_EQ(result.old_to_new[static_cast<std::size_t>(nv)], -1);
  for (Eigen::Index v = 0; v < nv; ++v) {
    const auto nv_new = result.old_to_new[static_cast<std::size_t>(v)];
    ASSERT_GE(nv_new, 0);
    EXPECT_EQ(result.mesh.vertices.row(nv_new), mesh.vertices.row(v));
  }
}

TEST(MeshOps, ValidationRejectsBadIndicesNaNAndMismatchedAttributes) {
  const TriangleMesh good = test::box(Eigen::Vector3d(1, 1, 1));
  EXPECT_NO_THROW(validateMesh(good));

  TriangleMesh out_of_range = good;
  out_of_range.faces(3, 1) = static_cast<int>(good.vertexCount());
  EXPECT_THROW(validateMesh(out_of_range), InvalidArgumentError);

  TriangleMesh negative = good;
  negative.faces(0, 0) = -1;
  EXPECT_THROW(validateMesh(negative), InvalidArgumentError);

  TriangleMesh nan_vertex = good;
  nan_vertex.vertices(2, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(validateMesh(nan_vertex), InvalidArgumentError);

  TriangleMesh bad_normals = good;
  bad_normals.normals = PointsN3::Zero(good.vertexCount() - 1, 3);
  EXPECT_THROW(validateMesh(bad_normals), InvalidArgumentError);

  TriangleMesh bad_colors = good;
  bad_colors.colors = PointsN3::Constant(good.vertexCount(), 3, std::numeric_limits<double>::infinity());
  EXPECT_THROW(validateMesh(bad_colors), InvalidArgumentError);

  try {
    validateMesh(out_of_range, "skull.stl");
    FAIL() << "expected InvalidArgumentError";
  } catch (const InvalidArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("skull.stl"), std::string::npos) << e.what();
  }
}

TEST(MeshOps, ClosednessDetectsOpenAndNonManifoldMeshes) {
  EXPECT_TRUE(isClosed(test::cylinder(3, 10, 24, 5, true)));
  EXPECT_FALSE(isClosed(test::cylinder(3, 10, 24, 5, false)));
  EXPECT_FALSE(isClosed(test::planeGrid(10, 4)));
  EXPECT_FALSE(isClosed(TriangleMesh{}));
  // Duplicating a face makes three faces share its edges.
  TriangleMesh doubled = test::box(Eigen::Vector3d(1, 1, 1));
  doubled.faces.conservativeResize(doubled.faceCount() + 1, 3);
  doubled.faces.row(doubled.faceCount() - 1) = doubled.faces.row(0);
  EXPECT_FALSE(isClosed(doubled));
}

}  // namespace
}  // namespace mrsns
