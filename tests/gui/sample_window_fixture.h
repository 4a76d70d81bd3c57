#pragma once
// A gtest fixture around the real main window, with a recording message
// presenter and the bundled sample session copied into a scratch folder.
#include <gtest/gtest.h>

#include <QTest>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>

#include "gui_test_app.h"
#include "main_window.h"
#include "message_presenter.h"
#include "mrsns/core/error.h"
#include "mrsns/workflow/steps.h"
#include "test_data.h"

namespace mrsns::test {

/// Whether this build ships the sample session (tests skip without it).
inline bool haveSampleSession() {
  try {
    (void)mrsns::workflow::sampleSessionPath();
    return true;
  } catch (const FileError&) {
    return false;
  }
}

class SampleWindowTest : public ::testing::Test {
 protected:
  explicit SampleWindowTest(std::string scratch_name) : scratch_name_(std::move(scratch_name)) {}

  void SetUp() override {
    guiApp();
    recorder_ = std::make_shared<gui::RecordingPresenter>();
    scratch_ = scratchDirectory(scratch_name_);
  }

  /// The main window at 1440x900, shown and exposed.
  std::unique_ptr<gui::MainWindow> makeWindow() {
    gui::MainWindowOptions options;
    options.presenter = recorder_;
    options.remember_window_state = false;
    options.sample_work_folder = QString::fromStdString((scratch_ / "sample").string());
    auto window = std::make_unique<gui::MainWindow>(options);
    window->resize(1440, 900);
    window->show();
    EXPECT_TRUE(QTest::qWaitForWindowExposed(window.get()));
    return window;
  }

  /// Every message the window presented, one per line (for failure output).
  std::string messages() const {
    std::string text;
    for (const auto& m : recorder_->messages) text += m.title.toStdString() + ": " + m.text.toStdString() + "\n";
    return text;
  }

  std::string scratch_name_;
  std::shared_ptr<gui::RecordingPresenter> recorder_;
  std::filesystem::path scratch_;
};

}  // namespace mrsns::test
