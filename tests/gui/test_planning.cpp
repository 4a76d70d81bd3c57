// Preparation and planning from the GUI on the real CT of the shared data:
// a session made from scratch (CT, label maps, models through the steps the
// panels run), a pedicle screw placed by clicking its entry and target on a
// slice, its entry dragged with its figures following, the rest of the plan
// from the planning calls, the trajectory view, screenshots of the planning
// views, and the session saved and reopened with nothing lost.
#include <gtest/gtest.h>

#include <QCheckBox>
#include <QComboBox>
#include <QLabel>
#include <QTableWidget>
#include <QTest>
#include <filesystem>

#include "display_area.h"
#include "gui_test_app.h"
#include "main_window.h"
#include "mrsns/io/image_io.h"
#include "mrsns/rendering/slice_views.h"
#include "mrsns/workflow/session.h"
#include "planning_panel.h"
#include "sample_window_fixture.h"
#include "test_data.h"

namespace {

using mrsns::gui::MainWindow;
namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr int kPlanningStepTimeoutMs = 180000;

class PlanningWindowTest : public mrsns::test::SampleWindowTest {
 protected:
  PlanningWindowTest() : SampleWindowTest("gui-planning") {}

  bool runAndWait(MainWindow& window, const QString& step, const Json& params) {
    if (!window.runStep(step, params)) return false;
    return mrsns::test::waitUntil([&] { return !window.taskRunning(); }, kPlanningStepTimeoutMs) &&
           window.sessionState()["steps"][step.toStdString()].value("status", "") == "ok";
  }

