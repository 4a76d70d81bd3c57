#include "mrsns/registration/screw_planning.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <numeric>
#include <utility>

#include "mrsns/core/error.h"
#include "mrsns/core/format.h"
#include "mrsns/core/mesh_ops.h"
#include "mrsns/core/units.h"

namespace mrsns::registration {
namespace {

// Names here are unique within the registration library's unity batches.

/// Volume, first and second moments of the volume enclosed by a closed mesh
/// about `ref` (tetrahedra from ref to each face, signed by the winding).
struct PlanningVolumeMoments {
  double volume = 0.0;
  Eigen::Vector3d first = Eigen::Vector3d::Zero();   // integral of (x - ref)
  Eigen::Matrix3d second = Eigen::Matrix3d::Zero();  // integral of (x - ref)(x - ref)^T
};

PlanningVolumeMoments planningVolumeMoments(const TriangleMesh& mesh, const Eigen::Vector3d& ref) {
  PlanningVolumeMoments m;
  for (Eigen::Index f = 0; f < mesh.faceCount(); ++f) {
    const Eigen::Vector3d a = mesh.vertices.row(mesh.faces(f, 0)).transpose() - ref;
    const Eigen::Vector3d b = mesh.vertices.row(mesh.faces(f, 1)).transpose() - ref;
    const Eigen::Vector3d c = mesh.vertices.row(mesh.faces(f, 2)).transpose() - ref;
    const double v = a.dot(b.cross(c)) / 6.0;
    const Eigen::Vector3d s = a + b + c;
    m.volume += v;
    m.first += v * s / 4.0;
    // Tetrahedron (0, a, b, c): integral of x x^T = V / 20 (sum_i p_i p_i^T + s s^T).
    m.second += (v / 20.0) * (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
  }
  return m;
}

constexpr std::array<std::array<int, 3>, 6> kPlanningPermutations = {
    {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}}};

double planningRadToDeg(double rad) {
  return rad / kDeg;
}

/// A unit vector perpendicular to `d` (unit), chosen from the coordinate
/// axis least aligned with it.
Eigen::Vector3d planningPerpendicular(const Eigen::Vector3d& d) {
  Eigen::Index k = 0;
  d.cwiseAbs().minCoeff(&k);
  return d.cross(Eigen::Vector3d::Unit(k)).normalized();
}

/// Where f changes sign (outside: f > 0) between a and b, by the Illinois
/// variant of regula falsi; fa and fb are f(a) and f(b) on opposite sides.
template <typename F>
double planningSignChange(const F& f, double a, double fa, double b, double fb) {
  int side = 0;
  double c = 0.5 * (a + b);
  for (int it = 0; it < 40; ++it) {
    c = (fa * b - fb * a) / (fa - fb);
    if (!(c > a && c < b)) c = 0.5 * (a + b);
    const double fc = f(c);
    if (std::abs(fc) < 1e-7 || b - a < 1e-5) break;
    if ((fc > 0.0) == (fb > 0.0)) {
      b = c;
      fb = fc;
      if (side == -1) fa *= 0.5;
      side = -1;
    } else {
      a = c;
      fa = fc;
      if (side == 1) fb *= 0.5;
      side = 1;
    }
  }
  return c;
}

/// The maximum of f over [lo, hi] by golden-section search, starting from a
/// known value at x0 (returned when nothing better is found).
template <typename F>
std::pair<double, double> planningGoldenMax(const F& f, double lo, double hi, double x0, double f0, int iterations) {
  std::pair<double, double> best{x0, f0};
  if (!(hi > lo)) return best;
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double a = lo;
  double b = hi;
  double x1 = b - g * (b - a);
  double x2 = a + g * (b - a);
  double f1 = f(x1);
  double f2 = f(x2);
  for (int it = 0; it < iterations; ++it) {
    if (f1 > best.second) best = {x1, f1};
    if (f2 > best.second) best = {x2, f2};
    if (f1 > f2) {
      b = x2;
      x2 = x1;
      f2 = f1;
      x1 = b - g * (b - a);
      f1 = f(x1);
    } else {
      a = x1;
      x1 = x2;
      f1 = f2;
      x2 = a + g * (b - a);
      f2 = f(x2);
    }
  }
  if (f1 > best.second) best = {x1, f1};
  if (f2 > best.second) best = {x2, f2};
  return best;
}

std::string planningLower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

/// Length of the screw axis inside a closed surface (mm), from the entry's
/// signed distance and the axis's crossings (each says which side follows);
/// also the entry's signed distance.
std::pair<double, double> planningAxisInBone(const ScrewPath& path, const MeshLocator& bone) {
  const double length = path.effectiveLength();
  const Eigen::Vector3d tip = path.tip();
  const double entry_sd = bone.signedClosestPoint(path.entry).signed_distance;
  if (entry_sd > length) return {0.0, entry_sd};  // the whole axis is outside
  bool inside = entry_sd < 0.0;
  double previous = 0.0;
  double in_bone = 0.0;
  for (const auto& hit : bone.intersectSegment(path.entry, tip)) {
    if (inside) in_bone += (hit.t - previous) * length;
    inside = hit.entering;
    previous = hit.t;
  }
  if (inside) in_bone += (1.0 - previous) * length;
  return {in_bone, entry_sd};
}

/// "medially", "anteriorly", ... for an outward direction at a screw on `side`.
std::string planningDirectionWord(const Eigen::Vector3d& direction, const VertebraFrame& frame,
                                  const std::string& side) {
  const Eigen::Vector3d c(direction.dot(frame.left), direction.dot(frame.posterior), direction.dot(frame.superior));
  Eigen::Index k = 0;
  c.cwiseAbs().maxCoeff(&k);
  if (k == 0) {
    const bool towards_left = c.x() > 0.0;
    if (side == "left") return towards_left ? "laterally" : "medially";
    if (side == "right") return towards_left ? "medially" : "laterally";
    return towards_left ? "to the left" : "to the right";
  }
  if (k == 1) return c.y() > 0.0 ? "posteriorly" : "anteriorly";
  return c.z() > 0.0 ? "superiorly" : "inferiorly";
}

}  // namespace

// ---------------------------------------------------------------------------
// Frame

Eigen::Matrix3d VertebraFrame::rotation() const {
  Eigen::Matrix3d r;
  r.col(0) = left;
  r.col(1) = posterior;
  r.col(2) = superior;
  return r;
}

Eigen::Isometry3d VertebraFrame::lps_T_vertebra() const {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = rotation();
  t.translation() = origin;
  return t;
}

VertebraFrame vertebraFrame(const TriangleMesh& vertebra, const VertebraFrameOptions& options) {
  const std::string what =
      vertebra.name.empty() ? std::string("vertebra mesh") : "vertebra mesh '" + vertebra.name + "'";
  validateMesh(vertebra, what);
  if (vertebra.faceCount() < 4) {
    throw InvalidArgumentError(what + " has " + std::to_string(vertebra.faceCount()) +
                               " faces: a closed surface needs at least 4; mesh the vertebra's label first");
  }
  if (!isClosed(vertebra)) {
    throw InvalidArgumentError(what +
                               " is not closed (some edge is not shared by exactly two consistently oriented "
                               "faces), so its enclosed volume is undefined: mesh the label map with "
                               "meshLabelMap (which closes surfaces at the image edge) or repair the mesh");
  }
  const Eigen::AlignedBox3d box = boundingBox(vertebra);
  const Eigen::Vector3d ref = box.center();
  const double diagonal = box.diagonal().norm();
  const PlanningVolumeMoments m = planningVolumeMoments(vertebra, ref);
  const double tiny_volume = 1e-9 * diagonal * diagonal * diagonal;
  if (m.volume < -tiny_volume) {
    throw InvalidArgumentError(what + " is inside-out (enclosed volume " + formatGeneral(m.volume) +
                               " mm^3 < 0: faces wound clockwise seen from outside): reverse the faces' winding");
  }
  if (!(m.volume > tiny_volume)) {
    throw InvalidArgumentError(what + " encloses no volume (" + formatGeneral(m.volume) +
                               " mm^3): it is degenerate; check the label map");
  }
  VertebraFrame frame;
  frame.volume_mm3 = m.volume;
  const Eigen::Vector3d centroid_ref = m.first / m.volume;
  frame.origin = ref + centroid_ref;
  Eigen::Matrix3d covariance = m.second / m.volume - centroid_ref * centroid_ref.transpose();
  covariance = 0.5 * (covariance + covariance.transpose()).eval();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(covariance);
  const Eigen::Vector3d moments = eigen.eigenvalues();  // ascending
  if (eigen.info() != Eigen::Success || !(moments(0) > 1e-8 * moments(2))) {
    throw InvalidArgumentError(what +
                               " is flat (its enclosed volume has no extent along one direction): it is "
                               "degenerate; check the label map");
  }
  const Eigen::Matrix3d vectors = eigen.eigenvectors();

  // The patient axes the principal axes are assigned to: LPS, or LPS turned
  // (by the smallest rotation) so that z lies on the hint.
  Eigen::Matrix3d patient = Eigen::Matrix3d::Identity();
  Eigen::Vector3d hint = Eigen::Vector3d::UnitZ();
  if (options.superior_hint) {
    hint = *options.superior_hint;
    if (!hint.allFinite() || !(hint.norm() > 1e-9)) {
      throw InvalidArgumentError(what +
                                 ": the superior hint is zero or not finite: give the spine's local direction, "
                                 "e.g. from the centroid of the vertebra below to the one above");
    }
    hint.normalize();
    if (hint.z() < 0.0) hint = -hint;
    const double from_z = std::acos(std::clamp(hint.z(), -1.0, 1.0));
    if (from_z > 80.0 * kDeg) {
      throw InvalidArgumentError(what + ": the superior hint is " + formatFixed(planningRadToDeg(from_z), 1) +
                                 " deg from +z (superior in LPS), more than 80 deg: is it in LPS millimetres?");
    }
    patient = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), hint).toRotationMatrix();
  }
  Eigen::Matrix3d cosines;  // (k, j): |principal axis k . patient axis j|
  for (int k = 0; k < 3; ++k) {
    for (int j = 0; j < 3; ++j) cosines(k, j) = std::abs(vectors.col(k).dot(patient.col(j)));
  }
  std::array<double, 6> scores{};
  for (std::size_t p = 0; p < kPlanningPermutations.size(); ++p) {
    for (int j = 0; j < 3; ++j) scores[p] += cosines(kPlanningPermutations[p][static_cast<std::size_t>(j)], j);
  }
  const auto best_it = std::max_element(scores.begin(), scores.end());
  const auto best = static_cast<std::size_t>(best_it - scores.begin());
  double second = -1.0;
  for (std::size_t p = 0; p < scores.size(); ++p) {
    if (p != best) second = std::max(second, scores[p]);
  }
  const auto& perm = kPlanningPermutations[best];
  Eigen::Matrix3d axes;
  for (int j = 0; j < 3; ++j) {
    const Eigen::Vector3d e = vectors.col(perm[static_cast<std::size_t>(j)]);
    axes.col(j) = e.dot(patient.col(j)) < 0.0 ? Eigen::Vector3d(-e) : e;
    frame.principal_rms_mm(j) = std::sqrt(moments(perm[static_cast<std::size_t>(j)]));
  }
  if (axes.determinant() < 0.0) {
    // Only possible when an axis is nearly perpendicular to its patient axis:
    // flip the one whose sign is least certain.
    Eigen::Index weakest = 0;
    Eigen::Vector3d agreement;
    for (int j = 0; j < 3; ++j) agreement(j) = cosines(perm[static_cast<std::size_t>(j)], j);
    agreement.minCoeff(&weakest);
    axes.col(weakest) = -axes.col(weakest);
    frame.warnings.push_back(what + ": the " +
                             std::string(weakest == 0   ? "left"
                                         : weakest == 1 ? "posterior"
                                                        : "superior") +
                             " axis was reversed to keep the frame right-handed: it is nearly perpendicular to its "
                             "patient axis");
  }
  frame.principal_axes = axes;
  frame.alignment = *best_it / 3.0;
  frame.confidence = std::clamp((*best_it - second) / 2.0, 0.0, 1.0);
  frame.moment_separation = std::min(moments(1) - moments(0), moments(2) - moments(1)) / moments(2);

  if (options.superior_hint) {
    frame.superior_from_hint = true;
    frame.superior = hint;
    frame.hint_angle = std::acos(std::clamp(axes.col(2).dot(hint), -1.0, 1.0));
    Eigen::Vector3d left = axes.col(0) - axes.col(0).dot(hint) * hint;
    if (!(left.norm() > 0.1)) {
      throw InvalidArgumentError(what +
                                 ": the superior hint lies within 6 deg of the vertebra's left axis: it cannot "
                                 "be the spine's direction; check the neighbouring vertebrae");
    }
    frame.left = left.normalized();
    frame.posterior = frame.superior.cross(frame.left).normalized();
  } else {
    frame.left = axes.col(0).normalized();
    frame.posterior = (axes.col(1) - axes.col(1).dot(frame.left) * frame.left).normalized();
    frame.superior = frame.left.cross(frame.posterior);
  }

  const Eigen::Matrix3d r = frame.rotation();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (Eigen::Index v = 0; v < vertebra.vertexCount(); ++v) {
    const Eigen::Vector3d offset = r.transpose() * (vertebra.vertices.row(v).transpose() - frame.origin);
    lo = lo.cwiseMin(offset);
    hi = hi.cwiseMax(offset);
  }
  frame.extent_min_mm = lo;
  frame.extent_max_mm = hi;
  frame.extent_mm = hi - lo;

  if (frame.confidence < options.min_confidence) {
    frame.ambiguous = true;
    frame.warnings.push_back(what +
                             ": its principal axes fit another assignment to the patient axes almost as well "
                             "(confidence " +
                             formatFixed(frame.confidence, 2) +
                             "): the vertebra may be turned more than ~35 deg; give the spine's direction as the "
                             "superior hint");
  }
  if (frame.moment_separation < options.min_moment_separation) {
    frame.ambiguous = true;
    frame.warnings.push_back(what + ": two of its principal moments are nearly equal (separation " +
                             formatFixed(frame.moment_separation, 3) +
                             "), so its axes in their plane are ill-defined; check the axes before reading angles");
  }
  return frame;
}

