// ImageToProbe from N-wire frames. A linear least-squares fit of the full
// 3x3 image-plane map (PLUS's formulation) starts a Levenberg-Marquardt fit
// of the physical model (rotation, translation, x/y pixel spacing), which
// minimises either the middle-wire point residuals or the distance of every
// dot from its wire; frames whose error stands out are dropped and the fit
// repeated.
#include "mrsns/ultrasound/spatial_calibration.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <tuple>
#include <utility>

#include "mrsns/core/error.h"
#include "mrsns/core/log.h"
#include "mrsns/core/rigid.h"

namespace mrsns::ultrasound {
namespace {

using Params = Eigen::Matrix<double, 8, 1>;  // rotation increment (3), translation (3), spacing x, y

struct Prepared {
  const CalibrationFrame* frame = nullptr;
  Eigen::Isometry3d probe_T_phantom = Eigen::Isometry3d::Identity();
  std::vector<Eigen::Vector3d> middle_probe;  // middle-wire point per pattern, probe frame
};

std::vector<Prepared> prepare(const std::vector<CalibrationFrame>& frames, const std::vector<NWirePattern>& patterns,
                              const Eigen::Isometry3d& reference_T_phantom) {
  std::vector<Prepared> out;
  out.reserve(frames.size());
  for (const auto& f : frames) {
    if (f.wire_points_px.size() != 3 * patterns.size()) {
      throw InvalidArgumentError("calibration frame " + std::to_string(f.frame_index) + " has " +
                                 std::to_string(f.wire_points_px.size()) + " wire points, the phantom has " +
                                 std::to_string(3 * patterns.size()) + " wires");
    }
    Prepared p;
    p.frame = &f;
    p.probe_T_phantom = f.reference_T_probe.inverse() * reference_T_phantom;
    for (std::size_t k = 0; k < patterns.size(); ++k) {
      const auto& w = f.wire_points_px;
      p.middle_probe.push_back(p.probe_T_phantom * middleWirePoint(patterns[k], w[3 * k], w[3 * k + 1], w[3 * k + 2]));
    }
    out.push_back(std::move(p));
  }
  return out;
}

Eigen::Vector3d mapPixel(const Eigen::Matrix4d& probe_T_image, const Eigen::Vector2d& px) {
  return probe_T_image.block<3, 2>(0, 0) * px + probe_T_image.block<3, 1>(0, 3);
}

// PLUS's linear solution: probe point = A * (u, v, 1) for all middle-wire points.
Eigen::Matrix3d linearFit(const std::vector<Prepared>& data) {
  Eigen::Matrix3d xtx = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d xtp = Eigen::Matrix3d::Zero();
  for (const auto& d : data) {
    for (std::size_t k = 0; k < d.middle_probe.size(); ++k) {
      const Eigen::Vector3d x(d.frame->wire_points_px[3 * k + 1].x(), d.frame->wire_points_px[3 * k + 1].y(), 1.0);
      xtx += x * x.transpose();
      xtp += x * d.middle_probe[k].transpose();
    }
  }
  const Eigen::Matrix3d at = xtx.ldlt().solve(xtp);  // rows: coefficients of u, v, 1
  return at.transpose();
}

// Residuals of one frame under `probe_T_image`.
void frameResiduals(const Eigen::Matrix4d& probe_T_image, const Prepared& d, const std::vector<NWirePattern>& patterns,
                    CalibrationObjective objective, Eigen::VectorXd& out, Eigen::Index& row) {
  const auto& w = d.frame->wire_points_px;
  if (objective != CalibrationObjective::DistanceToWires) {
    for (std::size_t k = 0; k < patterns.size(); ++k) {
      out.segment<3>(row) = mapPixel(probe_T_image, w[3 * k + 1]) - d.middle_probe[k];
      row += 3;
    }
    if (objective == CalibrationObjective::MiddleWirePoints) return;
  }
  const Eigen::Isometry3d phantom_T_probe = d.probe_T_phantom.inverse();
  for (std::size_t k = 0; k < patterns.size(); ++k) {
    for (int j = 0; j < 3; ++j) {
      const Eigen::Vector3d q = phantom_T_probe * mapPixel(probe_T_image, w[3 * k + j]);
      const Eigen::Vector3d r = q - patterns[k].front[j];
      out.segment<3>(row) = r - patterns[k].direction[j] * patterns[k].direction[j].dot(r);
      row += 3;
    }
  }
}

Eigen::Index residualsPerFrame(std::size_t pattern_count, CalibrationObjective objective) {
  const std::size_t per_pattern = objective == CalibrationObjective::MiddleWirePoints  ? 3
                                  : objective == CalibrationObjective::DistanceToWires ? 9
                                                                                       : 12;
  return static_cast<Eigen::Index>(pattern_count * per_pattern);
}

Eigen::Matrix4d modelMatrix(const Eigen::Matrix3d& r0, const Params& p) {
  return imageToProbeMatrix(so3Exp(p.head<3>()) * r0, p.segment<3>(3), p.tail<2>());
}

// Levenberg-Marquardt on the 8 physical parameters, rotation as a left
// increment on r0.
Params refine(const std::vector<Prepared>& data, const std::vector<NWirePattern>& patterns,
              CalibrationObjective objective, const Eigen::Matrix3d& r0, Params p, int& iterations) {
  const Eigen::Index per_frame = residualsPerFrame(patterns.size(), objective);
  const Eigen::Index m = per_frame * static_cast<Eigen::Index>(data.size());
  const auto evaluate = [&](const Params& q) {
    Eigen::VectorXd r(m);
    Eigen::Index row = 0;
    const Eigen::Matrix4d t = modelMatrix(r0, q);
    for (const auto& d : data) frameResiduals(t, d, patterns, objective, r, row);
    return r;
  };
  Eigen::VectorXd r = evaluate(p);
  double cost = r.squaredNorm();
  double lambda = 1e-3;
  Eigen::MatrixXd jac(m, 8);
  for (iterations = 0; iterations < 50; ++iterations) {
    for (int i = 0; i < 8; ++i) {
      const double h = i < 3 ? 1e-6 : (i < 6 ? 1e-4 : 1e-7);
      Params q = p;
      q[i] += h;
      jac.col(i) = (evaluate(q) - r) / h;
    }
    const Eigen::Matrix<double, 8, 8> jtj = jac.transpose() * jac;
    const Params g = jac.transpose() * r;
    bool improved = false;
    for (int attempt = 0; attempt < 10 && !improved; ++attempt) {
      Eigen::Matrix<double, 8, 8> a = jtj;
      a.diagonal() += lambda * jtj.diagonal();
      const Params step = a.ldlt().solve(-g);
      const Params q = p + step;
      const Eigen::VectorXd rq = evaluate(q);
      const double cq = rq.squaredNorm();
      if (cq < cost) {
        const double gain = cost - cq;
        p = q;
        r = rq;
        cost = cq;
        lambda = std::max(lambda / 10.0, 1e-9);
        improved = true;
        if (gain < 1e-12 * std::max(cost, 1e-12)) return p;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;
  }
  return p;
}

// Per-frame error used for outlier rejection (mean residual norm).
double frameError(const Eigen::Matrix4d& t, const Prepared& d, const std::vector<NWirePattern>& patterns,
                  CalibrationObjective objective) {
  Eigen::VectorXd r(residualsPerFrame(patterns.size(), objective));
  Eigen::Index row = 0;
  frameResiduals(t, d, patterns, objective, r, row);
  double sum = 0.0;
  for (Eigen::Index i = 0; i < r.size(); i += 3) sum += r.segment<3>(i).norm();
  return sum / static_cast<double>(r.size() / 3);
}

void checkMotion(const std::vector<Prepared>& data, const SpatialCalibrationOptions& options) {
  Eigen::Vector3d mean_pos = Eigen::Vector3d::Zero();
  for (const auto& d : data) mean_pos += d.probe_T_phantom.inverse().translation();
  mean_pos /= static_cast<double>(data.size());
  double motion = 0.0;
  for (const auto& d : data) motion += (d.probe_T_phantom.inverse().translation() - mean_pos).squaredNorm();
  motion = std::sqrt(motion / static_cast<double>(data.size()));
  // Spread of the middle-wire points in the probe frame (they lie in the image plane).
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::size_t n = 0;
  for (const auto& d : data) {
    for (const auto& p : d.middle_probe) {
      mean += p;
      ++n;
    }
  }
  mean /= static_cast<double>(n);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& d : data) {
    for (const auto& p : d.middle_probe) cov += (p - mean) * (p - mean).transpose();
  }
  cov /= static_cast<double>(n);
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov).eigenvalues();  // ascending
  const double spread = std::sqrt(std::max(ev[1], 0.0));
  if (motion < options.min_probe_motion_mm || spread < options.min_point_spread_mm) {
    throw ComputationError("too little probe motion for a spatial calibration: the probe positions spread " +
                           std::to_string(motion) + " mm RMS (need " + std::to_string(options.min_probe_motion_mm) +
                           ") and the wire points " + std::to_string(spread) + " mm across the image (need " +
                           std::to_string(options.min_point_spread_mm) +
                           "); record the phantom while sweeping and tilting the probe");
  }
}

}  // namespace

Eigen::Matrix4d imageToProbeMatrix(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation_mm,
                                   const Eigen::Vector2d& pixel_spacing_mm) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.block<3, 1>(0, 0) = rotation.col(0) * pixel_spacing_mm.x();
  m.block<3, 1>(0, 1) = rotation.col(1) * pixel_spacing_mm.y();
  m.block<3, 1>(0, 2) = rotation.col(2) * 0.5 * (pixel_spacing_mm.x() + pixel_spacing_mm.y());
  m.block<3, 1>(0, 3) = translation_mm;
  return m;
}