  void screenshot(MainWindow& window, const std::string& name) {
    EXPECT_TRUE(window.saveScreenshot(QString::fromStdString((mrsns::test::guiArtifactDir() / name).string())))
        << messages();
  }
};

TEST_F(PlanningWindowTest, RealCtSessionFromScratchScrewsPlacedDraggedSavedAndReopened) {
  MRSNS_REQUIRE_DATA(ct, "ct/totalsegmentator/example_ct.nii.gz");
  MRSNS_REQUIRE_DATA(vertebrae, "ct/totalsegmentator/spine_report/example_ct_report/totalseg.nii.gz");
  MRSNS_REQUIRE_DATA(organs, "ct/totalsegmentator/example_seg.nii.gz");
  auto window = makeWindow();
  const QString folder = QString::fromStdString((scratch_ / "session").string());
  ASSERT_TRUE(window->createSession(folder)) << messages();

  // The patient's data, as the Data menu's steps import them.
  ASSERT_TRUE(window->importFile(mrsns::gui::ImportKind::CtImage, QString::fromStdString(ct.string())));
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !window->taskRunning(); }, kPlanningStepTimeoutMs));
  ASSERT_EQ(window->sessionState()["steps"]["import-ct"].value("status", ""), "ok") << messages();
  ASSERT_TRUE(runAndWait(*window, "import-label-map", {{"path", vertebrae.string()}})) << messages();
  ASSERT_TRUE(runAndWait(*window, "import-label-map", {{"path", organs.string()}, {"align_to", "labels"}}))
      << messages();
  ASSERT_TRUE(runAndWait(*window, "make-models", {{"label_map", "labels"}, {"labels", "L1,L2,L3,L4"}})) << messages();
  ASSERT_TRUE(runAndWait(*window, "make-models",
                         {{"label_map", "labels-2"}, {"labels", "aorta,inferior_vena_cava,spinal_cord"}}))
      << messages();
  auto& scene = window->displayArea()->scene();
  for (const char* name : {"vertebra:L1", "vertebra:L4", "tissue:aorta", "tissue:spinal_cord"}) {
    EXPECT_TRUE(scene.contains(name)) << name;
  }
  auto& slices = window->displayArea()->slices();
  ASSERT_TRUE(slices.hasVolume());
  if (!window->displayArea()->hasOpenGlViews()) GTEST_SKIP() << "placing on the slices needs the OpenGL views";

  // Bone window from the planning panel's presets.
  auto* presets = window->findChild<QComboBox*>("windowPreset");
  ASSERT_NE(presets, nullptr);
  presets->setCurrentIndex(0);
  emit presets->activated(0);
  EXPECT_EQ(slices.windowLevel(), Eigen::Vector2d(1000.0, 400.0));

  // A new screw: its entry, then its target, clicked on the axial slice through L1's pedicles.
  slices.setCursor(Eigen::Vector3d(0.0, -100.0, 382.0));
  window->displayArea()->render();
  const Eigen::Vector3d entry(25.5, -84.0, 382.0), target(5.5, -134.0, 382.0);
  ASSERT_TRUE(window->beginNewScrew()) << messages();
  EXPECT_TRUE(window->displayArea()->pickMode());
  const int axial = static_cast<int>(mrsns::rendering::SliceOrientation::Axial);
  for (const Eigen::Vector3d& p : {entry, target}) {
    const auto px = slices.displayPoint(mrsns::rendering::SliceOrientation::Axial, p);
    ASSERT_TRUE(px.has_value());
    window->displayArea()->slicePress(axial, px->x(), px->y());
    window->displayArea()->sliceRelease(axial, px->x(), px->y());
  }
  EXPECT_FALSE(window->displayArea()->pickMode());
  auto plan = window->shownPlan();
  ASSERT_EQ(plan.size(), 1u) << messages();
  // Named from the anatomy: the vertebra it lies in, the side it enters from.
  EXPECT_EQ(plan[0].name, "L1 left");
  // Picked to a pixel of a 3 mm CT shown about 1 mm per pixel.
  EXPECT_LT((plan[0].entry - entry).norm(), 1.0);
  EXPECT_LT((plan[0].target - target).norm(), 1.0);
  ASSERT_TRUE(plan[0].figures["breach"].is_object()) << plan[0].figures.dump();
  ASSERT_TRUE(plan[0].figures["clearance"]["vessel"].is_object());
  auto* figures = window->findChild<QLabel*>("screwFigures");
  ASSERT_NE(figures, nullptr);
  EXPECT_TRUE(figures->text().contains("Gertzbein-Robbins")) << figures->text().toStdString();
  EXPECT_TRUE(figures->text().contains("aorta")) << figures->text().toStdString();

  // The entry dragged 12 px along the view's x: it moves in the axial plane, the figures follow while it moves,
  // and the session holds the new plan once it is released.
  const auto from = slices.displayPoint(mrsns::rendering::SliceOrientation::Axial, plan[0].entry);
  ASSERT_TRUE(from.has_value());
  window->displayArea()->slicePress(axial, from->x(), from->y());
  window->displayArea()->sliceMove(axial, from->x() + 6.0, from->y());
  const auto dragging = window->shownPlan();
  EXPECT_GT((dragging[0].entry - plan[0].entry).norm(), 0.5) << "moved while dragging";
  window->displayArea()->sliceMove(axial, from->x() + 12.0, from->y());
  window->displayArea()->sliceRelease(axial, from->x() + 12.0, from->y());
  const auto session_plan = window->sessionState()["plans"];
  ASSERT_EQ(session_plan.size(), 1u);
  const Eigen::Vector3d moved(session_plan[0]["entry"][0].get<double>(), session_plan[0]["entry"][1].get<double>(),
                              session_plan[0]["entry"][2].get<double>());
  EXPECT_GT((moved - plan[0].entry).norm(), 5.0);
  EXPECT_NEAR(moved.z(), plan[0].entry.z(), 1e-9) << "a drag on the axial slice keeps the end's height";
  EXPECT_NE(session_plan[0]["figures"], Json(plan[0].figures)) << "figures recomputed for the new entry";

  // Back to the planned entry, and the other three screws, as the panel's fields would set them.
  for (const auto& [name, e, t] : std::vector<std::tuple<std::string, Eigen::Vector3d, Eigen::Vector3d>>{
           {"L1 left", entry, target},
           {"L1 right", {-18.5, -84.0, 382.0}, {1.5, -134.0, 382.0}},
           {"L2 left", {24.0, -92.0, 350.0}, {10.0, -142.0, 356.0}},
           {"L2 right", {-17.0, -93.0, 355.0}, {-5.0, -143.0, 358.0}}}) {
    mrsns::workflow::PlannedScrew screw;
    screw.name = name;
    screw.entry = e;
    screw.target = t;
    screw.diameter_mm = 6.0;
    screw.length_mm = 45.0;
    ASSERT_TRUE(window->planScrew(screw, name)) << messages();
  }
  EXPECT_EQ(window->findChild<QTableWidget*>("screwTable")->rowCount(), 4);
  window->planningPanel()->selectScrew(QStringLiteral("L2 left"));
  auto* trajectory = window->findChild<QCheckBox*>("showTrajectory");
  ASSERT_NE(trajectory, nullptr);
  trajectory->setChecked(true);
  EXPECT_TRUE(window->displayArea()->trajectoryVisible());
  EXPECT_TRUE(slices.hasTrajectory());

  // The planning views, to look at.
  slices.setCursor(Eigen::Vector3d(0.0, -100.0, 352.0));
  const auto artifacts = mrsns::test::guiArtifactDir();
  mrsns::rendering::snapshotSlicesPng(slices, artifacts / "planning_slices_L2.png", 1500, 500);
  mrsns::rendering::snapshotTrajectoryPng(slices, artifacts / "planning_trajectory_L2_left.png", 800, 400);
  window->findChild<QWidget*>("planningAreaDock")->raise();
  screenshot(*window, "planning_window_real_ct.png");
  EXPECT_TRUE(recorder_->messages.empty()) << messages();

  // Saved and reopened in a new window: the same plan with the same figures.
  const Json before = window->sessionState();
  ASSERT_TRUE(window->saveSession());
  window.reset();
  auto reopened = makeWindow();
  ASSERT_TRUE(reopened->openSession(folder)) << messages();
  EXPECT_EQ(reopened->sessionState()["plans"], before["plans"]);
  EXPECT_EQ(reopened->sessionState()["models"], before["models"]);
  EXPECT_EQ(reopened->shownPlan().size(), 4u);
  EXPECT_TRUE(reopened->displayArea()->scene().contains("path:L2 right"));
}