// ---------------------------------------------------------------------------
// Angles

ScrewAngles screwAngles(const ScrewPath& path, const VertebraFrame& frame, const ScrewAngleOptions& options) {
  validateScrewPath(path);
  const Eigen::Vector3d d = path.direction();
  ScrewAngles angles;
  const double dl = d.dot(frame.left);
  const double dp = d.dot(frame.posterior);
  const double ds = d.dot(frame.superior);
  angles.direction_in_frame = Eigen::Vector3d(dl, dp, ds);
  angles.cranial_deg = planningRadToDeg(std::asin(std::clamp(ds, -1.0, 1.0)));
  const double nan = std::numeric_limits<double>::quiet_NaN();
  angles.axial_deg = std::hypot(dl, dp) > 1e-12 ? planningRadToDeg(std::atan2(dl, -dp)) : nan;
  angles.points_posteriorly = dp > 0.0;
  angles.entry_offset_left_mm = (path.entry - frame.origin).dot(frame.left);
  if (std::abs(angles.entry_offset_left_mm) < options.midline_tolerance_mm) {
    angles.side = "midline";
    angles.medial_deg = nan;
  } else if (angles.entry_offset_left_mm > 0.0) {
    angles.side = "left";  // medial is towards -left
    angles.medial_deg = -angles.axial_deg;
    if (angles.medial_deg == -180.0) angles.medial_deg = 180.0;
  } else {
    angles.side = "right";  // medial is towards +left
    angles.medial_deg = angles.axial_deg;
  }
  return angles;
}

