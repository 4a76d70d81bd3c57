// The virtual operator at the headset: the workstation prompts through the
// hologram stream, and the operator confirms once the task's time has passed;
// timeline confirmations arrive at their times. Read from the workstation's
// side of the wire.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "mrsns/igtlink/server.h"
#include "mrsns/simulation/operating_room.h"
#include "mrsns/simulation/scenario.h"
#include "test_data.h"

namespace mrsns::simulation {
namespace {

using namespace std::chrono_literals;

TEST(HmdOperator, ThePromptedOperatorConfirmsAfterTheTaskAndOnTheTimeline) {
  igtlink::ServerOptions o;
  o.port = 0;
  igtlink::Server workstation(o);
  std::mutex mutex;
  std::vector<std::pair<std::chrono::steady_clock::time_point, std::string>> received;
  std::chrono::steady_clock::time_point prompted;
  workstation.onConnect([&](igtlink::ClientId id) {
    igtlink::StringContent prompt;
    prompt.text = "Align the calibration cube with its hologram, then confirm";
    {
      std::lock_guard lock(mutex);
      prompted = std::chrono::steady_clock::now();
    }
    workstation.send(id, igtlink::makeMessage("Prompt", prompt), igtlink::HeaderVersion::kV2,
                     igtlink::Channel::Reliable);
  });
  workstation.onMessage([&](igtlink::ClientId, const igtlink::Message& m) {
    if (const auto* text = m.as<igtlink::StringContent>()) {
      std::lock_guard lock(mutex);
      received.emplace_back(std::chrono::steady_clock::now(), m.header.device_name + ":" + text->text);
    }
  });
  workstation.start();
  const auto scenario = parseScenario(R"({"format": "mrsns-scenario/1", "tracker": {"port": 0},
      "hmd": {"port": )" + std::to_string(workstation.port()) +
                                          R"(,
              "respond": [{"prompt_contains": "calibration cube", "after_s": 1.5, "confirm": "cube-aligned"},
                          {"prompt_contains": "touch fiducial", "after_s": 0.5, "confirm": "touched"}],
              "confirmations": [{"at_s": 0.5, "confirm": "ready"}]},
      "duration_s": 3.0})",
                                      ".");
  OperatingRoom room(scenario);
  room.start();
  while (!room.finished()) std::this_thread::sleep_for(20ms);
  room.stop();
  workstation.stop();
  std::lock_guard lock(mutex);
  ASSERT_EQ(received.size(), 2u) << "one timeline confirmation and one answer; no answer to an unmatched prompt";
  EXPECT_EQ(received[0].second, "Confirm:ready");
  EXPECT_EQ(received[1].second, "Confirm:cube-aligned");
  const double after = std::chrono::duration<double>(received[1].first - prompted).count();
  // 1.5 s of task time, checked at 10 Hz, plus loopback.
  EXPECT_GE(after, 1.5);
  EXPECT_LT(after, 1.5 + 0.25);
  const auto dir = test::scratchDirectory("hmd-operator");
  room.writeTruth(dir / "truth.json");
  std::ifstream in(dir / "truth.json");
  const auto truth = nlohmann::json::parse(in);
  std::vector<std::string> events;
  for (const auto& e : truth["events"]) events.push_back(e["event"]);
  EXPECT_NE(std::find(events.begin(), events.end(), "hmd confirm: cube-aligned"), events.end());
  EXPECT_NE(
      std::find(events.begin(), events.end(), "hmd prompt: Align the calibration cube with its hologram, then confirm"),
      events.end());
  EXPECT_EQ(room.stats().faults_fired, 0u) << "prompts and confirmations are not faults";
}

}  // namespace
}  // namespace mrsns::simulation
