#include <gtest/gtest.h>

#include <cmath>

#include "mrsns/core/error.h"
#include "mrsns/deformation/model_building.h"
#include "mrsns/deformation/shape_model_ops.h"
#include "test_helpers.h"

namespace mrsns::deformation {
namespace {

TEST(ModelBuilding, RecoversBasisAndVariancesOfAKnownGaussian) {
  std::mt19937_64 rng(7);
  const Eigen::Vector3d variances(9.0, 4.0, 1.0);
  const ShapeModel truth = testing::randomModel(30, variances, rng);
  const int m = 4000;
  Eigen::MatrixXd shapes(truth.mean.size(), m);
  for (int j = 0; j < m; ++j) shapes.col(j) = sampleShape(truth, rng);
  ShapeModelBuildOptions opts;
  opts.align = false;
  const auto built = buildShapeModelFromVectors(truth.reference, shapes, opts);
  // Exactly rank 3 data: three modes (the rest are round-off).
  ASSERT_EQ(built.model.modeCount(), 3);
  for (int i = 0; i < 3; ++i) {
    // Sample variance has relative standard error sqrt(2/m) = 2.2 %: allow 4 of them.
    EXPECT_NEAR(built.model.variances[i] / variances[i], 1.0, 4.0 * std::sqrt(2.0 / m)) << i;
    // Eigenvector angle error ~ sqrt(l_i l_j / m) / (l_i - l_j): < 0.05 rad here.
    EXPECT_GT(std::abs(built.model.basis.col(i).dot(truth.basis.col(i))), std::cos(0.05)) << i;
  }
  const Eigen::MatrixXd gram = built.model.basis.transpose() * built.model.basis;
  EXPECT_TRUE(gram.isIdentity(1e-12));
  EXPECT_NEAR(built.model.noise_variance, 0.0, 0.0);
  EXPECT_NEAR(meanVertexDistance(built.model.mean, truth.mean), 0.0, 4.0 * std::sqrt(14.0 / m));
}

TEST(ModelBuilding, ProcrustesRemovesRigidMotion) {
  std::mt19937_64 rng(11);
  const TriangleMesh base = testing::stripMesh(50, rng);
  std::normal_distribution<double> n(0.0, 1.0);
  std::vector<TriangleMesh> examples;
  const double noise = 0.05;
  for (int i = 0; i < 6; ++i) {
    Eigen::Affine3d T = Eigen::Affine3d::Identity();
    T.linear() = Eigen::AngleAxisd(n(rng), Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized()).toRotationMatrix();
    T.translation() = 30.0 * Eigen::Vector3d(n(rng), n(rng), n(rng));
    TriangleMesh e = base;
    for (Eigen::Index v = 0; v < e.vertexCount(); ++v) {
      e.vertices.row(v) = (T * Eigen::Vector3d(base.vertices.row(v).transpose())).transpose() +
                          noise * Eigen::RowVector3d(n(rng), n(rng), n(rng));
    }
    examples.push_back(e);
  }
  const auto built = buildShapeModel(examples);
  // Without GPA the rigid motion would dominate (tens of mm); with it only the noise remains.
  EXPECT_LT(std::sqrt(built.total_variance / base.vertexCount()), 3.0 * noise);
  EXPECT_GE(built.procrustes_iterations, 1);
}

TEST(ModelBuilding, ProjectionReconstructionAndMahalanobis) {
  std::mt19937_64 rng(3);
  const ShapeModel model = testing::randomModel(20, Eigen::Vector4d(16.0, 9.0, 4.0, 1.0), rng);
  const Eigen::Vector4d alpha(1.0, -2.0, 0.5, 0.0);
  const Eigen::VectorXd shape = modelInstance(model, alpha);
  EXPECT_TRUE(projectShape(model, shape).isApprox(alpha, 1e-12));
  EXPECT_NEAR(mahalanobisDistance(projectShape(model, shape)), alpha.norm(), 1e-12);
  // A component orthogonal to the model is removed by reconstruction.
  Eigen::VectorXd off = Eigen::VectorXd::Random(shape.size());
  off -= model.basis * (model.basis.transpose() * off);
  EXPECT_LT(meanVertexDistance(reconstructShape(model, shape + off), shape), 1e-10);
  // Probabilistic PCA shrinks the coefficients by l / (l + noise).
  ShapeModel noisy = model;
  noisy.noise_variance = 1.0;
  EXPECT_NEAR(projectShape(noisy, shape)[0], alpha[0] * 16.0 / 17.0, 1e-12);
  EXPECT_THROW((void)projectShape(model, Eigen::VectorXd::Zero(9)), InvalidArgumentError);
  EXPECT_NO_THROW(validateShapeModel(model));
  ShapeModel bad = model;
  bad.variances[0] = -1.0;
  EXPECT_THROW(validateShapeModel(bad), InvalidArgumentError);
}

TEST(ModelBuilding, CompactnessGeneralisationSpecificity) {
  std::mt19937_64 rng(5);
  const ShapeModel truth = testing::randomModel(25, Eigen::Vector3d(25.0, 4.0, 1.0), rng);
  const int m = 12;
  Eigen::MatrixXd shapes(truth.mean.size(), m);
  for (int j = 0; j < m; ++j) shapes.col(j) = sampleShape(truth, rng);
  ShapeModelBuildOptions opts;
  opts.align = false;
  const auto built = buildShapeModelFromVectors(truth.reference, shapes, opts);
  const Eigen::VectorXd c = compactness(built.model);
  ASSERT_EQ(c.size(), 3);
  EXPECT_NEAR(c[2], 1.0, 1e-12);
  EXPECT_TRUE(c[0] < c[1] && c[1] <= c[2]);
  const auto g = generalization(truth.reference, shapes, opts);
  // Data of rank 3: three modes of any 11 examples reconstruct the 12th exactly.
  EXPECT_LT(g.mean_error_mm[2], 1e-9);
  EXPECT_GT(g.mean_error_mm[0], g.mean_error_mm[1]);
  EXPECT_LT(g.leave_one_out_error_mm.maxCoeff(), 1e-9);
  const auto s = specificity(built.model, shapes, 20, rng);
  ASSERT_EQ(s.mean_error_mm.size(), 3);
  EXPECT_GT(s.mean_error_mm[0], 0.0);
  EXPECT_THROW((void)generalization(truth.reference, shapes.leftCols(2), opts), InvalidArgumentError);
}

TEST(ModelBuilding, RefusesMeshesNotInCorrespondence) {
  std::mt19937_64 rng(1);
  std::vector<TriangleMesh> ex{testing::stripMesh(10, rng), testing::stripMesh(12, rng)};
  EXPECT_THROW((void)buildShapeModel(ex), InvalidArgumentError);
  std::vector<TriangleMesh> one{testing::stripMesh(10, rng)};
  EXPECT_THROW((void)buildShapeModel(one), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::deformation