// ---------------------------------------------------------------------------
// Breach

GertzbeinRobbins gertzbeinRobbinsGrade(double breach_mm) {
  if (!(breach_mm > 0.0)) return GertzbeinRobbins::A;
  if (breach_mm < 2.0) return GertzbeinRobbins::B;
  if (breach_mm < 4.0) return GertzbeinRobbins::C;
  if (breach_mm < 6.0) return GertzbeinRobbins::D;
  return GertzbeinRobbins::E;
}

char gertzbeinRobbinsLetter(GertzbeinRobbins grade) {
  return static_cast<char>('A' + static_cast<int>(grade));
}

BoneBreach screwBoneBreach(const ScrewPath& path, const MeshLocator& bone, const BreachOptions& options) {
  validateScrewPath(path);
  const std::string what = "screw '" + path.name + "'";
  if (!(options.step_mm > 0.0) || !std::isfinite(options.step_mm)) {
    throw InvalidArgumentError(what + " breach: step_mm must be a positive number of mm, got " +
                               std::to_string(options.step_mm));
  }
  if (options.circumference_samples < 3) {
    throw InvalidArgumentError(what + " breach: circumference_samples must be at least 3, got " +
                               std::to_string(options.circumference_samples));
  }
  const double radius = 0.5 * path.diameter_mm;
  const double length = path.effectiveLength();
  const double allowance = options.entry_allowance_mm.value_or(radius);
  if (!(allowance >= 0.0) || !std::isfinite(allowance) || !(allowance < length)) {
    throw InvalidArgumentError(what + " breach: the entry allowance (" + formatFixed(allowance, 2) +
                               " mm) must be >= 0 and shorter than the screw (" + formatFixed(length, 1) + " mm)");
  }
  if (!bone.closed()) {
    throw InvalidArgumentError(what +
                               " breach: the bone surface is not closed, so inside and outside are undefined: "
                               "use the vertebra's closed mesh (meshLabelMap)");
  }
  const Eigen::Vector3d dir = path.direction();
  const Eigen::Vector3d u = planningPerpendicular(dir);
  const Eigen::Vector3d v = dir.cross(u);
  const auto axisPoint = [&](double s) -> Eigen::Vector3d { return path.entry + s * dir; };
  const auto radial = [&](double theta) -> Eigen::Vector3d { return std::cos(theta) * u + std::sin(theta) * v; };

  BoneBreach result;
  result.entry_allowance_mm = allowance;
  result.screw_length_mm = length;
  const auto sd = [&](const Eigen::Vector3d& p) {
    ++result.distance_queries;
    return bone.signedClosestPoint(p).signed_distance;
  };

  // Stations: every step from the entry, the allowance, the tip.
  std::vector<double> depths;
  for (int i = 0;; ++i) {
    const double s = i * options.step_mm;
    if (s >= length - 1e-9) break;
    depths.push_back(s);
  }
  depths.push_back(length);
  if (allowance > 0.0) depths.push_back(allowance);
  std::sort(depths.begin(), depths.end());
  depths.erase(std::unique(depths.begin(), depths.end(), [](double a, double b) { return std::abs(a - b) < 1e-9; }),
               depths.end());
  const std::size_t n = depths.size();
  std::vector<double> axis_sd(n);
  for (std::size_t i = 0; i < n; ++i) axis_sd[i] = sd(axisPoint(depths[i]));
  result.entry_to_bone_mm = axis_sd[0];
  const auto counted = [&](std::size_t i) { return depths[i] >= allowance - 1e-9; };

  // The axis: lengths in and out of the bone, crossings refined between stations.
  const auto axisSd = [&](double s) { return sd(axisPoint(s)); };
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const double span = depths[i + 1] - depths[i];
    const bool out0 = axis_sd[i] > 0.0;
    const bool out1 = axis_sd[i + 1] > 0.0;
    double outside = out0 ? span : 0.0;
    if (out0 != out1) {
      const double c = planningSignChange(axisSd, depths[i], axis_sd[i], depths[i + 1], axis_sd[i + 1]);
      result.axis_crossings_mm.push_back(c);
      outside = out0 ? c - depths[i] : depths[i + 1] - c;
    }
    result.length_in_bone_mm += span - outside;
    if (counted(i)) result.axis_outside_mm += outside;
  }

  // The surface: circumference_samples points per station. The signed
  // distance is 1-Lipschitz, so a point's value is bounded by the axis's
  // plus the radius, by the same line's last evaluated value plus the depth
  // between them and by its evaluated neighbour's plus the chord: a point
  // is only evaluated where such a bound leaves its side open, or where it
  // could still hold the largest value (branch and bound).
  const int k_count = options.circumference_samples;
  const auto k_size = static_cast<std::size_t>(k_count);
  std::vector<Eigen::Vector3d> offsets;
  for (int k = 0; k < k_count; ++k) offsets.push_back(radius * radial(kTwoPi * k / k_count));
  const double chord = 2.0 * radius * std::sin(kPi / k_count);
  struct Best {
    double value = -std::numeric_limits<double>::infinity();
    double depth = 0.0;
    double theta = 0.0;
  } best;
  std::vector<double> value(n * k_size, 0.0);
  std::vector<double> bound(n * k_size, std::numeric_limits<double>::infinity());
  std::vector<char> evaluated(n * k_size, 0);
  const auto evaluatePoint = [&](std::size_t i, std::size_t k) {
    const double v_ik = sd(axisPoint(depths[i]) + offsets[k]);
    value[i * k_size + k] = v_ik;
    bound[i * k_size + k] = v_ik;
    evaluated[i * k_size + k] = 1;
    if (v_ik > best.value) best = {v_ik, depths[i], kTwoPi * static_cast<double>(k) / k_count};
    return v_ik;
  };
  std::vector<bool> outside(n, false);
  std::vector<double> line_value(k_size, 0.0);
  std::vector<double> line_depth(k_size, -std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < n; ++i) {
    if (!counted(i)) continue;
    const double axis_bound = axis_sd[i] + radius;
    for (std::size_t k = 0; k < k_size; ++k) bound[i * k_size + k] = axis_bound;
    if (axis_bound < 0.0) continue;   // the whole circle is inside
    if (axis_sd[i] - radius > 0.0) {  // the whole circle is outside
      outside[i] = true;
      continue;
    }
    for (std::size_t k = 0; k < k_size; ++k) {
      double u_ik = std::min(axis_bound, line_value[k] + (depths[i] - line_depth[k]));
      if (k > 0 && evaluated[i * k_size + k - 1]) u_ik = std::min(u_ik, value[i * k_size + k - 1] + chord);
      if (k + 1 == k_size && evaluated[i * k_size]) u_ik = std::min(u_ik, value[i * k_size] + chord);
      bound[i * k_size + k] = u_ik;
      if (u_ik < 0.0) continue;  // inside, proven
      const double v_ik = evaluatePoint(i, k);
      line_value[k] = v_ik;
      line_depth[k] = depths[i];
      if (v_ik > 0.0) {
        outside[i] = true;  // the rest keep their bounds for the maximum below
        break;
      }
    }
  }
  // Branch and bound for the largest signed distance (the margin when
  // nothing is outside): points in descending order of their bound.
  std::vector<std::size_t> candidates;
  for (std::size_t i = 0; i < n; ++i) {
    if (!counted(i)) continue;
    for (std::size_t k = 0; k < k_size; ++k) {
      if (!evaluated[i * k_size + k]) candidates.push_back(i * k_size + k);
    }
  }
  std::sort(candidates.begin(), candidates.end(), [&](std::size_t a, std::size_t b) { return bound[a] > bound[b]; });
  for (const std::size_t c : candidates) {
    if (bound[c] <= best.value) break;
    (void)evaluatePoint(c / k_size, c % k_size);
  }

  const auto surfaceOutsideAt = [&](double s) {
    const Eigen::Vector3d p = axisPoint(s);
    const double d0 = sd(p);
    if (d0 + radius < 0.0) return false;
    if (d0 - radius > 0.0) return true;
    for (const auto& offset : offsets) {
      if (sd(p + offset) > 0.0) return true;
    }
    return false;
  };
  for (std::size_t i = 0; i + 1 < n; ++i) {
    if (!counted(i)) continue;
    if (outside[i] && outside[i + 1]) {
      result.surface_outside_mm += depths[i + 1] - depths[i];
    } else if (outside[i] != outside[i + 1]) {
      double lo = depths[i];
      double hi = depths[i + 1];
      for (int it = 0; it < 6; ++it) {  // to 1/64 of a step
        const double mid = 0.5 * (lo + hi);
        (surfaceOutsideAt(mid) == outside[i] ? lo : hi) = mid;
      }
      const double c = 0.5 * (lo + hi);
      result.surface_outside_mm += outside[i] ? c - depths[i] : depths[i + 1] - c;
    }
  }

  // Refine the worst point between the samples: coordinate ascent in depth
  // and angle around the best sample.
  const auto surfaceSd = [&](double s, double theta) { return sd(axisPoint(s) + radius * radial(theta)); };
  double half_depth = options.step_mm;
  double half_angle = kTwoPi / k_count;
  for (int round = 0; round < 2; ++round) {
    const auto along = planningGoldenMax([&](double s) { return surfaceSd(s, best.theta); },
                                         std::max(allowance, best.depth - half_depth),
                                         std::min(length, best.depth + half_depth), best.depth, best.value, 8);
    best.depth = along.first;
    best.value = along.second;
    const auto around = planningGoldenMax([&](double t) { return surfaceSd(best.depth, t); }, best.theta - half_angle,
                                          best.theta + half_angle, best.theta, best.value, 8);
    best.theta = around.first;
    best.value = around.second;
    half_depth *= 0.25;
    half_angle *= 0.25;
  }
  result.max_signed_distance_mm = best.value;
  result.max_breach_mm = std::max(0.0, best.value);
  result.depth_of_max_breach_mm = best.depth;
  result.max_breach_direction = radial(best.theta);
  result.max_breach_point = axisPoint(best.depth) + radius * result.max_breach_direction;
  const GertzbeinRobbins grade = gertzbeinRobbinsGrade(result.max_breach_mm);
  result.grade = static_cast<int>(grade);
  result.grade_letter = gertzbeinRobbinsLetter(grade);

  result.profile.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    BreachSample& sample = result.profile[i];
    sample.depth_mm = depths[i];
    sample.axis_signed_distance_mm = axis_sd[i];
    sample.surface_outside = outside[i];
    bool all = counted(i);
    double m = -std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < k_size && all; ++k) {
      all = evaluated[i * k_size + k] != 0;
      m = std::max(m, value[i * k_size + k]);
    }
    if (all) sample.surface_max_signed_distance_mm = m;
  }
  return result;
}

