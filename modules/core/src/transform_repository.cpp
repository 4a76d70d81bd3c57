#include "mrsns/core/transform_repository.h"

#include <algorithm>
#include <cmath>
#include <deque>
#include <map>
#include <mutex>
#include <shared_mutex>
#include <unordered_map>

#include "mrsns/core/error.h"

namespace mrsns {
namespace {

bool isUpper(char c) {
  return c >= 'A' && c <= 'Z';
}

bool isRotation(const Eigen::Matrix3d& r) {
  constexpr double kTolerance = 1e-6;
  return ((r.transpose() * r) - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < kTolerance &&
         std::abs(r.determinant() - 1.0) < kTolerance;
}

}  // namespace

TransformName TransformName::parse(std::string_view name) {
  std::vector<std::size_t> splits;
  for (std::size_t i = 1; i + 2 < name.size(); ++i) {
    if (name[i] == 'T' && name[i + 1] == 'o' && isUpper(name[i + 2])) splits.push_back(i);
  }
  if (splits.empty()) {
    throw InvalidArgumentError("'" + std::string(name) +
                               "' is not a transform name: use FromToTo with capitalised frame names, e.g. "
                               "'ProbeToTracker'");
  }
  if (splits.size() > 1) {
    throw InvalidArgumentError("transform name '" + std::string(name) +
                               "' splits into frames in more than one way: name the two frames separately");
  }
  return TransformName{std::string(name.substr(0, splits[0])), std::string(name.substr(splits[0] + 2))};
}

struct TransformRepository::Impl {
  struct Edge {
    std::int32_t from = -1;
    std::int32_t to = -1;
    Eigen::Isometry3d to_T_from = Eigen::Isometry3d::Identity();
    TransformStatus status = TransformStatus::Missing;
    double timestamp = std::numeric_limits<double>::quiet_NaN();
    bool persistent = false;
    bool removed = false;
  };
  struct Neighbour {
    std::int32_t frame;
    std::int32_t edge;
    bool forward;  // true when the edge is stored as this frame -> neighbour
  };

  mutable std::shared_mutex mutex;
  std::unordered_map<std::string, std::int32_t> frame_ids;
  std::vector<std::string> frame_names;
  std::vector<std::vector<Neighbour>> adjacency;
  std::vector<Edge> edges;
  std::uint64_t topology_version = 1;

  // Paths of the string API, valid for one topology version.
  mutable std::mutex cache_mutex;
  mutable std::map<std::pair<std::string, std::string>, std::vector<Query::Step>, std::less<>> path_cache;
  mutable std::uint64_t cache_version = 0;

  std::int32_t findFrame(std::string_view name) const {
    const auto it = frame_ids.find(std::string(name));
    return it == frame_ids.end() ? -1 : it->second;
  }

  std::int32_t addFrame(std::string_view name) {
    if (const auto id = findFrame(name); id >= 0) return id;
    const auto id = static_cast<std::int32_t>(frame_names.size());
    frame_ids.emplace(std::string(name), id);
    frame_names.emplace_back(name);
    adjacency.emplace_back();
    ++topology_version;
    return id;
  }

  std::int32_t findEdge(std::int32_t a, std::int32_t b, bool* forward) const {
    if (a < 0 || b < 0) return -1;
    for (const auto& n : adjacency[static_cast<std::size_t>(a)]) {
      if (n.frame == b) {
        *forward = n.forward;
        return n.edge;
      }
    }
    return -1;
  }

