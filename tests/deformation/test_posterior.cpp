#include <gtest/gtest.h>

#include "mrsns/core/error.h"
#include "mrsns/deformation/posterior.h"
#include "mrsns/deformation/shape_model_ops.h"
#include "test_helpers.h"

namespace mrsns::deformation {
namespace {

Eigen::VectorXd spectrum(int n) {
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = 20.0 / (1.0 + i);
  return v;
}

TEST(Posterior, NoObservationsIsThePrior) {
  std::mt19937_64 rng(1);
  const ShapeModel model = testing::randomModel(40, spectrum(6), rng);
  const auto p = computePosterior(model, {});
  EXPECT_TRUE(p.mean.isApprox(model.mean, 1e-14));
  EXPECT_TRUE(p.coefficient_covariance.isIdentity(1e-14));
  EXPECT_EQ(p.mahalanobis, 0.0);
  EXPECT_TRUE(p.plausible);
  // Prior vertex covariance: Q_v Q_v^T.
  const Eigen::MatrixXd q = model.basis.middleRows(9, 3) * model.variances.cwiseSqrt().asDiagonal();
  EXPECT_TRUE(posteriorVertexCovariance(model, p, 3).isApprox(q * q.transpose(), 1e-12));
}

TEST(Posterior, ExactDenseObservationsWithTinySigmaReproduceTheShape) {
  std::mt19937_64 rng(2);
  const ShapeModel model = testing::randomModel(40, spectrum(8), rng);
  const Eigen::VectorXd truth = sampleShape(model, rng);
  std::vector<ModelPointObservation> obs;
  for (int v = 0; v < 40; ++v) obs.push_back(ModelPointObservation::atVertex(v, truth.segment<3>(3 * v)));
  PosteriorOptions opts;
  opts.noise_sigma_mm = 1e-5;
  opts.compute_vertex_covariances = true;
  const auto p = computePosterior(model, obs, opts);
  // Bias of the ridge term: sigma^2 / l_min relative, ~1e-9 mm here.
  EXPECT_LT(meanVertexDistance(p.mean, truth), 1e-7);
  EXPECT_TRUE(p.excluded.empty());
  for (const auto& c : p.vertex_covariances) EXPECT_LT(c.trace(), 1e-9);
}

TEST(Posterior, MatchesDenseComputationOfEq10And11) {
  std::mt19937_64 rng(3);
  const int points = 12;
  const ShapeModel model = testing::randomModel(points, spectrum(5), rng, 0.0);
  const Eigen::VectorXd truth = sampleShape(model, rng);
  std::normal_distribution<double> n(0.0, 0.3);
  std::vector<ModelPointObservation> obs;
  // Vertex, edge and 4-vertex observations.
  obs.push_back(ModelPointObservation::atVertex(0, truth.segment<3>(0) + Eigen::Vector3d(n(rng), n(rng), n(rng))));
  ModelPointObservation e;
  e.vertices = {3, 4, -1, -1};
  e.weights = Eigen::Vector4d(0.3, 0.7, 0, 0);
  e.point = 0.3 * truth.segment<3>(9) + 0.7 * truth.segment<3>(12);
  obs.push_back(e);
  ModelPointObservation f;
  f.vertices = {5, 6, 7, 9};
  f.weights = Eigen::Vector4d(0.1, 0.2, 0.3, 0.4);
  f.point = Eigen::Vector3d(n(rng), n(rng), n(rng));
  for (int s = 0; s < 4; ++s) f.point += f.weights[s] * truth.segment<3>(3 * f.vertices[s]);
  obs.push_back(f);
  obs.push_back(ModelPointObservation::atVertex(11, truth.segment<3>(33)));
  const double sigma = 0.7;
  PosteriorOptions opts;
  opts.noise_sigma_mm = sigma;
  opts.outlier_mahalanobis = 1e9;  // compare the plain formulas
  opts.compute_vertex_covariances = true;
  const auto p = computePosterior(model, obs, opts);

  // Dense: Q (3N x n), selection L (3k x 3N), Eq. 10 and Eq. 11 with full matrices,
  // and the Gaussian-process conditioning form K - K L^T (L K L^T + s^2 I)^-1 L K.
  const Eigen::MatrixXd q = model.basis * model.variances.cwiseSqrt().asDiagonal();
  const int k = static_cast<int>(obs.size());
  Eigen::MatrixXd l = Eigen::MatrixXd::Zero(3 * k, 3 * points);
  Eigen::VectorXd y(3 * k);
  for (int i = 0; i < k; ++i) {
    for (int s = 0; s < 4; ++s) {
      if (obs[i].vertices[s] < 0) continue;
      l.block(3 * i, 3 * obs[i].vertices[s], 3, 3) += obs[i].weights[s] * Eigen::Matrix3d::Identity();
    }
    y.segment<3>(3 * i) = obs[i].point;
  }
  const Eigen::MatrixXd qp = l * q;
  const Eigen::MatrixXd m = qp.transpose() * qp + sigma * sigma * Eigen::MatrixXd::Identity(5, 5);
  const Eigen::VectorXd mean10 = model.mean + q * m.inverse() * qp.transpose() * (y - l * model.mean);
  const Eigen::MatrixXd cov11 = sigma * sigma * q * m.inverse() * q.transpose();
  const Eigen::MatrixXd kk = q * q.transpose();
  const Eigen::MatrixXd s = l * kk * l.transpose() + sigma * sigma * Eigen::MatrixXd::Identity(3 * k, 3 * k);
  const Eigen::VectorXd mean_gp = model.mean + kk * l.transpose() * s.ldlt().solve(y - l * model.mean);
  const Eigen::MatrixXd cov_gp = kk - kk * l.transpose() * s.ldlt().solve(l * kk);

  EXPECT_LT((p.mean - mean10).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((p.mean - mean_gp).cwiseAbs().maxCoeff(), 1e-9);
  for (int v = 0; v < points; ++v) {
    EXPECT_LT((p.vertex_covariances[v] - cov11.block(3 * v, 3 * v, 3, 3)).cwiseAbs().maxCoeff(), 1e-9) << v;
    EXPECT_LT((p.vertex_covariances[v] - cov_gp.block(3 * v, 3 * v, 3, 3)).cwiseAbs().maxCoeff(), 1e-9) << v;
  }
}

TEST(Posterior, FlagsAndExcludesImplausibleObservations) {
  std::mt19937_64 rng(4);
  const ShapeModel model = testing::randomModel(60, spectrum(5), rng);
  const Eigen::VectorXd truth = sampleShape(model, rng);
  std::normal_distribution<double> n(0.0, 0.2);
  std::vector<ModelPointObservation> obs;
  for (int v = 0; v < 60; v += 3) {
    obs.push_back(
        ModelPointObservation::atVertex(v, truth.segment<3>(3 * v) + Eigen::Vector3d(n(rng), n(rng), n(rng))));
  }
  obs[4].point += Eigen::Vector3d(15.0, -10.0, 5.0);  // a segmentation blunder
  PosteriorOptions opts;
  opts.noise_sigma_mm = 0.2;
  const auto p = computePosterior(model, obs, opts);
  ASSERT_EQ(p.excluded.size(), 1u);
  EXPECT_EQ(p.excluded[0], 4);
  EXPECT_GT(p.residual_mahalanobis[4], opts.outlier_mahalanobis);
  // 19 points with 0.2 mm noise pin a 5-mode shape to ~0.1 mm.
  EXPECT_LT(meanVertexDistance(p.mean, truth), 0.3);
  EXPECT_TRUE(p.plausible);

  // Observations that no plausible shape explains: the whole shape moved 200 mm.
  for (auto& o : obs) o.point += Eigen::Vector3d(200.0, 0.0, 0.0);
  opts.max_outlier_rounds = 0;
  opts.noise_sigma_mm = 1.0;
  EXPECT_FALSE(computePosterior(model, obs, opts).plausible);
}

// The normal equations kept up to date by adds and replaces (the live
// tracker's path) give the posterior of the one-shot computation over the
// final observations, with outliers among them, after enough changes to
// pass a rebuild.
TEST(Posterior, IncrementalEquationsMatchTheOneShotPosteriorAfterAddsAndReplaces) {
  std::mt19937_64 rng(9);
  const int points = 60;
  const ShapeModel model = testing::randomModel(points, spectrum(7), rng, 0.0);
  const Eigen::VectorXd truth = sampleShape(model, rng);
  std::normal_distribution<double> noise(0.0, 0.5);
  std::uniform_int_distribution<int> vertex(0, points - 1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  auto observe = [&]() {
    ModelPointObservation o;
    const int a = vertex(rng), b = vertex(rng);
    const double t = unit(rng);
    o.vertices = {a, b, -1, -1};
    o.weights = Eigen::Vector4d(1.0 - t, t, 0.0, 0.0);
    o.point = (1.0 - t) * truth.segment<3>(3 * a) + t * truth.segment<3>(3 * b) +
              Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    if (unit(rng) < 0.03) o.point += Eigen::Vector3d(15.0, -10.0, 5.0);  // an outlier now and then
    return o;
  };
  PosteriorNormalEquations equations(model.modeCount(), 50);
  std::vector<ModelPointObservation> obs;
  std::uniform_real_distribution<double> coin(0.0, 1.0);
  for (int change = 0; change < 400; ++change) {
    if (obs.size() < 10 || coin(rng) < 0.4) {
      obs.push_back(observe());
      equations.add(model, obs.back());
    } else {
      const auto j = static_cast<std::size_t>(rng() % obs.size());
      obs[j] = observe();
      equations.replace(j, model, obs[j]);
    }
  }
  ASSERT_EQ(equations.size(), obs.size());
  PosteriorOptions options;
  options.noise_sigma_mm = 0.5;
  const PosteriorResult incremental = equations.solve(options);
  const PosteriorResult direct = computePosterior(model, obs, options);
  EXPECT_LT((incremental.coefficients - direct.coefficients).norm(), 1e-9 * (1.0 + direct.coefficients.norm()));
  EXPECT_LT((incremental.coefficient_covariance - direct.coefficient_covariance).norm(), 1e-9);
  EXPECT_EQ(incremental.excluded, direct.excluded);
  EXPECT_FALSE(direct.excluded.empty());
  EXPECT_NEAR(incremental.rms_residual_mm, direct.rms_residual_mm, 1e-9);
  EXPECT_EQ(incremental.mean.size(), 0);  // the shape is evaluated only on request
  EXPECT_LT((modelInstance(model, incremental.coefficients) - direct.mean).norm(), 1e-8);

  // Cleared, it is the prior again; a wrong index is refused.
  equations.clear();
  EXPECT_EQ(equations.solve(options).coefficients.norm(), 0.0);
  EXPECT_THROW(equations.replace(0, model, obs.front()), InvalidArgumentError);
}

TEST(Posterior, RefusesInvalidInput) {
  std::mt19937_64 rng(5);
  const ShapeModel model = testing::randomModel(10, spectrum(3), rng);
  PosteriorOptions opts;
  opts.noise_sigma_mm = 0.0;
  EXPECT_THROW((void)computePosterior(model, {}, opts), InvalidArgumentError);
  std::vector<ModelPointObservation> obs{ModelPointObservation::atVertex(10, Eigen::Vector3d::Zero())};
  EXPECT_THROW((void)computePosterior(model, obs), InvalidArgumentError);
  EXPECT_THROW((void)posteriorVertexCovariance(model, computePosterior(model, {}), 10), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::deformation
