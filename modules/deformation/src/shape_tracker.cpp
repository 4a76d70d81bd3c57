#include "mrsns/deformation/shape_tracker.h"

#include <algorithm>
#include <chrono>
#include <limits>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/deformation/shape_model_ops.h"

namespace mrsns::deformation {

PosteriorShapeTracker::PosteriorShapeTracker(ShapeModel model, const ShapeTrackerOptions& options)
    : model_(std::move(model)), options_(options), equations_(std::max<Eigen::Index>(model_.modeCount(), 1)) {
  validateShapeModel(model_, "PosteriorShapeTracker model");
  if (options_.contour_points < 3) throw InvalidArgumentError("PosteriorShapeTracker: contour_points must be >= 3");
  if (options_.max_observation_age_frames < 0) {
    throw InvalidArgumentError("PosteriorShapeTracker: max_observation_age_frames must be >= 0 (0: keep every observation)");
  }
  if (!(options_.update_threshold_mm >= 0.0)) {
    throw InvalidArgumentError("PosteriorShapeTracker: update_threshold_mm must be >= 0");
  }
  q_rows_ = model_.basis * model_.variances.cwiseSqrt().asDiagonal();
  vertex_gram_.resize(model_.pointCount(), 6);
  for (Eigen::Index v = 0; v < model_.pointCount(); ++v) {
    const auto q = q_rows_.middleRows(3 * v, 3);
    const Eigen::Matrix3d m = q * q.transpose();
    vertex_gram_.row(v) << m(0, 0), m(1, 1), m(2, 2), 2.0 * m(0, 1), 2.0 * m(0, 2), 2.0 * m(1, 2);
  }
  zero_coefficients_ = Eigen::VectorXd::Zero(model_.modeCount());
  reset();
}

void PosteriorShapeTracker::reset() {
  observations_.clear();
  observation_frames_.clear();
  equations_.clear();
  posterior_ = equations_.solve(options_.posterior);
  shape_valid_ = false;
}

const Eigen::VectorXd& PosteriorShapeTracker::currentShape() const {
  if (!shape_valid_) {
    shape_ = model_.mean;
    shape_.noalias() += q_rows_ * posterior_.coefficients;
    shape_valid_ = true;
  }
  return shape_;
}

Eigen::MatrixXd PosteriorShapeTracker::coefficientCovariance() const {
  if (posterior_.coefficient_covariance.rows() != model_.modeCount()) {
    return Eigen::MatrixXd::Identity(model_.modeCount(), model_.modeCount());
  }
  return posterior_.coefficient_covariance;
}

const PosteriorResult& PosteriorShapeTracker::posterior() const {
  if (posterior_.mean.size() != model_.mean.size()) posterior_.mean = currentShape();
  return posterior_;
}

TriangleMesh PosteriorShapeTracker::currentMesh() const {
  return shapeMesh(model_, currentShape());
}

const Eigen::VectorXd& PosteriorShapeTracker::cutCoefficients() const {
  return options_.cut_posterior ? posterior_.coefficients : zero_coefficients_;
}

std::vector<ModelContour> PosteriorShapeTracker::cutShape(const Eigen::VectorXd& alpha,
                                                          const Eigen::Vector3d& plane_point,
                                                          const Eigen::Vector3d& plane_normal) const {
  if (!plane_point.allFinite() || !plane_normal.allFinite() || !(plane_normal.squaredNorm() > 0.0)) {
    throw InvalidArgumentError("the image plane's point and normal must be finite and the normal non-zero");
  }
  const Eigen::Vector3d n = plane_normal.normalized();
  const Eigen::Index count = model_.pointCount();
  const double reach = alpha.norm();
  // Which side each vertex is on, from the prior mean and |Q_v alpha| <= |Q_v|_F |alpha|;
  // the few vertices the bound leaves open are evaluated exactly.
  std::vector<char> positive(static_cast<std::size_t>(count));
  std::vector<Eigen::Vector3d> position;
  std::vector<double> distance;
  std::vector<std::int32_t> slot(static_cast<std::size_t>(count), -1);
  auto evaluate = [&](Eigen::Index v) {
    // Three dot products of (row-major, contiguous) rows: a 3 x k product
    // through Eigen's general matrix-vector kernel cost more in dispatch than
    // in arithmetic (a third of a frame's time, by callgrind).
    Eigen::Vector3d x = model_.mean.segment<3>(3 * v);
    for (int c = 0; c < 3; ++c) x[c] += q_rows_.row(3 * v + c).dot(alpha);
    slot[static_cast<std::size_t>(v)] = static_cast<std::int32_t>(position.size());
    position.push_back(x);
    distance.push_back((x - plane_point).dot(n));
    return distance.back();
  };
  // The prior mean's distances in one matrix-vector product over the
  // (N x 3, row-major) mean: a scalar loop of 3-vectors was a third of a frame.
  const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>> mean_points(model_.mean.data(),
                                                                                                 count, 3);
  Eigen::VectorXd d_mean = mean_points * n;
  d_mean.array() -= plane_point.dot(n);
  // How far each vertex can move along n: |n.Q_v alpha| <= sqrt(n^T Q_v Q_v^T n) |alpha|. Along the normal only,
  // so a vessel cut across, whose vertices vary mostly within the plane, leaves a narrow band to evaluate (the
  // Frobenius bound |Q_v| |alpha| left three times as many).
  Eigen::Matrix<double, 6, 1> nn;
  nn << n.x() * n.x(), n.y() * n.y(), n.z() * n.z(), n.x() * n.y(), n.x() * n.z(), n.y() * n.z();
  // Compared squared, with a margin of round-off on top of the bound: a vertex within it is evaluated.
  const double scale = reach * (1.0 + 1e-9);
  const Eigen::ArrayXd slack = d_mean.array().square() - (vertex_gram_ * nn).array() * (scale * scale);
  for (Eigen::Index v = 0; v < count; ++v) {
    const double d = slack(v) > 1e-18 ? d_mean(v) : evaluate(v);
    positive[static_cast<std::size_t>(v)] = d >= 0.0 ? 1 : 0;
  }
  const auto cut = cutFacesWithPlane(
      model_.reference.faces, positive, [&](std::int32_t v, Eigen::Vector3d& x, double& d) {
        if (slot[static_cast<std::size_t>(v)] < 0) evaluate(v);
        const auto s = static_cast<std::size_t>(slot[static_cast<std::size_t>(v)]);
        x = position[s];
        d = distance[s];
      });
  std::vector<ModelContour> out;
  for (const auto& c : cut) {
    if (c.polyline.points.size() < 3) continue;
    ModelContour mc;
    mc.contour = c.polyline;
    for (const auto& e : c.edges) {
      mc.edge_vertices.emplace_back(e.a, e.b);
      mc.edge_t.push_back(e.t);
    }
    out.push_back(std::move(mc));
  }
  return out;
}

std::vector<Polyline3d> PosteriorShapeTracker::predictedContours(const Eigen::Isometry3d& model_T_image) const {
  const Eigen::Isometry3d image_T_model = model_T_image.inverse();
  std::vector<Polyline3d> out;
  for (const auto& c : cutShape(cutCoefficients(), model_T_image.translation(), model_T_image.linear().col(2))) {
    Polyline3d p;
    p.closed = c.contour.closed;
    for (const auto& q : c.contour.points) p.points.push_back(image_T_model * q);
    out.push_back(std::move(p));
  }
  return out;
}

std::vector<Eigen::Vector3d> alignCyclic(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b) {
  const std::size_t k = a.size();
  double best = std::numeric_limits<double>::infinity();
  std::vector<Eigen::Vector3d> out = b;
  for (int dir = 0; dir < 2; ++dir) {
    for (std::size_t shift = 0; shift < k; ++shift) {
      double sum = 0.0;
      for (std::size_t i = 0; i < k; ++i) {
        const std::size_t j = dir == 0 ? (i + shift) % k : (shift + k - i) % k;
        sum += (a[i] - b[j]).squaredNorm();
      }
      if (sum < best) {
        best = sum;
        for (std::size_t i = 0; i < k; ++i) out[i] = b[dir == 0 ? (i + shift) % k : (shift + k - i) % k];
      }
    }
  }
  return out;
}

namespace {

// The closest point of the closed polyline `c` to each of `points`.
std::vector<Eigen::Vector3d> closestOnPolyline(const std::vector<Eigen::Vector3d>& points, const Polyline3d& c) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(points.size());
  const std::size_t n = c.points.size();
  for (const auto& p : points) {
    double best = std::numeric_limits<double>::infinity();
    Eigen::Vector3d best_q = c.points.front();
    for (std::size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d& a = c.points[i];
      const Eigen::Vector3d& b = c.points[(i + 1) % n];
      const Eigen::Vector3d ab = b - a;
      const double len2 = ab.squaredNorm();
      const double t = len2 > 0.0 ? std::clamp((p - a).dot(ab) / len2, 0.0, 1.0) : 0.0;
      const Eigen::Vector3d q = a + t * ab;
      const double d = (q - p).squaredNorm();
      if (d < best) {
        best = d;
        best_q = q;
      }
    }
    out.push_back(best_q);
  }
  return out;
}

}  // namespace

