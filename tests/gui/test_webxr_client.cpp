// The WebXR client from the function panel: switched on, the panel shows the
// page's address and pairing code; a page (a TLS WebSocket client here; the
// real page in chromium is tests/webxr) pairs with that code and gets the
// session's models, a wrong code gets nothing; live navigation takes the
// service over on the same port with the same code (the sample session has
// no HMD calibration, so the page is told each model's tracking is lost
// rather than shown it anywhere), and hands it back when it stops; switched
// off, the port is closed.
#include <gtest/gtest.h>

#include <QCheckBox>
#include <QLabel>
#include <QPushButton>
#include <QSpinBox>
#include <QTest>
#include <atomic>
#include <thread>

#include "loopback_ports.h"
#include "mrsns/igtlink/server.h"
#include "mrsns/workflow/navigation.h"
#include "sample_window_fixture.h"
#include "tls_test_client.h"
#include "wait_for.h"

namespace {

using namespace std::chrono_literals;

class WebXrClientTest : public mrsns::test::SampleWindowTest {
 protected:
  WebXrClientTest() : SampleWindowTest("gui-webxr") {}
};

/// Pairs a page with `code`; what it received within `frames` frames (until every mesh has its status).
struct PageView {
  bool paired = false;
  int meshes = 0;
  int statuses = 0;
};

PageView pairAndRead(std::uint16_t port, const std::string& code, int frames) {
  PageView view;
  mrsns::test::TlsTestClient page(port);
  page.setTimeout(2.0);
  if (!page.upgrade()) return view;
  page.sendText(R"({"type":"pair","code":")" + code + "\"}");
  for (int i = 0; i < frames; ++i) {
    const auto frame = page.readFrame();
    if (!frame || frame->opcode == 0x8) break;
    if (frame->payload == R"({"type":"paired"})") view.paired = true;
    if (frame->opcode == 0x2 && frame->payload.find(R"("type":"mesh")") != std::string::npos) ++view.meshes;
    if (frame->payload.find(R"("type":"status")") != std::string::npos) ++view.statuses;
    if (view.meshes > 0 && view.statuses >= view.meshes) break;
  }
  return view;
}

/// pairAndRead on a thread while the GUI's event loop turns (the window's service is updated from its timer).
PageView pairWhileTheWindowRuns(int port, const std::string& code, int frames, int timeout_ms) {
  std::atomic<bool> done{false};
  PageView view;
  std::thread page([&] {
    view = pairAndRead(static_cast<std::uint16_t>(port), code, frames);
    done = true;
  });
  const bool finished = mrsns::test::waitUntil([&] { return done.load(); }, timeout_ms);
  page.join();
  EXPECT_TRUE(finished) << "the page did not finish reading within " << timeout_ms << " ms";
  return view;
}

TEST_F(WebXrClientTest, PanelShowsTheCodeAPagePairsAndNavigationTakesItOver) {
  if (!mrsns::test::haveSampleSession()) GTEST_SKIP() << "no bundled sample session";
  auto window = makeWindow();
  ASSERT_TRUE(window->openSampleSession()) << messages();
  auto* toggle = window->findChild<QPushButton*>("webxrClient");
  auto* port_box = window->findChild<QSpinBox*>("webxrPort");
  auto* status = window->findChild<QLabel*>("webxrStatus");
  auto* network = window->findChild<QCheckBox*>("webxrNetwork");
  ASSERT_TRUE(toggle && port_box && status && network);
  EXPECT_FALSE(network->isChecked()) << "the page is served to this machine only unless asked";
  const int port = mrsns::igtlink::freeLocalPort();
  port_box->setValue(port);
  QTest::mouseClick(toggle, Qt::LeftButton);
  ASSERT_TRUE(window->webXrServing()) << messages();
  const std::string code = window->webXrPairingCode();
  ASSERT_EQ(code.size(), 6U);
  EXPECT_TRUE(status->text().contains(QString::fromStdString(code))) << status->text().toStdString();
  EXPECT_TRUE(status->text().contains(QStringLiteral("https://127.0.0.1:%1/").arg(port)))
      << status->text().toStdString();
  EXPECT_FALSE(port_box->isEnabled());
  const auto screenshot = mrsns::test::guiArtifactDir() / "main_window_webxr_panel.png";
  window->saveScreenshot(QString::fromStdString(screenshot.string()));

  // A wrong code gets nothing; the right one gets every model the session shows.
  const PageView wrong = pairAndRead(static_cast<std::uint16_t>(port), "000000", 5);
  EXPECT_FALSE(wrong.paired);
  EXPECT_EQ(wrong.meshes, 0);
  // The window's service runs on the GUI's event loop (its timer): it keeps turning while the page reads.
  const PageView right = pairWhileTheWindowRuns(port, code, 40, 20000);
  EXPECT_TRUE(right.paired);
  EXPECT_GE(right.meshes, 3) << "the sample session's vertebrae, vessel and screws";

  // Live navigation serves the page now, on the same port with the same code, with the tracked poses.
  mrsns::workflow::NavigationOptions options;
  options.robot.robot = "none";
  ASSERT_TRUE(window->startNavigation(options)) << messages();
  EXPECT_EQ(window->webXrPairingCode(), code);
  const PageView live = pairWhileTheWindowRuns(port, code, 400, 30000);
  EXPECT_TRUE(live.paired);
  EXPECT_GE(live.meshes, 3);
  EXPECT_EQ(live.statuses, live.meshes) << "each model's tracking state from the navigation loop";
  window->stopNavigation();
  EXPECT_TRUE(window->webXrServing()) << "the window serves the page again after navigation";
  const PageView after = pairWhileTheWindowRuns(port, code, 40, 20000);
  EXPECT_TRUE(after.paired);

  QTest::mouseClick(toggle, Qt::LeftButton);
  EXPECT_FALSE(window->webXrServing());
  EXPECT_TRUE(port_box->isEnabled());
  EXPECT_THROW(mrsns::test::TlsTestClient closed(static_cast<std::uint16_t>(port)), std::system_error);
}

}  // namespace