/// A CT imported into a session that has one: the user is asked first; no keeps everything, yes sets the old
/// CT and what was made from it aside in the session (nothing deleted) and imports the new one.
TEST_F(PlanningWindowTest, ASecondCtAsksBeforeTheFirstIsSetAside) {
  const auto write_ct = [&](const std::string& name, double hu) {
    mrsns::ImageVolume ct;
    ct.size = {24, 20, 16};
    ct.spacing = Eigen::Vector3d(1.0, 1.0, 2.0);
    ct.pixel_type = mrsns::PixelType::Int16;
    ct.data.resize(ct.byteCount());
    auto* v = reinterpret_cast<std::int16_t*>(ct.data.data());
    for (std::size_t i = 0; i < ct.voxelCount(); ++i) v[i] = static_cast<std::int16_t>(i % 7 == 0 ? hu : -1000);
    const auto file = scratch_ / (name + ".nrrd");
    mrsns::io::writeImage(ct, file);
    return QString::fromStdString(file.string());
  };
  auto window = makeWindow();
  ASSERT_TRUE(window->createSession(QString::fromStdString((scratch_ / "two-cts").string())));
  const auto import = [&](const QString& file) {
    if (!window->importFile(mrsns::gui::ImportKind::CtImage, file)) return false;
    return mrsns::test::waitUntil([&] { return !window->taskRunning(); }, kPlanningStepTimeoutMs);
  };
  ASSERT_TRUE(import(write_ct("first", 1200.0))) << messages();
  EXPECT_TRUE(recorder_->questions.empty()) << "nothing to replace: no question";
  ASSERT_TRUE(window->runStep("place-fiducial", {{"position", "3,3,3"}}));
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !window->taskRunning(); }, kPlanningStepTimeoutMs));

  recorder_->answer = false;
  EXPECT_FALSE(import(write_ct("second", 1500.0)));
  ASSERT_EQ(recorder_->questions.size(), 1u);
  EXPECT_TRUE(recorder_->questions[0].text.contains("first")) << recorder_->questions[0].text.toStdString();
  EXPECT_EQ(window->sessionState()["images"][0]["name"], "first") << "no: the session is as it was";
  EXPECT_FALSE(window->sessionState()["fiducials"].is_null());

  recorder_->answer = true;
  ASSERT_TRUE(import(write_ct("second", 1500.0))) << messages();
  const auto state = window->sessionState();
  EXPECT_EQ(state["images"][0]["name"], "second");
  EXPECT_TRUE(state["fiducials"].is_null()) << "the new CT starts without the old fiducials";
  ASSERT_EQ(state["set_aside"].size(), 1u);
  EXPECT_EQ(state["set_aside"][0]["images"][0]["name"], "first");
  EXPECT_EQ(state["set_aside"][0]["fiducials"]["points"].size(), 1u);
  EXPECT_TRUE(recorder_->messages.empty()) << messages();
}

}  // namespace
