// Multi-view averaging (paper 001 Eq. 18-20): properties of the mean and the spread.
#include <gtest/gtest.h>

#include <vector>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/hmd/multi_view.h"

namespace mrsns::hmd {
namespace {

Eigen::Isometry3d base() {
  Vector6d xi;
  xi << -40, 250, 1100, 2.5, -0.7, 0.9;  // a large rotation (2.7 rad) to stay away from identity
  return se3Exp(xi);
}

Eigen::Isometry3d perturbed(const Eigen::Vector3d& phi, const Eigen::Vector3d& dt) {
  Eigen::Isometry3d T = base();
  T.linear() = T.linear() * so3Exp(phi);
  T.translation() += dt;
  return T;
}

TEST(MultiView, IdenticalViewsGiveTheSamePoseAndNoSpread) {
  const std::vector<Eigen::Isometry3d> views(4, base());
  const auto r = averageViews(views);
  EXPECT_LT((r.tracker_T_hololens.matrix() - base().matrix()).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT(r.max_pairwise_rotation_rad, 1e-7);
  EXPECT_LT(r.max_pairwise_translation_mm, 1e-12);
}

TEST(MultiView, SymmetricPerturbationsCancel) {
  // Front/left/right/ground with opposite errors: +-2 degrees about two axes, +-1.5 mm.
  const double a = 2.0 * M_PI / 180.0;
  const std::vector<Eigen::Isometry3d> views = {perturbed({a, 0, 0}, {1.5, 0, 0}), perturbed({-a, 0, 0}, {-1.5, 0, 0}),
                                                perturbed({0, a, 0}, {0, 0, 1.5}), perturbed({0, -a, 0}, {0, 0, -1.5})};
  const auto r = averageViews(views);
  EXPECT_LT(rotationAngleBetween(r.tracker_T_hololens.linear(), base().linear()), 1e-9);
  EXPECT_LT((r.tracker_T_hololens.translation() - base().translation()).norm(), 1e-9);
  for (double e : r.rotation_from_mean_rad) EXPECT_NEAR(e, a, 1e-9);
  for (double d : r.translation_from_mean_mm) EXPECT_NEAR(d, 1.5, 1e-9);
  EXPECT_NEAR(r.max_pairwise_rotation_rad, 2.0 * a, 1e-9);
  EXPECT_NEAR(r.max_pairwise_translation_mm, 3.0, 1e-9);
}

TEST(MultiView, TwoViewsMeetHalfWayOnTheGeodesic) {
  const Eigen::Vector3d phi = Eigen::Vector3d(0.3, -0.2, 0.5).normalized() * 0.2;
  const std::vector<Eigen::Isometry3d> views = {base(), perturbed(phi, {0, 2, 0})};
  const auto r = averageViews(views);
  EXPECT_LT(rotationAngleBetween(r.tracker_T_hololens.linear(), base().linear() * so3Exp(0.5 * phi)), 1e-9);
  EXPECT_NEAR(r.rotation_from_mean_rad[0], 0.1, 1e-9);
  EXPECT_NEAR(r.translation_from_mean_mm[1], 1.0, 1e-12);
}

TEST(MultiView, RefusesEmptyInput) {
  EXPECT_THROW(averageViews({}), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::hmd
