#include "mrsns/registration/fiducials_from_mesh.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <sstream>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/core/mesh_locator.h"

namespace mrsns::registration {
namespace {

struct Clustering {
  PointsN3 centres;
  std::vector<int> labels;
  double inertia = 0.0;
  int iterations = 0;
};

// k-means++: each next centre drawn with probability proportional to the
// squared distance to the nearest centre chosen so far.
PointsN3 seedPlusPlus(const PointsN3& x, int k, std::mt19937_64& rng) {
  const Eigen::Index n = x.rows();
  PointsN3 c(k, 3);
  std::uniform_int_distribution<Eigen::Index> first(0, n - 1);
  c.row(0) = x.row(first(rng));
  std::vector<double> d2(static_cast<std::size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) d2[static_cast<std::size_t>(i)] = (x.row(i) - c.row(0)).squaredNorm();
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  for (int j = 1; j < k; ++j) {
    const double total = std::accumulate(d2.begin(), d2.end(), 0.0);
    Eigen::Index pick = 0;
    if (total > 0.0) {
      double r = uniform(rng) * total;
      for (pick = 0; pick < n - 1; ++pick) {
        r -= d2[static_cast<std::size_t>(pick)];
        if (r <= 0.0) break;
      }
    } else {
      pick = first(rng);  // all points coincide with centres: any will do
    }
    c.row(j) = x.row(pick);
    for (Eigen::Index i = 0; i < n; ++i) {
      d2[static_cast<std::size_t>(i)] = std::min(d2[static_cast<std::size_t>(i)], (x.row(i) - c.row(j)).squaredNorm());
    }
  }
  return c;
}

Clustering lloyd(const PointsN3& x, PointsN3 c, int max_iterations) {
  const Eigen::Index n = x.rows();
  const auto k = c.rows();
  Clustering out;
  out.labels.assign(static_cast<std::size_t>(n), -1);
  for (int it = 0; it < max_iterations; ++it) {
    bool changed = false;
    out.inertia = 0.0;
    for (Eigen::Index i = 0; i < n; ++i) {
      int best = 0;
      double best_d = std::numeric_limits<double>::infinity();
      for (Eigen::Index j = 0; j < k; ++j) {
        const double d = (x.row(i) - c.row(j)).squaredNorm();
        if (d < best_d) {
          best_d = d;
          best = static_cast<int>(j);
        }
      }
      out.inertia += best_d;
      if (out.labels[static_cast<std::size_t>(i)] != best) {
        out.labels[static_cast<std::size_t>(i)] = best;
        changed = true;
      }
    }
    out.iterations = it + 1;
    if (!changed && it > 0) break;
    PointsN3 sum = PointsN3::Zero(k, 3);
    std::vector<int> count(static_cast<std::size_t>(k), 0);
    for (Eigen::Index i = 0; i < n; ++i) {
      const int l = out.labels[static_cast<std::size_t>(i)];
      sum.row(l) += x.row(i);
      ++count[static_cast<std::size_t>(l)];
    }
    for (Eigen::Index j = 0; j < k; ++j) {
      // An emptied cluster keeps its centre; a later assignment may refill it.
      if (count[static_cast<std::size_t>(j)] > 0) c.row(j) = sum.row(j) / count[static_cast<std::size_t>(j)];
    }
  }
  out.centres = c;
  return out;
}

}  // namespace

KMeansResult kMeans(const PointsN3& points, int k, const KMeansOptions& options) {
  if (k < 1) throw InvalidArgumentError("k-means: the number of clusters must be >= 1, got " + std::to_string(k));
  if (points.rows() < k) {
    throw InvalidArgumentError("k-means: " + std::to_string(k) + " clusters requested but only " +
                               std::to_string(points.rows()) +
                               " points given: check the number of fiducials and the screw mesh");
  }
  if (!points.allFinite()) throw InvalidArgumentError("k-means: the points hold NaN or infinite values");
  if (options.restarts < 1 || options.max_iterations < 1) {
    throw InvalidArgumentError("k-means: restarts and max_iterations must be >= 1");
  }
  std::mt19937_64 rng(options.seed);
  Clustering best;
  best.inertia = std::numeric_limits<double>::infinity();
  for (int r = 0; r < options.restarts; ++r) {
    auto run = lloyd(points, seedPlusPlus(points, k, rng), options.max_iterations);
    if (run.inertia < best.inertia) best = std::move(run);
  }
  // Canonical order: by centre coordinates (lexicographic).
  std::vector<int> order(static_cast<std::size_t>(k));
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    for (int d = 0; d < 3; ++d) {
      if (best.centres(a, d) != best.centres(b, d)) return best.centres(a, d) < best.centres(b, d);
    }
    return a < b;
  });
  std::vector<int> rank(static_cast<std::size_t>(k));
  KMeansResult result;
  result.centres.resize(k, 3);
  for (int j = 0; j < k; ++j) {
    rank[static_cast<std::size_t>(order[static_cast<std::size_t>(j)])] = j;
    result.centres.row(j) = best.centres.row(order[static_cast<std::size_t>(j)]);
  }
  result.labels.resize(best.labels.size());
  result.sizes.assign(static_cast<std::size_t>(k), 0);
  for (std::size_t i = 0; i < best.labels.size(); ++i) {
    result.labels[i] = rank[static_cast<std::size_t>(best.labels[i])];
    ++result.sizes[static_cast<std::size_t>(result.labels[i])];
  }
  result.inertia = best.inertia;
  result.iterations = best.iterations;
  return result;
}

