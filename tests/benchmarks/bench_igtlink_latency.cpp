// End-to-end latency of the hologram stream on loopback, in one process:
// a server playing PlusServer sends TRANSFORMs for 10 tools at 1 kHz; an
// IgtlTrackingSource receives them into the repository; its update callback
// drives a HologramStreamer that forwards each tool as TRANSFORM to a
// receiving client (the HMD). Latency = HMD receive time - PlusServer send
// time of the same sample (matched by tool and header timestamp), so it
// includes both loopback hops, decoding, the repository and re-encoding.
//
//   ./mrsns_bench_igtlink_latency   (counters p50_us, p99_us, max_us)
#include <benchmark/benchmark.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

#include "mrsns/igtlink/client.h"
#include "mrsns/igtlink/server.h"
#include "mrsns/tracking/hologram_streamer.h"
#include "mrsns/tracking/igtl_source.h"

namespace {

using Clock = std::chrono::steady_clock;
using namespace mrsns;

constexpr int kTools = 10;
constexpr double kRateHz = 1000.0;
constexpr int kTicks = 3000;  // 3 s at 1 kHz
constexpr double kBaseTime = 1.7e9;

std::string toolName(int i) {
  return "Tool" + std::to_string(i) + "ToTracker";
}

void BM_HologramStreamLatency(benchmark::State& state) {
  for (auto _ : state) {
    // PlusServer stand-in.
    igtlink::ServerOptions plus_options;
    plus_options.port = 0;
    plus_options.stream_queue_limit = 64;
    igtlink::Server plus(plus_options);
    plus.start();

    auto repository = std::make_shared<TransformRepository>();
    tracking::IgtlSourceOptions source_options;
    source_options.client.port = plus.port();
    source_options.stale_after_s = 0.0;
    tracking::IgtlTrackingSource source(repository, source_options);

    igtlink::ServerOptions hmd_options;
    hmd_options.port = 0;
    hmd_options.stream_queue_limit = 64;
    igtlink::Server hmd_server(hmd_options);
    tracking::HologramStreamOptions stream_options;
    for (int i = 0; i < kTools; ++i) stream_options.forward_transforms.push_back(toolName(i));
    stream_options.version = igtlink::HeaderVersion::kV1;
    tracking::HologramStreamer streamer(hmd_server, repository, {}, stream_options);
    source.setUpdateCallback(
        [&streamer](std::span<const tracking::ToolUpdate> u) { streamer.update(u.front().timestamp); });
    hmd_server.start();

    std::vector<Clock::time_point> sent(kTicks);
    std::mutex mutex;
    std::vector<double> latencies_us;
    latencies_us.reserve(static_cast<std::size_t>(kTicks) * kTools * 2);
    igtlink::ClientOptions hmd_client_options;
    hmd_client_options.port = hmd_server.port();
    igtlink::Client hmd(hmd_client_options);
    hmd.onMessage([&](const igtlink::Message& m) {
      const auto now = Clock::now();
      if (m.header.type != "TRANSFORM") return;
      const double tick = (m.header.timestampSeconds() - kBaseTime) * kRateHz;
      const auto index = static_cast<long>(std::lround(tick));
      if (index < 0 || index >= kTicks) return;
      std::lock_guard lock(mutex);
      // The streamer sends a tool only when its timestamp changed, so each
      // received message is the one its own PlusServer message caused.
      latencies_us.push_back(std::chrono::duration<double, std::micro>(now - sent[index]).count());
    });
    source.start();
    hmd.start();
    while (!(source.connected() && streamer.readyClients() == 1 && plus.stats().clients == 1)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }

    // Pre-encoded messages, so the sender's own encoding is not measured.
    const auto t0 = Clock::now();
    for (int tick = 0; tick < kTicks; ++tick) {
      std::this_thread::sleep_until(t0 + std::chrono::microseconds(static_cast<long>(tick * 1e6 / kRateHz)));
      const double t = kBaseTime + tick / kRateHz;
      sent[tick] = Clock::now();
      for (int i = 0; i < kTools; ++i) {
        Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
        pose.translation() = Eigen::Vector3d(i, tick * 0.01, -1000.0);
        plus.broadcast(igtlink::makeMessage(toolName(i), igtlink::TransformContent::fromIsometry(pose), t),
                       igtlink::HeaderVersion::kV1, igtlink::Channel::Stream);
      }
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    source.stop();
    hmd.stop();
    hmd_server.stop();
    plus.stop();

    std::lock_guard lock(mutex);
    std::sort(latencies_us.begin(), latencies_us.end());
    auto percentile = [&](double p) {
      return latencies_us.empty() ? 0.0 : latencies_us[static_cast<std::size_t>(p * (latencies_us.size() - 1))];
    };
    state.counters["p50_us"] = percentile(0.50);
    state.counters["p99_us"] = percentile(0.99);
    state.counters["max_us"] = latencies_us.empty() ? 0.0 : latencies_us.back();
    state.counters["received"] = static_cast<double>(latencies_us.size());
    state.counters["plus_dropped"] = static_cast<double>(plus.stats().stream_messages_dropped);
    state.counters["hmd_dropped"] = static_cast<double>(hmd_server.stats().stream_messages_dropped);
  }
}
BENCHMARK(BM_HologramStreamLatency)->Iterations(1)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
