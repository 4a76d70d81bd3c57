// ICP on real anatomical surfaces from the shared data (skipped when absent):
// a scalismo shape-model mesh and the statismo femurs.
#include <gtest/gtest.h>

#include <random>

#include "mrsns/io/landmarks_io.h"
#include "mrsns/io/mesh_io.h"
#include "mrsns/registration/surface_registration.h"
#include "surface_fixtures.h"
#include "test_data.h"

namespace mrsns::registration {
namespace {

using test::centroid;

using test::kDegree;

std::vector<Eigen::Vector3d> vertexSubset(const TriangleMesh& mesh, int stride) {
  std::vector<Eigen::Vector3d> points;
  for (Eigen::Index i = 0; i < mesh.vertexCount(); i += stride) points.emplace_back(mesh.vertices.row(i).transpose());
  return points;
}

TEST(IcpRealData, ScalismoMeshAgainstATransformedVertexSubsetOfItself) {
  MRSNS_REQUIRE_DATA(file, "ssm/scalismo/0.stl");
  const auto mesh = io::readMesh(file);
  const IcpSurface surface(mesh);
  const auto fixed_points = vertexSubset(mesh, 2);  // the vertices lie on the surface: noise-free
  const Eigen::Vector3d c = centroid(fixed_points);
  std::mt19937_64 rng(3);
  const auto truth = test::randomPerturbation(rng, 25 * kDegree, 30.0, c);
  const auto moving = test::transformPoints(truth.inverse(), fixed_points);
  for (int k = 0; k < 5; ++k) {
    const auto start = test::randomPerturbation(rng, 20 * kDegree, 20.0, c) * truth;
    const auto r = registerSurface(moving, surface, start);
    const auto e = test::poseError(r.fixed_T_moving, truth, centroid(moving));
    SCOPED_TRACE("start " + std::to_string(k));
    EXPECT_TRUE(r.converged);
    // Exact data: only the stopping tolerance (1e-4 mm motion) remains.
    EXPECT_LT(e.rotation, 0.01 * kDegree);
    EXPECT_LT(e.translation, 0.01);
    EXPECT_LT(r.rms_mm, 1e-3);
  }
}

TEST(IcpRealData, FemurSurfacePointsWithNoiseFromTwentyMillimetreStarts) {
  MRSNS_REQUIRE_DATA(file, "ssm/statismo/femur_meshes/VSD001_femur.vtk");
  const auto mesh = io::readMesh(file);
  const IcpSurface surface(mesh);
  // 0.2 mm per-axis Gaussian noise on a vertex subset (~2,000 points).
  std::mt19937_64 rng(5);
  std::normal_distribution<double> g(0.0, 0.2);
  auto points = vertexSubset(mesh, 9);
  for (auto& p : points) p += Eigen::Vector3d(g(rng), g(rng), g(rng));
  const Eigen::Vector3d c = centroid(points);
  const auto truth = test::randomPerturbation(rng, 15 * kDegree, 25.0, c);
  const auto moving = test::transformPoints(truth.inverse(), points);
  for (int k = 0; k < 3; ++k) {
    const auto start = test::randomPerturbation(rng, 20 * kDegree, 20.0, c) * truth;
    const auto r = registerSurface(moving, surface, start);
    const auto e = test::poseError(r.fixed_T_moving, truth, centroid(moving));
    SCOPED_TRACE("start " + std::to_string(k));
    // A long bone: rotation about its axis is the weakest direction, still
    // well determined by the condyles and the head.
    EXPECT_LT(e.rotation, 0.1 * kDegree);
    EXPECT_LT(e.translation, 0.1);
    EXPECT_NEAR(r.rms_mm, 0.2, 0.03);
  }
}

TEST(IcpRealData, TwoDifferentFemursAlignFromTheirLandmarks) {
  // Different subjects: no true transform, but ICP must improve on the
  // landmark alignment and end with a shape-difference RMS of a few mm.
  MRSNS_REQUIRE_DATA(fixed_file, "ssm/statismo/femur_meshes/VSD001_femur.vtk");
  MRSNS_REQUIRE_DATA(moving_file, "ssm/statismo/femur_meshes/VSD002_femur.vtk");
  MRSNS_REQUIRE_DATA(fixed_lm_file, "ssm/statismo/femur_meshes/VSD001-lm.csv");
  MRSNS_REQUIRE_DATA(moving_lm_file, "ssm/statismo/femur_meshes/VSD002-lm.csv");
  const auto fixed = io::readMesh(fixed_file);
  const auto moving_mesh = io::readMesh(moving_file);
  std::vector<Eigen::Vector3d> fixed_lm;
  std::vector<Eigen::Vector3d> moving_lm;
  for (const auto& p : io::readLandmarks(fixed_lm_file).points) fixed_lm.push_back(p.position);
  for (const auto& p : io::readLandmarks(moving_lm_file).points) moving_lm.push_back(p.position);
  ASSERT_EQ(fixed_lm.size(), 4u);
  const auto init = initialAlignmentFromLandmarks(moving_lm, fixed_lm);
  const IcpSurface surface(fixed);
  IcpOptions o;
  o.trim_fraction = 0.9;  // the femurs' ends differ most
  const auto r = registerSurface(vertexSubset(moving_mesh, 4), surface, init, o);
  EXPECT_TRUE(r.converged);
  EXPECT_LT(r.rms_mm, 0.7 * r.initial_rms_mm);
  // Plausibility: shapes of two adult femurs differ by a few mm; a wrong
  // (e.g. flipped) alignment leaves > 10 mm.
  EXPECT_LT(r.rms_mm, 5.0);
  RecordProperty("femur_to_femur_rms_mm", std::to_string(r.rms_mm));
  RecordProperty("landmark_start_rms_mm", std::to_string(r.initial_rms_mm));
  EXPECT_NEAR(r.inlier_fraction, 0.9, 0.01);
  // The landmark start was already close: ICP refines, it does not jump.
  EXPECT_LT(rotationAngleBetween(r.fixed_T_moving.linear(), init.linear()), 10 * kDegree);
}

}  // namespace
}  // namespace mrsns::registration
