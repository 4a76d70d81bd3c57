// mrsns-sim's headset as a process: a scenario's `hmd` connects to the
// workstation's hologram stream (`mrsns-cli serve`), displays its models,
// drops off at a scheduled hmd_disconnect and comes back; the truth file holds
// what it displayed.
#include <gtest/gtest.h>

#include <fstream>

#include "../cli/serve_process.h"
#include "mrsns/core/mesh.h"
#include "mrsns/io/mesh_io.h"
#include "sim_process.h"
#include "test_data.h"

namespace mrsns::test {
namespace {

using Json = nlohmann::json;

TEST(SimHmd, TheHeadsetDisplaysTheWorkstationsModelsAndReconnectsAfterADisconnect) {
  const auto dir = scratchDirectory("sim-hmd");
  TriangleMesh mesh;
  mesh.vertices.resize(4, 3);
  mesh.vertices << 0, 0, 0, 10, 0, 0, 0, 10, 0, 0, 0, 10;
  mesh.faces.resize(4, 3);
  mesh.faces << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  io::writeMesh(mesh, dir / "C5.stl");
  const auto port = freePort();
  ServeProcess serve({"--port", std::to_string(port), "--source", "simulator", "--rate", "60", "--models",
                      (dir / "C5.stl").string(), "--json"});
  ASSERT_TRUE(serve.started());
  std::ofstream(dir / "s.json") << R"({"format": "mrsns-scenario/1", "tracker": {"port": 0},
      "hmd": {"port": )" << port << R"(, "drift_mm_per_min": 1.0, "jitter_mm": 0.2},
      "faults": [{"kind": "hmd_disconnect", "at_s": 1.5, "duration_s": 1.0}],
      "duration_s": 4.0})";
  const auto run =
      runSim({"run", "--scenario", (dir / "s.json").string(), "--truth", (dir / "truth.json").string(), "--json"});
  serve.terminate();
  const auto served = serve.wait();
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto summary = Json::parse(run.out);
  EXPECT_TRUE(summary["hmd"]["enabled"].get<bool>());
  EXPECT_GE(summary["hmd"]["meshes"].get<int>(), 2) << "the model, again after the reconnection";
  EXPECT_GT(summary["hmd"]["transforms_displayed"].get<int>(), 60);
  std::ifstream in(dir / "truth.json");
  const auto truth = Json::parse(in);
  const double utc0 = truth["utc_start"].get<double>();
  int shown_before = 0, shown_during = 0, shown_after = 0;
  for (const auto& h : truth["hmd_displayed"]) {
    const double t = h["utc"].get<double>() - utc0;
    for (std::size_t i = 0; i < h["models"].size(); ++i) {
      if (h["models"][i] != "C5" || !h["visible"][i].get<bool>()) continue;
      if (t < 1.4) ++shown_before;
      if (t > 1.6 && t < 2.4) ++shown_during;
      if (t > 3.0) ++shown_after;
    }
  }
  EXPECT_GT(shown_before, 5) << "displayed at 10 Hz once connected";
  EXPECT_EQ(shown_during, 0) << "hidden while the headset is disconnected";
  EXPECT_GT(shown_after, 5) << "displayed again after it reconnected";
  ASSERT_EQ(served.exit_code, 0) << served.err;
  EXPECT_GE(Json::parse(served.out)["clients"].get<int>(), 2) << "the headset connected twice";
}

}  // namespace
}  // namespace mrsns::test
