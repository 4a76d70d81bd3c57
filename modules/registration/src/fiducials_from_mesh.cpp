#include "mrsns/registration/fiducials_from_mesh.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>
#include <optional>
#include <random>
#include <sstream>

#include "mrsns/core/dense_solvers.h"
#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/core/mesh_locator.h"
#include "mrsns/registration/label_meshing.h"

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

/// Where the axis c + t * axis meets the bone surface around the screw: a quadric height field
/// w = a + b u + c v + d u^2 + e u v + f v^2 (w along the axis) fitted to the bone vertices at radial distance
/// [radius + 1, radius + 1 + ring_width] from the axis and within the screw's axial extent (grown by the ring's
/// width), evaluated on the axis. Exact for a locally quadratic surface, whatever hole the screw left in it.
std::optional<Eigen::Vector3d> entryFromSurroundingSurface(const TriangleMesh& bone, const PointsN3& bone_normals,
                                                           const Eigen::Vector3d& c, const Eigen::Vector3d& axis,
                                                           double t_lo, double t_hi, double radius,
                                                           const FiducialsFromMeshOptions& options) {
  const Eigen::Vector3d helper = std::abs(axis.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  const Eigen::Vector3d u = axis.cross(helper).normalized();
  const Eigen::Vector3d v = axis.cross(u);
  const double r_in = radius + 1.0, r_out = r_in + options.ring_width_mm;
  std::vector<Eigen::Matrix<double, 6, 1>> rows;
  std::vector<double> heights;
  for (Eigen::Index i = 0; i < bone.vertices.rows(); ++i) {
    const Eigen::Vector3d d = bone.vertices.row(i).transpose() - c;
    const double w = axis.dot(d);
    if (w < t_lo - options.ring_width_mm || w > t_hi + options.ring_width_mm) continue;
    const double x = u.dot(d), y = v.dot(d);
    const double r = std::hypot(x, y);
    if (r < r_in || r > r_out) continue;
    // Only the cortex the screw enters faces its head: the far side of a thin lamina, or the wall of the tunnel
    // the screw left in the segmentation, face elsewhere.
    if (bone_normals.row(i).dot(axis.transpose()) < 0.3) continue;
    Eigen::Matrix<double, 6, 1> row;
    row << 1.0, x, y, x * x, x * y, y * y;
    rows.push_back(row);
    heights.push_back(w);
  }
  if (rows.size() < 12) return std::nullopt;
  Eigen::MatrixXd a(static_cast<Eigen::Index>(rows.size()), 6);
  Eigen::VectorXd b(static_cast<Eigen::Index>(rows.size()));
  for (std::size_t i = 0; i < rows.size(); ++i) {
    a.row(static_cast<Eigen::Index>(i)) = rows[i].transpose();
    b(static_cast<Eigen::Index>(i)) = heights[i];
  }
  const Eigen::VectorXd q = qrLeastSquares(a, b);
  // A surface that is not a single sheet around the screw (two cortices, a fold) fits badly: no estimate then.
  const double rms = std::sqrt((a * q - b).squaredNorm() / static_cast<double>(rows.size()));
  if (!std::isfinite(q(0)) || rms > 0.5 * options.ring_width_mm) return std::nullopt;
  return c + q(0) * axis;
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
  const PointsN3 bone_normals =
      options.entry_from_surrounding_surface ? vertexNormals(bone) : PointsN3(PointsN3::Zero(0, 3));
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
    if (options.entry_from_surrounding_surface) {
      double radius = 0.0;
      for (auto i : members) {
        const Eigen::Vector3d d = screws.vertices.row(i).transpose() - c;
        radius = std::max(radius, (d - axis.dot(d) * axis).norm());
      }
      if (const auto around = entryFromSurroundingSurface(bone, bone_normals, c, axis, t_lo, t_hi, radius, options)) {
        const double disagreement = f.axis_hits_bone ? (f.position - *around).norm() : 1e300;
        if (disagreement > options.surface_agreement_mm) {
          f.position = *around;
          f.entry_from = "surrounding surface";
          f.axis_hits_bone = true;
          best_gap = std::max(0.0, std::max(t_lo - axis.dot(*around - c), axis.dot(*around - c) - t_hi));
        }
      }
    }
    if (!f.axis_hits_bone) {
      f.entry_from = "head";
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

namespace {

/// Sizes of the 26-connected regions of the non-zero voxels of `mask`.
std::vector<std::size_t> maskRegions(const ImageVolume& mask) {
  std::vector<char> seen(mask.voxelCount(), 0);
  std::vector<std::size_t> sizes;
  std::vector<std::array<int, 3>> stack;
  for (int k = 0; k < mask.size[2]; ++k) {
    for (int j = 0; j < mask.size[1]; ++j) {
      for (int i = 0; i < mask.size[0]; ++i) {
        const auto start = mask.linearIndex(i, j, k);
        if (seen[start] || mask.valueAtIndex(start) == 0.0) continue;
        seen[start] = 1;
        stack.push_back({i, j, k});
        std::size_t voxels = 0;
        while (!stack.empty()) {
          const auto [x, y, z] = stack.back();
          stack.pop_back();
          ++voxels;
          for (int dz = -1; dz <= 1; ++dz) {
            for (int dy = -1; dy <= 1; ++dy) {
              for (int dx = -1; dx <= 1; ++dx) {
                if (!mask.contains(x + dx, y + dy, z + dz)) continue;
                const auto q = mask.linearIndex(x + dx, y + dy, z + dz);
                if (seen[q] || mask.valueAtIndex(q) == 0.0) continue;
                seen[q] = 1;
                stack.push_back({x + dx, y + dy, z + dz});
              }
            }
          }
        }
        sizes.push_back(voxels);
      }
    }
  }
  std::sort(sizes.rbegin(), sizes.rend());
  return sizes;
}

}  // namespace

FiducialScrewsInMaskResult findFiducialScrewsInMask(const ImageVolume& mask, const TriangleMesh& bone,
                                                    const FiducialScrewsInMaskOptions& options) {
  if (mask.empty() || mask.data.size() != mask.byteCount()) {
    throw InvalidArgumentError("find fiducials: the screw mask is empty or inconsistent");
  }
  if (options.count < 0) throw InvalidArgumentError("find fiducials: the screw count must be >= 0 (0 = one per region)");
  FiducialScrewsInMaskResult result;
  for (const auto size : maskRegions(mask)) {
    if (size >= options.min_voxels) result.region_voxels.push_back(size);
  }
  result.regions = static_cast<int>(result.region_voxels.size());
  if (result.regions == 0) {
    throw ComputationError("find fiducials: the mask holds no region of at least " +
                           std::to_string(options.min_voxels) + " voxels: there is no screw to find there");
  }
  const int count = options.count > 0 ? options.count : result.regions;
  if (count > result.regions) {
    throw ComputationError("find fiducials: " + std::to_string(count) + " screws asked for, but the mask holds " +
                           std::to_string(result.regions) + " separate region(s): screws that touch merge into one "
                           "region; give count= the number of screws only if some touch");
  }
  LabelMeshOptions mesh_options;
  mesh_options.smoothing_iterations = 0;  // a 2 mm shaft is a few voxels wide: smoothing would shrink it away
  mesh_options.scheme = LabelScheme::Generic;
  ImageVolume binary = mask;
  if (binary.pixel_type != PixelType::UInt8) {
    binary.pixel_type = PixelType::UInt8;
    binary.data.assign(mask.voxelCount(), std::byte{0});
    for (std::size_t i = 0; i < mask.voxelCount(); ++i) {
      if (mask.valueAtIndex(i) != 0.0) binary.data[i] = std::byte{1};
    }
  } else {
    for (auto& b : binary.data) b = b == std::byte{0} ? std::byte{0} : std::byte{1};
  }
  const auto screws = meshLabelMap(binary, mesh_options);
  result.found = findFiducialsFromMeshes(screws.meshes.at(0).mesh, bone, count, options.mesh);
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
