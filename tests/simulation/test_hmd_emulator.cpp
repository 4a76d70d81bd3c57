// The HMD emulator against the workstation's own hologram stream in process
// (igtlink::Server + tracking::HologramStreamer over a TransformRepository):
// meshes, poses within float32, lost chains, reconnection, the Unity
// convention, the headset's drift and jitter, and the operator's
// confirmation that the stream must ignore.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <mutex>
#include <numbers>
#include <optional>
#include <thread>

#include "mrsns/core/error.h"
#include "mrsns/core/rigid.h"
#include "mrsns/core/transform_repository.h"
#include "mrsns/core/wall_clock.h"
#include "mrsns/igtlink/server.h"
#include "mrsns/simulation/hmd_emulator.h"
#include "mrsns/tracking/hologram_streamer.h"

namespace mrsns::simulation {
namespace {

bool waitUntil(const std::function<bool()>& done, double timeout_s = 5.0) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return done();
}

TriangleMesh tetrahedron() {
  TriangleMesh mesh;
  mesh.vertices.resize(4, 3);
  mesh.vertices << 0, 0, 0, 10, 0, 0, 0, 10, 0, 0, 0, 10;
  mesh.faces.resize(4, 3);
  mesh.faces << 0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3;
  return mesh;
}

TriangleMesh box() {  // 8 vertices, 12 triangles, 40 x 20 x 10 mm, off the origin
  TriangleMesh mesh;
  mesh.vertices.resize(8, 3);
  for (int i = 0; i < 8; ++i) {
    mesh.vertices.row(i) << 5.0 + 40.0 * (i & 1), -3.0 + 20.0 * ((i >> 1) & 1), 7.0 + 10.0 * ((i >> 2) & 1);
  }
  mesh.faces.resize(12, 3);
  mesh.faces << 0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6, 1, 3, 5, 3,
      7, 5;
  return mesh;
}

Eigen::Isometry3d pose(double rx_deg, double ry_deg, double rz_deg, double x, double y, double z) {
  Eigen::Isometry3d p = Eigen::Isometry3d::Identity();
  p.linear() = (Eigen::AngleAxisd(rx_deg * std::numbers::pi / 180.0, Eigen::Vector3d::UnitX()) *
                Eigen::AngleAxisd(ry_deg * std::numbers::pi / 180.0, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(rz_deg * std::numbers::pi / 180.0, Eigen::Vector3d::UnitZ()))
                   .toRotationMatrix();
  p.translation() = Eigen::Vector3d(x, y, z);
  return p;
}

// The workstation side: Eq. 1's chain in a repository and the stream on a server.
//   C5 -> Preop -> Reference -> Tracker <- Hologram      (model "C5", 4 vertices)
//   Probe -> Tracker <- Hologram                         (model "Probe", 8 vertices)
struct Workstation {
  explicit Workstation(tracking::HologramStreamOptions options = {}, std::uint16_t port = 0) {
    repository = std::make_shared<TransformRepository>();
    repository->setTransform("C5", "Preop", pose(3, -2, 10, 12.5, -40.25, 8.0), TransformStatus::Ok, NAN, true);
    repository->setTransform("Preop", "Reference", pose(-20, 5, 170, 31.0, 102.0, -55.5), TransformStatus::Ok, NAN,
                             true);
    igtlink::ServerOptions server_options;
    server_options.port = port;
    server = std::make_unique<igtlink::Server>(server_options);
    options.hologram_frame = "Hologram";
    std::vector<tracking::HologramModel> models = {{"C5", tetrahedron(), "C5"}, {"Probe", box(), "Probe"}};
    streamer = std::make_unique<tracking::HologramStreamer>(*server, repository, models, options);
    server->start();
  }
  ~Workstation() { server->stop(); }

  // One tracker sample: the tools and the headset at time t (UTC s), then the stream's update.
  void track(double t, int step, bool probe_ok = true) {
    repository->setTransform("Reference", "Tracker", pose(10 + step, -5, 30 - step, -50 + step, 20, -1100 + 0.5 * step),
                             TransformStatus::Ok, t);
    repository->setTransform("Probe", "Tracker", pose(100 - 3 * step, 40, -60, 80 - step, -35, -900 - step),
                             probe_ok ? TransformStatus::Ok : TransformStatus::Invalid, t);
    repository->setTransform("Hologram", "Tracker", pose(-90, 0.5 * step, 180, 250, -1500 + step, 300), TransformStatus::Ok,
                             t);
    streamer->update(t);
  }
  Eigen::Isometry3d hologramT(const std::string& frame) const {
    return repository->getTransform(frame, "Hologram").to_T_from;
  }

  std::shared_ptr<TransformRepository> repository;
  std::unique_ptr<igtlink::Server> server;
  std::unique_ptr<tracking::HologramStreamer> streamer;
};

HmdEmulatorOptions emulatorOptions(std::uint16_t port) {
  HmdEmulatorOptions o;
  o.port = port;
  o.reconnect_max_s = 0.1;
  return o;
}

std::optional<DisplayedModel> find(const HmdEmulator& hmd, const std::string& name) {
  for (auto& m : hmd.displayed()) {
    if (m.name == name) return m;
  }
  return std::nullopt;
}

std::uint64_t updatesOf(const HmdEmulator& hmd, const std::string& name) {
  const auto m = find(hmd, name);
  return m ? m->updates : 0;
}

// Max element difference of the rotation block and of the translation (mm).
std::pair<double, double> difference(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  return {(a.linear() - b.linear()).cwiseAbs().maxCoeff(), (a.translation() - b.translation()).cwiseAbs().maxCoeff()};
}

// Largest element error of `received` in units of float32 rounding of `sent`
// (round to nearest: at most 2^-24 relative); <= 1 when only the wire rounded.
double float32Ulps(const Eigen::Isometry3d& received, const Eigen::Isometry3d& sent) {
  double worst = 0.0;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) {
      const double bound = std::ldexp(std::abs(sent.matrix()(r, c)), -24) + 1e-15;
      worst = std::max(worst, std::abs(received.matrix()(r, c) - sent.matrix()(r, c)) / bound);
    }
  }
  return worst;
}