SpatialCalibrationResult calibrateSpatial(const std::vector<CalibrationFrame>& frames,
                                          const std::vector<NWirePattern>& patterns,
                                          const Eigen::Isometry3d& reference_T_phantom,
                                          const SpatialCalibrationOptions& options) {
  if (patterns.empty()) throw InvalidArgumentError("calibrateSpatial: the phantom has no N-wire pattern");
  if (frames.size() < std::max<std::size_t>(options.min_frames, 3)) {
    throw ComputationError("too few segmented frames for a spatial calibration: " + std::to_string(frames.size()) +
                           ", at least " + std::to_string(std::max<std::size_t>(options.min_frames, 3)) +
                           " needed; record more frames with the wires visible");
  }
  auto data = prepare(frames, patterns, reference_T_phantom);
  checkMotion(data, options);

  SpatialCalibrationResult result;
  std::vector<Prepared> active = data;
  Params p = Params::Zero();
  Eigen::Matrix3d r0 = Eigen::Matrix3d::Identity();
  for (int round = 0; round <= options.max_outlier_iterations; ++round) {
    if (round == 0) {
      const Eigen::Matrix3d a = linearFit(active);
      const Eigen::Vector3d cx = a.col(0), cy = a.col(1);
      Eigen::Matrix3d basis;
      basis << cx.normalized(), cy.normalized(), cx.cross(cy).normalized();
      r0 = nearestRotation(basis);
      p.setZero();
      p.segment<3>(3) = a.col(2);
      p[6] = cx.norm();
      p[7] = cy.norm();
    }
    int iterations = 0;
    p = refine(active, patterns, options.objective, r0, p, iterations);
    result.iterations += iterations;
    const Eigen::Matrix4d t = modelMatrix(r0, p);
    std::vector<double> errors;
    for (const auto& d : active) errors.push_back(frameError(t, d, patterns, options.objective));
    const double mean = std::accumulate(errors.begin(), errors.end(), 0.0) / static_cast<double>(errors.size());
    double var = 0.0;
    for (const double e : errors) var += (e - mean) * (e - mean);
    const double limit = mean + options.outlier_factor * std::sqrt(var / static_cast<double>(errors.size()));
    std::vector<Prepared> kept;
    for (std::size_t i = 0; i < active.size(); ++i) {
      if (errors[i] <= limit) {
        kept.push_back(active[i]);
      } else {
        result.rejected_frames.push_back(active[i].frame->frame_index);
      }
    }
    if (kept.size() == active.size() || round == options.max_outlier_iterations) break;
    if (kept.size() < std::max<std::size_t>(options.min_frames, 3)) {
      throw ComputationError("spatial calibration: only " + std::to_string(kept.size()) +
                             " frames are consistent with each other; check the phantom registration and segmentation");
    }
    active = std::move(kept);
  }
  std::sort(result.rejected_frames.begin(), result.rejected_frames.end());
  result.rotation = so3Exp(p.head<3>()) * r0;
  result.translation_mm = p.segment<3>(3);
  result.pixel_spacing_mm = p.tail<2>();
  result.probe_T_image = imageToProbeMatrix(result.rotation, result.translation_mm, result.pixel_spacing_mm);
  result.frames_used = active.size();
  std::vector<CalibrationFrame> used;
  for (const auto& d : active) used.push_back(*d.frame);
  result.calibration = evaluateSpatialCalibration(result.probe_T_image, used, patterns, reference_T_phantom);
  logger()->info("spatial calibration: {} frames used, {} rejected, 3D reprojection {:.3f} +/- {:.3f} mm",
                 result.frames_used, result.rejected_frames.size(), result.calibration.reprojection_3d_mean_mm,
                 result.calibration.reprojection_3d_std_mm);
  return result;
}