// ---------------------------------------------------------------------------
// The planning panel

std::string_view structureKindName(StructureKind kind) {
  switch (kind) {
    case StructureKind::Vessel: return "vessel";
    case StructureKind::SoftTissue: return "soft_tissue";
    case StructureKind::Neural: return "neural";
    case StructureKind::Other: return "other";
  }
  return "other";
}

std::string_view vertebraSourceName(VertebraSource source) {
  switch (source) {
    case VertebraSource::Named: return "named by the plan";
    case VertebraSource::MostAxisInBone: return "most of the axis in bone";
    case VertebraSource::NearestToEntry: return "nearest to the entry";
    case VertebraSource::None: return "none";
  }
  return "none";
}

ScrewPlanFigures evaluateScrewPlan(const ScrewPath& path, const PlanningAnatomy& anatomy,
                                   const ScrewPlanOptions& options) {
  validateScrewPath(path);
  for (const auto& bone : anatomy.vertebrae) {
    if (bone.surface == nullptr) {
      throw InvalidArgumentError("screw planning: vertebra '" + bone.name +
                                 "' has no surface: give its mesh's locator");
    }
    if (!bone.surface->closed()) {
      throw InvalidArgumentError("screw planning: the surface of vertebra '" + bone.name +
                                 "' is not closed, so inside and outside are undefined: use its closed mesh "
                                 "(meshLabelMap)");
    }
  }
  for (const auto& structure : anatomy.avoidance) {
    if (structure.surface == nullptr) {
      throw InvalidArgumentError("screw planning: structure '" + structure.name +
                                 "' has no surface: give its mesh's locator");
    }
  }
  ScrewPlanFigures figures;
  figures.screw = path.name;
  const double radius = 0.5 * path.diameter_mm;

  // The screw's vertebra.
  std::vector<std::string> choice_warnings;
  std::optional<std::size_t> chosen;
  if (!path.vertebra.empty()) {
    for (std::size_t i = 0; i < anatomy.vertebrae.size() && !chosen; ++i) {
      if (anatomy.vertebrae[i].name == path.vertebra) chosen = i;
    }
    for (std::size_t i = 0; i < anatomy.vertebrae.size() && !chosen; ++i) {
      if (planningLower(anatomy.vertebrae[i].name) == planningLower(path.vertebra)) chosen = i;
    }
    if (chosen) figures.vertebra_from = VertebraSource::Named;
  }
  if (!chosen && !anatomy.vertebrae.empty()) {
    std::size_t most = 0;
    std::size_t nearest = 0;
    double most_mm = -1.0;
    double nearest_mm = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < anatomy.vertebrae.size(); ++i) {
      const auto [in_bone, entry_sd] = planningAxisInBone(path, *anatomy.vertebrae[i].surface);
      figures.axis_in_bone_mm.emplace_back(anatomy.vertebrae[i].name, in_bone);
      if (in_bone > most_mm) {
        most_mm = in_bone;
        most = i;
      }
      if (std::abs(entry_sd) < nearest_mm) {
        nearest_mm = std::abs(entry_sd);
        nearest = i;
      }
    }
    if (most_mm > 0.0) {
      chosen = most;
      figures.vertebra_from = VertebraSource::MostAxisInBone;
    } else {
      chosen = nearest;
      figures.vertebra_from = VertebraSource::NearestToEntry;
      choice_warnings.push_back("the screw is in no vertebra; measured against the one nearest to the entry, " +
                                anatomy.vertebrae[nearest].name);
    }
    if (!path.vertebra.empty()) {
      choice_warnings.insert(choice_warnings.begin(), "the plan names " + path.vertebra +
                                                          ", which is not among the vertebrae; measured against " +
                                                          anatomy.vertebrae[*chosen].name + " (" +
                                                          std::string(vertebraSourceName(figures.vertebra_from)) + ")");
    }
  }
  if (anatomy.vertebrae.empty()) choice_warnings.push_back("no vertebra in the anatomy: no angles or breach");

  std::vector<std::string> breach_warnings;
  std::vector<std::string> entry_warnings;
  std::vector<std::string> angle_warnings;
  if (chosen) {
    const BoneStructure& bone = anatomy.vertebrae[*chosen];
    figures.vertebra = bone.name;
    figures.breach = screwBoneBreach(path, *bone.surface, options.breach);
    if (bone.frame) {
      figures.angles = screwAngles(path, *bone.frame, options.angles);
      if (figures.angles->points_posteriorly) angle_warnings.push_back("the screw points posteriorly");
      if (figures.angles->side == "midline") {
        angle_warnings.push_back("the entry is on the midline of " + bone.name + ": the medial angle is undefined");
      }
      if (bone.frame->ambiguous) {
        angle_warnings.push_back("the anatomical frame of " + bone.name + " is uncertain (confidence " +
                                 formatFixed(bone.frame->confidence, 2) + ", moment separation " +
                                 formatFixed(bone.frame->moment_separation, 3) + "): check the angles");
      }
    } else {
      angle_warnings.push_back("no anatomical frame for " + bone.name + ": angles not computed");
    }
    const BoneBreach& b = *figures.breach;
    if (b.breached()) {
      std::string text = "breaches the cortex by " + formatFixed(b.max_breach_mm, 1) + " mm (Gertzbein-Robbins " +
                         std::string(1, b.grade_letter) + ") at " + formatFixed(b.depth_of_max_breach_mm, 0) + " mm";
      if (bone.frame) {
        text += ", " + planningDirectionWord(b.max_breach_direction, *bone.frame, figures.angles->side);
      }
      breach_warnings.push_back(text);
    }
    if (b.entry_to_bone_mm > options.warn_entry_outside_mm) {
      entry_warnings.push_back("entry " + formatFixed(b.entry_to_bone_mm, 1) + " mm outside the bone of " + bone.name);
    } else if (b.entry_to_bone_mm < -options.warn_entry_inside_mm) {
      entry_warnings.push_back("entry " + formatFixed(-b.entry_to_bone_mm, 1) + " mm inside the bone of " + bone.name +
                               " (expected on the cortex)");
    }
  }

  // Structures to avoid.
  for (std::size_t k = 0; k < kStructureKindCount; ++k) figures.by_kind[k].kind = static_cast<StructureKind>(k);
  for (const auto& structure : anatomy.avoidance) {
    StructureClearance c;
    c.name = structure.name;
    c.kind = structure.kind;
    c.clearance = screwPathClearance(path, *structure.surface, options.clearance);
    c.min_clearance_mm = c.clearance.min_clearance_mm;
    c.depth_mm = c.clearance.min_depth_mm;
    c.cuts = c.clearance.cuts_surface;
    if (!c.cuts && c.clearance.crossings_mm.empty() && structure.surface->closed() &&
        structure.surface->signedClosestPoint(path.entry).signed_distance < 0.0) {
      c.inside = true;
      c.cuts = true;
      c.min_clearance_mm = -radius;
      c.depth_mm = 0.0;
    }
    figures.clearances.push_back(std::move(c));
  }
  std::vector<std::pair<double, std::string>> cut_warnings;
  std::vector<std::pair<double, std::string>> near_warnings;
  for (std::size_t i = 0; i < figures.clearances.size(); ++i) {
    const StructureClearance& c = figures.clearances[i];
    KindClearance& kind = figures.by_kind[static_cast<std::size_t>(c.kind)];
    ++kind.structures;
    if (!kind.min_clearance_mm || c.min_clearance_mm < *kind.min_clearance_mm) {
      kind.closest = i;
      kind.name = c.name;
      kind.min_clearance_mm = c.min_clearance_mm;
      kind.cuts = c.cuts;
    }
    if (c.inside) {
      cut_warnings.emplace_back(c.min_clearance_mm, "lies inside " + c.name);
    } else if (c.cuts) {
      const double at = c.clearance.crossings_mm.empty() ? c.depth_mm : c.clearance.crossings_mm.front();
      cut_warnings.emplace_back(c.min_clearance_mm, "cuts " + c.name + " at " + formatFixed(at, 0) + " mm");
    } else if (c.min_clearance_mm < options.warn_within_mm[static_cast<std::size_t>(c.kind)]) {
      near_warnings.emplace_back(c.min_clearance_mm, "within " + formatFixed(c.min_clearance_mm, 1) + " mm of " +
                                                         c.name + " at " + formatFixed(c.depth_mm, 0) + " mm");
    }
  }
  std::stable_sort(cut_warnings.begin(), cut_warnings.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  std::stable_sort(near_warnings.begin(), near_warnings.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });

  auto& w = figures.warnings;
  w.insert(w.end(), breach_warnings.begin(), breach_warnings.end());
  for (auto& [value, text] : cut_warnings) w.push_back(std::move(text));
  for (auto& [value, text] : near_warnings) w.push_back(std::move(text));
  w.insert(w.end(), entry_warnings.begin(), entry_warnings.end());
  w.insert(w.end(), angle_warnings.begin(), angle_warnings.end());
  w.insert(w.end(), choice_warnings.begin(), choice_warnings.end());
  return figures;
}

}  // namespace mrsns::registration
