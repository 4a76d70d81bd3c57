#include "mrsns/registration/surface_registration.h"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <string>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/core/parallel.h"
#include "mrsns/core/rigid.h"
#include "mrsns/registration/paired_point.h"

namespace mrsns::registration {
namespace {

struct Correspondence {
  int index = 0;          // moving point
  Eigen::Vector3d p;      // moving point in the fixed frame (current estimate)
  Eigen::Vector3d q;      // closest surface point
  Eigen::Vector3d n;      // unit normal of the face holding q
  double distance = 0.0;  // |p - q|
  double weight = 1.0;
};

void checkOptions(const IcpOptions& o) {
  if (o.max_iterations < 0) throw InvalidArgumentError("ICP: max_iterations must be >= 0");
  if (!(o.max_correspondence_distance_mm > 0.0)) {
    throw InvalidArgumentError("ICP: max_correspondence_distance_mm must be > 0 (use infinity to keep all)");
  }
  if (!(o.trim_fraction > 0.0 && o.trim_fraction <= 1.0)) {
    throw InvalidArgumentError("ICP: trim_fraction must be in (0, 1], got " + std::to_string(o.trim_fraction));
  }
  if (!(o.min_robust_scale_mm > 0.0)) throw InvalidArgumentError("ICP: min_robust_scale_mm must be > 0");
}

void checkPoints(std::span<const Eigen::Vector3d> moving) {
  if (moving.size() < 3) {
    throw InvalidArgumentError("ICP needs at least 3 moving points, got " + std::to_string(moving.size()) +
                               ": give more surface points");
  }
  for (std::size_t i = 0; i < moving.size(); ++i) {
    if (!moving[i].allFinite()) {
      throw InvalidArgumentError("ICP: moving point " + std::to_string(i) +
                                 " is NaN or infinite: remove invalid points before registering");
    }
  }
}

double defaultK(RobustLoss loss) {
  return loss == RobustLoss::Tukey ? 4.685 : 1.345;
}

double robustWeight(RobustLoss loss, double r, double c) {
  switch (loss) {
    case RobustLoss::Huber: return r <= c ? 1.0 : c / r;
    case RobustLoss::Tukey: {
      if (r >= c) return 0.0;
      const double u = 1.0 - (r / c) * (r / c);
      return u * u;
    }
    case RobustLoss::None: break;
  }
  return 1.0;
}

// The closest surface point to p. `bound` is a distance within which a
// surface point is known to exist (the previous correspondence moved with
// the points): searching only that far is exact and prunes most of the BVH.
SurfacePoint closest(const MeshLocator& locator, const Eigen::Vector3d& p, double bound, double max_distance) {
  if (bound < max_distance) {
    SurfacePoint sp = locator.closestPointWithin(p, bound * (1.0 + 1e-9) + 1e-9);
    if (sp.face >= 0) return sp;
  }
  if (std::isfinite(max_distance)) return locator.closestPointWithin(p, max_distance);
  return locator.closestPoint(p);
}

// The points in Morton (Z-curve) order of their positions: consecutive
// queries then walk nearly the same BVH path and find it in cache. A random
// order (points sampled anywhere on a 151k-triangle surface) misses the
// cache at almost every level of the tree and costs several times more.
std::vector<std::uint32_t> spatialOrder(std::span<const Eigen::Vector3d> points) {
  Eigen::Vector3d lo = points.front(), hi = points.front();
  for (const auto& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const Eigen::Vector3d extent = (hi - lo).cwiseMax(1e-12);
  auto spread = [](std::uint64_t x) {  // 21 bits -> every third bit
    x &= 0x1fffffULL;
    x = (x | (x << 32)) & 0x1f00000000ffffULL;
    x = (x | (x << 16)) & 0x1f0000ff0000ffULL;
    x = (x | (x << 8)) & 0x100f00f00f00f00fULL;
    x = (x | (x << 4)) & 0x10c30c30c30c30c3ULL;
    x = (x | (x << 2)) & 0x1249249249249249ULL;
    return x;
  };
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d u = ((points[i] - lo).cwiseQuotient(extent) * 2097151.0).cwiseMax(0.0).cwiseMin(2097151.0);
    keyed[i] = {spread(static_cast<std::uint64_t>(u.x())) | (spread(static_cast<std::uint64_t>(u.y())) << 1) |
                    (spread(static_cast<std::uint64_t>(u.z())) << 2),
                static_cast<std::uint32_t>(i)};
  }
  std::sort(keyed.begin(), keyed.end());
  std::vector<std::uint32_t> order(points.size());
  for (std::size_t i = 0; i < keyed.size(); ++i) order[i] = keyed[i].second;
  return order;
}

// Correspondences of the transformed points, after distance rejection,
// trimming and robust weighting. `previous` (per point, the last closest
// point, NaN when unknown) speeds up the search and is updated.
std::vector<Correspondence> correspond(std::span<const Eigen::Vector3d> moving, const IcpSurface& fixed,
                                       const Eigen::Isometry3d& T, const IcpOptions& options,
                                       std::vector<Eigen::Vector3d>& previous, std::vector<SurfacePoint>& found,
                                       const std::vector<std::uint32_t>& order,
                                       const std::vector<std::uint32_t>& by_index) {
  // The queries are independent: found in parallel (each thread a run of the
  // spatial order) into per-point slots, gathered in index order (the same
  // result for any thread count). Only the points of `order` (the same
  // points as `by_index`) take part.
  found.resize(moving.size());
  const double inf = std::numeric_limits<double>::infinity();
  parallelForBlocks(
      0, order.size(),
      [&](std::size_t first, std::size_t last) {
        // Any surface point bounds the distance to the closest one: this
        // point's last closest point moved with the points, or the closest
        // point just found for its neighbour in the spatial order (the
        // tighter while a step moves the points far, and on the first pass).
        // The bound only prunes the search: the result is the same.
        Eigen::Vector3d neighbour_closest = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
        for (std::size_t n = first; n < last; ++n) {
          const std::size_t i = order[n];
          const Eigen::Vector3d p = T * moving[i];
          double bound = previous[i].allFinite() ? (p - previous[i]).norm() : inf;
          if (neighbour_closest.allFinite()) bound = std::min(bound, (p - neighbour_closest).norm());
          found[i] = closest(fixed.locator(), p, bound, options.max_correspondence_distance_mm);
          if (found[i].face >= 0) neighbour_closest = found[i].point;
        }
      },
      options.threads, 256);
  std::vector<Correspondence> c;
  c.reserve(by_index.size());
  for (const std::uint32_t i : by_index) {
    const SurfacePoint& sp = found[i];
    if (sp.face < 0 || sp.distance > options.max_correspondence_distance_mm) {
      previous[i].setConstant(std::numeric_limits<double>::quiet_NaN());
      continue;
    }
    previous[i] = sp.point;
    Correspondence k;
    k.index = static_cast<int>(i);
    k.p = T * moving[i];
    k.q = sp.point;
    // The plane's normal is the gradient of the distance to the surface at
    // the point: the face's normal when the closest point is inside a face,
    // the direction to it when it is on an edge or a corner (where the
    // faces' normals jump, and steps would otherwise bounce between them).
    const bool on_feature = sp.barycentric.minCoeff() == 0.0;
    if (on_feature && sp.distance > 1e-9) {
      k.n = (k.p - sp.point) / sp.distance;
    } else {
      k.n = fixed.faceNormals().row(sp.face).transpose();
    }
    k.distance = sp.distance;
    c.push_back(k);
  }
  if (options.trim_fraction < 1.0) {
    const auto keep = std::max<std::size_t>(
        3, static_cast<std::size_t>(std::llround(options.trim_fraction * static_cast<double>(by_index.size()))));
    if (keep < c.size()) {
      // Ties broken by index so the kept set never depends on the sort's whims.
      auto closer = [](const Correspondence& a, const Correspondence& b) {
        return a.distance < b.distance || (a.distance == b.distance && a.index < b.index);
      };
      std::nth_element(c.begin(), c.begin() + static_cast<std::ptrdiff_t>(keep), c.end(), closer);
      c.resize(keep);
      std::sort(c.begin(), c.end(), [](const auto& a, const auto& b) { return a.index < b.index; });
    }
  }
  if (options.loss != RobustLoss::None && !c.empty()) {
    std::vector<double> d(c.size());
    for (std::size_t i = 0; i < c.size(); ++i) d[i] = c[i].distance;
    auto mid = d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2);
    std::nth_element(d.begin(), mid, d.end());
    // Distances are |residuals|, so their median is the MAD of a zero-mean residual.
    const double scale = std::max(1.4826 * *mid, options.min_robust_scale_mm);
    const double k = options.robust_k > 0.0 ? options.robust_k : defaultK(options.loss);
    for (auto& x : c) x.weight = robustWeight(options.loss, x.distance, k * scale);
    std::erase_if(c, [](const Correspondence& x) { return x.weight <= 0.0; });
  }
  return c;
}

// Weighted least-squares rigid motion (Kabsch/Umeyama with weights) taking
// the current points onto their closest points.
Eigen::Isometry3d solvePointToPoint(const std::vector<Correspondence>& c) {
  double wsum = 0.0;
  Eigen::Vector3d cp = Eigen::Vector3d::Zero();
  Eigen::Vector3d cq = Eigen::Vector3d::Zero();
  for (const auto& x : c) {
    wsum += x.weight;
    cp += x.weight * x.p;
    cq += x.weight * x.q;
  }
  cp /= wsum;
  cq /= wsum;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (const auto& x : c) H += x.weight * (x.p - cp) * (x.q - cq).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();
  delta.linear() = svd.matrixV() * D * svd.matrixU().transpose();
  delta.translation() = cq - delta.linear() * cp;
  return delta;
}

// One Gauss-Newton step of the point-to-plane error, linearised about the
// points' weighted centroid (better conditioned than about the origin).
Eigen::Isometry3d solvePointToPlane(const std::vector<Correspondence>& c) {
  double wsum = 0.0;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const auto& x : c) {
    wsum += x.weight;
    centre += x.weight * x.p;
  }
  centre /= wsum;
  Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
  for (const auto& x : c) {
    Eigen::Matrix<double, 6, 1> J;
    J.head<3>() = (x.p - centre).cross(x.n);
    J.tail<3>() = x.n;
    const double r = x.n.dot(x.p - x.q);
    A.selfadjointView<Eigen::Lower>().rankUpdate(J, x.weight);
    b -= x.weight * r * J;
  }
  A = A.selfadjointView<Eigen::Lower>();
  // A whisper of damping keeps sliding directions (planes, cylinders) at zero
  // motion instead of letting round-off move along them.
  A.diagonal().array() += 1e-12 * (A.trace() + 1.0);
  const Eigen::Matrix<double, 6, 1> x = A.ldlt().solve(b);
  Eigen::Isometry3d delta = Eigen::Isometry3d::Identity();
  delta.linear() = so3Exp(x.head<3>());
  delta.translation() = centre + x.tail<3>() - delta.linear() * centre;
  return delta;
}

