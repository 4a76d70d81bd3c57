#pragma once
// The posterior shape update per frame as it was before the incremental
// normal equations and the cut near the plane (kept verbatim in substance:
// the plane cut of the whole evaluated mesh with its edges found through a
// map of the crossing points, the Qp system rebuilt from every observation,
// and the whole 3N mean shape evaluated each frame), with the tracker's
// default options (arc-length pairing, no gate). The peer of
// bench_posterior.cpp, in the same run.
#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <map>
#include <span>
#include <tuple>
#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/deformation/contour_features.h"
#include "mrsns/deformation/posterior.h"
#include "mrsns/deformation/shape_model_ops.h"
#include "mrsns/deformation/shape_tracker.h"

namespace mrsns::deformation::previous {

inline std::vector<ModelContour> cutModelWithPlane(const TriangleMesh& mesh, const Eigen::Vector3d& plane_point,
                                            const Eigen::Vector3d& plane_normal) {
  const std::vector<Polyline3d> contours = intersectMeshWithPlane(mesh, plane_point, plane_normal);
  std::vector<ModelContour> out;
  if (contours.empty()) return out;
  // Recover each contour point's edge by recomputing the crossing points with
  // the same arithmetic as intersectMeshWithPlane (bit-identical positions).
  const Eigen::Vector3d n = plane_normal.normalized();
  const Eigen::VectorXd d = (mesh.vertices.rowwise() - plane_point.transpose()) * n;
  using Key = std::tuple<double, double, double>;
  std::map<Key, std::pair<Eigen::Vector2i, double>> edge_of_point;
  for (Eigen::Index f = 0; f < mesh.faceCount(); ++f) {
    for (int k = 0; k < 3; ++k) {
      std::int32_t a = mesh.faces(f, k);
      std::int32_t b = mesh.faces(f, (k + 1) % 3);
      if ((d(a) >= 0.0) == (d(b) >= 0.0)) continue;
      if (a > b) std::swap(a, b);
      const double t = d(a) / (d(a) - d(b));
      const Eigen::Vector3d va = mesh.vertices.row(a).transpose();
      const Eigen::Vector3d vb = mesh.vertices.row(b).transpose();
      const Eigen::Vector3d p = va + t * (vb - va);
      edge_of_point.emplace(Key{p.x(), p.y(), p.z()}, std::make_pair(Eigen::Vector2i(a, b), t));
    }
  }
  for (const auto& c : contours) {
    ModelContour mc;
    mc.contour = c;
    bool complete = true;
    for (const auto& p : c.points) {
      const auto it = edge_of_point.find(Key{p.x(), p.y(), p.z()});
      if (it == edge_of_point.end()) {
        complete = false;
        break;
      }
      mc.edge_vertices.push_back(it->second.first);
      mc.edge_t.push_back(it->second.second);
    }
    if (complete && c.points.size() >= 3) out.push_back(std::move(mc));
  }
  return out;
}

inline PosteriorResult computePosterior(const ShapeModel& model, std::span<const ModelPointObservation> observations,
                                 const PosteriorOptions& options) {
  if (!(options.noise_sigma_mm > 0.0) || !std::isfinite(options.noise_sigma_mm)) {
    throw InvalidArgumentError("computePosterior: noise_sigma_mm must be positive and finite, got " +
                               std::to_string(options.noise_sigma_mm));
  }
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

/// The state the previous tracker kept: V^p, the posterior and the mesh of its mean.
struct PreviousTracker {
  const ShapeModel* model = nullptr;
  ShapeTrackerOptions options;
  std::vector<ModelPointObservation> observations;
  PosteriorResult posterior;
  TriangleMesh current;

  explicit PreviousTracker(const ShapeModel& m) : model(&m), current(shapeMesh(m, m.mean)) {}

  int update(const Eigen::Isometry3d& model_T_image, std::span<const Polyline3d> feature_contours) {
    const auto model_contours =
        cutModelWithPlane(current, model_T_image.translation(), model_T_image.linear().col(2));
    const int k = options.contour_points;
    std::vector<char> used(model_contours.size(), 0);
    int matched = 0;
    for (const Polyline3d& fc_image : feature_contours) {
      if (fc_image.points.size() < 3) continue;
      Polyline3d fc;
      fc.closed = true;
      for (const auto& p : fc_image.points) fc.points.push_back(model_T_image * p);
      const Eigen::Vector3d fcen = polylineCentroid(fc);
      int best = -1;
      double best_d = options.max_centroid_distance_mm;
      for (std::size_t m = 0; m < model_contours.size(); ++m) {
        if (used[m] || !model_contours[m].contour.closed) continue;
        const double dist = (polylineCentroid(model_contours[m].contour) - fcen).norm();
        if (dist < best_d) {
          best_d = dist;
          best = static_cast<int>(m);
        }
      }
      if (best < 0) continue;
      used[static_cast<std::size_t>(best)] = 1;
      ++matched;
      const ModelContour& mc = model_contours[static_cast<std::size_t>(best)];
      const auto mparams = nearArcLengthParameters(mc.contour, k);
      const Polyline3d fres = resampleNearArcLength(fc, k);
      std::vector<Eigen::Vector3d> mpts;
      for (const auto& p : mparams) mpts.push_back(mc.modelPoint(p).point);
      const std::vector<Eigen::Vector3d> fpts = alignCyclic(mpts, fres.points);
      for (int i = 0; i < k; ++i) {
        ModelPointObservation o = mc.modelPoint(mparams[static_cast<std::size_t>(i)]);
        o.point = fpts[static_cast<std::size_t>(i)];
        int nearest = -1;
        double nearest_d = options.update_threshold_mm;
        for (std::size_t j = 0; j < observations.size(); ++j) {
          const double dist = (observations[j].point - o.point).norm();
          if (dist < nearest_d) {
            nearest_d = dist;
            nearest = static_cast<int>(j);
          }
        }
        if (nearest >= 0) {
          observations[static_cast<std::size_t>(nearest)] = o;
        } else {
          observations.push_back(o);
        }
      }
    }
    if (matched == 0) return 0;
    posterior = previous::computePosterior(*model, observations, options.posterior);
    for (Eigen::Index v = 0; v < current.vertexCount(); ++v) {
      current.vertices.row(v) = posterior.mean.segment<3>(3 * v);
    }
    return matched;
  }
};

}  // namespace mrsns::deformation::previous
