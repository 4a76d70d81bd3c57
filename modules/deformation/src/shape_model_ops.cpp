#include "mrsns/deformation/shape_model_ops.h"

#include <cmath>

#include "mrsns/core/error.h"

namespace mrsns::deformation {

void validateShapeModel(const ShapeModel& model, const std::string& what) {
  const Eigen::Index dim = model.mean.size();
  if (dim == 0 || dim % 3 != 0) {
    throw InvalidArgumentError(what + ": mean has " + std::to_string(dim) +
                               " entries; expected 3 per point (x0 y0 z0 x1 ...), at least one point");
  }
  if (model.basis.rows() != dim) {
    throw InvalidArgumentError(what + ": basis has " + std::to_string(model.basis.rows()) + " rows but the mean has " +
                               std::to_string(dim) + " entries; they must match");
  }
  if (model.variances.size() != model.basis.cols()) {
    throw InvalidArgumentError(what + ": " + std::to_string(model.variances.size()) + " variances for " +
                               std::to_string(model.basis.cols()) + " basis columns; give one per column");
  }
  if (model.reference.vertexCount() != dim / 3) {
    throw InvalidArgumentError(what + ": reference mesh has " + std::to_string(model.reference.vertexCount()) +
                               " vertices but the model has " + std::to_string(dim / 3) + " points");
  }
  if (!model.mean.allFinite() || !model.basis.allFinite() || !model.variances.allFinite() ||
      !std::isfinite(model.noise_variance)) {
    throw InvalidArgumentError(what + ": contains NaN or infinite values");
  }
  if ((model.variances.array() < 0.0).any() || model.noise_variance < 0.0) {
    throw InvalidArgumentError(what + ": negative variance; variances must be >= 0");
  }
  validateMesh(model.reference, what + " reference");
}

Eigen::VectorXd shapeVector(const PointsN3& vertices) {
  Eigen::VectorXd v(vertices.rows() * 3);
  for (Eigen::Index i = 0; i < vertices.rows(); ++i) v.segment<3>(3 * i) = vertices.row(i).transpose();
  return v;
}

PointsN3 shapePoints(const Eigen::VectorXd& shape) {
  if (shape.size() % 3 != 0) {
    throw InvalidArgumentError("shape vector has " + std::to_string(shape.size()) +
                               " entries; expected 3 per point (x0 y0 z0 x1 ...)");
  }
  PointsN3 p(shape.size() / 3, 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i) p.row(i) = shape.segment<3>(3 * i).transpose();
  return p;
}

TriangleMesh shapeMesh(const ShapeModel& model, const Eigen::VectorXd& shape) {
  TriangleMesh mesh;
  mesh.vertices = shapePoints(shape);
  mesh.faces = model.reference.faces;
  mesh.frame = model.reference.frame;
  mesh.name = model.reference.name;
  return mesh;
}

namespace {
void requireShapeSize(const ShapeModel& model, const Eigen::VectorXd& shape, const char* what) {
  if (shape.size() != model.mean.size()) {
    throw InvalidArgumentError(std::string(what) + ": shape has " + std::to_string(shape.size()) +
                               " entries but the model has " + std::to_string(model.mean.size()) +
                               " (3 per point); use shapes in correspondence with the model reference");
  }
}
}  // namespace

Eigen::VectorXd modelInstance(const ShapeModel& model, const Eigen::VectorXd& coefficients) {
  if (coefficients.size() > model.modeCount()) {
    throw InvalidArgumentError("modelInstance: " + std::to_string(coefficients.size()) +
                               " coefficients for a model with " + std::to_string(model.modeCount()) + " modes");
  }
  const Eigen::Index k = coefficients.size();
  const Eigen::VectorXd scaled = model.variances.head(k).array().sqrt() * coefficients.array();
  return model.mean + model.basis.leftCols(k) * scaled;
}

Eigen::VectorXd sampleShape(const ShapeModel& model, std::mt19937_64& rng, bool with_noise) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::VectorXd alpha(model.modeCount());
  for (Eigen::Index i = 0; i < alpha.size(); ++i) alpha[i] = normal(rng);
  Eigen::VectorXd shape = modelInstance(model, alpha);
  if (with_noise && model.noise_variance > 0.0) {
    const double s = std::sqrt(model.noise_variance);
    for (Eigen::Index i = 0; i < shape.size(); ++i) shape[i] += s * normal(rng);
  }
  return shape;
}

Eigen::VectorXd projectShape(const ShapeModel& model, const Eigen::VectorXd& shape) {
  requireShapeSize(model, shape, "projectShape");
  const Eigen::VectorXd u_t_d = model.basis.transpose() * (shape - model.mean);
  Eigen::VectorXd alpha(model.modeCount());
  for (Eigen::Index i = 0; i < alpha.size(); ++i) {
    const double l = model.variances[i];
    const double denom = l + model.noise_variance;
    // A zero-variance mode cannot explain anything: its coefficient is 0.
    alpha[i] = denom > 0.0 ? std::sqrt(l) / denom * u_t_d[i] : 0.0;
  }
  return alpha;
}

Eigen::VectorXd reconstructShape(const ShapeModel& model, const Eigen::VectorXd& shape) {
  return modelInstance(model, projectShape(model, shape));
}

double mahalanobisDistance(const Eigen::VectorXd& coefficients) {
  return coefficients.norm();
}

double shapeMahalanobisDistance(const ShapeModel& model, const Eigen::VectorXd& shape) {
  return mahalanobisDistance(projectShape(model, shape));
}

double meanVertexDistance(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  if (a.size() != b.size() || a.size() % 3 != 0 || a.size() == 0) {
    throw InvalidArgumentError("meanVertexDistance: shapes of " + std::to_string(a.size()) + " and " +
                               std::to_string(b.size()) + " entries; need equal non-zero multiples of 3");
  }
  double sum = 0.0;
  for (Eigen::Index i = 0; i < a.size(); i += 3) sum += (a.segment<3>(i) - b.segment<3>(i)).norm();
  return sum / static_cast<double>(a.size() / 3);
}

}  // namespace mrsns::deformation
