#include "mrsns/deformation/posterior.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "mrsns/core/error.h"
#include "mrsns/deformation/shape_model_ops.h"

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

// `index` names the observation in the message (its place in V^p).
void validateObservation(const ShapeModel& model, const ModelPointObservation& o, std::size_t index) {
  const Eigen::Index n_points = model.pointCount();
  bool any = false;
  for (int s = 0; s < 4; ++s) {
    const auto v = o.vertices[s];
    if (v < -1 || v >= n_points) {
      throw InvalidArgumentError("computePosterior: observation " + std::to_string(index) + " refers to vertex " +
                                 std::to_string(v) + " of a model with " + std::to_string(n_points) + " points");
    }
    any = any || (v >= 0 && o.weights[s] != 0.0);
  }
  if (!any || !o.point.allFinite() || !o.weights.allFinite()) {
    throw InvalidArgumentError("computePosterior: observation " + std::to_string(index) +
                               " has no vertex with non-zero weight or a non-finite point/weight");
  }
}

}  // namespace

PosteriorNormalEquations::PosteriorNormalEquations(Eigen::Index modes, int rebuild_interval)
    : rebuild_interval_(std::max(1, rebuild_interval)) {
  if (modes < 1) throw InvalidArgumentError("PosteriorNormalEquations: the model has no modes");
  qtq_ = Eigen::MatrixXd::Zero(modes, modes);
  qtd_ = Eigen::VectorXd::Zero(modes);
  rows_.resize(3 * 64, modes);
  residuals_.resize(3 * 64);
}

void PosteriorNormalEquations::add(const ShapeModel& model, const ModelPointObservation& observation) {
  validateObservation(model, observation, size());
  if (model.modeCount() != modes()) {
    throw InvalidArgumentError("PosteriorNormalEquations: the model has " + std::to_string(model.modeCount()) +
                               " modes, the equations " + std::to_string(modes()));
  }
  if (3 * (count_ + 1) > rows_.rows()) {
    // Grow geometrically: amortised O(1) copies per observation.
    rows_.conservativeResize(2 * rows_.rows(), Eigen::NoChange);
    residuals_.conservativeResize(2 * residuals_.size());
  }
  auto rows = rows_.middleRows(3 * count_, 3);
  rows.noalias() = observationRows(model, observation);
  residuals_.segment<3>(3 * count_) = observation.point - observationMean(model, observation);
  qtq_.noalias() += rows.transpose() * rows;
  qtd_.noalias() += rows.transpose() * residuals_.segment<3>(3 * count_);
  ++count_;
  if (++changes_since_rebuild_ >= rebuild_interval_) rebuild();
}

void PosteriorNormalEquations::replace(std::size_t index, const ShapeModel& model,
                                       const ModelPointObservation& observation) {
  if (index >= size()) {
    throw InvalidArgumentError("PosteriorNormalEquations::replace: observation " + std::to_string(index) + " of " +
                               std::to_string(size()));
  }
  validateObservation(model, observation, index);
  const auto i = static_cast<Eigen::Index>(index);
  auto rows = rows_.middleRows(3 * i, 3);
  qtq_.noalias() -= rows.transpose() * rows;
  qtd_.noalias() -= rows.transpose() * residuals_.segment<3>(3 * i);
  rows.noalias() = observationRows(model, observation);
  residuals_.segment<3>(3 * i) = observation.point - observationMean(model, observation);
  qtq_.noalias() += rows.transpose() * rows;
  qtd_.noalias() += rows.transpose() * residuals_.segment<3>(3 * i);
  if (++changes_since_rebuild_ >= rebuild_interval_) rebuild();
}

void PosteriorNormalEquations::clear() {
  count_ = 0;
  qtq_.setZero();
  qtd_.setZero();
  changes_since_rebuild_ = 0;
}

void PosteriorNormalEquations::rebuild() {
  const auto rows = rows_.topRows(3 * count_);
  qtq_.noalias() = rows.transpose() * rows;
  qtd_.noalias() = rows.transpose() * residuals_.head(3 * count_);
  changes_since_rebuild_ = 0;
}

PosteriorResult PosteriorNormalEquations::solve(const PosteriorOptions& options) const {
  if (!(options.noise_sigma_mm > 0.0) || !std::isfinite(options.noise_sigma_mm)) {
    throw InvalidArgumentError("computePosterior: noise_sigma_mm must be positive and finite, got " +
                               std::to_string(options.noise_sigma_mm));
  }
  const Eigen::Index n = modes();
  const Eigen::Index k = count_;
  const double sigma2 = options.noise_sigma_mm * options.noise_sigma_mm;
  const auto qp = rows_.topRows(3 * k);
  const auto dp = residuals_.head(3 * k);

  PosteriorResult r;
  std::vector<char> used(static_cast<std::size_t>(k), 1);
  Eigen::MatrixXd m = qtq_;
  Eigen::VectorXd rhs = qtd_;
  for (int round = 0;; ++round) {
    // M = Qp^T Qp + sigma^2 I over the used observations (n x n, Eq. 10).
    m.diagonal().array() += sigma2;
    const Eigen::LLT<Eigen::MatrixXd> llt(m);
    if (llt.info() != Eigen::Success)
      throw ComputationError("computePosterior: the n x n system is not positive definite");
    r.coefficients = llt.solve(rhs);
    r.coefficient_covariance = sigma2 * llt.solve(Eigen::MatrixXd::Identity(n, n));

    // Residuals against the posterior predictive N(Qp_i alpha, Qp_i S Qp_i^T + sigma^2 I),
    // with Qp_i S Qp_i^T = sigma^2 X_i^T X_i, X = L^-1 Qp^T (one triangular solve for all).
    const Eigen::VectorXd e_all = dp - qp * r.coefficients;
    const Eigen::MatrixXd x = llt.matrixL().solve(qp.transpose());
    r.residuals_mm.resize(k);
    r.residual_mahalanobis.resize(k);
    for (Eigen::Index i = 0; i < k; ++i) {
      const Eigen::Vector3d e = e_all.segment<3>(3 * i);
      const auto xi = x.middleCols(3 * i, 3);
      Eigen::Matrix3d c = sigma2 * (xi.transpose() * xi);
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
    if (worst < 0) break;
    used[static_cast<std::size_t>(worst)] = 0;
    // The system over the used observations, summed afresh (exclusions are rare).
    m.setZero();
    rhs.setZero();
    for (Eigen::Index i = 0; i < k; ++i) {
      if (!used[static_cast<std::size_t>(i)]) continue;
      const auto rows = qp.middleRows(3 * i, 3);
      m.noalias() += rows.transpose() * rows;
      rhs.noalias() += rows.transpose() * dp.segment<3>(3 * i);
    }
  }

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
  return r;
}

PosteriorResult computePosterior(const ShapeModel& model, std::span<const ModelPointObservation> observations,
                                 const PosteriorOptions& options) {
  if (model.modeCount() < 1) throw InvalidArgumentError("computePosterior: the model has no modes");
  // add() validates each observation (named by its index), solve() the options.
  PosteriorNormalEquations equations(model.modeCount(), std::numeric_limits<int>::max());
  for (const auto& o : observations) equations.add(model, o);
  PosteriorResult r = equations.solve(options);
  r.mean = modelInstance(model, r.coefficients);
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
