#pragma once
// Nearest-neighbour queries over a fixed set of 3D points (a KD-tree).
#include <Eigen/Core>
#include <memory>
#include <vector>

#include "mrsns/core/mesh_ops.h"

namespace mrsns {

struct PointNeighbor {
  Eigen::Index index = -1;  ///< Row of the point in the locator's point set.
  double distance = 0.0;    ///< Euclidean distance to the query (mm).
};

/// A KD-tree over a copy of the points. Queries are const and may run from
/// several threads at once.
class PointLocator {
 public:
  /// Throws InvalidArgumentError when `points` is empty or holds NaN/inf.
  explicit PointLocator(PointsN3 points);
  ~PointLocator();
  PointLocator(PointLocator&&) noexcept;
  PointLocator& operator=(PointLocator&&) noexcept;
  PointLocator(const PointLocator&) = delete;
  PointLocator& operator=(const PointLocator&) = delete;

  [[nodiscard]] Eigen::Index size() const;
  [[nodiscard]] const PointsN3& points() const;

  /// The closest point; ties resolve to either.
  [[nodiscard]] PointNeighbor nearest(const Eigen::Vector3d& query) const;

  /// The min(k, size()) closest points, nearest first.
  [[nodiscard]] std::vector<PointNeighbor> kNearest(const Eigen::Vector3d& query, std::size_t k) const;

  /// All points with distance <= radius (mm), nearest first. Throws
  /// InvalidArgumentError for a negative or non-finite radius.
  [[nodiscard]] std::vector<PointNeighbor> withinRadius(const Eigen::Vector3d& query, double radius) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mrsns
