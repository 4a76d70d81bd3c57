// Interop with pyigtl (PyPI) both ways: pyigtl sends OpenIGTLink v2
// messages with metadata to an MR-SNS server, which must decode them exactly;
// the server answers with v2 IMAGE, STRING and POINT that pyigtl must decode
// (checked in pyigtl_send.py). Skipped (not failed) when no Python with
// pyigtl is available.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <thread>

#include "mrsns/igtlink/server.h"

namespace mrsns::igtlink {
namespace {

std::string pythonWithPyigtl() {
  const char* env = std::getenv("MRSNS_PYTHON");
  const std::string python = env != nullptr ? env : MRSNS_PYTHON_DEFAULT;
  std::error_code ec;
  if (python.empty() || !std::filesystem::exists(python, ec)) return {};
  const std::string probe = "'" + python + "' -c 'import pyigtl, numpy' >/dev/null 2>&1";
  return std::system(probe.c_str()) == 0 ? python : std::string();
}

TEST(Pyigtl, ExchangesV2MessagesWithMetadataBothWays) {
  const auto python = pythonWithPyigtl();
  if (python.empty()) {
    GTEST_SKIP() << "no Python with pyigtl (scripts/test.sh creates build/venv with pyigtl==0.3.4, or set "
                    "MRSNS_PYTHON)";
  }
  ServerOptions options;
  options.port = 0;
  Server server(options);
  std::mutex mutex;
  std::vector<Message> received;
  server.onMessage([&](ClientId client, const Message& m) {
    std::lock_guard lock(mutex);
    received.push_back(m);
    if (m.header.type != "POINT") return;
    // pyigtl sends POINT last: answer with our own encodings.
    ImageContent image;
    image.resizeWhole({3, 2, 2});
    image.setGeometry(Eigen::Vector3d(0.3, 0.4, 1.5), Eigen::Matrix3d::Identity(), Eigen::Vector3d(1, 2, 3));
    for (int k = 0; k < 2; ++k) {
      for (int j = 0; j < 2; ++j) {
        for (int i = 0; i < 3; ++i)
          image.pixels[static_cast<std::size_t>(i + 3 * j + 6 * k)] = static_cast<std::uint8_t>(3 * k + 2 * j + i);
      }
    }
    auto image_message = makeMessage("MrsnsImage", image);
    image_message.metadata.push_back({"Source", kEncodingUsAscii, "mrsns"});
    server.send(client, image_message, HeaderVersion::kV2, Channel::Reliable);
    server.send(client, makeMessage("MrsnsText", StringContent{kEncodingUsAscii, "hello from mrsns"}),
                HeaderVersion::kV2, Channel::Reliable);
    PointContent points;
    points.points.push_back({"Nasion", "Fiducial", {255, 0, 0, 255}, {1, 2, 3}, 1.0, "CT"});
    points.points.push_back({"Tip", "Fiducial", {0, 255, 0, 255}, {7.5, -8.0, 9.25}, 1.0, "CT"});
    server.send(client, makeMessage("MrsnsPoints", points), HeaderVersion::kV2, Channel::Reliable);
  });
  server.start();
  const std::string command =
      "'" + python + "' '" MRSNS_INTEROP_DIR "/pyigtl_send.py' --port " + std::to_string(server.port()) + " 2>&1";
  const int status = std::system(command.c_str());
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
      << "pyigtl_send.py failed (its FAIL line above says what): " << command;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  for (;;) {
    {
      std::lock_guard lock(mutex);
      if (received.size() >= 4) break;
    }
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "fewer than 4 messages arrived";
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  std::lock_guard lock(mutex);
  ASSERT_EQ(received.size(), 4u);
  EXPECT_EQ(server.stats().malformed_messages, 0u);

  const auto& transform = received[0];
  EXPECT_EQ(transform.header.type, "TRANSFORM");
  EXPECT_EQ(transform.header.device_name, "PyProbeToTracker");
  EXPECT_EQ(transform.header.version, 2);
  EXPECT_EQ(transform.metadataValue("Source").value_or(""), "pyigtl");
  EXPECT_EQ(transform.metadataValue("TransformStatus").value_or(""), "OK");
  ASSERT_NE(transform.as<TransformContent>(), nullptr);
  Eigen::Matrix4d expected;
  expected << 0, -1, 0, 10.5, 1, 0, 0, -20.25, 0, 0, 1, 30.0, 0, 0, 0, 1;
  EXPECT_LT((transform.as<TransformContent>()->matrix - expected).cwiseAbs().maxCoeff(), 1e-6);
  EXPECT_NEAR(timestampToSeconds(transform.header.timestamp), 1700000000.5, 1e-6);

  const auto& image = received[1];
  EXPECT_EQ(image.header.type, "IMAGE");
  EXPECT_EQ(image.metadataValue("Modality").value_or(""), "US");
  const auto* pixels = image.as<ImageContent>();
  ASSERT_NE(pixels, nullptr);
  EXPECT_EQ(pixels->size, (std::array<std::uint16_t, 3>{4, 3, 2}));
  EXPECT_EQ(pixels->scalar_type, ScalarType::kUint8);
  EXPECT_TRUE(pixels->spacing().isApprox(Eigen::Vector3d(0.5, 0.75, 2.0), 1e-6)) << pixels->spacing().transpose();
  ASSERT_EQ(pixels->pixels.size(), 24u);
  for (int k = 0; k < 2; ++k) {
    for (int j = 0; j < 3; ++j) {
      for (int i = 0; i < 4; ++i) {
        EXPECT_EQ(pixels->pixels[static_cast<std::size_t>(i + 4 * j + 12 * k)], 100 * k + 10 * j + i);
      }
    }
  }

  const auto& text = received[2];
  ASSERT_NE(text.as<StringContent>(), nullptr);
  EXPECT_EQ(text.as<StringContent>()->text, "hello from pyigtl");
  EXPECT_EQ(text.metadataValue("Language").value_or(""), "en");

  const auto& points = received[3];
  ASSERT_NE(points.as<PointContent>(), nullptr);
  ASSERT_EQ(points.as<PointContent>()->points.size(), 2u);
  EXPECT_EQ(points.as<PointContent>()->points[0].name, "Entry");
  EXPECT_TRUE(points.as<PointContent>()->points[1].position.isApprox(Eigen::Vector3d(-4.5, 5.5, 6.25)));
}

}  // namespace
}  // namespace mrsns::igtlink
