#pragma once
// The hologram stream to HMD clients (Eq. 1 of paper 001):
//
//   T_Vir^Hol = (T_Hol^Tra)^-1 * T_Pat^Tra * T_Pre^Pat * T_Vir^Pre
//
// i.e. hologram_T_model, which the transform repository answers by path
// search (Model -> Preop -> Patient -> Tracker <- Hologram) once tracking,
// registration and HMD calibration have set their edges.
//
// On every client connection the streamer queues each model as POLYDATA on
// the Reliable channel, then the current STATUS of each model; only then does
// that client get the TRANSFORM stream (Stream channel, one TRANSFORM per
// model per update(), device name = model name). When a model's chain stops
// being Ok (tool lost, stale) it sends STATUS (code NotReady, "TrackingLost")
// and no TRANSFORM for that model; when the chain is Ok again, STATUS Ok.
//
// The operator's prompt (setPrompt) goes to every ready client as a STRING
// (device "Prompt", Reliable channel), and again to a client that connects
// later, so a headset that reconnects shows what it is asked.
//
// Nothing a client sends reaches the repository or the models. Two messages are
// let through, each only when the owner asked for it, handed to that callback
// and nowhere else (the HMD calibrations take them; the stream never passes
// them to a robot):
//  - on_confirmation: a STRING on device "Confirm" of at most
//    kMaxConfirmationBytes, the operator's confirmation from the headset;
//  - on_camera_image: an IMAGE on device kCameraImageDevice, a photo from the
//    headset's camera: 8-bit grey, one component, one whole 2D slice of
//    kMinCameraImageSide-kMaxCameraImageSide pixels a side (the server's
//    decode.max_body_size must let it through), with its v2 metadata
//    "CameraIntrinsics" when the headset sent them.
// Everything else is counted, logged (rate-limited) and ignored.
//
// The stream is send-only, so the streamer limits what its server reads
// (igtlink::Server::limitInbound): a message body of at most
// kMaxClientMessageBodyBytes (a confirmation, a STATUS, a GET_ request or a
// client's own TRANSFORM with its v2 metadata fit many times over), the
// camera's IMAGE excepted when photos are asked for; a client whose header
// asks for more is disconnected before any of its body is stored. A client
// sending more than kMaxClientMessagesPerSecond is not read until it is back
// under that rate (TCP holds the flood on its side).
#include <chrono>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "mrsns/core/mesh.h"
#include "mrsns/core/transform_repository.h"
#include "mrsns/igtlink/server.h"

namespace mrsns::tracking {

struct HologramModel {
  /// Device name on the wire (at most 20 characters, unique).
  std::string name;
  /// Vertices in `frame`, mm.
  TriangleMesh mesh;
  /// The frame the mesh lives in (a repository frame, e.g. "Preop" or "C5").
  std::string frame;
};

/// The largest body of a client message other than a camera photo.
inline constexpr std::uint64_t kMaxClientMessageBodyBytes = 4096;
/// Client messages read per second on average (and at once): a headset that
/// sends its own pose or its screws back at 60 Hz each stays far below.
inline constexpr double kMaxClientMessagesPerSecond = 1000.0;
/// The longest confirmation text accepted from a client.
inline constexpr std::size_t kMaxConfirmationBytes = 256;
/// The device name of the headset camera's photos.
inline constexpr const char* kCameraImageDevice = "HmdCamera";
inline constexpr int kMinCameraImageSide = 16;
inline constexpr int kMaxCameraImageSide = 4096;
/// The longest "CameraIntrinsics" metadata value kept.
inline constexpr std::size_t kMaxCameraIntrinsicsBytes = 1024;
/// The largest camera photo's body: the IMAGE header, the largest 8-bit
/// slice and room for the v2 extended header and metadata.
inline constexpr std::uint64_t kMaxCameraImageBodyBytes =
    std::uint64_t{kMaxCameraImageSide} * kMaxCameraImageSide + 64 * 1024;

/// A photo from the headset's camera, as a client sent it.
struct HeadsetCameraImage {
  int width = 0, height = 0;
  std::vector<std::uint8_t> pixels;  ///< grey, row-major (the IMAGE's i fastest)
  double sent_utc = 0.0;             ///< the message's header timestamp (the headset's clock; 0: unset)
  std::string intrinsics;            ///< metadata "CameraIntrinsics" ("fx fy cx cy k1 k2 p1 p2 k3 w h") or empty
};

struct HologramStreamOptions {
  /// The HMD's hologram (world) frame in the repository.
  std::string hologram_frame = "Hologram";
  /// Left-handed metres for Unity clients (see unity_convention.h); applied
  /// to meshes and transforms alike.
  bool unity = false;
  igtlink::HeaderVersion version = igtlink::HeaderVersion::kV2;
  /// Send TRANSFORMs alone: no POLYDATA, STATUS or prompt STRING, for a client
  /// whose reader stops at any other type (its models are preloaded by name;
  /// lost tracking shows as its model no longer moving). See
  /// hologram_client_preset.h.
  bool transforms_only = false;
  /// At most this many transforms streamed (models and forward_transforms
  /// together), for a client that moves one object with every TRANSFORM it
  /// receives whatever its name; 0: no limit. More is refused at construction.
  std::size_t max_streams = 0;
  /// Repository transforms also streamed under their own names (e.g.
  /// "ProbeToTracker" for a Slicer client); sent when Ok, like the models.
  std::vector<std::string> forward_transforms;
  /// At most one log line per client per this many seconds about ignored messages.
  double client_log_interval_s = 1.0;
  /// Called on the I/O thread for each operator confirmation (STRING "Confirm") a client sends, with its
  /// text. Empty: confirmations are ignored like any other client message. Must not call the streamer.
  std::function<void(igtlink::ClientId client, const std::string& text)> on_confirmation;
  /// Called on the I/O thread for each headset camera photo a client sends (see the header comment). Empty:
  /// photos are ignored like any other client message. Must not call the streamer.
  std::function<void(igtlink::ClientId client, HeadsetCameraImage image)> on_camera_image;
};

struct HologramStreamStats {
  std::uint64_t updates = 0;
  std::uint64_t transforms_queued = 0;
  std::uint64_t meshes_queued = 0;
  std::uint64_t statuses_queued = 0;
  std::uint64_t clients_served = 0;
  std::uint64_t client_messages_ignored = 0;
  std::uint64_t confirmations = 0;
  std::uint64_t camera_images = 0;
  std::uint64_t prompts_queued = 0;
  std::uint64_t vertex_updates_queued = 0;  ///< NDARRAY vertex updates, per client
};

class HologramStreamer {
 public:
  /// Installs the server's connect/disconnect/message handlers and its
  /// inbound limits: construct it before server.start(). Encodes every mesh
  /// once. Throws
  /// InvalidArgumentError for an empty or too long or repeated device name, an
  /// empty mesh or frame name, a forward transform that is not "AToB", or
  /// more streams than options.max_streams.
  HologramStreamer(igtlink::Server& server, std::shared_ptr<TransformRepository> repository,
                   std::vector<HologramModel> models, HologramStreamOptions options = {});
  ~HologramStreamer();
  HologramStreamer(const HologramStreamer&) = delete;
  HologramStreamer& operator=(const HologramStreamer&) = delete;