  // Breadth-first search; returns false when no path exists.
  bool findPath(std::int32_t from, std::int32_t to, std::vector<Query::Step>& steps) const {
    steps.clear();
    if (from == to) return true;
    const auto n = frame_names.size();
    std::vector<std::int32_t> parent_frame(n, -1);
    std::vector<Query::Step> parent_step(n, Query::Step{-1, true});
    std::vector<bool> seen(n, false);
    std::deque<std::int32_t> queue{from};
    seen[static_cast<std::size_t>(from)] = true;
    while (!queue.empty()) {
      const auto u = queue.front();
      queue.pop_front();
      if (u == to) break;
      for (const auto& nb : adjacency[static_cast<std::size_t>(u)]) {
        if (seen[static_cast<std::size_t>(nb.frame)]) continue;
        seen[static_cast<std::size_t>(nb.frame)] = true;
        parent_frame[static_cast<std::size_t>(nb.frame)] = u;
        parent_step[static_cast<std::size_t>(nb.frame)] = Query::Step{nb.edge, nb.forward};
        queue.push_back(nb.frame);
      }
    }
    if (!seen[static_cast<std::size_t>(to)]) return false;
    for (auto v = to; v != from; v = parent_frame[static_cast<std::size_t>(v)]) {
      steps.push_back(parent_step[static_cast<std::size_t>(v)]);
    }
    std::reverse(steps.begin(), steps.end());
    return true;
  }

  std::vector<std::string> reachable(std::int32_t start) const {
    std::vector<std::string> names;
    std::vector<bool> seen(frame_names.size(), false);
    std::deque<std::int32_t> queue{start};
    seen[static_cast<std::size_t>(start)] = true;
    while (!queue.empty()) {
      const auto u = queue.front();
      queue.pop_front();
      names.push_back(frame_names[static_cast<std::size_t>(u)]);
      for (const auto& nb : adjacency[static_cast<std::size_t>(u)]) {
        if (!seen[static_cast<std::size_t>(nb.frame)]) {
          seen[static_cast<std::size_t>(nb.frame)] = true;
          queue.push_back(nb.frame);
        }
      }
    }
    std::sort(names.begin(), names.end());
    return names;
  }

  // Caller holds the shared lock.
  TransformResult compose(const std::vector<Query::Step>& steps) const noexcept {
    TransformResult result;
    result.status = TransformStatus::Ok;
    double oldest = std::numeric_limits<double>::infinity();
    for (const auto& step : steps) {
      const Edge& e = edges[static_cast<std::size_t>(step.edge)];
      if (step.forward) {
        result.to_T_from = e.to_T_from * result.to_T_from;
      } else {
        result.to_T_from = e.to_T_from.inverse(Eigen::Isometry) * result.to_T_from;
      }
      result.status = worse(result.status, e.status);
      if (!e.persistent && !std::isnan(e.timestamp)) oldest = std::min(oldest, e.timestamp);
    }
    if (std::isfinite(oldest)) result.timestamp = oldest;
    return result;
  }

  [[noreturn]] void throwNoPath(std::string_view from, std::string_view to, std::int32_t f, std::int32_t t) const {
    auto join = [](const std::vector<std::string>& names) {
      std::string s;
      for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
      return s;
    };
    throw FrameError("no transform path from '" + std::string(from) + "' to '" + std::string(to) + "': '" +
                     std::string(from) + "' reaches {" + join(reachable(f)) + "} and '" + std::string(to) +
                     "' reaches {" + join(reachable(t)) +
                     "}; set a transform connecting the two groups (check the tool and calibration names)");
  }

  [[noreturn]] void throwUnknownFrame(std::string_view frame) const {
    std::vector<std::string> known = frame_names;
    std::sort(known.begin(), known.end());
    std::string list;
    for (const auto& n : known) list += (list.empty() ? "" : ", ") + n;
    throw FrameError("unknown coordinate frame '" + std::string(frame) +
                     "' (known frames: " + (list.empty() ? std::string("none yet") : list) + ")");
  }

