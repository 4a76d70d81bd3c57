#pragma once
// Feature contours from an external segmenter over OpenIGTLink (the Mask
// R-CNN of paper 001, or any other): a POLYDATA message whose line (or
// polygon) cells are the contours, or a POINT message whose elements are
// grouped into contours by their `group` field, in message order. Points are
// in the image frame of Algorithm 1 (mm: pixel (c, r) at (c s, r s, 0)); z is
// dropped. The message timestamp pairs the contours with their ultrasound frame.
//
// Codec only (no sockets): the network side hands decoded messages to
// contoursFromMessage (e.g. from an igtlink::Server or Client handler) and the
// tracking loop takes them from a ContourInbox. Nothing here throws on bad
// messages: they come in through a real-time path and are reported.

#include <deque>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mrsns/core/plane_intersection.h"
#include "mrsns/igtlink/message.h"

namespace mrsns::deformation {

/// The contours of one ultrasound frame from an external segmenter.
struct ExternalContours {
  double timestamp_s = 0.0;
  std::string device;  ///< the message's device name
  std::vector<Polyline3d> contours;
};

struct ContourMessageResult {
  bool ok = false;
  std::string status;  ///< "ok" or why the message gave no contours
  ExternalContours contours;
};

/// Contours with fewer points than this are dropped (an ellipse needs 5).
inline constexpr std::size_t kMinExternalContourPoints = 5;

/// POLYDATA (lines, then polygons; a repeated first point is dropped) or
/// POINT (grouped by `group`). Any other type, non-finite points, or no
/// contour of >= kMinExternalContourPoints points gives ok = false.
[[nodiscard]] ContourMessageResult contoursFromMessage(const igtlink::Message& message);

/// The inverse, for segmenters written here and for tests: one closed line
/// cell per contour (first point repeated at the end, as VTK closes a line).
[[nodiscard]] igtlink::Message contoursToPolyDataMessage(std::span<const Polyline3d> contours,
                                                         const std::string& device, double timestamp_s);
/// One POINT element per contour point, group "Contour<i>".
[[nodiscard]] igtlink::Message contoursToPointMessage(std::span<const Polyline3d> contours, const std::string& device,
                                                      double timestamp_s);

/// A bounded, thread-safe store of received contours: the network thread
/// pushes, the tracking loop takes the contours of the frame it processes.
class ContourInbox {
 public:
  explicit ContourInbox(std::size_t capacity = 256) : capacity_(capacity) {}
  /// Adds the contours of a message; false (with the status counted as
  /// refused) when the message held none.
  bool push(const igtlink::Message& message);
  void push(ExternalContours contours);
  /// Removes and returns the entry whose timestamp is nearest `timestamp_s`
  /// within `tolerance_s` (older entries are discarded with it).
  [[nodiscard]] std::optional<ExternalContours> take(double timestamp_s, double tolerance_s);
  [[nodiscard]] std::size_t size() const;
  [[nodiscard]] std::size_t refused() const;

 private:
  mutable std::mutex mutex_;
  std::deque<ExternalContours> entries_;
  std::size_t capacity_;
  std::size_t refused_ = 0;
};

}  // namespace mrsns::deformation
