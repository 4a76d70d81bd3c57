#pragma once
// Working with a ShapeModel: shapes as vectors and meshes, sampling,
// projection (coefficients of a shape), reconstruction, Mahalanobis distance.

#include <Eigen/Core>
#include <random>
#include <string>

#include "mrsns/core/mesh.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/core/shape_model.h"

namespace mrsns::deformation {

/// Throws InvalidArgumentError when sizes disagree (mean 3N, basis 3N x n,
/// variances n, reference with N vertices), a value is not finite, a variance
/// or the noise variance is negative. `what` names the model in the message.
void validateShapeModel(const ShapeModel& model, const std::string& what = "shape model");

/// Vertices as a shape vector x0 y0 z0 x1 ... (size 3N).
[[nodiscard]] Eigen::VectorXd shapeVector(const PointsN3& vertices);
/// The inverse of shapeVector. Throws InvalidArgumentError when the size is not a multiple of 3.
[[nodiscard]] PointsN3 shapePoints(const Eigen::VectorXd& shape);
/// The model's reference topology with the vertices of `shape`.
[[nodiscard]] TriangleMesh shapeMesh(const ShapeModel& model, const Eigen::VectorXd& shape);

/// mean + basis * diag(sqrt(variances)) * coefficients. Throws InvalidArgumentError
/// when coefficients has more entries than the model has modes (fewer are padded with 0).
[[nodiscard]] Eigen::VectorXd modelInstance(const ShapeModel& model, const Eigen::VectorXd& coefficients);

/// A random shape: coefficients ~ N(0, I), plus isotropic noise of the model's
/// noise variance when `with_noise`.
[[nodiscard]] Eigen::VectorXd sampleShape(const ShapeModel& model, std::mt19937_64& rng, bool with_noise = false);

/// The most probable coefficients of `shape` (probabilistic PCA, as statismo's
/// ComputeCoefficients): alpha_i = sqrt(l_i) / (l_i + noise) * u_i^T (shape - mean).
/// With zero noise this is the orthogonal projection onto the model space.
[[nodiscard]] Eigen::VectorXd projectShape(const ShapeModel& model, const Eigen::VectorXd& shape);

/// modelInstance(projectShape(shape)): the closest shape the model can represent.
[[nodiscard]] Eigen::VectorXd reconstructShape(const ShapeModel& model, const Eigen::VectorXd& shape);

/// |alpha|, the Mahalanobis distance of coefficients from the mean (alpha ~ N(0, I)).
[[nodiscard]] double mahalanobisDistance(const Eigen::VectorXd& coefficients);

/// Mahalanobis distance of a shape: of its projection's coefficients.
[[nodiscard]] double shapeMahalanobisDistance(const ShapeModel& model, const Eigen::VectorXd& shape);

/// Mean Euclidean distance between corresponding vertices of two shape vectors (mm).
[[nodiscard]] double meanVertexDistance(const Eigen::VectorXd& a, const Eigen::VectorXd& b);

}  // namespace mrsns::deformation