TEST(HmdEmulator, RefusesBadOptionsAndEmptyConfirmations) {
  auto expectRefused = [](HmdEmulatorOptions o) { EXPECT_THROW(HmdEmulator{o}, InvalidArgumentError); };
  HmdEmulatorOptions o;
  o.port = 0;
  expectRefused(o);
  o = {};
  o.host = "";
  expectRefused(o);
  o = {};
  o.drift_mm_per_min = -1.0;
  expectRefused(o);
  o = {};
  o.jitter_mm = std::nan("");
  expectRefused(o);
  o = {};
  o.reconnect_max_s = std::numeric_limits<double>::infinity();
  expectRefused(o);

  HmdEmulator hmd(HmdEmulatorOptions{});
  EXPECT_THROW(hmd.confirm(""), InvalidArgumentError);
  EXPECT_THROW(hmd.confirm(std::string(70000, 'x')), InvalidArgumentError);
  EXPECT_FALSE(hmd.confirm("cube-aligned"));  // not started: nothing to send on
  EXPECT_TRUE(hmd.displayed().empty());
}

class HmdEmulatorVersions : public ::testing::TestWithParam<igtlink::HeaderVersion> {};

TEST_P(HmdEmulatorVersions, DisplaysEveryModelAtTheRepositoryPoseWithinFloat32) {
  tracking::HologramStreamOptions stream_options;
  stream_options.version = GetParam();
  Workstation ws(stream_options);
  HmdEmulator hmd(emulatorOptions(ws.server->port()));
  hmd.start();
  ASSERT_TRUE(waitUntil([&] { return hmd.stats().meshes == 2 && ws.streamer->readyClients() == 1; }));
  // Both meshes, in mm, before any pose: not shown yet.
  for (const auto& [name, mesh] : {std::pair{"C5", tetrahedron()}, std::pair{"Probe", box()}}) {
    const auto shown = find(hmd, name);
    ASSERT_TRUE(shown) << name;
    EXPECT_EQ(shown->vertices, static_cast<std::size_t>(mesh.vertexCount())) << name;
    ASSERT_TRUE(shown->mesh);
    EXPECT_LT((shown->mesh->vertices - mesh.vertices).cwiseAbs().maxCoeff(), 1e-5) << name;
    EXPECT_EQ(shown->mesh->faces, mesh.faces) << name;
    EXPECT_FALSE(shown->visible);
    EXPECT_FALSE(shown->posed);
  }

  double worst_rotation = 0.0;
  double worst_translation_mm = 0.0;
  double worst_latency_s = 0.0;
  double worst_ulps = 0.0;
  constexpr int kSteps = 30;
  for (int step = 0; step < kSteps; ++step) {
    const double t = unixTimeSeconds();
    ws.track(t, step);
    ASSERT_TRUE(waitUntil([&] {
      return updatesOf(hmd, "C5") == static_cast<std::uint64_t>(step + 1) &&
             updatesOf(hmd, "Probe") == static_cast<std::uint64_t>(step + 1);
    })) << "step " << step;
    for (const char* name : {"C5", "Probe"}) {
      const auto shown = find(hmd, name);
      ASSERT_TRUE(shown);
      EXPECT_TRUE(shown->visible);
      EXPECT_EQ(shown->status, "TrackingOk");
      const auto [rotation, translation] = difference(shown->hologram_T_model, ws.hologramT(name));
      worst_rotation = std::max(worst_rotation, rotation);
      worst_translation_mm = std::max(worst_translation_mm, translation);
      worst_ulps = std::max(worst_ulps, float32Ulps(shown->hologram_T_model, ws.hologramT(name)));
      // No drift or jitter configured: the headset shows the pose as received.
      EXPECT_TRUE(shown->world_T_model.isApprox(shown->hologram_T_model, 1e-12));
      EXPECT_NEAR(shown->sent_utc, t, 1e-6);  // 32.32 fixed point
      EXPECT_GE(shown->received_utc, t - 1e-6);
      worst_latency_s = std::max(worst_latency_s, shown->received_utc - shown->sent_utc);
    }
  }
  std::cout << "[ figures ] header v" << static_cast<int>(GetParam()) << ": worst rotation element error "
            << worst_rotation << ", worst translation component error " << worst_translation_mm
            << " mm, worst element error " << worst_ulps << " x float32 rounding, worst latency "
            << worst_latency_s * 1e3 << " ms over " << kSteps << " updates\n";
  EXPECT_LE(worst_ulps, 1.0);             // nothing but the float32 rounding of the wire
  EXPECT_LT(worst_rotation, 1e-6);        // float32: 6e-8 relative
  EXPECT_LT(worst_translation_mm, 1e-4);  // float32 of coordinates under 1.6 m: under 1e-4 mm
  EXPECT_LT(worst_latency_s, 1.0);
  const auto stats = hmd.stats();
  EXPECT_TRUE(stats.connected);
  EXPECT_EQ(stats.connects, 1U);
  EXPECT_EQ(stats.transforms, 2U * kSteps);
  EXPECT_EQ(stats.malformed, 0U);
  EXPECT_EQ(stats.convention_mismatches, 0U);
  EXPECT_EQ(stats.other_messages, 0U);
}

