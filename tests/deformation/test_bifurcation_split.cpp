// Slices near the carotid bifurcation: the model's cut is two overlapping
// branch loops and the image shows their merged lumen. Each lumen is
// segmented from its own loop without the shared side, instead of being
// refused as ambiguous, and both contours reach Algorithm 1.
#include <gtest/gtest.h>

#include <random>

#include "mrsns/deformation/bmode.h"
#include "mrsns/deformation/model_building.h"
#include "mrsns/deformation/shape_tracker.h"
#include "mrsns/deformation/vessel_phantom.h"

namespace mrsns::deformation {
namespace {

struct Loop {
  Polyline3d contour;  // image coordinates
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double radius = 0.0;  // mean distance of the loop's points from its centre
};

std::vector<Loop> loopsInImage(const TriangleMesh& mesh, const Eigen::Isometry3d& model_T_image) {
  std::vector<Loop> out;
  for (const auto& c : intersectMeshWithPlane(mesh, model_T_image.translation(), model_T_image.linear().col(2))) {
    if (!c.closed || c.points.size() < 3) continue;
    Loop l;
    l.contour.closed = true;
    for (const auto& p : c.points) l.contour.points.push_back(model_T_image.inverse() * p);
    for (const auto& p : l.contour.points) l.centre += p.head<2>();
    l.centre /= static_cast<double>(l.contour.points.size());
    for (const auto& p : l.contour.points) l.radius += (p.head<2>() - l.centre).norm();
    l.radius /= static_cast<double>(l.contour.points.size());
    out.push_back(std::move(l));
  }
  return out;
}

// A transverse slice (image x lateral, y depth, the vessel 12 mm deep) at
// height z of the undeformed phantom.
Eigen::Isometry3d transverse(double z) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(-16.0, -12.0, z);
  return t;
}

// The highest slice whose cut is exactly the two branch loops (ICA, ECA),
// still overlapping: the case the segmenter used to refuse. Lower slices
// have one loop mostly inside the other, which stays refused.
double overlappingBranchSlice(const TriangleMesh& mesh) {
  double found = -1.0;
  for (double z = 0.5; z < 15.0; z += 0.5) {
    const auto loops = loopsInImage(mesh, transverse(z));
    if (loops.size() == 2 && (loops[0].centre - loops[1].centre).norm() < loops[0].radius + loops[1].radius) {
      found = z;
    }
  }
  return found;
}

TEST(BifurcationSplit, OverlappingBranchLoopsGiveTwoLumensInsteadOfARefusal) {
  const TriangleMesh truth = makeVesselPhantom({});
  const double z = overlappingBranchSlice(truth);
  ASSERT_GT(z, 0.0) << "the phantom has no slice with two overlapping branch loops";
  std::mt19937_64 rng(5);
  const BModeImage image = renderBMode(truth, transverse(z), {}, rng);
  const auto loops = loopsInImage(truth, transverse(z));
  // Seeds: the true loops displaced by 0.6 mm, as a model with calibration error.
  std::vector<Polyline3d> seeds;
  for (const auto& l : loops) {
    Polyline3d s = l.contour;
    for (auto& p : s.points) p += Eigen::Vector3d(0.5, -0.33, 0.0);
    seeds.push_back(std::move(s));
  }
  LumenSegmentationOptions refuse;
  refuse.split_overlapping = false;
  for (const auto& r : segmentLumens(image, seeds, refuse)) EXPECT_FALSE(r.ok);

  const auto lumens = segmentLumens(image, seeds);
  ASSERT_EQ(lumens.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    ASSERT_TRUE(lumens[i].ok) << "loop " << i << ": " << lumens[i].status;
    EXPECT_TRUE(lumens[i].split);
    // Pixel 0.2 mm and a 3x3 speckle cell as for a single lumen, but the
    // ellipse is fitted to the unshared arc only (>= 55 % of the rays) and the
    // loops of an oblique branch are not exact ellipses: within 0.5 mm.
    EXPECT_LT((lumens[i].center - loops[i].centre).norm(), 0.5) << "loop " << i;
    EXPECT_NEAR(0.5 * (lumens[i].semi_major_mm + lumens[i].semi_minor_mm), loops[i].radius, 0.5) << "loop " << i;
  }
  // The two contours are told apart: each lies nearer its own loop.
  EXPECT_LT((lumens[0].center - loops[0].centre).norm(), (lumens[0].center - loops[1].centre).norm());
  EXPECT_LT((lumens[1].center - loops[1].centre).norm(), (lumens[1].center - loops[0].centre).norm());

  // Both reach Algorithm 1 and are paired with their own model loop.
  std::vector<TriangleMesh> training;
  std::mt19937_64 shape_rng(9);
  for (int i = 0; i < 8; ++i) training.push_back(makeVesselPhantom(randomVesselDeformation(shape_rng)));
  ShapeModelBuildOptions build;
  build.align = false;
  PosteriorShapeTracker tracker(buildShapeModel(training, build).model);
  std::vector<Polyline3d> features;
  for (const auto& l : lumens) features.push_back(l.contour);
  const FrameUpdate u = tracker.update(transverse(z), features);
  EXPECT_TRUE(u.updated) << u.status;
  EXPECT_EQ(u.matched_contours, 2);
}

}  // namespace
}  // namespace mrsns::deformation
