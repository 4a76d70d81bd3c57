#include "mrsns/deformation/igtl_contours.h"

#include <cmath>
#include <map>

namespace mrsns::deformation {
namespace {

bool finite(const Eigen::Vector3d& p) {
  return p.allFinite();
}

// A contour from point indices; a repeated first point (a closed VTK line) is dropped.
bool addContour(const std::vector<Eigen::Vector3d>& pts, std::vector<Polyline3d>& out) {
  Polyline3d c;
  c.closed = true;
  for (const auto& p : pts) {
    if (!finite(p)) return false;
    c.points.emplace_back(p.x(), p.y(), 0.0);
  }
  if (c.points.size() > 1 && (c.points.front() - c.points.back()).norm() < 1e-9) c.points.pop_back();
  if (c.points.size() >= kMinExternalContourPoints) out.push_back(std::move(c));
  return true;
}

}  // namespace

ContourMessageResult contoursFromMessage(const igtlink::Message& message) {
  ContourMessageResult r;
  r.contours.device = message.header.device_name;
  r.contours.timestamp_s = message.header.timestampSeconds();
  if (const auto* poly = std::get_if<igtlink::PolyDataContent>(&message.content)) {
    for (const igtlink::CellArray* cells : {&poly->lines, &poly->polygons}) {
      for (std::size_t c = 0; c < cells->size(); ++c) {
        std::vector<Eigen::Vector3d> pts;
        for (std::uint32_t i : cells->cell(c)) {
          if (i >= static_cast<std::uint32_t>(poly->points.rows())) {
            r.status = "POLYDATA cell " + std::to_string(c) + " refers to a point beyond the point list";
            return r;
          }
          pts.push_back(poly->points.row(i).transpose());
        }
        if (!addContour(pts, r.contours.contours)) {
          r.status = "POLYDATA holds non-finite points";
          return r;
        }
      }
    }
  } else if (const auto* points = std::get_if<igtlink::PointContent>(&message.content)) {
    std::vector<std::string> order;
    std::map<std::string, std::vector<Eigen::Vector3d>> groups;
    for (const auto& e : points->points) {
      if (!groups.contains(e.group)) order.push_back(e.group);
      groups[e.group].push_back(e.position);
    }
    for (const auto& g : order) {
      if (!addContour(groups[g], r.contours.contours)) {
        r.status = "POINT message holds non-finite points";
        return r;
      }
    }
  } else {
    r.status = "message type " + message.header.type + " carries no contours (send POLYDATA or POINT)";
    return r;
  }
  if (r.contours.contours.empty()) {
    r.status = "no contour with at least " + std::to_string(kMinExternalContourPoints) + " points";
    return r;
  }
  r.ok = true;
  r.status = "ok";
  return r;
}

igtlink::Message contoursToPolyDataMessage(std::span<const Polyline3d> contours, const std::string& device,
                                           double timestamp_s) {
  igtlink::PolyDataContent poly;
  std::size_t total = 0;
  for (const auto& c : contours) total += c.points.size();
  poly.points.resize(static_cast<Eigen::Index>(total), 3);
  std::uint32_t next = 0;
  for (const auto& c : contours) {
    std::vector<std::uint32_t> cell;
    for (const auto& p : c.points) {
      poly.points.row(next) = p.transpose();
      cell.push_back(next++);
    }
    if (!cell.empty()) cell.push_back(cell.front());
    poly.lines.add(cell);
  }
  return igtlink::makeMessage(device, poly, timestamp_s);
}

igtlink::Message contoursToPointMessage(std::span<const Polyline3d> contours, const std::string& device,
                                        double timestamp_s) {
  igtlink::PointContent content;
  for (std::size_t i = 0; i < contours.size(); ++i) {
    for (std::size_t k = 0; k < contours[i].points.size(); ++k) {
      igtlink::PointElement e;
      e.name = "C" + std::to_string(i) + "-" + std::to_string(k);
      e.group = "Contour" + std::to_string(i);
      e.position = contours[i].points[k];
      content.points.push_back(e);
    }
  }
  return igtlink::makeMessage(device, content, timestamp_s);
}

bool ContourInbox::push(const igtlink::Message& message) {
  ContourMessageResult r = contoursFromMessage(message);
  if (!r.ok) {
    std::lock_guard lock(mutex_);
    ++refused_;
    return false;
  }
  push(std::move(r.contours));
  return true;
}

void ContourInbox::push(ExternalContours contours) {
  std::lock_guard lock(mutex_);
  entries_.push_back(std::move(contours));
  while (entries_.size() > capacity_) entries_.pop_front();
}

std::optional<ExternalContours> ContourInbox::take(double timestamp_s, double tolerance_s) {
  std::lock_guard lock(mutex_);
  std::size_t best = entries_.size();
  double best_dt = tolerance_s;
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    const double dt = std::abs(entries_[i].timestamp_s - timestamp_s);
    if (dt <= best_dt) {
      best_dt = dt;
      best = i;
    }
  }
  if (best == entries_.size()) return std::nullopt;
  ExternalContours out = std::move(entries_[best]);
  entries_.erase(entries_.begin(), entries_.begin() + static_cast<std::ptrdiff_t>(best) + 1);
  return out;
}

std::size_t ContourInbox::size() const {
  std::lock_guard lock(mutex_);
  return entries_.size();
}

std::size_t ContourInbox::refused() const {
  std::lock_guard lock(mutex_);
  return refused_;
}

}  // namespace mrsns::deformation
