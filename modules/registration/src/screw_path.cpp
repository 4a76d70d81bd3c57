#include "mrsns/registration/screw_path.h"

#include <cmath>
#include <sstream>

#include "mrsns/core/error.h"

namespace mrsns::registration {

Eigen::Vector3d ScrewPath::direction() const {
  const Eigen::Vector3d d = target - entry;
  const double n = d.norm();
  if (!(n > 1e-9) || !d.allFinite()) {
    throw InvalidArgumentError("screw path '" + name +
                               "': entry and target coincide or are not finite: place the target "
                               "along the planned screw direction");
  }
  return d / n;
}

double ScrewPath::effectiveLength() const {
  return length_mm > 0.0 ? length_mm : (target - entry).norm();
}

Eigen::Vector3d ScrewPath::tip() const {
  return entry + effectiveLength() * direction();
}

void validateScrewPath(const ScrewPath& path) {
  (void)path.direction();
  if (!(path.diameter_mm > 0.0) || !std::isfinite(path.diameter_mm)) {
    throw InvalidArgumentError("screw path '" + path.name + "': diameter must be a positive number of mm, got " +
                               std::to_string(path.diameter_mm));
  }
  if (!std::isfinite(path.length_mm)) {
    throw InvalidArgumentError("screw path '" + path.name + "': length is not finite");
  }
}

PathClearance screwPathClearance(const ScrewPath& path, const MeshLocator& surface, const ClearanceOptions& options) {
  validateScrewPath(path);
  if (!(options.step_mm > 0.0)) throw InvalidArgumentError("screw path clearance: step_mm must be > 0");
  const Eigen::Vector3d dir = path.direction();
  const double length = path.effectiveLength();
  const double radius = 0.5 * path.diameter_mm;
  const auto sample = [&](double s) {
    ClearanceSample c;
    c.depth_mm = s;
    c.axis_point = path.entry + s * dir;
    const auto sp = surface.closestPoint(c.axis_point);
    c.surface_point = sp.point;
    c.clearance_mm = sp.distance - radius;
    return c;
  };

  PathClearance result;
  const auto steps = static_cast<int>(std::floor(length / options.step_mm + 1e-9));
  for (int i = 0; i <= steps; ++i) result.profile.push_back(sample(i * options.step_mm));
  if (result.profile.back().depth_mm < length - 1e-9) result.profile.push_back(sample(length));

  std::size_t best = 0;
  for (std::size_t i = 1; i < result.profile.size(); ++i) {
    if (result.profile[i].clearance_mm < result.profile[best].clearance_mm) best = i;
  }
  ClearanceSample min = result.profile[best];
  // The distance along a line is not unimodal in general, but within one
  // step of the best sample it is close enough for golden-section search.
  double a = result.profile[best > 0 ? best - 1 : best].depth_mm;
  double b = result.profile[std::min(best + 1, result.profile.size() - 1)].depth_mm;
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  for (int it = 0; it < 40 && b - a > 1e-4; ++it) {
    const double x1 = b - g * (b - a);
    const double x2 = a + g * (b - a);
    if (sample(x1).clearance_mm < sample(x2).clearance_mm) {
      b = x2;
    } else {
      a = x1;
    }
  }
  const auto refined = sample(0.5 * (a + b));
  if (refined.clearance_mm < min.clearance_mm) min = refined;

  for (const auto& hit : surface.intersectSegment(path.entry, path.entry + length * dir)) {
    result.crossings_mm.push_back(hit.t * length);
  }
  if (!result.crossings_mm.empty() && min.clearance_mm > -radius) {
    min = sample(result.crossings_mm.front());
    min.clearance_mm = -radius;
    min.surface_point = min.axis_point;
  }
  result.min_clearance_mm = min.clearance_mm;
  result.min_depth_mm = min.depth_mm;
  result.min_axis_point = min.axis_point;
  result.min_surface_point = min.surface_point;
  result.cuts_surface = result.min_clearance_mm < 0.0;
  return result;
}

std::string screwPathDescription(const ScrewPath& path) {
  std::ostringstream s;
  s.precision(10);
  s << "vertebra=" << path.vertebra << "; diameter_mm=" << path.diameter_mm << "; length_mm=" << path.length_mm;
  return s.str();
}

ScrewPath screwPathFromLine(const std::string& name, const Eigen::Vector3d& entry, const Eigen::Vector3d& target,
                            const std::string& description) {
  ScrewPath path;
  path.name = name;
  path.entry = entry;
  path.target = target;
  std::istringstream in(description);
  std::string item;
  const auto trim = [](std::string s) {
    const auto b = s.find_first_not_of(" \t");
    const auto e = s.find_last_not_of(" \t");
    return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
  };
  while (std::getline(in, item, ';')) {
    const auto eq = item.find('=');
    if (eq == std::string::npos) continue;
    const std::string key = trim(item.substr(0, eq));
    const std::string value = trim(item.substr(eq + 1));
    const auto number = [&]() {
      try {
        std::size_t used = 0;
        const double v = std::stod(value, &used);
        if (used != value.size()) throw std::invalid_argument(value);
        return v;
      } catch (const std::exception&) {
        throw InvalidArgumentError("screw path '" + name + "': " + key + " '" + value +
                                   "' is not a number: write e.g. '" + key + "=3.5' in the line's description");
      }
    };
    if (key == "vertebra") path.vertebra = value;
    if (key == "diameter_mm") path.diameter_mm = number();
    if (key == "length_mm") path.length_mm = number();
  }
  return path;
}

}  // namespace mrsns::registration