  const std::vector<Query::Step>& cachedPath(std::string_view from, std::string_view to, std::int32_t f,
                                             std::int32_t t) const {
    std::lock_guard cache_lock(cache_mutex);
    if (cache_version != topology_version) {
      path_cache.clear();
      cache_version = topology_version;
    }
    auto key = std::make_pair(std::string(from), std::string(to));
    auto it = path_cache.find(key);
    if (it == path_cache.end()) {
      std::vector<Query::Step> steps;
      if (!findPath(f, t, steps)) throwNoPath(from, to, f, t);
      it = path_cache.emplace(std::move(key), std::move(steps)).first;
    }
    return it->second;
  }
};

TransformRepository::TransformRepository() : impl_(std::make_unique<Impl>()) {}
TransformRepository::~TransformRepository() = default;

void TransformRepository::setTransform(std::string_view from, std::string_view to, const Eigen::Isometry3d& to_T_from,
                                       TransformStatus status, double timestamp, bool persistent) {
  if (from.empty() || to.empty()) throw InvalidArgumentError("transform frame names must not be empty");
  if (from == to) {
    throw InvalidArgumentError("transform '" + std::string(from) + "To" + std::string(to) +
                               "' connects a frame to itself; name two different frames");
  }
  if (!to_T_from.matrix().allFinite() || !isRotation(to_T_from.linear())) {
    throw InvalidArgumentError("transform '" + std::string(from) + "To" + std::string(to) +
                               "' is not rigid (rotation part not orthonormal, or NaN): orthonormalise it first");
  }
  std::unique_lock lock(impl_->mutex);
  const auto f = impl_->addFrame(from);
  const auto t = impl_->addFrame(to);
  bool forward = true;
  const auto existing = impl_->findEdge(f, t, &forward);
  if (existing >= 0) {
    auto& e = impl_->edges[static_cast<std::size_t>(existing)];
    e.to_T_from = forward ? to_T_from : to_T_from.inverse(Eigen::Isometry);
    e.status = status;
    e.timestamp = timestamp;
    e.persistent = persistent;
    return;
  }
  std::vector<Query::Step> steps;
  if (impl_->findPath(f, t, steps)) {
    std::string route;
    auto u = f;
    route = impl_->frame_names[static_cast<std::size_t>(u)];
    for (const auto& s : steps) {
      const auto& e = impl_->edges[static_cast<std::size_t>(s.edge)];
      u = s.forward ? e.to : e.from;
      route += " -> " + impl_->frame_names[static_cast<std::size_t>(u)];
    }
    throw FrameError("cannot set '" + std::string(from) + "To" + std::string(to) +
                     "': the frames are already connected (" + route +
                     "), and a second path could contradict it; remove one of those transforms first");
  }
  Impl::Edge edge;
  edge.from = f;
  edge.to = t;
  edge.to_T_from = to_T_from;
  edge.status = status;
  edge.timestamp = timestamp;
  edge.persistent = persistent;
  const auto id = static_cast<std::int32_t>(impl_->edges.size());
  impl_->edges.push_back(edge);
  impl_->adjacency[static_cast<std::size_t>(f)].push_back({t, id, true});
  impl_->adjacency[static_cast<std::size_t>(t)].push_back({f, id, false});
  ++impl_->topology_version;
}

void TransformRepository::setTransform(std::string_view name, const Eigen::Isometry3d& to_T_from,
                                       TransformStatus status, double timestamp, bool persistent) {
  const auto parsed = TransformName::parse(name);
  setTransform(parsed.from, parsed.to, to_T_from, status, timestamp, persistent);
}

void TransformRepository::setStatus(std::string_view from, std::string_view to, TransformStatus status,
                                    double timestamp) {
  std::unique_lock lock(impl_->mutex);
  bool forward = true;
  const auto id = impl_->findEdge(impl_->findFrame(from), impl_->findFrame(to), &forward);
  if (id < 0) {
    throw FrameError("cannot set the status of '" + std::string(from) + "To" + std::string(to) +
                     "': no such transform has been set");
  }
  auto& e = impl_->edges[static_cast<std::size_t>(id)];
  e.status = status;
  e.timestamp = timestamp;
}

bool TransformRepository::removeTransform(std::string_view from, std::string_view to) {
  std::unique_lock lock(impl_->mutex);
  const auto f = impl_->findFrame(from);
  const auto t = impl_->findFrame(to);
  bool forward = true;
  const auto id = impl_->findEdge(f, t, &forward);
  if (id < 0) return false;
  auto erase = [id](std::vector<Impl::Neighbour>& list) {
    list.erase(std::remove_if(list.begin(), list.end(), [id](const Impl::Neighbour& n) { return n.edge == id; }),
               list.end());
  };
  erase(impl_->adjacency[static_cast<std::size_t>(f)]);
  erase(impl_->adjacency[static_cast<std::size_t>(t)]);
  // Edge slots are never reused, so prepared queries holding an old index
  // are caught by the topology version instead of reading a different edge.
  impl_->edges[static_cast<std::size_t>(id)].removed = true;
  ++impl_->topology_version;
  return true;
}

void TransformRepository::clear() {
  std::unique_lock lock(impl_->mutex);
  impl_->frame_ids.clear();
  impl_->frame_names.clear();
  impl_->adjacency.clear();
  impl_->edges.clear();
  ++impl_->topology_version;
}

TransformResult TransformRepository::getTransform(std::string_view from, std::string_view to) const {
  std::shared_lock lock(impl_->mutex);
  const auto f = impl_->findFrame(from);
  if (f < 0) impl_->throwUnknownFrame(from);
  const auto t = impl_->findFrame(to);
  if (t < 0) impl_->throwUnknownFrame(to);
  return impl_->compose(impl_->cachedPath(from, to, f, t));
}

TransformResult TransformRepository::getTransform(std::string_view name) const {
  const auto parsed = TransformName::parse(name);
  return getTransform(parsed.from, parsed.to);
}

TransformRepository::Query TransformRepository::prepare(std::string_view from, std::string_view to) const {
  Query query;
  query.from_ = std::string(from);
  query.to_ = std::string(to);
  return query;
}

TransformResult TransformRepository::evaluate(Query& query) const noexcept {
  std::shared_lock lock(impl_->mutex);
  if (query.topology_version_ != impl_->topology_version) {
    query.topology_version_ = impl_->topology_version;
    const auto f = impl_->findFrame(query.from_);
    const auto t = impl_->findFrame(query.to_);
    query.resolved_ = f >= 0 && t >= 0 && impl_->findPath(f, t, query.steps_);
  }
  if (!query.resolved_) return TransformResult{};
  return impl_->compose(query.steps_);
}

bool TransformRepository::hasFrame(std::string_view frame) const {
  std::shared_lock lock(impl_->mutex);
  return impl_->findFrame(frame) >= 0;
}

bool TransformRepository::isConnected(std::string_view from, std::string_view to) const {
  std::shared_lock lock(impl_->mutex);
  const auto f = impl_->findFrame(from);
  const auto t = impl_->findFrame(to);
  std::vector<Query::Step> steps;
  return f >= 0 && t >= 0 && impl_->findPath(f, t, steps);
}

std::vector<std::string> TransformRepository::path(std::string_view from, std::string_view to) const {
  std::shared_lock lock(impl_->mutex);
  const auto f = impl_->findFrame(from);
  if (f < 0) impl_->throwUnknownFrame(from);
  const auto t = impl_->findFrame(to);
  if (t < 0) impl_->throwUnknownFrame(to);
  std::vector<Query::Step> steps;
  if (!impl_->findPath(f, t, steps)) impl_->throwNoPath(from, to, f, t);
  std::vector<std::string> names{impl_->frame_names[static_cast<std::size_t>(f)]};
  for (const auto& s : steps) {
    const auto& e = impl_->edges[static_cast<std::size_t>(s.edge)];
    names.push_back(impl_->frame_names[static_cast<std::size_t>(s.forward ? e.to : e.from)]);
  }
  return names;
}

std::vector<std::string> TransformRepository::frames() const {
  std::shared_lock lock(impl_->mutex);
  auto names = impl_->frame_names;
  std::sort(names.begin(), names.end());
  return names;
}

std::vector<TransformEdgeInfo> TransformRepository::edges() const {
  std::shared_lock lock(impl_->mutex);
  std::vector<TransformEdgeInfo> list;
  for (const auto& e : impl_->edges) {
    if (e.removed) continue;
    list.push_back(TransformEdgeInfo{impl_->frame_names[static_cast<std::size_t>(e.from)],
                                     impl_->frame_names[static_cast<std::size_t>(e.to)], e.to_T_from, e.status,
                                     e.timestamp, e.persistent});
  }
  return list;
}

}  // namespace mrsns