  /// Evaluates every model's chain and queues its TRANSFORM (or STATUS on a
  /// change) for every ready client; a chain whose timestamp has not changed
  /// since it was last sent (no new tracking data on its path) is not sent
  /// again, so a tracker that reports tools one message each does not
  /// multiply the stream. Call it from the tracking source's
  /// update callback. `fallback_timestamp` (s since 1970) is used when the
  /// chain has no timestamp (all persistent). Never throws.
  void update(double fallback_timestamp) noexcept;

  /// Shows `text` to the operator on every headset (now and on later connections). Empty clears it (an
  /// empty STRING is sent). Throws InvalidArgumentError for more than 65535 bytes.
  void setPrompt(const std::string& text);

  /// Moves the vertices of `model` on every headset (a deforming soft tissue: the same count and order as
  /// its mesh, in the model's frame, mm): an NDARRAY message (N x 3 float32, in the stream's convention)
  /// named as the model, not a whole POLYDATA; a client that connects later gets the latest after the mesh.
  /// Nothing is sent to a transforms-only client (its models are its own). Throws InvalidArgumentError for
  /// an unknown model, another vertex count, more than 65535 vertices or a non-finite value.
  void updateMeshVertices(const std::string& model,
                          const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>& vertices);

  [[nodiscard]] HologramStreamStats stats() const;
  [[nodiscard]] std::size_t readyClients() const;

 private:
  struct Stream {
    std::string device;
    TransformRepository::Query query;
    bool ok = false;
    bool announced = false;                                       // a status has been established (first update)
    double last_sent = std::numeric_limits<double>::quiet_NaN();  // chain timestamp last sent
  };
  void onConnect(igtlink::ClientId client) noexcept;
  void onDisconnect(igtlink::ClientId client) noexcept;
  void onClientMessage(igtlink::ClientId client, const igtlink::Message& message) noexcept;
  std::shared_ptr<const std::vector<std::uint8_t>> statusBytes(const Stream& stream, double timestamp) const;
  std::shared_ptr<const std::vector<std::uint8_t>> promptBytes() const;  // mutex_ held
  void sendToReady(const std::shared_ptr<const std::vector<std::uint8_t>>& bytes, igtlink::Channel channel);

  igtlink::Server& server_;
  std::shared_ptr<TransformRepository> repository_;
  HologramStreamOptions options_;
  std::vector<std::shared_ptr<const std::vector<std::uint8_t>>> mesh_bytes_;
  std::map<std::string, Eigen::Index> model_vertices_;  // each model's vertex count

  mutable std::mutex mutex_;  // guards everything below
  std::vector<Stream> streams_;
  std::string prompt_;
  std::map<std::string, std::shared_ptr<const std::vector<std::uint8_t>>> latest_vertices_;
  std::set<igtlink::ClientId> ready_;
  std::map<igtlink::ClientId, std::chrono::steady_clock::time_point> last_log_;
  HologramStreamStats stats_;
};

}  // namespace mrsns::tracking