FiducialsFromMeshResult findFiducialsFromMeshes(const TriangleMesh& screws, const TriangleMesh& bone, int count,
                                                const FiducialsFromMeshOptions& options) {
  if (screws.vertexCount() == 0) {
    throw InvalidArgumentError("find fiducials: the screw mesh '" + screws.name +
                               "' has no vertices: check the screw segmentation threshold");
  }
  validateMesh(screws, "screw mesh '" + screws.name + "'");
  if (bone.empty()) {
    throw InvalidArgumentError("find fiducials: the bone mesh '" + bone.name +
                               "' has no triangles: give the bone surface mesh");
  }
  if (count < 1 || count > screws.vertexCount()) {
    throw InvalidArgumentError("find fiducials: cannot find " + std::to_string(count) +
                               " fiducials in a screw mesh of " + std::to_string(screws.vertexCount()) +
                               " vertices: give the number of screws (>= 1)");
  }
  const MeshLocator locator(bone);
  FiducialsFromMeshResult result;
  result.clusters = kMeans(screws.vertices, count, options.kmeans);
  const double mean_size = static_cast<double>(screws.vertexCount()) / count;

  for (int j = 0; j < count; ++j) {
    std::vector<Eigen::Index> members;
    for (std::size_t i = 0; i < result.clusters.labels.size(); ++i) {
      if (result.clusters.labels[i] == j) members.push_back(static_cast<Eigen::Index>(i));
    }
    DetectedFiducial f;
    f.label = "F-" + std::to_string(j + 1);
    f.vertex_count = static_cast<int>(members.size());
    f.size_balance = std::min<double>(f.vertex_count, mean_size) / std::max<double>(f.vertex_count, mean_size);
    if (members.empty()) {
      f.position = result.clusters.centres.row(j).transpose();
      f.hit_distance_mm = std::numeric_limits<double>::quiet_NaN();
      result.fiducials.push_back(f);
      continue;
    }
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (auto i : members) c += screws.vertices.row(i).transpose();
    c /= static_cast<double>(members.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (auto i : members) {
      const Eigen::Vector3d d = screws.vertices.row(i).transpose() - c;
      cov += d * d.transpose();
    }
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov / static_cast<double>(members.size()));
    Eigen::Vector3d axis = eig.eigenvectors().col(2);
    f.elongation = std::sqrt(eig.eigenvalues()(2) / std::max(eig.eigenvalues()(1), 1e-12));
    double t_lo = std::numeric_limits<double>::infinity();
    double t_hi = -t_lo;
    for (auto i : members) {
      const double t = axis.dot(screws.vertices.row(i).transpose() - c);
      t_lo = std::min(t_lo, t);
      t_hi = std::max(t_hi, t);
    }
    // The head is the end outside the bone (larger signed distance).
    const auto outside = [&](double t) { return locator.signedClosestPoint(c + t * axis, true).signed_distance; };
    if (outside(t_lo) > outside(t_hi)) {
      axis = -axis;
      std::swap(t_lo, t_hi);
      t_lo = -t_lo;
      t_hi = -t_hi;
    }
    f.axis = axis;
    f.cluster_centroid = c;
    f.head_point = c + t_hi * axis;
    // The bone crossing nearest to the screw: within its extent if any.
    double best_gap = std::numeric_limits<double>::infinity();
    double best_abs_t = std::numeric_limits<double>::infinity();
    for (const auto& hit : locator.intersectLine(c, axis)) {
      const double gap = hit.t < t_lo ? t_lo - hit.t : (hit.t > t_hi ? hit.t - t_hi : 0.0);
      if (gap < best_gap || (gap == best_gap && std::abs(hit.t) < best_abs_t)) {
        best_gap = gap;
        best_abs_t = std::abs(hit.t);
        f.position = hit.point;
      }
    }
    f.axis_hits_bone = best_gap <= options.max_hit_distance_mm;
    if (!f.axis_hits_bone) {
      f.position = f.head_point;
      f.hit_distance_mm = std::isfinite(best_gap) ? best_gap : std::numeric_limits<double>::quiet_NaN();
      logger()->warn("find fiducials: the axis of {} misses the bone within {} mm; using the screw-head end point",
                     f.label, options.max_hit_distance_mm);
    } else {
      f.hit_distance_mm = best_gap;
    }
    const double elongation_score = std::clamp((f.elongation - 1.0) / (options.good_elongation - 1.0), 0.0, 1.0);
    const double hit_score = f.axis_hits_bone ? std::exp(-f.hit_distance_mm / 5.0) : 0.25;
    f.confidence = f.size_balance * elongation_score * hit_score;
    result.fiducials.push_back(f);
  }
  return result;
}

LandmarkSet fiducialLandmarks(const FiducialsFromMeshResult& result, const std::string& frame) {
  LandmarkSet set;
  set.name = "Fiducials";
  set.frame = frame;
  for (const auto& f : result.fiducials) {
    Landmark l;
    l.label = f.label;
    l.position = f.position;
    std::ostringstream d;
    d.precision(3);
    d << "confidence=" << f.confidence << "; vertices=" << f.vertex_count << "; elongation=" << f.elongation
      << (f.axis_hits_bone ? "; axis-bone intersection" : "; axis misses bone: screw-head end point");
    l.description = d.str();
    set.points.push_back(l);
  }
  return set;
}

}  // namespace mrsns::registration