double PosteriorShapeTracker::contourMahalanobisRms(const ModelContour& mc, const std::vector<ContourParameter>& params,
                                                    const std::vector<Eigen::Vector3d>& feature_points) const {
  const double s2 = options_.posterior.noise_sigma_mm * options_.posterior.noise_sigma_mm;
  const bool prior = posterior_.coefficient_covariance.rows() != model_.modeCount();
  double sum = 0.0;
  for (std::size_t i = 0; i < params.size(); ++i) {
    const ModelPointObservation o = mc.modelPoint(params[i]);
    const Eigen::Matrix<double, 3, Eigen::Dynamic> q = observationRows(model_, o);
    Eigen::Matrix3d cov = (prior ? Eigen::Matrix3d(q * q.transpose())
                                 : Eigen::Matrix3d(q * posterior_.coefficient_covariance * q.transpose())) +
                          s2 * Eigen::Matrix3d::Identity();
    const Eigen::Vector3d d = feature_points[i] - o.point;
    sum += d.dot(cov.ldlt().solve(d));
  }
  return params.empty() ? 0.0 : std::sqrt(sum / static_cast<double>(params.size()));
}

FrameUpdate PosteriorShapeTracker::update(const Eigen::Isometry3d& model_T_image,
                                          std::span<const Polyline3d> feature_contours) {
  const auto t0 = std::chrono::steady_clock::now();
  FrameUpdate r;
  r.observations = static_cast<int>(observations_.size());
  if (!model_T_image.matrix().allFinite()) {
    r.status = "pose not finite";
    return r;
  }
  if (feature_contours.empty()) {
    r.status = "no feature contour";
    return r;
  }
  std::vector<ModelContour> model_contours;
  try {
    model_contours = cutShape(cutCoefficients(), model_T_image.translation(), model_T_image.linear().col(2));
  } catch (const Error& e) {
    r.status = std::string("plane cut failed: ") + e.what();
    return r;
  }
  r.model_contours = static_cast<int>(model_contours.size());
  if (model_contours.empty()) {
    r.status = "the model does not intersect the image plane";
    return r;
  }
  const int k = options_.contour_points;
  ++frames_;
  if (options_.max_observation_age_frames > 0) {
    const auto limit = static_cast<std::uint64_t>(options_.max_observation_age_frames);
    std::size_t kept = 0;
    for (std::size_t j = 0; j < observations_.size(); ++j) {
      if (frames_ - observation_frames_[j] > limit) continue;
      observations_[kept] = observations_[j];
      observation_frames_[kept] = observation_frames_[j];
      ++kept;
    }
    if (kept != observations_.size()) {
      r.forgotten = static_cast<int>(observations_.size() - kept);
      observations_.resize(kept);
      observation_frames_.resize(kept);
      equations_.clear();
      for (const auto& o : observations_) equations_.add(model_, o);
    }
  }
  // Kept to undo the frame (reject_implausible_frames).
  const std::size_t count_before = observations_.size();
  std::vector<std::pair<std::size_t, ModelPointObservation>> replaced_before;
  std::vector<std::uint64_t> frames_before = observation_frames_;
  std::vector<char> model_used(model_contours.size(), 0);
  for (const Polyline3d& fc_image : feature_contours) {
    if (fc_image.points.size() < 3) continue;
    Polyline3d fc;
    fc.closed = true;
    for (const auto& p : fc_image.points) fc.points.push_back(model_T_image * p);
    const Eigen::Vector3d fcen = polylineCentroid(fc);
    int best = -1;
    double best_d = options_.max_centroid_distance_mm;
    for (std::size_t m = 0; m < model_contours.size(); ++m) {
      if (model_used[m] || !model_contours[m].contour.closed) continue;
      const double dist = (polylineCentroid(model_contours[m].contour) - fcen).norm();
      if (dist < best_d) {
        best_d = dist;
        best = static_cast<int>(m);
      }
    }
    if (best < 0) continue;
    model_used[static_cast<std::size_t>(best)] = 1;
    ++r.matched_contours;
    const ModelContour& mc = model_contours[static_cast<std::size_t>(best)];
    // Step (c)3: both contours to K points by Eq. 8.
    const auto mparams = nearArcLengthParameters(mc.contour, k);
    const Polyline3d fres = resampleNearArcLength(fc, k);
    std::vector<Eigen::Vector3d> mpts;
    for (const auto& p : mparams) mpts.push_back(mc.modelPoint(p).point);
    const std::vector<Eigen::Vector3d> fpts = options_.correspondence == ContourCorrespondence::ArcLength
                                                  ? alignCyclic(mpts, fres.points)
                                                  : closestOnPolyline(mpts, fc);
    if (options_.contour_gate_mahalanobis > 0.0 &&
        contourMahalanobisRms(mc, mparams, fpts) > options_.contour_gate_mahalanobis) {
      model_used[static_cast<std::size_t>(best)] = 0;
      --r.matched_contours;
      ++r.gated_contours;
      continue;
    }
    // Step (d): replace the nearest stored observation within D^Thr, else add.
    for (int i = 0; i < k; ++i) {
      ModelPointObservation o = mc.modelPoint(mparams[static_cast<std::size_t>(i)]);
      o.point = fpts[static_cast<std::size_t>(i)];
      int nearest = -1;
      double nearest_d = options_.update_threshold_mm;
      for (std::size_t j = 0; j < observations_.size(); ++j) {
        const double dist = (observations_[j].point - o.point).norm();
        if (dist < nearest_d) {
          nearest_d = dist;
          nearest = static_cast<int>(j);
        }
      }
      if (nearest >= 0) {
        const auto j = static_cast<std::size_t>(nearest);
        if (j < count_before) replaced_before.emplace_back(j, observations_[j]);
        observations_[j] = o;
        observation_frames_[j] = frames_;
        equations_.replace(j, model_, o);
        ++r.replaced;
      } else {
        observations_.push_back(o);
        observation_frames_.push_back(frames_);
        equations_.add(model_, o);
        ++r.added;
      }
    }
  }
  r.observations = static_cast<int>(observations_.size());
  if (r.matched_contours == 0) {
    r.status = "no feature contour near the model's contours";
    r.elapsed_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return r;
  }
  // Step (e): the posterior (its coefficients; the shape is evaluated where needed).
  PosteriorResult candidate;
  try {
    candidate = equations_.solve(options_.posterior);
  } catch (const Error& e) {
    r.status = std::string("posterior failed: ") + e.what();
    return r;
  }
  if (options_.reject_implausible_frames && !candidate.plausible) {
    // Undo in reverse order, so an observation replaced twice gets its first value back.
    for (auto it = replaced_before.rbegin(); it != replaced_before.rend(); ++it) observations_[it->first] = it->second;
    observations_.resize(count_before);
    observation_frames_ = std::move(frames_before);
    equations_.clear();
    for (const auto& o : observations_) equations_.add(model_, o);
    r.observations = static_cast<int>(observations_.size());
    r.status = "frame undone: it made the posterior implausible";
    r.elapsed_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    return r;
  }
  posterior_ = std::move(candidate);
  shape_valid_ = false;
  r.updated = true;
  r.status = "ok";
  r.excluded = static_cast<int>(posterior_.excluded.size());
  r.mahalanobis = posterior_.mahalanobis;
  r.plausible = posterior_.plausible;
  r.elapsed_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace mrsns::deformation
