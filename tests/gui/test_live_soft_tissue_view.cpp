// The GUI's live navigation on a PlusServer's ultrasound (the simulated operating room in process, its noise
// model in ../workflow/live_soft_tissue_room.h): the source's own B-mode frame is drawn where Eq. 4 places it
// in the CT, with the lumen outline the live soft tissue segmented in it, and the status line says the soft
// tissue is tracking. Screenshot: artifacts/gui/view3d_live_soft_tissue.png.
#include <gtest/gtest.h>

#include <QWidget>

#include "../workflow/live_soft_tissue_room.h"
#include "display_area.h"
#include "live_navigation.h"
#include "main_window.h"
#include "mrsns/rendering/scene.h"
#include "sample_window_fixture.h"

namespace {

class LiveSoftTissueViewTest : public mrsns::test::SampleWindowTest {
 protected:
  LiveSoftTissueViewTest() : SampleWindowTest("gui-live-soft-tissue") {}
};

TEST_F(LiveSoftTissueViewTest, TheSourcesFrameAndItsLumenOutlineAreShownWhereEq4PlacesThem) {
  if (!mrsns::test::haveSampleSession()) GTEST_SKIP() << "no bundled sample session";
  auto room = mrsns::test::startLiveRoom("gui-live-soft-tissue-room", 1);
  auto window = makeWindow();
  ASSERT_TRUE(window->openSampleSession()) << messages();
  mrsns::workflow::NavigationOptions options = mrsns::test::liveLoopOptions(room);
  ASSERT_TRUE(window->startNavigation(options)) << messages();
  auto* live = window->liveNavigation();
  ASSERT_NE(live, nullptr);
  const auto& scene = window->displayArea()->scene();
  ASSERT_TRUE(mrsns::test::waitUntil(
      [&] {
        return live->status().soft_tissue_updates >= 10 && scene.contains(mrsns::gui::kUltrasoundObject) &&
               scene.contains(mrsns::gui::kUltrasoundOutlineObject);
      },
      30000))
      << live->status().soft_tissue << ", " << live->status().us_frames_received << " frames";
  EXPECT_EQ(live->status().soft_tissue, "tracking");
  if (window->displayArea()->hasOpenGlViews()) {
    // Looking down the probe's beam onto the frame: the vessel's dark lumen ringed by its outline.
    const Eigen::Vector3d centre = mrsns::test::kModelInCt + Eigen::Vector3d(0.0, 0.0, -15.0);
    window->displayArea()->scene().setCamera(centre + Eigen::Vector3d(0.0, 0.0, -120.0), centre,
                                             Eigen::Vector3d(0.0, -1.0, 0.0));
    window->displayArea()->renderScene();
    const auto png = mrsns::test::guiArtifactDir() / "view3d_live_soft_tissue.png";
    EXPECT_TRUE(window->findChild<QWidget*>("view3d")->grab().toImage().save(QString::fromStdString(png.string())));
  }
  window->stopNavigation();
  EXPECT_FALSE(scene.contains(mrsns::gui::kUltrasoundOutlineObject)) << "the outline goes with the navigation";
  room.room->stop();
}

}  // namespace