INSTANTIATE_TEST_SUITE_P(HeaderVersions, HmdEmulatorVersions,
                         ::testing::Values(igtlink::HeaderVersion::kV1, igtlink::HeaderVersion::kV2),
                         [](const auto& param_info) { return param_info.param == igtlink::HeaderVersion::kV1 ? "v1" : "v2"; });

TEST(HmdEmulator, HidesAModelWhoseChainIsLostOrMissingAndShowsItAgain) {
  Workstation ws;
  HmdEmulator hmd(emulatorOptions(ws.server->port()));
  hmd.start();
  ASSERT_TRUE(waitUntil([&] { return hmd.stats().meshes == 2 && ws.streamer->readyClients() == 1; }));
  ws.track(unixTimeSeconds(), 0);
  ASSERT_TRUE(waitUntil([&] { return updatesOf(hmd, "C5") == 1 && updatesOf(hmd, "Probe") == 1; }));

  // The probe's marker is occluded: the probe is hidden, the vertebra still follows.
  ws.track(unixTimeSeconds(), 1, /*probe_ok=*/false);
  ASSERT_TRUE(waitUntil([&] { return hmd.stats().statuses == 1 && updatesOf(hmd, "C5") == 2; }));
  auto probe = find(hmd, "Probe");
  ASSERT_TRUE(probe);
  EXPECT_FALSE(probe->visible);
  EXPECT_EQ(probe->status, "TrackingLost");
  EXPECT_EQ(probe->updates, 1U);
  EXPECT_TRUE(find(hmd, "C5")->visible);

  // Still lost on the next samples: no pose, no repeated status.
  ws.track(unixTimeSeconds(), 2, false);
  ASSERT_TRUE(waitUntil([&] { return updatesOf(hmd, "C5") == 3; }));
  EXPECT_FALSE(find(hmd, "Probe")->visible);
  EXPECT_EQ(hmd.stats().statuses, 1U);

  // Seen again: status Ok then the new pose.
  ws.track(unixTimeSeconds(), 3);
  ASSERT_TRUE(waitUntil([&] { return updatesOf(hmd, "Probe") == 2; }));
  probe = find(hmd, "Probe");
  EXPECT_TRUE(probe->visible);
  EXPECT_EQ(probe->status, "TrackingOk");
  EXPECT_LT(difference(probe->hologram_T_model, ws.hologramT("Probe")).second, 1e-4);

  // The headset's own marker is never reported again (the edge is gone): both hidden.
  ws.repository->removeTransform("Hologram", "Tracker");
  ws.streamer->update(unixTimeSeconds());
  ASSERT_TRUE(waitUntil([&] { return hmd.stats().statuses == 4; }));  // Probe Ok, then both lost
  for (const char* name : {"C5", "Probe"}) {
    EXPECT_FALSE(find(hmd, name)->visible) << name;
    EXPECT_EQ(find(hmd, name)->status, "TrackingLost") << name;
  }
}

