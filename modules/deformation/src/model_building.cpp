#include "mrsns/deformation/model_building.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "mrsns/core/dense_solvers.h"
#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/deformation/shape_model_ops.h"
#include "mrsns/registration/paired_point.h"

namespace mrsns::deformation {
namespace {

std::vector<Eigen::Vector3d> toPoints(const PointsN3& p) {
  std::vector<Eigen::Vector3d> out(static_cast<std::size_t>(p.rows()));
  for (Eigen::Index i = 0; i < p.rows(); ++i) out[static_cast<std::size_t>(i)] = p.row(i).transpose();
  return out;
}

PointsN3 applyTransform(const Eigen::Affine3d& T, const PointsN3& p) {
  PointsN3 out(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i) out.row(i) = (T * Eigen::Vector3d(p.row(i).transpose())).transpose();
  return out;
}

double rmsDistance(const PointsN3& a, const PointsN3& b) {
  return std::sqrt((a - b).rowwise().squaredNorm().mean());
}

}  // namespace

ProcrustesResult alignGeneralizedProcrustes(std::span<const PointsN3> examples, const ProcrustesOptions& options) {
  if (examples.size() < 2) {
    throw InvalidArgumentError("alignGeneralizedProcrustes: " + std::to_string(examples.size()) +
                               " examples; need at least 2");
  }
  const Eigen::Index n = examples[0].rows();
  for (std::size_t i = 0; i < examples.size(); ++i) {
    if (examples[i].rows() != n || n < 3) {
      throw InvalidArgumentError("alignGeneralizedProcrustes: example " + std::to_string(i) + " has " +
                                 std::to_string(examples[i].rows()) + " points, example 0 has " + std::to_string(n) +
                                 "; examples must be in correspondence with >= 3 points");
    }
  }
  registration::PairedPointOptions pp;
  pp.estimate_scale = options.estimate_scale;
  pp.leave_one_out = false;

  ProcrustesResult result;
  result.aligned.assign(examples.begin(), examples.end());
  result.mean_T_example.assign(examples.size(), Eigen::Affine3d::Identity());
  PointsN3 mean = examples[0];
  for (int it = 0; it < options.max_iterations; ++it) {
    const std::vector<Eigen::Vector3d> target = toPoints(mean);
    for (std::size_t i = 0; i < examples.size(); ++i) {
      const std::vector<Eigen::Vector3d> moving = toPoints(examples[i]);
      const auto r = registration::registerPairedPoints(moving, target, pp);
      result.mean_T_example[i] = r.fixed_T_moving;
      result.aligned[i] = applyTransform(r.fixed_T_moving, examples[i]);
    }
    PointsN3 new_mean = PointsN3::Zero(n, 3);
    for (const auto& a : result.aligned) new_mean += a;
    new_mean /= static_cast<double>(examples.size());
    // Pin the mean to the first example's pose (and size) so the iteration
    // cannot drift or shrink.
    const auto pin = registration::registerPairedPoints(toPoints(new_mean), toPoints(examples[0]), pp);
    new_mean = applyTransform(pin.fixed_T_moving, new_mean);
    const double change = rmsDistance(new_mean, mean);
    mean = new_mean;
    result.iterations = it + 1;
    if (change < options.tolerance_mm) {
      result.converged = true;
      break;
    }
  }
  // Final alignment to the settled mean.
  const std::vector<Eigen::Vector3d> target = toPoints(mean);
  double sq = 0.0;
  for (std::size_t i = 0; i < examples.size(); ++i) {
    const auto r = registration::registerPairedPoints(toPoints(examples[i]), target, pp);
    result.mean_T_example[i] = r.fixed_T_moving;
    result.aligned[i] = applyTransform(r.fixed_T_moving, examples[i]);
    sq += (result.aligned[i] - mean).rowwise().squaredNorm().sum();
  }
  result.mean = mean;
  result.rms_to_mean_mm = std::sqrt(sq / static_cast<double>(examples.size() * static_cast<std::size_t>(n)));
  return result;
}

ShapeModelBuildResult buildShapeModelFromVectors(const TriangleMesh& reference, const Eigen::MatrixXd& shapes,
                                                 const ShapeModelBuildOptions& options) {
  const Eigen::Index m = shapes.cols();
  if (m < 2) throw InvalidArgumentError("buildShapeModel: " + std::to_string(m) + " examples; need at least 2");
  if (shapes.rows() != 3 * reference.vertexCount()) {
    throw InvalidArgumentError("buildShapeModel: shapes have " + std::to_string(shapes.rows()) +
                               " rows but the reference has " + std::to_string(reference.vertexCount()) +
                               " vertices (need 3 rows per vertex)");
  }
  if (!shapes.allFinite()) throw InvalidArgumentError("buildShapeModel: example shapes contain NaN or infinity");
  if (options.noise_variance < 0.0) throw InvalidArgumentError("buildShapeModel: noise_variance must be >= 0");

  ShapeModelBuildResult result;
  result.aligned_shapes = shapes;
  const Eigen::VectorXd mean = shapes.rowwise().mean();
  const Eigen::MatrixXd centred = shapes.colwise() - mean;
  // Thin SVD of the 3N x m data matrix: U spans the shape space, s^2/(m-1) are
  // the sample variances. Cost O(N m^2), never forms the 3N x 3N covariance.
  const ThinSvd svd = thinSvd(centred, SvdVectors::kU);
  const Eigen::VectorXd& s = svd.singular_values;
  result.singular_values = s;
  const double denom = static_cast<double>(m - 1);
  const Eigen::VectorXd sample_var = s.array().square() / denom;
  result.total_variance = sample_var.sum();

  const double largest = sample_var.size() > 0 ? sample_var[0] : 0.0;
  Eigen::Index keep = 0;
  // At most m - 1 modes: centring removes one degree of freedom.
  const Eigen::Index max_keep = std::min<Eigen::Index>(m - 1, s.size());
  while (keep < max_keep && sample_var[keep] - options.noise_variance > options.min_relative_variance * largest &&
         sample_var[keep] > 0.0) {
    ++keep;
  }
  if (options.max_modes > 0) keep = std::min<Eigen::Index>(keep, options.max_modes);

  ShapeModel& model = result.model;
  model.reference = reference;
  model.reference.vertices = shapePoints(mean);
  model.reference.normals.resize(0, 3);
  model.reference.colors.resize(0, 3);
  model.mean = mean;
  model.basis = svd.u.leftCols(keep);
  model.variances = (sample_var.head(keep).array() - options.noise_variance).matrix();
  model.noise_variance = options.noise_variance;
  result.retained_variance_fraction =
      result.total_variance > 0.0 ? sample_var.head(keep).sum() / result.total_variance : 1.0;
  return result;
}

ShapeModelBuildResult buildShapeModel(std::span<const TriangleMesh> examples, const ShapeModelBuildOptions& options) {
  if (examples.size() < 2) {
    throw InvalidArgumentError("buildShapeModel: " + std::to_string(examples.size()) + " examples; need at least 2");
  }
  const TriangleMesh& ref = examples[0];
  validateMesh(ref, "example 0");
  for (std::size_t i = 1; i < examples.size(); ++i) {
    if (examples[i].vertexCount() != ref.vertexCount()) {
      throw InvalidArgumentError("buildShapeModel: example " + std::to_string(i) + " has " +
                                 std::to_string(examples[i].vertexCount()) + " vertices, example 0 has " +
                                 std::to_string(ref.vertexCount()) + "; establish correspondence to a reference first");
    }
  }
  std::vector<PointsN3> points;
  points.reserve(examples.size());
  for (const auto& e : examples) points.push_back(e.vertices);
  Eigen::MatrixXd shapes(3 * ref.vertexCount(), static_cast<Eigen::Index>(examples.size()));
  int iterations = 0;
  if (options.align) {
    const ProcrustesResult gpa = alignGeneralizedProcrustes(points, options.procrustes);
    iterations = gpa.iterations;
    for (std::size_t i = 0; i < examples.size(); ++i) {
      shapes.col(static_cast<Eigen::Index>(i)) = shapeVector(gpa.aligned[i]);
    }
  } else {
    for (std::size_t i = 0; i < examples.size(); ++i) shapes.col(static_cast<Eigen::Index>(i)) = shapeVector(points[i]);
  }
  ShapeModelBuildResult result = buildShapeModelFromVectors(ref, shapes, options);
  result.procrustes_iterations = iterations;
  logger()->debug("shape model: {} examples, {} points, {} modes, {:.1f}% variance", examples.size(), ref.vertexCount(),
                  result.model.modeCount(), 100.0 * result.retained_variance_fraction);
  return result;
}

Eigen::VectorXd compactness(const ShapeModel& model) {
  Eigen::VectorXd c(model.modeCount());
  const double total = model.variances.sum();
  double acc = 0.0;
  for (Eigen::Index k = 0; k < c.size(); ++k) {
    acc += model.variances[k];
    c[k] = total > 0.0 ? acc / total : 1.0;
  }
  return c;
}

GeneralizationResult generalization(const TriangleMesh& reference, const Eigen::MatrixXd& aligned_shapes,
                                    const ShapeModelBuildOptions& options) {
  const Eigen::Index m = aligned_shapes.cols();
  if (m < 3) throw InvalidArgumentError("generalization: need at least 3 examples, got " + std::to_string(m));
  const Eigen::Index kmax = m - 2;
  GeneralizationResult g;
  g.mean_error_mm = Eigen::VectorXd::Zero(kmax);
  g.leave_one_out_error_mm = Eigen::VectorXd::Zero(m);
  ShapeModelBuildOptions opts = options;
  opts.align = false;
  opts.max_modes = 0;
  for (Eigen::Index left = 0; left < m; ++left) {
    Eigen::MatrixXd others(aligned_shapes.rows(), m - 1);
    for (Eigen::Index j = 0, c = 0; j < m; ++j) {
      if (j != left) others.col(c++) = aligned_shapes.col(j);
    }
    const ShapeModel model = buildShapeModelFromVectors(reference, others, opts).model;
    const Eigen::VectorXd x = aligned_shapes.col(left);
    const Eigen::VectorXd alpha = projectShape(model, x);
    for (Eigen::Index k = 1; k <= kmax; ++k) {
      const Eigen::Index kk = std::min(k, model.modeCount());
      g.mean_error_mm[k - 1] += meanVertexDistance(x, modelInstance(model, alpha.head(kk)));
    }
    g.leave_one_out_error_mm[left] = meanVertexDistance(x, modelInstance(model, alpha));
  }
  g.mean_error_mm /= static_cast<double>(m);
  return g;
}

SpecificityResult specificity(const ShapeModel& model, const Eigen::MatrixXd& aligned_shapes, int sample_count,
                              std::mt19937_64& rng) {
  if (sample_count < 1) throw InvalidArgumentError("specificity: sample_count must be >= 1");
  if (aligned_shapes.rows() != model.mean.size() || aligned_shapes.cols() < 1) {
    throw InvalidArgumentError("specificity: training shapes do not match the model size");
  }
  SpecificityResult r;
  r.mean_error_mm = Eigen::VectorXd::Zero(model.modeCount());
  std::normal_distribution<double> normal(0.0, 1.0);
  for (Eigen::Index k = 1; k <= model.modeCount(); ++k) {
    double sum = 0.0;
    for (int s = 0; s < sample_count; ++s) {
      Eigen::VectorXd alpha(k);
      for (Eigen::Index i = 0; i < k; ++i) alpha[i] = normal(rng);
      const Eigen::VectorXd x = modelInstance(model, alpha);
      double best = std::numeric_limits<double>::infinity();
      for (Eigen::Index j = 0; j < aligned_shapes.cols(); ++j) {
        best = std::min(best, meanVertexDistance(x, aligned_shapes.col(j)));
      }
      sum += best;
    }
    r.mean_error_mm[k - 1] = sum / sample_count;
  }
  return r;
}

}  // namespace mrsns::deformation
