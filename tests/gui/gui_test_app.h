#pragma once
// One QApplication for the whole GUI test program (Qt allows one per
// process), with settings and the sample copy kept inside the build tree.
#include <QApplication>
#include <QSettings>
#include <QStandardPaths>
#include <QTest>
#include <filesystem>
#include <functional>

#include "display_area.h"

namespace mrsns::test {

inline std::filesystem::path guiArtifactDir() {
  const char* binary = std::getenv("MRSNS_BINARY_DIR");
  if (binary == nullptr) binary = MRSNS_TEST_BINARY_DIR;
  const auto dir = std::filesystem::path(binary) / "test-artifacts" / "gui";
  std::filesystem::create_directories(dir);
  return dir;
}

inline QApplication& guiApp() {
  static int argc = 1;
  static char name[] = "mrsns_gui_tests";
  static char* argv[] = {name, nullptr};
  static QApplication* app = [] {
    mrsns::gui::prepareOpenGlSurfaceFormat();
    QStandardPaths::setTestModeEnabled(true);
    auto* a = new QApplication(argc, argv);
    QApplication::setOrganizationName(QStringLiteral("MR-SNS-tests"));
    QApplication::setApplicationName(QStringLiteral("mrsns-gui-tests"));
    const auto settings = guiArtifactDir().parent_path() / "gui-settings";
    QSettings::setPath(QSettings::NativeFormat, QSettings::UserScope, QString::fromStdString(settings.string()));
    return a;
  }();
  return *app;
}

/// Processes events until `done` holds or `timeout_ms` passes (QTRY_VERIFY's loop, for gtest).
inline bool waitUntil(const std::function<bool()>& done, int timeout_ms) {
  return QTest::qWaitFor(done, timeout_ms);
}

}  // namespace mrsns::test
