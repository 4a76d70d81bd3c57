#include <gtest/gtest.h>

#include <QSignalSpy>
#include <thread>

#include "gui_test_app.h"
#include "mrsns/core/error.h"
#include "task_runner.h"

using mrsns::gui::TaskControl;
using mrsns::gui::TaskOutcome;
using mrsns::gui::TaskRunner;

namespace {

TaskOutcome waitForOutcome(TaskRunner& runner, QSignalSpy& finished) {
  EXPECT_TRUE(mrsns::test::waitUntil([&] { return !finished.isEmpty(); }, 5000));
  EXPECT_FALSE(runner.busy());
  return finished.isEmpty() ? TaskOutcome{} : finished.first().at(1).value<TaskOutcome>();
}

TaskOutcome okOutcome() {
  TaskOutcome outcome;
  outcome.ok = true;
  return outcome;
}

}  // namespace

TEST(TaskRunner, RunsOffTheGuiThreadAndReportsProgress) {
  mrsns::test::guiApp();
  TaskRunner runner;
  QSignalSpy finished(&runner, &TaskRunner::finished);
  QSignalSpy progressed(&runner, &TaskRunner::progressed);
  const auto gui_thread = std::this_thread::get_id();
  std::thread::id worker_thread;
  ASSERT_TRUE(runner.start("work", [&](const TaskControl& control) {
    worker_thread = std::this_thread::get_id();
    control.progress(0.5, "half");
    control.progress(1.0, "done");
    TaskOutcome outcome;
    outcome.ok = true;
    outcome.figures["rms_mm"] = 0.25;
    return outcome;
  }));
  EXPECT_TRUE(runner.busy());
  const TaskOutcome outcome = waitForOutcome(runner, finished);
  EXPECT_TRUE(outcome.ok);
  EXPECT_DOUBLE_EQ(outcome.figures["rms_mm"].get<double>(), 0.25);
  EXPECT_NE(worker_thread, gui_thread);
  // The final report (fraction 1) always passes the throttle.
  ASSERT_TRUE(mrsns::test::waitUntil([&] { return !progressed.isEmpty(); }, 1000));
  EXPECT_DOUBLE_EQ(progressed.last().at(1).toDouble(), 1.0);
}

TEST(TaskRunner, OneTaskAtATime) {
  mrsns::test::guiApp();
  TaskRunner runner;
  QSignalSpy finished(&runner, &TaskRunner::finished);
  std::atomic<bool> release{false};
  ASSERT_TRUE(runner.start("slow", [&](const TaskControl&) {
    while (!release) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    return okOutcome();
  }));
  EXPECT_FALSE(runner.start("second", [](const TaskControl&) { return okOutcome(); }));
  release = true;
  waitForOutcome(runner, finished);
  EXPECT_EQ(finished.first().at(0).toString(), QStringLiteral("slow"));
}

TEST(TaskRunner, CancelIsSeenByTheTaskAndReportedAsCancelled) {
  mrsns::test::guiApp();
  TaskRunner runner;
  QSignalSpy finished(&runner, &TaskRunner::finished);
  ASSERT_TRUE(runner.start("loop", [](const TaskControl& control) {
    while (!control.cancel->load()) std::this_thread::sleep_for(std::chrono::milliseconds(1));
    return TaskOutcome{};  // not ok: stopped early
  }));
  runner.cancel();
  const TaskOutcome outcome = waitForOutcome(runner, finished);
  EXPECT_FALSE(outcome.ok);
  EXPECT_TRUE(outcome.cancelled);
}

TEST(TaskRunner, ThrownErrorsBecomeMessagesNotCrashes) {
  mrsns::test::guiApp();
  TaskRunner runner;
  QSignalSpy finished(&runner, &TaskRunner::finished);
  ASSERT_TRUE(runner.start("bad", [](const TaskControl&) -> TaskOutcome {
    throw mrsns::FileError("'x.stl' does not exist: choose an existing file");
  }));
  TaskOutcome outcome = waitForOutcome(runner, finished);
  EXPECT_FALSE(outcome.ok);
  EXPECT_FALSE(outcome.cancelled);
  EXPECT_TRUE(outcome.error.contains("x.stl"));

  finished.clear();
  ASSERT_TRUE(runner.start("defect", [](const TaskControl&) -> TaskOutcome { throw std::logic_error("bug"); }));
  outcome = waitForOutcome(runner, finished);
  EXPECT_TRUE(outcome.error.contains("bug"));
  EXPECT_TRUE(outcome.error.contains("report"));
}
