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

TEST(HmdOperator, ATrackedHeadsetShowsWhereTheWearerSeesEachModelInTheTrackerFrame) {
  // The workstation streams one pose; the headset (anchored at its marker, no drift) displays it.
  Eigen::Isometry3d hologram_T_model = Eigen::Isometry3d::Identity();
  hologram_T_model.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix();
  hologram_T_model.translation() = Eigen::Vector3d(10, -20, 400);
  igtlink::ServerOptions o;
  o.port = 0;
  igtlink::Server workstation(o);
  workstation.onConnect([&](igtlink::ClientId id) {
    workstation.send(id, igtlink::makeMessage("C5", igtlink::TransformContent::fromIsometry(hologram_T_model)),
                     igtlink::HeaderVersion::kV2, igtlink::Channel::Reliable);
  });
  workstation.start();
  const auto scenario = parseScenario(R"({"format": "mrsns-scenario/1", "tracker": {"port": 0},
      "tools": [{"name": "HeadsetToTracker",
                 "start": {"translation_mm": [100, -50, -1200], "rotation_deg": [0, 0, 30]}}],
      "hmd": {"port": )" + std::to_string(workstation.port()) +
                                          R"(, "marker_tool": "HeadsetToTracker",
              "world_to_marker": {"translation_mm": [0, 40, 20], "rotation_deg": [90, 0, 0]}},
      "duration_s": 1.5})",
                                      ".");
  OperatingRoom room(scenario);
  room.start();
  while (!room.finished()) std::this_thread::sleep_for(20ms);
  room.stop();
  workstation.stop();
  const auto dir = test::scratchDirectory("hmd-tracked");
  room.writeTruth(dir / "truth.json");
  std::ifstream in(dir / "truth.json");
  const auto truth = nlohmann::json::parse(in);
  ASSERT_TRUE(truth.contains("HeadsetWorldToTracker"));
  const Eigen::Isometry3d tracker_T_marker = scenario.tools[0].start;
  const Eigen::Isometry3d expected = tracker_T_marker * scenario.hmd.marker_T_world * hologram_T_model;
  int checked = 0;
  for (const auto& h : truth["hmd_displayed"]) {
    if (!h.contains("tracker_T_model") || h["models"].empty() || !h["visible"][0].get<bool>()) continue;
    const auto& p = h["tracker_T_model"][0];
    // TRANSFORM carries float32: ~1e-4 mm at these distances.
    EXPECT_LT((Eigen::Vector3d(p[0], p[1], p[2]) - expected.translation()).norm(), 1e-3);
    const Eigen::Quaterniond q(p[3].get<double>(), p[4].get<double>(), p[5].get<double>(), p[6].get<double>());
    EXPECT_LT(q.angularDistance(Eigen::Quaterniond(expected.linear())), 1e-6);
    ++checked;
  }
  EXPECT_GT(checked, 5) << "displayed at 10 Hz";
}

}  // namespace
}  // namespace mrsns::simulation
