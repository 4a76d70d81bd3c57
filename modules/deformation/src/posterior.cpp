#include "mrsns/deformation/posterior.h"

#include <Eigen/Cholesky>
#include <cmath>

#include "mrsns/core/error.h"

namespace mrsns::deformation {

Eigen::Matrix<double, 3, Eigen::Dynamic> observationRows(const ShapeModel& model, const ModelPointObservation& o) {
  Eigen::Matrix<double, 3, Eigen::Dynamic> rows = Eigen::Matrix<double, 3, Eigen::Dynamic>::Zero(3, model.modeCount());
  for (int s = 0; s < 4; ++s) {
    if (o.vertices[s] < 0 || o.weights[s] == 0.0) continue;
    rows += o.weights[s] * model.basis.middleRows(3 * o.vertices[s], 3);
  }
  // Q = U diag(sqrt(lambda)): scale columns.
  return rows * model.variances.cwiseSqrt().asDiagonal();
}

Eigen::Vector3d observationMean(const ShapeModel& model, const ModelPointObservation& o) {
  Eigen::Vector3d m = Eigen::Vector3d::Zero();
  for (int s = 0; s < 4; ++s) {
    if (o.vertices[s] < 0 || o.weights[s] == 0.0) continue;
    m += o.weights[s] * model.mean.segment<3>(3 * o.vertices[s]);
  }
  return m;
}

namespace {

void validateObservations(const ShapeModel& model, std::span<const ModelPointObservation> obs) {
  const Eigen::Index n_points = model.pointCount();
  for (std::size_t i = 0; i < obs.size(); ++i) {
    bool any = false;
    for (int s = 0; s < 4; ++s) {
      const auto v = obs[i].vertices[s];
      if (v < -1 || v >= n_points) {
        throw InvalidArgumentError("computePosterior: observation " + std::to_string(i) + " refers to vertex " +
                                   std::to_string(v) + " of a model with " + std::to_string(n_points) + " points");
      }
      any = any || (v >= 0 && obs[i].weights[s] != 0.0);
    }
    if (!any || !obs[i].point.allFinite() || !obs[i].weights.allFinite()) {
      throw InvalidArgumentError("computePosterior: observation " + std::to_string(i) +
                                 " has no vertex with non-zero weight or a non-finite point/weight");
    }
  }
}

}  // namespace

PosteriorResult computePosterior(const ShapeModel& model, std::span<const ModelPointObservation> observations,
                                 const PosteriorOptions& options) {
  if (!(options.noise_sigma_mm > 0.0) || !std::isfinite(options.noise_sigma_mm)) {
    throw InvalidArgumentError("computePosterior: noise_sigma_mm must be positive and finite, got " +
                               std::to_string(options.noise_sigma_mm));
  }
  validateObservations(model, observations);
  const Eigen::Index n = model.modeCount();
  const Eigen::Index k = static_cast<Eigen::Index>(observations.size());
  const double sigma2 = options.noise_sigma_mm * options.noise_sigma_mm;

  // Stacked Qp (3k x n) and residual to the prior mean, built once.
  Eigen::MatrixXd qp(3 * k, n);
  Eigen::VectorXd dp(3 * k);
  for (Eigen::Index i = 0; i < k; ++i) {
    const auto& o = observations[static_cast<std::size_t>(i)];
    qp.middleRows(3 * i, 3) = observationRows(model, o);
    dp.segment<3>(3 * i) = o.point - observationMean(model, o);
  }

  PosteriorResult r;
  std::vector<char> used(static_cast<std::size_t>(k), 1);
  Eigen::MatrixXd m_inv;
  for (int round = 0;; ++round) {
    // M = Qp^T Qp + sigma^2 I over the used observations (n x n, Eq. 10).
    Eigen::MatrixXd m = sigma2 * Eigen::MatrixXd::Identity(n, n);
    Eigen::VectorXd rhs = Eigen::VectorXd::Zero(n);
    for (Eigen::Index i = 0; i < k; ++i) {
      if (!used[static_cast<std::size_t>(i)]) continue;
      const auto rows = qp.middleRows(3 * i, 3);
      m.noalias() += rows.transpose() * rows;
      rhs.noalias() += rows.transpose() * dp.segment<3>(3 * i);
    }
    const Eigen::LLT<Eigen::MatrixXd> llt(m);
    if (llt.info() != Eigen::Success)
      throw ComputationError("computePosterior: the n x n system is not positive definite");
    r.coefficients = llt.solve(rhs);
    m_inv = llt.solve(Eigen::MatrixXd::Identity(n, n));
    r.coefficient_covariance = sigma2 * m_inv;

    // Residuals against the posterior predictive N(Qp_i alpha, Qp_i S Qp_i^T + sigma^2 I).
    r.residuals_mm.resize(k);
    r.residual_mahalanobis.resize(k);
    int newly_excluded = 0;
    for (Eigen::Index i = 0; i < k; ++i) {
      const auto rows = qp.middleRows(3 * i, 3);
      const Eigen::Vector3d e = dp.segment<3>(3 * i) - rows * r.coefficients;
      Eigen::Matrix3d c = rows * r.coefficient_covariance * rows.transpose();
      // A used observation pulls the posterior towards itself, so it is judged
      // by its leave-one-out residual, which for this Gaussian model reduces to
      // d^2 = e^T (sigma^2 I - C)^-1 e with C the posterior covariance at it.
      if (used[static_cast<std::size_t>(i)]) {
        const Eigen::Matrix3d s_used = sigma2 * Eigen::Matrix3d::Identity() - c;
        r.residual_mahalanobis[i] = std::sqrt(std::max(0.0, e.dot(s_used.ldlt().solve(e))));
      } else {
        c += sigma2 * Eigen::Matrix3d::Identity();
        r.residual_mahalanobis[i] = std::sqrt(std::max(0.0, e.dot(c.ldlt().solve(e))));
      }
      r.residuals_mm[i] = e.norm();
    }
    if (round >= options.max_outlier_rounds) break;
    // Exclude the worst implausible observation per round: one bad point can
    // make its neighbours look bad until it is gone.
    Eigen::Index worst = -1;
    for (Eigen::Index i = 0; i < k; ++i) {
      if (used[static_cast<std::size_t>(i)] && r.residual_mahalanobis[i] > options.outlier_mahalanobis &&
          (worst < 0 || r.residual_mahalanobis[i] > r.residual_mahalanobis[worst])) {
        worst = i;
      }
    }
    if (worst >= 0) {
      used[static_cast<std::size_t>(worst)] = 0;
      ++newly_excluded;
    }
    if (newly_excluded == 0) break;
  }

  r.mean = model.mean + model.basis * (model.variances.cwiseSqrt().asDiagonal() * r.coefficients);
  r.mahalanobis = r.coefficients.norm();
  const double nn = static_cast<double>(n);
  r.plausible = r.mahalanobis * r.mahalanobis <= nn + options.implausible_sigmas * std::sqrt(2.0 * nn);
  double sq = 0.0;
  for (Eigen::Index i = 0; i < k; ++i) {
    if (used[static_cast<std::size_t>(i)]) {
      ++r.used_observations;
      sq += r.residuals_mm[i] * r.residuals_mm[i];
    } else {
      r.excluded.push_back(static_cast<int>(i));
    }
  }
  r.rms_residual_mm = r.used_observations > 0 ? std::sqrt(sq / r.used_observations) : 0.0;
  if (options.compute_vertex_covariances) {
    r.vertex_covariances.resize(static_cast<std::size_t>(model.pointCount()));
    for (Eigen::Index v = 0; v < model.pointCount(); ++v) {
      r.vertex_covariances[static_cast<std::size_t>(v)] = posteriorVertexCovariance(model, r, v);
    }
  }
  return r;
}

Eigen::Matrix3d posteriorVertexCovariance(const ShapeModel& model, const PosteriorResult& posterior,
                                          Eigen::Index vertex) {
  if (vertex < 0 || vertex >= model.pointCount()) {
    throw InvalidArgumentError("posteriorVertexCovariance: vertex " + std::to_string(vertex) + " out of range [0, " +
                               std::to_string(model.pointCount()) + ")");
  }
  const Eigen::Matrix<double, 3, Eigen::Dynamic> q =
      model.basis.middleRows(3 * vertex, 3) * model.variances.cwiseSqrt().asDiagonal();
  return q * posterior.coefficient_covariance * q.transpose();
}

}  // namespace mrsns::deformation
