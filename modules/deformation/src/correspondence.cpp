#include "mrsns/deformation/correspondence.h"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <string>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/core/point_locator.h"
#include "mrsns/registration/paired_point.h"
#include "mrsns/registration/surface_registration.h"

namespace mrsns::deformation {
namespace {

std::vector<Eigen::Vector3d> rowsOf(const PointsN3& p) {
  std::vector<Eigen::Vector3d> v(static_cast<std::size_t>(p.rows()));
  for (Eigen::Index i = 0; i < p.rows(); ++i) v[static_cast<std::size_t>(i)] = p.row(i).transpose();
  return v;
}

std::vector<std::pair<int, int>> uniqueEdges(const TriangleMesh& mesh) {
  std::vector<std::pair<int, int>> edges;
  edges.reserve(static_cast<std::size_t>(3 * mesh.faceCount()));
  for (Eigen::Index f = 0; f < mesh.faceCount(); ++f) {
    for (int k = 0; k < 3; ++k) {
      int a = mesh.faces(f, k), b = mesh.faces(f, (k + 1) % 3);
      if (a > b) std::swap(a, b);
      if (a != b) edges.emplace_back(a, b);
    }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  return edges;
}

// The rigid stage: landmarks or principal axes, ICP, then (optionally) a
// trimmed similarity refinement on closest points.
Eigen::Affine3d rigidStage(const TriangleMesh& reference, const registration::IcpSurface& surface,
                           const NonRigidFitOptions& o, std::span<const Eigen::Vector3d> ref_lm,
                           std::span<const Eigen::Vector3d> ex_lm) {
  const std::vector<Eigen::Vector3d> pts = rowsOf(reference.vertices);
  Eigen::Isometry3d start = Eigen::Isometry3d::Identity();
  if (!ref_lm.empty()) {
    start = registration::initialAlignmentFromLandmarks(ref_lm, ex_lm);
  } else {
    start = registration::initialAlignmentFromPrincipalAxes(pts, surface).fixed_T_moving;
  }
  registration::IcpOptions icp;
  icp.trim_fraction = 0.9;
  const registration::IcpResult r = registration::registerSurface(pts, surface, start, icp);
  Eigen::Affine3d t(r.fixed_T_moving.matrix());
  if (!o.estimate_scale) return t;
  registration::PairedPointOptions pp;
  pp.estimate_scale = true;
  pp.leave_one_out = false;
  std::vector<std::pair<double, std::size_t>> order(pts.size());
  std::vector<Eigen::Vector3d> moving, fixed;
  for (int it = 0; it < o.rigid_iterations; ++it) {
    std::vector<Eigen::Vector3d> closest(pts.size());
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const SurfacePoint sp = surface.locator().closestPoint(t * pts[i]);
      closest[i] = sp.point;
      order[i] = {sp.distance, i};
    }
    const std::size_t keep = std::max<std::size_t>(3, static_cast<std::size_t>(0.9 * static_cast<double>(pts.size())));
    std::nth_element(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(keep - 1), order.end());
    moving.clear();
    fixed.clear();
    for (std::size_t k = 0; k < keep; ++k) {
      moving.push_back(pts[order[k].second]);
      fixed.push_back(closest[order[k].second]);
    }
    const Eigen::Affine3d next = registration::registerPairedPoints(moving, fixed, pp).fixed_T_moving;
    const double change = (next.matrix() - t.matrix()).cwiseAbs().maxCoeff();
    t = next;
    if (change < 1e-7) break;
  }
  return t;
}

}  // namespace

NonRigidFitResult fitReferenceToExample(const TriangleMesh& reference, const TriangleMesh& example,
                                        const NonRigidFitOptions& o,
                                        std::span<const Eigen::Vector3d> reference_landmarks,
                                        std::span<const Eigen::Vector3d> example_landmarks) {
  validateMesh(reference, "reference mesh");
  validateMesh(example, "example mesh");
  if (reference.empty() || example.empty()) {
    throw InvalidArgumentError("fitReferenceToExample: the reference and the example need vertices and faces");
  }
  if (reference_landmarks.size() != example_landmarks.size() ||
      (!reference_landmarks.empty() && reference_landmarks.size() < 3)) {
    throw InvalidArgumentError(
        "fitReferenceToExample: give the same number (>= 3) of reference and example landmarks (" +
        std::to_string(reference_landmarks.size()) + " vs " + std::to_string(example_landmarks.size()) + "), or none");
  }
  if (o.stiffness.empty() || o.iterations_per_stiffness < 1) {
    throw InvalidArgumentError(
        "fitReferenceToExample: the stiffness schedule must hold at least one value and "
        "iterations_per_stiffness must be >= 1");
  }
  for (double a : o.stiffness) {
    if (!(a > 0.0) || !std::isfinite(a))
      throw InvalidArgumentError("fitReferenceToExample: stiffness values must be > 0");
  }
  NonRigidFitResult result;
  const registration::IcpSurface surface(example);
  result.example_T_reference = rigidStage(reference, surface, o, reference_landmarks, example_landmarks);
  result.scale = std::cbrt(std::abs(result.example_T_reference.linear().determinant()));

  const Eigen::Index n = reference.vertexCount();
  PointsN3 x0(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    x0.row(i) = (result.example_T_reference * Eigen::Vector3d(reference.vertices.row(i).transpose())).transpose();
  }
  const auto edges = uniqueEdges(reference);
  double edge_sum = 0.0;
  for (const auto& [a, b] : edges) edge_sum += (x0.row(a) - x0.row(b)).norm();
  result.mean_edge_length_mm = edges.empty() ? 0.0 : edge_sum / static_cast<double>(edges.size());
  result.rigid_mean_distance_mm = pointsToSurfaceDistance(x0, surface.locator()).mean;

  for (std::size_t k = 0; k < reference_landmarks.size(); ++k) {
    const Eigen::Vector3d p = reference_landmarks[k];
    Eigen::Index best = 0;
    (reference.vertices.rowwise() - p.transpose()).rowwise().squaredNorm().minCoeff(&best);
    result.landmark_vertices.push_back(static_cast<int>(best));
    result.rigid_landmark_error_mm.push_back((x0.row(best).transpose() - example_landmarks[k]).norm());
  }

  // Graph Laplacian of the reference (the stiffness term), pattern fixed.
  std::vector<Eigen::Triplet<double>> lap;
  lap.reserve(4 * edges.size() + static_cast<std::size_t>(n));
  for (const auto& [a, b] : edges) {
    lap.emplace_back(a, a, 1.0);
    lap.emplace_back(b, b, 1.0);
    lap.emplace_back(a, b, -1.0);
    lap.emplace_back(b, a, -1.0);
  }
  for (Eigen::Index i = 0; i < n; ++i) lap.emplace_back(static_cast<int>(i), static_cast<int>(i), 0.0);
  Eigen::SparseMatrix<double> laplacian(n, n);
  laplacian.setFromTriplets(lap.begin(), lap.end());
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver;
  solver.analyzePattern(laplacian);

  const double max_distance = o.max_distance_mm > 0.0
                                  ? o.max_distance_mm
                                  : 5.0 * result.mean_edge_length_mm + 3.0 * result.rigid_mean_distance_mm;
  const double cos_max = std::cos(o.max_normal_angle_rad);
  const PointsN3 example_normals = vertexNormals(example);
  const PointsN3& face_normals = surface.faceNormals();
  const double reverse_weight = static_cast<double>(n) / static_cast<double>(example.vertexCount());

  Eigen::MatrixXd d = Eigen::MatrixXd::Zero(n, 3);
  TriangleMesh current = reference;
  current.frame = example.frame;
  for (double alpha : o.stiffness) {
    for (int it = 0; it < o.iterations_per_stiffness; ++it) {
      current.vertices = x0 + d;
      const PointsN3 normals = vertexNormals(current);
      Eigen::VectorXd w = Eigen::VectorXd::Zero(n);
      Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(n, 3);
      for (Eigen::Index i = 0; i < n; ++i) {
        const Eigen::Vector3d x = current.vertices.row(i).transpose();
        const SurfacePoint sp = surface.locator().closestPointWithin(x, max_distance);
        if (sp.face < 0) continue;
        const Eigen::Vector3d fn = face_normals.row(sp.face).transpose();
        if (normals.row(i).dot(fn.transpose()) < cos_max) continue;
        w[i] += 1.0;
        rhs.row(i) += (sp.point.transpose() - x0.row(i));
      }
      if (o.symmetric) {
        const PointLocator nearest(current.vertices);
        for (Eigen::Index j = 0; j < example.vertexCount(); ++j) {
          const Eigen::Vector3d t = example.vertices.row(j).transpose();
          const PointNeighbor nb = nearest.nearest(t);
          if (nb.distance > max_distance) continue;
          if (normals.row(nb.index).dot(example_normals.row(j)) < cos_max) continue;
          w[nb.index] += reverse_weight;
          rhs.row(nb.index) += reverse_weight * (t.transpose() - x0.row(nb.index));
        }
      }
      for (std::size_t k = 0; k < result.landmark_vertices.size() && o.landmark_weight > 0.0; ++k) {
        const int v = result.landmark_vertices[k];
        w[v] += o.landmark_weight;
        rhs.row(v) += o.landmark_weight * (example_landmarks[k].transpose() - x0.row(v));
      }
      // A vanishing diagonal term keeps vertices without correspondences
      // (and the matrix) well posed: they follow their neighbours.
      Eigen::SparseMatrix<double> a = alpha * laplacian;
      a.diagonal() += (w.array() + 1e-6).matrix();
      solver.factorize(a);
      if (solver.info() != Eigen::Success) {
        throw ComputationError("fitReferenceToExample: the non-rigid system could not be factorised");
      }
      d = solver.solve(rhs);
      ++result.iterations;
    }
  }
  current.vertices = x0 + d;
  current.normals.resize(0, 3);
  result.fitted = std::move(current);
  result.fitted_to_example = pointsToSurfaceDistance(result.fitted.vertices, surface.locator());
  result.example_to_fitted = pointsToSurfaceDistance(example.vertices, result.fitted);
  for (std::size_t k = 0; k < result.landmark_vertices.size(); ++k) {
    result.landmark_error_mm.push_back(
        (result.fitted.vertices.row(result.landmark_vertices[k]).transpose() - example_landmarks[k]).norm());
  }
  logger()->debug("non-rigid fit: scale {:.4f}, rigid mean {:.3f} mm, fitted mean {:.3f} / {:.3f} mm, {} iterations",
                  result.scale, result.rigid_mean_distance_mm, result.fitted_to_example.mean,
                  result.example_to_fitted.mean, result.iterations);
  return result;
}

std::vector<NonRigidFitResult> establishCorrespondence(const TriangleMesh& reference,
                                                       std::span<const TriangleMesh> examples,
                                                       const NonRigidFitOptions& options,
                                                       std::span<const std::vector<Eigen::Vector3d>> example_landmarks,
                                                       std::span<const Eigen::Vector3d> reference_landmarks) {
  if (!example_landmarks.empty() && example_landmarks.size() != examples.size()) {
    throw InvalidArgumentError("establishCorrespondence: give one landmark set per example (" +
                               std::to_string(example_landmarks.size()) + " sets for " +
                               std::to_string(examples.size()) + " examples), or none");
  }
  std::vector<NonRigidFitResult> fits;
  fits.reserve(examples.size());
  for (std::size_t i = 0; i < examples.size(); ++i) {
    if (example_landmarks.empty()) {
      fits.push_back(fitReferenceToExample(reference, examples[i], options));
    } else {
      fits.push_back(fitReferenceToExample(reference, examples[i], options, reference_landmarks, example_landmarks[i]));
    }
  }
  return fits;
}

}  // namespace mrsns::deformation