double weightedRms(const std::vector<Correspondence>& c) {
  double wsum = 0.0;
  double s = 0.0;
  for (const auto& x : c) {
    wsum += x.weight;
    s += x.weight * x.distance * x.distance;
  }
  return wsum > 0.0 ? std::sqrt(s / wsum) : 0.0;
}

}  // namespace

IcpSurface::IcpSurface(const TriangleMesh& mesh) {
  if (mesh.empty()) {
    throw InvalidArgumentError("ICP: the fixed surface '" + mesh.name +
                               "' has no triangles: give a surface mesh, not an empty mesh or a point cloud");
  }
  locator_ = std::make_shared<const MeshLocator>(mesh);
  // Exact moments of uniform density over each triangle:
  //   int x dA = A s / 3,  int x x^T dA = A / 12 (sum v v^T + s s^T),  s = a + b + c.
  double area = 0.0;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();
  for (Eigen::Index f = 0; f < mesh.faceCount(); ++f) {
    const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, 0)).transpose();
    const Eigen::Vector3d b = mesh.vertices.row(mesh.faces(f, 1)).transpose();
    const Eigen::Vector3d c = mesh.vertices.row(mesh.faces(f, 2)).transpose();
    const double A = 0.5 * (b - a).cross(c - a).norm();
    const Eigen::Vector3d sum = a + b + c;
    area += A;
    first += A * sum / 3.0;
    second += A / 12.0 * (a * a.transpose() + b * b.transpose() + c * c.transpose() + sum * sum.transpose());
  }
  if (!(area > 0.0)) {
    throw InvalidArgumentError("ICP: the fixed surface '" + mesh.name + "' has zero area: give a real surface mesh");
  }
  centroid_ = first / area;
  covariance_ = second / area - centroid_ * centroid_.transpose();
}

