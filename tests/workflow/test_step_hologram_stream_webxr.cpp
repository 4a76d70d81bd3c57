// A step's hologram stream with the WebXR page (webxr_port): a paired page is
// the step's headset (the stream counts it only while paired), it receives
// the cube's mesh and the step's prompt, and its confirmation reaches the
// step's callback; unity and the page do not go together.
#include <gtest/gtest.h>

#include <atomic>

#include "loopback_ports.h"
#include "mrsns/core/error.h"
#include "step_hologram_stream.h"
#include "test_data.h"
#include "tls_test_client.h"
#include "wait_for.h"
#include "webxr_test_scene.h"

namespace mrsns::workflow::detail {
namespace {

using namespace std::chrono_literals;

const std::initializer_list<const char*> kKnown = {"hmd_address",   "hmd_port",   "unity",        "webxr_port",
                                                   "webxr_address", "webxr_code", "webxr_tls_dir"};

TEST(StepHologramStreamWebXr, APairedPageIsTheStepsHeadset) {
  const int hmd_port = test::closedPort();
  const int web_port = test::closedPort();
  ASSERT_GT(hmd_port, 0);
  ASSERT_GT(web_port, 0);
  const Params p("hmd-calibration",
                 Json{{"hmd_port", hmd_port},
                      {"webxr_port", web_port},
                      {"webxr_code", "864209"},
                      {"webxr_tls_dir", test::scratchDirectory("tls").string()}},
                 kKnown);
  const StepStreamAddress address = stepStreamAddress("hmd-calibration", p, 64 * 1024);
  EXPECT_NE(address.endpoint.find("https://127.0.0.1:" + std::to_string(web_port) + "/"), std::string::npos)
      << address.endpoint;
  EXPECT_NE(address.endpoint.find("864209"), std::string::npos) << address.endpoint;

  std::atomic<int> confirmations{0};
  tracking::HologramStreamOptions options;
  options.on_confirmation = [&](igtlink::ClientId, const std::string& text) {
    if (text == "select gesture") ++confirmations;
  };
  auto repository = std::make_shared<TransformRepository>();
  StepHologramStream stream(
      "hmd-calibration", address, repository,
      {tracking::HologramModel{"CalibrationCube", test::boxMesh({30.0, 30.0, 30.0}, {0.0, 0.0, 0.0}), "Hologram"}},
      options);
  stream.streamer().setPrompt("front view: line up the cube with its hologram, hold it still and confirm");
  EXPECT_EQ(stream.streamer().readyClients(), 0U);
  {
    test::TlsTestClient page(static_cast<std::uint16_t>(web_port));
    ASSERT_TRUE(page.upgrade());
    page.sendText(R"({"type":"pair","code":"864209"})");
    bool cube = false;
    bool prompt = false;
    for (int i = 0; i < 50 && !(cube && prompt); ++i) {
      const auto frame = page.readFrame();
      ASSERT_TRUE(frame) << "the page's stream ended";
      if (frame->opcode == 0x2 && frame->payload.find(R"("name":"CalibrationCube")") != std::string::npos) cube = true;
      if (frame->payload.find("front view: line up the cube") != std::string::npos) prompt = true;
    }
    EXPECT_TRUE(cube) << "the page did not receive the cube";
    EXPECT_TRUE(prompt) << "the page did not receive the step's prompt";
    EXPECT_TRUE(test::waitFor([&] { return stream.streamer().readyClients() == 1; }, 5s));
    page.sendText(R"({"type":"confirm","text":"select gesture"})");
    EXPECT_TRUE(test::waitFor([&] { return confirmations.load() == 1; }, 5s));
  }
  // The page gone, the step's headset is gone.
  EXPECT_TRUE(test::waitFor([&] { return stream.streamer().readyClients() == 0; }, 5s));
}

TEST(StepHologramStreamWebXr, UnityAndThePageAreRefusedTogether) {
  const Params p("hmd-calibration", Json{{"hmd_port", 18945}, {"webxr_port", 8443}, {"unity", true}}, kKnown);
  EXPECT_THROW((void)stepStreamAddress("hmd-calibration", p, 64 * 1024), InvalidArgumentError);
  const Params bad_code("hmd-calibration", Json{{"hmd_port", 18945}, {"webxr_port", 8443}, {"webxr_code", "12a"}},
                        kKnown);
  EXPECT_THROW((void)stepStreamAddress("hmd-calibration", bad_code, 64 * 1024), InvalidArgumentError);
}

}  // namespace
}  // namespace mrsns::workflow::detail
