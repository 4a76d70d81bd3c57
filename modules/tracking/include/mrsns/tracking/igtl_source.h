#pragma once
// Tracking from PlusServer (or any OpenIGTLink tracker) through the
// reconnecting mrsns::igtlink::Client.
//
// - TRANSFORM "ProbeToTracker": one update. The tool is Invalid when the
//   message says so (v2 metadata "TransformStatus" other than "OK", or
//   "TransformValid" = "false", as PLUS writes them; or a matrix that is not
//   finite or not rigid).
// - TDATA: one update per element; an element name without "To" gets
//   "To<tdata_reference>" appended. With request_tdata, STT_TDATA is sent on
//   every (re)connection to start the stream.
// - STATUS: its text is the device's identity (see identify_device).
// - IMAGE: kept as latestImage(); device "Image_Reference" (PLUS) is placed in
//   frame "Reference". OpenIGTLink sends the position of the volume's centre;
//   ijk_to_frame is converted to the position of voxel (0,0,0).
// - Lost tools: a tool with no update for longer than stale_after_s is set
//   Invalid (stale), and every tool is set Invalid when the connection drops.
// Timestamps are the message's (UTC seconds); a zero header timestamp is
// replaced by the receive time.
#include <chrono>
#include <condition_variable>
#include <map>
#include <thread>

#include "mrsns/igtlink/client.h"
#include "mrsns/tracking/tracking_source.h"

namespace mrsns::tracking {

struct IgtlSourceOptions {
  igtlink::ClientOptions client;
  bool request_tdata = false;
  std::int32_t tdata_resolution_ms = 0;
  std::string tdata_reference = "Tracker";
  igtlink::HeaderVersion request_version = igtlink::HeaderVersion::kV1;
  /// No update for longer than this (s) makes a tool Invalid; 0 disables.
  double stale_after_s = 0.2;
  /// Sends GET_STATUS on every (re)connection and keeps the STATUS text the
  /// device answers with as deviceIdentity() (PlusServer ignores it; mrsns-sim
  /// says what it is, so its results are marked simulated).
  bool identify_device = false;
};

struct IgtlSourceStats {
  std::uint64_t transforms = 0;
  std::uint64_t tdata_messages = 0;
  std::uint64_t images = 0;
  std::uint64_t ignored_messages = 0;
  std::uint64_t stale_events = 0;
  std::uint64_t invalid_reports = 0;
};

class IgtlTrackingSource : public TrackingSource {
 public:
  /// Throws InvalidArgumentError for a negative stale_after_s.
  IgtlTrackingSource(std::shared_ptr<TransformRepository> repository, IgtlSourceOptions options);
  ~IgtlTrackingSource() override;

  /// Starts connecting (throws NetworkError when the host cannot be resolved).
  void start() override;
  void stop() override;
  [[nodiscard]] std::string name() const override;
  [[nodiscard]] std::vector<std::string> toolNames() const override;
  [[nodiscard]] std::optional<TrackedImage> latestImage() const override;
  [[nodiscard]] std::string deviceIdentity() const override;
  [[nodiscard]] IgtlSourceStats stats() const;
  [[nodiscard]] bool connected() const;

  /// Handles one message as if received (tests, relays). Never throws.
  void handleMessage(const igtlink::Message& message) noexcept;

 private:
  using Clock = std::chrono::steady_clock;
  struct Tool {
    Clock::time_point last_update;
    bool valid = false;
  };
  void onConnection(bool connected) noexcept;
  void markAll(TransformStatus status, const std::vector<std::string>& names) noexcept;
  void watchdog();
  void publishLocked(std::vector<ToolUpdate>& updates);

  IgtlSourceOptions options_;
  std::unique_ptr<igtlink::Client> client_;

  mutable std::mutex mutex_;  // guards tools_, stats_, image_; publish runs under it (one writer at a time)
  std::map<std::string, Tool> tools_;
  IgtlSourceStats stats_;
  std::optional<TrackedImage> image_;
  std::string device_identity_;

  std::mutex watchdog_mutex_;
  std::condition_variable watchdog_wake_;
  bool running_ = false;
  std::thread watchdog_;
};

}  // namespace mrsns::tracking