TEST(HmdEmulator, ReconnectsAfterTheWorkstationRestartsAndGetsTheModelsAgain) {
  std::uint16_t port = 0;
  auto first = std::make_unique<Workstation>();
  port = first->server->port();
  HmdEmulator hmd(emulatorOptions(port));
  hmd.start();
  ASSERT_TRUE(waitUntil([&] { return hmd.stats().meshes == 2 && first->streamer->readyClients() == 1; }));
  first->track(unixTimeSeconds(), 0);
  ASSERT_TRUE(waitUntil([&] { return updatesOf(hmd, "C5") == 1 && updatesOf(hmd, "Probe") == 1; }));

  first.reset();  // the workstation goes away
  ASSERT_TRUE(waitUntil([&] { return !hmd.stats().connected; }));
  for (const auto& m : hmd.displayed()) {
    EXPECT_FALSE(m.visible) << m.name;
    EXPECT_EQ(m.status, "Disconnected") << m.name;
  }

  // It comes back on the same port with the probe occluded: the new client
  // gets both meshes, the probe's lost status, then the vertebra's pose.
  Workstation second({}, port);
  second.track(unixTimeSeconds(), 5, /*probe_ok=*/false);
  ASSERT_TRUE(waitUntil([&] { return hmd.stats().connects == 2 && second.streamer->readyClients() == 1; }, 10.0));
  ASSERT_TRUE(waitUntil([&] { return hmd.stats().meshes == 4 && hmd.stats().statuses >= 1; }));
  second.track(unixTimeSeconds(), 6, false);
  ASSERT_TRUE(waitUntil([&] { return updatesOf(hmd, "C5") >= 2; }));
  const auto c5 = find(hmd, "C5");
  EXPECT_TRUE(c5->visible);
  EXPECT_LT(difference(c5->hologram_T_model, second.hologramT("C5")).second, 1e-4);
  const auto probe = find(hmd, "Probe");
  EXPECT_FALSE(probe->visible);
  EXPECT_EQ(probe->status, "TrackingLost");
  EXPECT_TRUE(hmd.stats().connected);
}

