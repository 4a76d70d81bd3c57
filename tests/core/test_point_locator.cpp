#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>
#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/core/point_locator.h"

namespace mrsns {
namespace {

PointsN3 randomPoints(int n, std::mt19937& rng, double half_extent) {
  std::uniform_real_distribution<double> u(-half_extent, half_extent);
  PointsN3 p(n, 3);
  for (int i = 0; i < n; ++i) p.row(i) << u(rng), u(rng), u(rng);
  return p;
}

std::vector<double> bruteForceDistances(const PointsN3& points, const Eigen::Vector3d& q) {
  std::vector<double> d(static_cast<std::size_t>(points.rows()));
  for (Eigen::Index i = 0; i < points.rows(); ++i)
    d[static_cast<std::size_t>(i)] = (points.row(i).transpose() - q).norm();
  return d;
}

TEST(PointLocator, NearestAndKNearestMatchBruteForce) {
  std::mt19937 rng(7);
  const PointsN3 points = randomPoints(3000, rng, 50.0);
  const PointLocator locator(points);
  EXPECT_EQ(locator.size(), 3000);
  const PointsN3 queries = randomPoints(200, rng, 70.0);  // some outside the cloud
  for (Eigen::Index qi = 0; qi < queries.rows(); ++qi) {
    const Eigen::Vector3d q = queries.row(qi).transpose();
    std::vector<double> d = bruteForceDistances(points, q);
    const PointNeighbor nn = locator.nearest(q);
    EXPECT_NEAR(nn.distance, *std::min_element(d.begin(), d.end()), 1e-12);
    EXPECT_NEAR((points.row(nn.index).transpose() - q).norm(), nn.distance, 1e-12);

    const auto knn = locator.kNearest(q, 8);
    ASSERT_EQ(knn.size(), 8U);
    std::sort(d.begin(), d.end());
    for (std::size_t k = 0; k < knn.size(); ++k) {
      EXPECT_NEAR(knn[k].distance, d[k], 1e-12);
      if (k > 0) {
        EXPECT_LE(knn[k - 1].distance, knn[k].distance);
      }
    }
  }
}

TEST(PointLocator, RadiusSearchMatchesBruteForceAndIncludesBoundary) {
  std::mt19937 rng(11);
  const PointsN3 points = randomPoints(2000, rng, 20.0);
  const PointLocator locator(points);
  for (int trial = 0; trial < 50; ++trial) {
    const Eigen::Vector3d q = randomPoints(1, rng, 20.0).row(0).transpose();
    const double radius = 2.0 + trial * 0.1;
    const auto found = locator.withinRadius(q, radius);
    const std::vector<double> d = bruteForceDistances(points, q);
    const auto expected = std::count_if(d.begin(), d.end(), [&](double x) { return x <= radius; });
    ASSERT_EQ(static_cast<long>(found.size()), expected);
    for (std::size_t k = 0; k < found.size(); ++k) {
      EXPECT_LE(found[k].distance, radius);
      if (k > 0) {
        EXPECT_LE(found[k - 1].distance, found[k].distance);
      }
    }
  }
  // Integer lattice: from a lattice point the 6 face neighbours lie exactly at radius 1.
  PointsN3 grid(27, 3);
  int row = 0;
  for (int x = -1; x <= 1; ++x)
    for (int y = -1; y <= 1; ++y)
      for (int z = -1; z <= 1; ++z) grid.row(row++) << x, y, z;
  const PointLocator lattice(grid);
  EXPECT_EQ(lattice.withinRadius(Eigen::Vector3d::Zero(), 1.0).size(), 7U);
  EXPECT_EQ(lattice.withinRadius(Eigen::Vector3d::Zero(), 0.0).size(), 1U);
}

TEST(PointLocator, KLargerThanSizeAndSinglePoint) {
  PointsN3 one(1, 3);
  one << 1, 2, 3;
  const PointLocator locator(one);
  const auto knn = locator.kNearest(Eigen::Vector3d(1, 2, 4), 5);
  ASSERT_EQ(knn.size(), 1U);
  EXPECT_EQ(knn[0].index, 0);
  EXPECT_NEAR(knn[0].distance, 1.0, 1e-15);
  EXPECT_TRUE(locator.kNearest(Eigen::Vector3d::Zero(), 0).empty());
}

TEST(PointLocator, SurvivesMoveAndRejectsInvalidInput) {
  std::mt19937 rng(3);
  PointLocator a(randomPoints(100, rng, 1.0));
  const PointNeighbor before = a.nearest(Eigen::Vector3d(0.1, 0.2, 0.3));
  PointLocator b(std::move(a));
  const PointNeighbor after = b.nearest(Eigen::Vector3d(0.1, 0.2, 0.3));
  EXPECT_EQ(before.index, after.index);

  EXPECT_THROW(PointLocator(PointsN3(0, 3)), InvalidArgumentError);
  PointsN3 nan_points = randomPoints(5, rng, 1.0);
  nan_points(3, 1) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(PointLocator{nan_points}, InvalidArgumentError);
  EXPECT_THROW((void)b.withinRadius(Eigen::Vector3d::Zero(), -1.0), InvalidArgumentError);
  EXPECT_THROW((void)b.nearest(Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN())),
               InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns
