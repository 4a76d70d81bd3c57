#pragma once
// Tracked ultrasound frames as PLUS records them: an image per frame plus the
// tracker transforms, timestamp and free-form fields of that instant. The
// pixels of a frame are optional so that a streaming reader can hand out the
// metadata of every frame and the pixels of one frame at a time.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "mrsns/core/image.h"
#include "mrsns/core/transform_status.h"

namespace mrsns {

/// One named transform of one frame. `matrix` is kept as the full 4x4 the
/// file holds (PLUS writes rounded, not exactly orthonormal rotations), so a
/// read-write round trip is lossless; convert to Isometry3d where needed.
struct FrameTransform {
  Eigen::Matrix4d matrix = Eigen::Matrix4d::Identity();
  TransformStatus status = TransformStatus::Ok;

  bool operator==(const FrameTransform& other) const { return status == other.status && matrix == other.matrix; }
};

/// Storage of one pixel of a frame: scalar type and number of components
/// (1 for B-mode, 3 for RGB video).
struct FramePixelFormat {
  PixelType scalar = PixelType::UInt8;
  int components = 1;

  [[nodiscard]] std::size_t bytesPerPixel() const {
    return pixelTypeSize(scalar) * static_cast<std::size_t>(components);
  }
  bool operator==(const FramePixelFormat&) const = default;
};

/// Geometry shared by every frame of a sequence. Frames are 2D images
/// (`dimensions` 2, size[2] == 1) or 3D volumes (`dimensions` 3). Spacing,
/// origin and direction (columns = i, j, k axes) are those of the file, in mm.
struct ImageFrameGeometry {
  int dimensions = 2;
  std::array<std::int64_t, 3> size{0, 0, 1};
  std::array<double, 3> spacing{1.0, 1.0, 1.0};
  std::array<double, 3> origin{0.0, 0.0, 0.0};
  Eigen::Matrix3d direction = Eigen::Matrix3d::Identity();

  [[nodiscard]] std::size_t pixelsPerFrame() const {
    return static_cast<std::size_t>(size[0]) * static_cast<std::size_t>(size[1]) * static_cast<std::size_t>(size[2]);
  }
  bool operator==(const ImageFrameGeometry&) const = default;
};

/// One frame: acquisition time, the transforms reported at that time (a name
/// absent from `transforms` is Missing in this frame), the image status
/// ("OK" or "INVALID" in PLUS files), other per-frame fields verbatim, and the
/// pixels when they were loaded (empty otherwise).
struct TrackedFrame {
  double timestamp = 0.0;
  std::map<std::string, FrameTransform> transforms;  ///< "ProbeToTracker" -> matrix + status
  std::string image_status = "OK";
  std::map<std::string, std::string> custom_fields;  ///< e.g. "UnfilteredTimestamp" -> "425.39"
  std::vector<std::uint8_t> pixels;                  ///< row-major, x fastest, components interleaved

  [[nodiscard]] bool hasPixels() const { return !pixels.empty(); }

  /// Status of `name` in this frame (Missing when the frame does not report it).
  [[nodiscard]] TransformStatus transformStatus(const std::string& name) const {
    const auto it = transforms.find(name);
    return it == transforms.end() ? TransformStatus::Missing : it->second.status;
  }

  bool operator==(const TrackedFrame&) const = default;
};

/// A recorded sequence of tracked frames. `custom_header_fields` holds the
/// global fields that are not part of the image geometry (e.g.
/// AnatomicalOrientation, or any field a device added), in file order.
struct TrackedSequence {
  ImageFrameGeometry geometry;
  FramePixelFormat pixel_format;
  std::string orientation = "MF";  ///< PLUS UltrasoundImageOrientation: MF, MFA, UF, ...
  std::vector<std::pair<std::string, std::string>> custom_header_fields;
  std::vector<TrackedFrame> frames;

  /// Bytes of the pixel data of one frame.
  [[nodiscard]] std::size_t frameBytes() const { return geometry.pixelsPerFrame() * pixel_format.bytesPerPixel(); }

  /// A tracker buffer: frames with transforms and no image (PLUS writes
  /// them with DimSize = 0 0 N).
  [[nodiscard]] bool trackingOnly() const { return geometry.size[0] == 0 && geometry.size[1] == 0; }

  /// Every transform name reported by at least one frame, sorted.
  [[nodiscard]] std::vector<std::string> transformNames() const {
    std::set<std::string> names;
    for (const auto& frame : frames) {
      for (const auto& entry : frame.transforms) names.insert(entry.first);
    }
    return {names.begin(), names.end()};
  }

  bool operator==(const TrackedSequence&) const = default;
};

}  // namespace mrsns