TEST(HmdEmulator, UnityStreamIsConvertedBackToTheSamePoseInMillimetres) {
  tracking::HologramStreamOptions stream_options;
  stream_options.unity = true;
  Workstation ws(stream_options);
  auto options = emulatorOptions(ws.server->port());
  options.unity = true;
  HmdEmulator hmd(options);
  // A headset left in the MR-SNS convention on a Unity stream: it must notice.
  HmdEmulator misconfigured(emulatorOptions(ws.server->port()));
  hmd.start();
  misconfigured.start();
  ASSERT_TRUE(waitUntil([&] { return ws.streamer->readyClients() == 2; }));
  ASSERT_TRUE(waitUntil([&] { return hmd.stats().meshes == 2 && misconfigured.stats().meshes == 2; }));
  double worst_mm = 0.0;
  for (int step = 0; step < 10; ++step) {
    ws.track(unixTimeSeconds(), step);
    ASSERT_TRUE(waitUntil([&] {
      return updatesOf(hmd, "Probe") == static_cast<std::uint64_t>(step + 1) &&
             updatesOf(misconfigured, "Probe") == static_cast<std::uint64_t>(step + 1);
    }));
    for (const char* name : {"C5", "Probe"}) {
      const auto [rotation, translation] = difference(find(hmd, name)->hologram_T_model, ws.hologramT(name));
      EXPECT_LT(rotation, 1e-6) << name;
      worst_mm = std::max(worst_mm, translation);
    }
  }
  std::cout << "[ figures ] unity: worst translation error " << worst_mm << " mm\n";
  EXPECT_LT(worst_mm, 1e-3);
  // The meshes come back in mm, x not flipped, winding restored.
  const auto probe = find(hmd, "Probe");
  EXPECT_LT((probe->mesh->vertices - box().vertices).cwiseAbs().maxCoeff(), 1e-4);
  EXPECT_EQ(probe->mesh->faces, box().faces);
  EXPECT_EQ(hmd.stats().convention_mismatches, 0U);
  // The misconfigured one shows metres as millimetres and says so.
  EXPECT_EQ(misconfigured.stats().convention_mismatches, 2U);
  EXPECT_GT(difference(find(misconfigured, "Probe")->hologram_T_model, ws.hologramT("Probe")).second, 100.0);
}

TEST(HmdEmulator, HeadsetWorldFrameDriftsAndJittersAsConfigured) {
  HmdEmulatorOptions options;
  options.drift_mm_per_min = 6.0;
  options.jitter_mm = 0.5;
  options.seed = 7;
  const HmdEmulator hmd(options);
  // Ten minutes of display frames (centres), then a least-squares line through them.
  const int n = 36000;
  Eigen::MatrixXd a(n, 2);
  Eigen::MatrixXd y(n, 3);
  for (int k = 0; k < n; ++k) {
    const double t = (k + 0.5) / kHmdDisplayRateHz;
    const Eigen::Isometry3d w = hmd.headsetWorldTHologram(t);
    ASSERT_TRUE(w.linear().isIdentity(0.0));  // translation only
    a.row(k) << 1.0, t;
    y.row(k) = w.translation().transpose();
  }
  const Eigen::MatrixXd fit = a.colPivHouseholderQr().solve(y);  // 2 x 3: offset, velocity
  const Eigen::MatrixXd residual = y - a * fit;
  const double drift_mm_per_min = fit.row(1).norm() * 60.0;
  const double jitter_rms = std::sqrt(residual.rowwise().squaredNorm().mean());
  double lag1 = 0.0;
  for (int k = 1; k < n; ++k) lag1 += residual.row(k).dot(residual.row(k - 1));
  lag1 /= (n - 1) * jitter_rms * jitter_rms;
  std::cout << "[ figures ] headset frame: drift " << drift_mm_per_min << " mm/min (6 set), jitter " << jitter_rms
            << " mm RMS (0.5 set), lag-1 correlation " << lag1 << ", offset " << fit.row(0).norm() << " mm\n";
  EXPECT_NEAR(drift_mm_per_min, 6.0, 0.06);
  EXPECT_NEAR(jitter_rms, 0.5, 0.01);  // 108000 degrees of freedom: 0.2 % standard error
  EXPECT_LT(std::abs(lag1), 0.02);
  EXPECT_LT(fit.row(0).norm(), 0.02);
  // The jitter holds for a display frame, then changes.
  HmdEmulatorOptions jitter_only;
  jitter_only.jitter_mm = 0.5;
  const HmdEmulator jittery(jitter_only);
  for (int k = 0; k < 100; ++k) {
    const double t = k / kHmdDisplayRateHz;
    EXPECT_TRUE(jittery.headsetWorldTHologram(t + 0.1 / kHmdDisplayRateHz)
                    .isApprox(jittery.headsetWorldTHologram(t + 0.9 / kHmdDisplayRateHz), 0.0));
    EXPECT_GT((jittery.headsetWorldTHologram(t + 1.1 / kHmdDisplayRateHz).translation() -
               jittery.headsetWorldTHologram(t + 0.9 / kHmdDisplayRateHz).translation())
                  .norm(),
              0.0);
  }
  // Seeded: the same seed gives the same frame, another seed another one.
  const HmdEmulator same(options);
  options.seed = 8;
  const HmdEmulator other(options);
  EXPECT_TRUE(same.headsetWorldTHologram(12.3).isApprox(hmd.headsetWorldTHologram(12.3), 0.0));
  EXPECT_GT((other.headsetWorldTHologram(12.3).translation() - hmd.headsetWorldTHologram(12.3).translation()).norm(),
            1e-3);
  // Nothing configured: the identity.
  EXPECT_TRUE(HmdEmulator(HmdEmulatorOptions{}).headsetWorldTHologram(100.0).isApprox(Eigen::Isometry3d::Identity(), 0.0));
}

