#include "mrsns/core/point_locator.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <nanoflann.hpp>
#include <string>

#include "mrsns/core/error.h"

namespace mrsns {
namespace {

// nanoflann's dataset adaptor over the row-major point matrix.
struct PointCloudAdaptor {
  const PointsN3* points = nullptr;
  [[nodiscard]] std::size_t kdtree_get_point_count() const { return static_cast<std::size_t>(points->rows()); }
  [[nodiscard]] double kdtree_get_pt(std::size_t i, std::size_t dim) const {
    return (*points)(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(dim));
  }
  template <class Box>
  bool kdtree_get_bbox(Box& /*box*/) const {
    return false;  // let nanoflann compute the bounds
  }
};

using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointCloudAdaptor>,
                                                   PointCloudAdaptor, 3, std::uint32_t>;

void checkQuery(const Eigen::Vector3d& query) {
  if (!query.allFinite()) {
    throw InvalidArgumentError("PointLocator: the query point is not finite; pass a point in mm without NaN");
  }
}

}  // namespace

struct PointLocator::Impl {
  PointsN3 points;
  PointCloudAdaptor adaptor;
  std::unique_ptr<KdTree> tree;
};

PointLocator::PointLocator(PointsN3 points) : impl_(std::make_unique<Impl>()) {
  if (points.rows() == 0) {
    throw InvalidArgumentError("PointLocator: the point set is empty; pass at least one point");
  }
  if (points.rows() > static_cast<Eigen::Index>(std::numeric_limits<std::uint32_t>::max())) {
    throw InvalidArgumentError("PointLocator: too many points (" + std::to_string(points.rows()) +
                               "); subsample to fewer than 2^32");
  }
  for (Eigen::Index i = 0; i < points.rows(); ++i) {
    if (!points.row(i).allFinite()) {
      throw InvalidArgumentError("PointLocator: point " + std::to_string(i) +
                                 " is not finite; remove NaN/inf points before building the locator");
    }
  }
  impl_->points = std::move(points);
  impl_->adaptor.points = &impl_->points;
  impl_->tree =
      std::make_unique<KdTree>(3, impl_->adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(/*leaf_max_size=*/10));
}

PointLocator::~PointLocator() = default;
PointLocator::PointLocator(PointLocator&&) noexcept = default;
PointLocator& PointLocator::operator=(PointLocator&&) noexcept = default;

Eigen::Index PointLocator::size() const {
  return impl_->points.rows();
}
const PointsN3& PointLocator::points() const {
  return impl_->points;
}

PointNeighbor PointLocator::nearest(const Eigen::Vector3d& query) const {
  const auto result = kNearest(query, 1);
  return result.front();
}

std::vector<PointNeighbor> PointLocator::kNearest(const Eigen::Vector3d& query, std::size_t k) const {
  checkQuery(query);
  k = std::min<std::size_t>(k, static_cast<std::size_t>(impl_->points.rows()));
  if (k == 0) return {};  // nanoflann's result set needs capacity >= 1
  std::vector<std::uint32_t> indices(k);
  std::vector<double> squared(k);
  const std::size_t found = impl_->tree->knnSearch(query.data(), k, indices.data(), squared.data());
  std::vector<PointNeighbor> out(found);
  for (std::size_t i = 0; i < found; ++i) out[i] = {static_cast<Eigen::Index>(indices[i]), std::sqrt(squared[i])};
  return out;
}

std::vector<PointNeighbor> PointLocator::withinRadius(const Eigen::Vector3d& query, double radius) const {
  checkQuery(query);
  if (!std::isfinite(radius) || radius < 0.0) {
    throw InvalidArgumentError("PointLocator::withinRadius: radius " + std::to_string(radius) +
                               " mm is invalid; pass a finite radius >= 0");
  }
  std::vector<std::pair<std::uint32_t, double>> matches;
  nanoflann::SearchParams params;
  params.sorted = true;
  // nanoflann's L2 adaptor compares squared distances; its radius test is strict,
  // so nudge the bound up by one ulp to include points exactly on the sphere.
  const double squared_radius = std::nextafter(radius * radius, std::numeric_limits<double>::infinity());
  impl_->tree->radiusSearch(query.data(), squared_radius, matches, params);
  std::vector<PointNeighbor> out;
  out.reserve(matches.size());
  for (const auto& [index, squared] : matches) {
    if (squared <= radius * radius) out.push_back({static_cast<Eigen::Index>(index), std::sqrt(squared)});
  }
  return out;
}

}  // namespace mrsns
