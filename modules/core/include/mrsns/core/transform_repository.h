#pragma once
// A graph of named coordinate frames (PLUS-style transform repository).
//
// Set `ProbeToTracker`, `ImageToProbe`, `ReferenceToTracker`; ask for any
// `ImageToReference` and the repository finds the path, inverts edges walked
// backwards, multiplies, and reports the worst status and the oldest
// timestamp along the path. Thread-safe: one writer (tracking) and many
// readers (rendering, streaming, supervisor) at once; a reader never sees a
// half-written matrix.
#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "mrsns/core/transform_status.h"

namespace mrsns {

/// A transform name split into frames: "ProbeToTracker" -> {"Probe", "Tracker"}.
struct TransformName {
  std::string from;
  std::string to;

  /// Splits PLUS-style names at the "To" followed by an upper-case letter.
  /// Throws InvalidArgumentError when the name has no such split, or more
  /// than one (use the two-frame overloads for such names).
  static TransformName parse(std::string_view name);
  [[nodiscard]] std::string str() const { return from + "To" + to; }
};

/// The answer to a query: `to_T_from` maps points from `from` to `to`.
struct TransformResult {
  Eigen::Isometry3d to_T_from = Eigen::Isometry3d::Identity();
  /// Worst status along the path (Missing when there is no path).
  TransformStatus status = TransformStatus::Missing;
  /// Oldest acquisition time of the non-persistent edges on the path (s);
  /// NaN when every edge is persistent (calibrations) or there is no path.
  double timestamp = std::numeric_limits<double>::quiet_NaN();

  [[nodiscard]] bool ok() const { return status == TransformStatus::Ok; }
};

/// One stored edge, as set (not inverted).
struct TransformEdgeInfo {
  std::string from;
  std::string to;
  Eigen::Isometry3d to_T_from = Eigen::Isometry3d::Identity();
  TransformStatus status = TransformStatus::Missing;
  double timestamp = std::numeric_limits<double>::quiet_NaN();
  bool persistent = false;
};

class TransformRepository {
 public:
  /// A path resolved once and evaluated many times without string look-ups
  /// (for real-time loops). Re-resolves itself when the graph changes.
  class Query {
   public:
    Query() = default;
    [[nodiscard]] const std::string& from() const { return from_; }
    [[nodiscard]] const std::string& to() const { return to_; }

   private:
    friend class TransformRepository;
    struct Step {
      std::int32_t edge;
      bool forward;
    };
    std::string from_;
    std::string to_;
    std::uint64_t topology_version_ = 0;
    bool resolved_ = false;
    std::vector<Step> steps_;
  };

  TransformRepository();
  ~TransformRepository();
  TransformRepository(const TransformRepository&) = delete;
  TransformRepository& operator=(const TransformRepository&) = delete;

  /// Sets (adds or updates) the edge `from` -> `to`. Updating `to` -> `from`
  /// updates the same edge with the inverse. Throws InvalidArgumentError for
  /// empty or equal frame names or a non-rigid matrix, and FrameError when
  /// the frames are already connected by another path (a second path could
  /// contradict the first; remove an edge first). `persistent` marks
  /// calibrations that do not age.
  void setTransform(std::string_view from, std::string_view to, const Eigen::Isometry3d& to_T_from,
                    TransformStatus status = TransformStatus::Ok,
                    double timestamp = std::numeric_limits<double>::quiet_NaN(), bool persistent = false);
  void setTransform(std::string_view name, const Eigen::Isometry3d& to_T_from,
                    TransformStatus status = TransformStatus::Ok,
                    double timestamp = std::numeric_limits<double>::quiet_NaN(), bool persistent = false);

  /// Changes the status (and timestamp) of an existing edge, keeping its
  /// matrix: a tracker reports a lost tool this way. Throws FrameError if the
  /// edge does not exist.
  void setStatus(std::string_view from, std::string_view to, TransformStatus status,
                 double timestamp = std::numeric_limits<double>::quiet_NaN());

  /// Removes the edge between the two frames (either direction). Returns
  /// false when there was none.
  bool removeTransform(std::string_view from, std::string_view to);

  /// Removes every edge and frame.
  void clear();

  /// The transform `to_T_from` by path search. Throws FrameError for an
  /// unknown frame or when no path connects the two (the message lists the
  /// frames each side can reach).
  [[nodiscard]] TransformResult getTransform(std::string_view from, std::string_view to) const;
  [[nodiscard]] TransformResult getTransform(std::string_view name) const;

  /// Prepares a query; the frames need not exist yet.
  [[nodiscard]] Query prepare(std::string_view from, std::string_view to) const;
  /// Evaluates a prepared query. Never throws: an unknown frame or missing
  /// path gives status Missing. Updates the query's cached path.
  TransformResult evaluate(Query& query) const noexcept;

  [[nodiscard]] bool hasFrame(std::string_view frame) const;
  /// True when a path connects the frames (both must exist).
  [[nodiscard]] bool isConnected(std::string_view from, std::string_view to) const;
  /// Frames along the path from `from` to `to`, both included. Throws as getTransform.
  [[nodiscard]] std::vector<std::string> path(std::string_view from, std::string_view to) const;
  [[nodiscard]] std::vector<std::string> frames() const;
  [[nodiscard]] std::vector<TransformEdgeInfo> edges() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace mrsns