TEST(HmdEmulator, DisplaysEachPoseInItsOwnDriftingWorldFrame) {
  Workstation ws;
  auto options = emulatorOptions(ws.server->port());
  options.drift_mm_per_min = 60.0;  // 1 mm/s: visible within the test
  options.jitter_mm = 1.0;
  options.seed = 3;
  HmdEmulator hmd(options);
  hmd.start();
  ASSERT_TRUE(waitUntil([&] { return hmd.stats().meshes == 2 && ws.streamer->readyClients() == 1; }));
  // One sample per display frame or slower, so the jitter samples are independent.
  std::vector<double> times;
  std::vector<Eigen::Vector3d> offsets;
  double worst_composition = 0.0;
  std::int64_t last_frame = -1;
  for (int step = 0; step < 400 && offsets.size() < 120; ++step) {
    ws.track(unixTimeSeconds(), step);
    ASSERT_TRUE(waitUntil([&] { return updatesOf(hmd, "C5") == static_cast<std::uint64_t>(step + 1); }));
    const auto c5 = *find(hmd, "C5");
    // Exactly the headset's frame at display time times the received pose.
    const Eigen::Isometry3d expected = hmd.headsetWorldTHologram(c5.headset_time_s) * c5.hologram_T_model;
    worst_composition = std::max(worst_composition, (c5.world_T_model.matrix() - expected.matrix()).cwiseAbs().maxCoeff());
    EXPECT_TRUE(c5.world_T_model.linear().isApprox(c5.hologram_T_model.linear(), 1e-12));
    const auto frame = static_cast<std::int64_t>(std::floor(c5.headset_time_s * kHmdDisplayRateHz));
    if (frame != last_frame) {
      times.push_back(c5.headset_time_s);
      offsets.push_back(c5.world_T_model.translation() - c5.hologram_T_model.translation());
      last_frame = frame;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(12));
  }
  EXPECT_LT(worst_composition, 1e-9);
  ASSERT_GE(offsets.size(), 60U);
  // Line through the offsets: its slope is the drift, the residual the jitter.
  const auto n = static_cast<Eigen::Index>(offsets.size());
  Eigen::MatrixXd a(n, 2);
  Eigen::MatrixXd y(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    a.row(i) << 1.0, times[static_cast<std::size_t>(i)];
    y.row(i) = offsets[static_cast<std::size_t>(i)].transpose();
  }
  const Eigen::MatrixXd fit = a.colPivHouseholderQr().solve(y);
  const double speed_mm_per_s = fit.row(1).norm();
  const double jitter_rms = std::sqrt((y - a * fit).rowwise().squaredNorm().sum() / static_cast<double>(n - 2));
  std::cout << "[ figures ] displayed: " << n << " frames over " << times.back() - times.front() << " s, drift "
            << speed_mm_per_s * 60.0 << " mm/min (60 set), jitter " << jitter_rms << " mm RMS (1 set)\n";
  // 3(n-2) degrees of freedom (n >= 60): the RMS has a standard error under 5 %;
  // the slope's error is the jitter over the spread of the times (~1.5 s).
  EXPECT_NEAR(jitter_rms, 1.0, 0.2);
  EXPECT_NEAR(speed_mm_per_s, 1.0, 0.5);
}

TEST(HmdEmulator, ConfirmationReachesTheStreamAsAStringAndChangesNothing) {
  Workstation ws;
  ws.track(unixTimeSeconds(), 0);
  HmdEmulator hmd(emulatorOptions(ws.server->port()));
  hmd.start();
  ASSERT_TRUE(waitUntil([&] { return hmd.stats().meshes == 2 && ws.streamer->readyClients() == 1; }));
  const auto edges_before = ws.repository->edges();
  ASSERT_TRUE(hmd.confirm("cube-aligned"));
  ASSERT_TRUE(waitUntil([&] { return ws.streamer->stats().client_messages_ignored == 1; }));
  EXPECT_EQ(ws.server->stats().messages_received, 1U);
  EXPECT_EQ(ws.server->stats().malformed_messages, 0U);
  const auto edges_after = ws.repository->edges();
  ASSERT_EQ(edges_after.size(), edges_before.size());
  for (std::size_t i = 0; i < edges_after.size(); ++i) {
    EXPECT_EQ(edges_after[i].from, edges_before[i].from);
    EXPECT_TRUE(edges_after[i].to_T_from.isApprox(edges_before[i].to_T_from, 0.0));
    EXPECT_EQ(edges_after[i].status, edges_before[i].status);
  }
  EXPECT_EQ(hmd.stats().confirmations, 1U);
}