IcpResult registerSurface(std::span<const Eigen::Vector3d> moving, const TriangleMesh& fixed,
                          const Eigen::Isometry3d& initial_fixed_T_moving, const IcpOptions& options) {
  checkPoints(moving);
  checkOptions(options);
  return registerSurface(moving, IcpSurface(fixed), initial_fixed_T_moving, options);
}

IcpResult registerSurface(std::span<const Eigen::Vector3d> moving, const IcpSurface& fixed,
                          const Eigen::Isometry3d& initial_fixed_T_moving, const IcpOptions& options) {
  checkPoints(moving);
  checkOptions(options);
  if (!initial_fixed_T_moving.matrix().allFinite()) {
    throw InvalidArgumentError("ICP: the initial transform holds NaN or infinite values");
  }
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : moving) centroid += p;
  centroid /= static_cast<double>(moving.size());
  double radius = 0.0, spread = 0.0;
  for (const auto& p : moving) {
    radius = std::max(radius, (p - centroid).norm());
    spread += (p - centroid).squaredNorm();
  }
  spread = std::sqrt(spread / static_cast<double>(moving.size()));  // RMS distance to the centroid

  IcpResult result;
  Eigen::Isometry3d T = initial_fixed_T_moving;
  std::vector<Eigen::Vector3d> previous(moving.size(),
                                        Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()));
  double previous_rms = std::numeric_limits<double>::infinity();
  bool coarse = options.method == IcpMethod::PointToPlane && options.point_to_point_warmup_ratio > 0.0;
  std::vector<SurfacePoint> found;
  // Coarse to fine: iterations run on a subset of the points until they
  // converge, then on the next larger subset, and last on all points until
  // they converge again. The subsets take every 4^k-th point in spatial
  // order (so they spread like all of them) and keep at least 1000 points:
  // far from the solution a few points steer as well as all of them, for a
  // fraction of the queries, and the far queries are the dear ones (a wide
  // search around each point). Each subset holds the next coarser one.
  struct Level {
    std::vector<std::uint32_t> order;     // spatial order
    std::vector<std::uint32_t> by_index;  // the same points, ascending
  };
  std::vector<Level> levels;  // coarsest first, all points last
  const std::vector<std::uint32_t> order = spatialOrder(moving);
  if (options.coarse_to_fine && moving.size() >= 4000) {
    for (std::size_t stride = 4; moving.size() / stride >= 1000; stride *= 4) {
      Level level;
      for (std::size_t n = 0; n < order.size(); n += stride) level.order.push_back(order[n]);
      level.by_index = level.order;
      std::sort(level.by_index.begin(), level.by_index.end());
      levels.insert(levels.begin(), std::move(level));
    }
  }
  levels.push_back({order, {}});
  levels.back().by_index.resize(moving.size());
  std::iota(levels.back().by_index.begin(), levels.back().by_index.end(), 0U);
  std::size_t level = 0;
  // The correspondences of all points from the last iteration, when it
  // converged by a step too small to matter: the result is then that
  // iteration's transform, and its figures need no more search.
  std::vector<Correspondence> last_all;
  bool figures_ready = false;
  for (int iteration = 0; iteration < options.max_iterations; ++iteration) {
    const bool coarse_level = level + 1 < levels.size();
    auto c = correspond(moving, fixed, T, options, previous, found, levels[level].order, levels[level].by_index);
    if (c.size() < 3) {
      throw ComputationError("ICP: only " + std::to_string(c.size()) + " of " + std::to_string(moving.size()) +
                             " points have a surface point within the correspondence distance at iteration " +
                             std::to_string(iteration) +
                             ": start closer (initial alignment) or raise max_correspondence_distance_mm");
    }
    const double rms = weightedRms(c);
    if (iteration == 0) result.initial_rms_mm = rms;
    const bool warmup_step = coarse;
    const bool plane_step = options.method == IcpMethod::PointToPlane && c.size() >= 6 && !coarse;
    const Eigen::Isometry3d delta = plane_step ? solvePointToPlane(c) : solvePointToPoint(c);
    // Largest displacement of any moving point by this step (bounded over the set's sphere).
    const Eigen::Vector3d centre_before = T * centroid;
    const double step_rotation = rotationAngle(delta.linear());
    const double step_shift = (delta * centre_before - centre_before).norm();
    const double motion = step_shift + step_rotation * radius;
    const Eigen::Isometry3d T_before = T;
    T = delta * T;
    result.iterations = iteration + 1;
    // Far from the solution, point-to-plane steps can slide into a wrong
    // (e.g. flipped) basin; point-to-point steps have the wider basin. Switch
    // once a step moves the points less than their distance to the surface.
    // Point-to-point converges linearly (each step ~0.7 of the last on
    // smooth surfaces), so once its steps rotate by less than a couple of
    // degrees and shift the centroid by a small part of the points' spread,
    // the remaining error is well inside point-to-plane's basin.
    if (coarse && (motion <= options.point_to_point_warmup_ratio * rms ||
                   (step_rotation <= options.warmup_rotation_rad && step_shift <= 0.1 * spread))) {
      coarse = false;
    }
    const bool small_motion = motion < options.motion_tolerance_mm;
    const double rms_change = std::abs(previous_rms - rms) / std::max(rms, 1e-12);
    const bool flat_rms = rms_change <= options.relative_rms_tolerance;
    previous_rms = rms;
    // Convergence counts only for steps of the requested method, on all
    // points. A coarse level hands over sooner: its optimum is within the
    // noise of all points' anyway, which the following steps reach.
    if (coarse_level && !warmup_step &&
        (motion < 100.0 * options.motion_tolerance_mm || rms_change <= 1e3 * options.relative_rms_tolerance)) {
      ++level;
      previous_rms = std::numeric_limits<double>::infinity();  // another set of points
      continue;
    }
    if ((small_motion || flat_rms) && !warmup_step && !coarse_level) {
      result.converged = true;
      if (small_motion) {
        // This step moves no point by more than the tolerance: stop at the
        // transform whose correspondences are at hand (exact figures
        // without another search, at most motion_tolerance_mm from the
        // stepped one).
        T = T_before;
        last_all = std::move(c);
        figures_ready = true;
      }
      break;
    }
  }
  if (options.max_iterations == 0) result.converged = true;
  result.fixed_T_moving = T;

  // Figures at the result: the correspondences of all points at it.
  const auto c = figures_ready ? std::move(last_all)
                               : correspond(moving, fixed, T, options, previous, found, levels.back().order,
                                            levels.back().by_index);
  result.inliers.reserve(c.size());
  double sum = 0.0;
  for (const auto& x : c) {
    result.inliers.push_back(x.index);
    sum += x.distance * x.distance;
  }
  result.rms_mm = c.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(c.size()));
  result.inlier_fraction = static_cast<double>(c.size()) / static_cast<double>(moving.size());
  // Every point's distance: the last search found it for the points within
  // the correspondence distance; the others are searched without a limit.
  result.distances_mm.resize(moving.size());
  parallelForBlocks(
      0, moving.size(),
      [&](std::size_t first, std::size_t last) {
        for (std::size_t n = first; n < last; ++n) {
          const std::size_t i = order[n];
          result.distances_mm[i] =
              found[i].face >= 0 ? found[i].distance : fixed.locator().closestPoint(T * moving[i]).distance;
        }
      },
      options.threads, 256);
  if (options.max_iterations == 0) result.initial_rms_mm = result.rms_mm;
  logger()->debug("ICP: {} iterations, rms {:.4f} mm (start {:.4f}), inliers {:.3f}, converged {}", result.iterations,
                  result.rms_mm, result.initial_rms_mm, result.inlier_fraction, result.converged);
  return result;
}

