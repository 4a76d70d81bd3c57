#pragma once
// A PlusServer on the wire: what a workstation connected to a real
// PlusServer receives, produced from simulated (or replayed) measurements.
//  - Header version per client, PlusServer's rule: a client gets v1 until it
//    sends a v2 message, then v2 (up to max_header_version).
//  - TRANSFORM per tool ("StylusToTracker"), to every client. Invalid tools
//    are not sent (SendValidTransformsOnly, PLUS's default), or sent to v2
//    clients with metadata TransformStatus=INVALID when that is off. v2
//    messages carry TransformStatus=OK for valid tools as PLUS 2.8 does.
//  - TDATA with every valid tool, to clients that sent STT_TDATA (respecting
//    its resolution), until they send STP_TDATA.
//  - IMAGE (8-bit B-mode) with the image's placement in the ijk matrix, to
//    every client; RTS_TDATA answers STT/STP_TDATA, STATUS answers GET_STATUS.
// Binds 127.0.0.1 unless told otherwise. Thread-safe: publish from any thread.
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace mrsns::simulation {

struct PlusServerOptions {
  std::string bind_address = "127.0.0.1";
  std::uint16_t port = 18944;  ///< 0: a free port
  int max_header_version = 2;
  bool send_valid_transforms_only = true;
  /// The serial number of this room's UR controller, told in the STATUS answer to GET_STATUS, so a
  /// workstation can refuse to drive any other controller while its tracker is this simulated one.
  std::string robot_serial;
};

struct MeasuredTool {
  std::string name;  ///< "StylusToTracker"
  Eigen::Matrix4d tracker_T_tool = Eigen::Matrix4d::Identity();
  bool valid = true;
};

struct BModeFrame {
  std::string device_name = "Image_Image";
  int width = 0;
  int height = 0;
  double spacing_x_mm = 0.1;
  double spacing_y_mm = 0.1;
  /// Pixel (0,0)'s frame: where the image sits in the frame its device name
  /// ends with (Image_Reference: ImageToReference); identity for Image_Image.
  Eigen::Matrix4d frame_T_image = Eigen::Matrix4d::Identity();
  std::vector<std::uint8_t> pixels;  ///< row-major, 8 bit
};

struct PlusServerStats {
  std::uint64_t clients_connected = 0;
  std::uint64_t transform_messages = 0;
  std::uint64_t tdata_messages = 0;
  std::uint64_t image_messages = 0;
  std::uint64_t requests = 0;
  std::size_t clients = 0;
};

class PlusServerEmulator {
 public:
  explicit PlusServerEmulator(PlusServerOptions options);
  ~PlusServerEmulator();
  PlusServerEmulator(const PlusServerEmulator&) = delete;
  PlusServerEmulator& operator=(const PlusServerEmulator&) = delete;

  /// Binds and listens. Throws NetworkError (port in use) saying what to do.
  void start();
  /// Closes every client and stops listening (a tracker disconnect); start() again to come back on the same port.
  void stop();
  [[nodiscard]] bool running() const;
  [[nodiscard]] std::uint16_t port() const;

  /// One tracker sample of every tool, with its acquisition time (UTC seconds).
  void publishTools(const std::vector<MeasuredTool>& tools, double timestamp_utc);
  void publishImage(const BModeFrame& frame, double timestamp_utc);

  [[nodiscard]] PlusServerStats stats() const;
  /// Waits until every message published so far is written to its client's socket, at most `timeout_s`;
  /// false on timeout. A replay that ends calls it before the room stops, so its last frame is not lost with
  /// the connection.
  bool waitUntilSent(double timeout_s) const;

 private:
  struct Impl;
  std::shared_ptr<Impl> impl_;
};

}  // namespace mrsns::simulation