TEST(HmdEmulator, KeepsPromptsAnswersInTheStreamsVersionAndCountsWhatItCannotShow) {
  igtlink::ServerOptions server_options;
  server_options.port = 0;
  igtlink::Server server(server_options);
  std::mutex mutex;
  std::vector<igtlink::Message> received;
  std::vector<igtlink::ClientId> clients;
  server.onConnect([&](igtlink::ClientId c) {
    std::lock_guard lock(mutex);
    clients.push_back(c);
  });
  server.onMessage([&](igtlink::ClientId, const igtlink::Message& m) {
    std::lock_guard lock(mutex);
    received.push_back(m);
  });
  server.start();
  HmdEmulator hmd(emulatorOptions(server.port()));
  hmd.start();
  ASSERT_TRUE(waitUntil([&] { return hmd.stats().connected && server.stats().clients == 1; }));

  // Before the stream said anything: header v1.
  ASSERT_TRUE(hmd.confirm("ready"));
  ASSERT_TRUE(waitUntil([&] {
    std::lock_guard lock(mutex);
    return received.size() == 1;
  }));

  // A v2 prompt, an unknown message, a transform that is not rigid, a mesh with a bad index.
  auto prompt = igtlink::makeMessage("Prompt", igtlink::StringContent{igtlink::kEncodingUsAscii, "Align the cube"});
  prompt.header.version = 2;
  server.broadcast(prompt, igtlink::HeaderVersion::kV2, igtlink::Channel::Reliable);
  server.broadcast(igtlink::makeMessage("Point", igtlink::PointContent{}), igtlink::HeaderVersion::kV2,
                   igtlink::Channel::Reliable);
  Eigen::Matrix4d scaled = Eigen::Matrix4d::Identity();
  scaled.topLeftCorner<3, 3>() *= 2.0;
  server.broadcast(igtlink::makeMessage("C5", igtlink::TransformContent{scaled}), igtlink::HeaderVersion::kV2,
                   igtlink::Channel::Reliable);
  igtlink::PolyDataContent bad;
  bad.points.resize(3, 3);
  bad.points.setZero();
  bad.triangle_strips.add({0, 1});  // a strip of two corners: not a surface
  server.broadcast(igtlink::makeMessage("Skin", bad), igtlink::HeaderVersion::kV2, igtlink::Channel::Reliable);
  ASSERT_TRUE(waitUntil([&] {
    const auto s = hmd.stats();
    return s.prompts == 1 && s.other_messages == 1 && s.malformed == 2;
  })) << hmd.stats().malformed;
  ASSERT_EQ(hmd.prompts(), std::vector<std::string>{"Align the cube"});
  EXPECT_FALSE(find(hmd, "C5") && find(hmd, "C5")->posed);

  ASSERT_TRUE(hmd.confirm("cube-aligned"));
  ASSERT_TRUE(waitUntil([&] {
    std::lock_guard lock(mutex);
    return received.size() == 2;
  }));
  std::lock_guard lock(mutex);
  for (std::size_t i = 0; i < 2; ++i) {
    const auto& m = received[i];
    EXPECT_EQ(m.header.type, "STRING");
    EXPECT_EQ(m.header.device_name, "Confirm");
    EXPECT_EQ(m.header.version, i == 0 ? 1 : 2);
    ASSERT_NE(m.as<igtlink::StringContent>(), nullptr);
    EXPECT_GT(m.header.timestampSeconds(), unixTimeSeconds() - 60.0);
  }
  EXPECT_EQ(received[0].as<igtlink::StringContent>()->text, "ready");
  EXPECT_EQ(received[1].as<igtlink::StringContent>()->text, "cube-aligned");
  EXPECT_EQ(hmd.stats().confirmations, 2U);
}

}  // namespace
}  // namespace mrsns::simulation
