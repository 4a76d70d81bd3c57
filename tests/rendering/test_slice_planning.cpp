// The slice views as a planning tool: scrolling by a voxel, picking a point
// of a plane under the mouse and back, the screw ends under the mouse, the
// window/level presets and the trajectory views resliced along a screw.
#include <gtest/gtest.h>

#include <vtkNew.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>

#include <cstdlib>
#include <filesystem>

#include "mrsns/core/error.h"
#include "mrsns/rendering/slice_views.h"
#include "test_data.h"

namespace mrsns::rendering {
namespace {

bool haveDisplay() {
  const char* d = std::getenv("DISPLAY");
  return d != nullptr && *d != '\0';
}

/// A 60 x 50 x 40 volume of 0.8 x 0.8 x 2.5 mm with a bright bar along x: anisotropic on purpose.
ImageVolume volume() {
  ImageVolume v;
  v.size = {60, 50, 40};
  v.spacing = Eigen::Vector3d(0.8, 0.8, 2.5);
  v.origin = Eigen::Vector3d(-20, -10, 30);
  v.pixel_type = PixelType::Int16;
  v.data.assign(v.byteCount(), std::byte{0});
  for (int k = 0; k < v.size[2]; ++k) {
    for (int j = 0; j < v.size[1]; ++j) {
      for (int i = 0; i < v.size[0]; ++i) {
        const std::int16_t value = (std::abs(j - 25) < 3 && std::abs(k - 20) < 2) ? 1000 : -1000;
        std::memcpy(v.data.data() + 2 * v.linearIndex(i, j, k), &value, 2);
      }
    }
  }
  return v;
}

TEST(SlicePlanning, ScrollingMovesOneVoxelAlongTheViewAndStopsAtTheVolume) {
  SliceViews views;
  views.setVolume(volume());
  const Eigen::Vector3d start = views.cursor();
  views.scroll(SliceOrientation::Axial, 3);
  EXPECT_NEAR((views.cursor() - start).dot(sliceNormal(SliceOrientation::Axial)), 3 * 2.5, 1e-9);
  EXPECT_NEAR((views.cursor() - start).head<2>().norm(), 0.0, 1e-12) << "only along the axial normal";
  views.scroll(SliceOrientation::Sagittal, -2);
  EXPECT_NEAR(std::abs(views.cursor().x() - start.x()), 2 * 0.8, 1e-9);
  views.scroll(SliceOrientation::Axial, 1000);
  EXPECT_NEAR(views.cursor().z(), 30.0 + 39 * 2.5, 1e-9) << "kept inside the volume";
  EXPECT_EQ(ctWindowLevelPresets().front().name, "bone");
  EXPECT_EQ(ctWindowLevelPresets().front().window, 1000.0);
}

TEST(SlicePlanning, PickedPointsLieOnThePlaneAndProjectBackToThePixel) {
  if (!haveDisplay()) GTEST_SKIP() << "needs an X display (xvfb-run -a)";
  SliceViews views;
  views.setVolume(volume());
  vtkNew<vtkRenderWindow> window;
  window->SetOffScreenRendering(1);
  window->SetSize(400, 300);
  window->AddRenderer(views.renderer(SliceOrientation::Coronal));
  window->Render();
  EXPECT_FALSE(views.pointAt(SliceOrientation::Axial, 10, 10).has_value()) << "a view in no window picks nothing";
  for (const auto& [x, y] : {std::pair{200.0, 150.0}, std::pair{37.0, 260.0}, std::pair{390.0, 5.0}}) {
    const auto p = views.pointAt(SliceOrientation::Coronal, x, y);
    ASSERT_TRUE(p.has_value());
    EXPECT_NEAR(p->y(), views.cursor().y(), 1e-6) << "on the coronal plane through the cursor";
    const auto back = views.displayPoint(SliceOrientation::Coronal, *p);
    ASSERT_TRUE(back.has_value());
    EXPECT_NEAR(back->x(), x, 1e-6);
    EXPECT_NEAR(back->y(), y, 1e-6);
  }
  // The screw end under the pointer, the nearest of two, and none beyond the tolerance.
  SliceScrew a{"a", views.cursor() + Eigen::Vector3d(-5, 0, 0), views.cursor() + Eigen::Vector3d(15, 0, 10), 4.0};
  SliceScrew b{"b", views.cursor() + Eigen::Vector3d(0, 30, 0), views.cursor() + Eigen::Vector3d(0, 30, -20), 4.0};
  views.setScrews({a, b});
  const auto tip = views.displayPoint(SliceOrientation::Coronal, a.tip);
  const auto handle = views.handleAt(SliceOrientation::Coronal, tip->x() + 2.0, tip->y() - 1.0);
  ASSERT_TRUE(handle.has_value());
  EXPECT_EQ(handle->screw, 0u);
  EXPECT_EQ(handle->end, ScrewEnd::Tip);
  // b runs along y: seen end on in the coronal view, its entry and tip project to one pixel; either is it.
  const auto b_entry = views.displayPoint(SliceOrientation::Coronal, b.entry);
  const auto on_b = views.handleAt(SliceOrientation::Coronal, b_entry->x(), b_entry->y());
  ASSERT_TRUE(on_b.has_value());
  EXPECT_EQ(on_b->screw, 1u);
  EXPECT_FALSE(views.handleAt(SliceOrientation::Coronal, tip->x() + 40.0, tip->y(), 8.0).has_value());
  EXPECT_THROW(views.setScrews({SliceScrew{"bad", a.entry, a.tip, 0.0}}), InvalidArgumentError);
}

TEST(SlicePlanning, TheTrajectoryViewsRenderAlongTheScrew) {
  if (!haveDisplay()) GTEST_SKIP() << "needs an X display (xvfb-run -a)";
  SliceViews views;
  views.setVolume(volume());
  EXPECT_THROW(snapshotTrajectoryPng(views, test::scratchDirectory("t") / "none.png", 400, 200), InvalidArgumentError);
  const Eigen::Vector3d entry = views.cursor() + Eigen::Vector3d(-10, 0, 0);
  EXPECT_THROW(views.setTrajectory(entry, entry, 4.0, 10.0), InvalidArgumentError);
  views.setTrajectory(entry, entry + Eigen::Vector3d(30, 0, 0), 4.0, 15.0);
  EXPECT_TRUE(views.hasTrajectory());
  const auto png = test::scratchDirectory("t") / "trajectory.png";
  snapshotTrajectoryPng(views, png, 400, 200);
  EXPECT_GT(std::filesystem::file_size(png), 1000u);
  views.clearTrajectory();
  EXPECT_FALSE(views.hasTrajectory());
}

}  // namespace
}  // namespace mrsns::rendering