Eigen::Isometry3d initialAlignmentFromLandmarks(std::span<const Eigen::Vector3d> moving_landmarks,
                                                std::span<const Eigen::Vector3d> fixed_landmarks) {
  PairedPointOptions options;
  options.leave_one_out = false;
  const auto r = registerPairedPoints(moving_landmarks, fixed_landmarks, options);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = r.rotation;
  T.translation() = r.translation;
  return T;
}

namespace {

struct Principal {
  Eigen::Vector3d centroid;
  Eigen::Matrix3d axes;  // columns, largest extent first, det +1
  Eigen::Vector3d sd;    // standard deviations along the axes
};

Principal principal(const Eigen::Vector3d& centroid, const Eigen::Matrix3d& cov) {
  Principal pr;
  pr.centroid = centroid;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  for (int k = 0; k < 3; ++k) {
    pr.axes.col(k) = eig.eigenvectors().col(2 - k);
    pr.sd(k) = std::sqrt(std::max(eig.eigenvalues()(2 - k), 0.0));
  }
  if (pr.axes.determinant() < 0.0) pr.axes.col(2) = -pr.axes.col(2);
  return pr;
}

}  // namespace

PrincipalAxesResult initialAlignmentFromPrincipalAxes(std::span<const Eigen::Vector3d> moving, const IcpSurface& fixed,
                                                      const PrincipalAxesOptions& options) {
  checkPoints(moving);
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const auto& p : moving) centroid += p;
  centroid /= static_cast<double>(moving.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : moving) cov += (p - centroid) * (p - centroid).transpose();
  const auto pm = principal(centroid, cov / static_cast<double>(moving.size()));
  const auto pf = principal(fixed.surfaceCentroid(), fixed.surfaceCovariance());
  if (pm.sd(2) <= 1e-3 * pm.sd(0) || pf.sd(2) <= 1e-3 * pf.sd(0)) {
    throw ComputationError(
        "principal-axes alignment: the points or the surface are (nearly) planar or linear, so their axes do not "
        "define a rotation: use landmarks for the initial alignment");
  }
  PrincipalAxesResult result;
  result.moving_extent_mm = pm.sd;
  result.fixed_extent_mm = pf.sd;
  const double signs[4][3] = {{1, 1, 1}, {-1, -1, 1}, {-1, 1, -1}, {1, -1, -1}};
  double best = std::numeric_limits<double>::infinity();
  IcpOptions icp = options.icp;
  icp.max_iterations = options.refine_iterations;
  for (int k = 0; k < 4; ++k) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = pf.axes * Eigen::Vector3d(signs[k][0], signs[k][1], signs[k][2]).asDiagonal() * pm.axes.transpose();
    T.translation() = pf.centroid - T.linear() * pm.centroid;
    double rms = std::numeric_limits<double>::infinity();
    try {
      rms = registerSurface(moving, fixed, T, icp).rms_mm;
    } catch (const ComputationError&) {
      // This candidate leaves too few points near the surface: it loses.
    }
    result.candidate_rms_mm.push_back(rms);
    if (rms < best) {
      best = rms;
      result.chosen = k;
      result.fixed_T_moving = T;
    }
  }
  return result;
}

}  // namespace mrsns::registration