CalibrationErrorReport evaluateSpatialCalibration(const Eigen::Matrix4d& probe_T_image,
                                                  const std::vector<CalibrationFrame>& frames,
                                                  const std::vector<NWirePattern>& patterns,
                                                  const Eigen::Isometry3d& reference_T_phantom,
                                                  const std::vector<std::string>& wire_names) {
  CalibrationErrorReport report;
  report.frames = frames.size();
  const auto data = prepare(frames, patterns, reference_T_phantom);
  const std::size_t wire_count = 3 * patterns.size();
  std::vector<std::vector<Eigen::Vector2d>> wire_errors(wire_count);
  std::vector<double> wire_distance_sum(wire_count, 0.0);
  std::vector<double> all;
  double distance_sq = 0.0;
  std::size_t distance_n = 0;
  const Eigen::Matrix4d image_T_probe = probe_T_image.inverse();
  const double spacing_x = probe_T_image.block<3, 1>(0, 0).norm();
  const double spacing_y = probe_T_image.block<3, 1>(0, 1).norm();
  for (const auto& d : data) {
    double frame_sum = 0.0;
    for (std::size_t k = 0; k < patterns.size(); ++k) {
      const double e = (mapPixel(probe_T_image, d.frame->wire_points_px[3 * k + 1]) - d.middle_probe[k]).norm();
      all.push_back(e);
      frame_sum += e;
    }
    report.reprojection_3d_per_frame_mm.push_back(frame_sum / static_cast<double>(patterns.size()));
    const Eigen::Matrix4d image_T_phantom = image_T_probe * d.probe_T_phantom.matrix();
    const Eigen::Isometry3d phantom_T_probe = d.probe_T_phantom.inverse();
    for (std::size_t k = 0; k < patterns.size(); ++k) {
      for (int j = 0; j < 3; ++j) {
        const std::size_t w = 3 * k + static_cast<std::size_t>(j);
        const Eigen::Vector2d px = d.frame->wire_points_px[w];
        // Where the wire crosses the image plane (z = 0 in image coordinates).
        const Eigen::Vector3d a = (image_T_phantom * patterns[k].front[j].homogeneous()).head<3>();
        const Eigen::Vector3d b =
            (image_T_phantom * (patterns[k].front[j] + patterns[k].direction[j]).homogeneous()).head<3>();
        if (std::abs(b.z() - a.z()) > 1e-12) {
          const double s = -a.z() / (b.z() - a.z());
          const Eigen::Vector3d hit = a + s * (b - a);
          wire_errors[w].push_back(px - hit.head<2>());
          wire_distance_sum[w] +=
              Eigen::Vector2d((px.x() - hit.x()) * spacing_x, (px.y() - hit.y()) * spacing_y).norm();
        }
        const double dist = distanceToWire(patterns[k], j, phantom_T_probe * mapPixel(probe_T_image, px));
        distance_sq += dist * dist;
        ++distance_n;
      }
    }
  }
  if (!all.empty()) {
    const auto stats = [](const std::vector<double>& v) {
      const double mean = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
      double var = 0.0;
      for (const double e : v) var += (e - mean) * (e - mean);
      return std::pair{mean, std::sqrt(var / static_cast<double>(v.size()))};
    };
    std::tie(report.reprojection_3d_all_mean_mm, report.reprojection_3d_all_std_mm) = stats(all);
    std::vector<double> kept = all;
    for (;;) {
      const auto [mean, sd] = stats(kept);
      std::vector<double> next;
      for (const double e : kept) {
        if (e <= mean + 2.0 * sd) next.push_back(e);
      }
      if (next.size() == kept.size() || next.empty()) {
        report.reprojection_3d_mean_mm = mean;
        report.reprojection_3d_std_mm = sd;
        break;
      }
      kept = std::move(next);
    }
    report.reprojection_3d_count = kept.size();
  }
  report.wire_distance_rms_mm = distance_n ? std::sqrt(distance_sq / static_cast<double>(distance_n)) : 0.0;
  for (std::size_t w = 0; w < wire_count; ++w) {
    WireReprojection wr;
    wr.wire_name = w < wire_names.size() ? wire_names[w] : "wire " + std::to_string(w + 1);
    wr.count = wire_errors[w].size();
    if (wr.count > 0) {
      for (const auto& e : wire_errors[w]) wr.mean_px += e;
      wr.mean_px /= static_cast<double>(wr.count);
      for (const auto& e : wire_errors[w]) wr.std_px += (e - wr.mean_px).cwiseAbs2();
      wr.std_px = (wr.std_px / static_cast<double>(wr.count)).cwiseSqrt();
      wr.mean_distance_mm = wire_distance_sum[w] / static_cast<double>(wr.count);
    }
    report.wires.push_back(wr);
  }
  return report;
}

}  // namespace mrsns::ultrasound
