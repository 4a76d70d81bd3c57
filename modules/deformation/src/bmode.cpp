#include "mrsns/deformation/bmode.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <numbers>

#include "mrsns/core/error.h"

namespace mrsns::deformation {

double BModeImage::sample(double x_mm, double y_mm) const {
  const double cx = x_mm / spacing_mm;
  const double cy = y_mm / spacing_mm;
  if (!(cx >= 0.0) || !(cy >= 0.0) || cx > width - 1 || cy > height - 1) return 0.0;
  const int c0 = std::min(static_cast<int>(cx), width - 2);
  const int r0 = std::min(static_cast<int>(cy), height - 2);
  const double fx = cx - c0;
  const double fy = cy - r0;
  return (1 - fx) * (1 - fy) * at(c0, r0) + fx * (1 - fy) * at(c0 + 1, r0) + (1 - fx) * fy * at(c0, r0 + 1) +
         fx * fy * at(c0 + 1, r0 + 1);
}

namespace {

bool insidePolygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  bool inside = false;
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const auto& a = poly[i];
    const auto& b = poly[j];
    if ((a.y() > p.y()) != (b.y() > p.y()) && p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x()) {
      inside = !inside;
    }
  }
  return inside;
}

double distanceToPolygon(const std::vector<Eigen::Vector2d>& poly, const Eigen::Vector2d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0, j = poly.size() - 1; i < poly.size(); j = i++) {
    const Eigen::Vector2d ab = poly[i] - poly[j];
    const double t = std::clamp((p - poly[j]).dot(ab) / std::max(ab.squaredNorm(), 1e-18), 0.0, 1.0);
    best = std::min(best, (poly[j] + t * ab - p).norm());
  }
  return best;
}

}  // namespace

BModeImage renderBMode(const TriangleMesh& truth, const Eigen::Isometry3d& model_T_image,
                       const BModeSimulationOptions& o, std::mt19937_64& rng) {
  if (o.width < 8 || o.height < 8 || !(o.spacing_mm > 0.0)) {
    throw InvalidArgumentError("renderBMode: image must be at least 8 x 8 pixels with a positive spacing");
  }
  BModeImage img;
  img.width = o.width;
  img.height = o.height;
  img.spacing_mm = o.spacing_mm;
  // Echo amplitude map: tissue, then lumens and walls from the true cut.
  std::vector<float> echo(static_cast<std::size_t>(o.width) * o.height, static_cast<float>(o.tissue_echo));
  const Eigen::Isometry3d image_T_model = model_T_image.inverse();
  const auto cuts = intersectMeshWithPlane(truth, model_T_image.translation(), model_T_image.linear().col(2));
  std::vector<std::vector<Eigen::Vector2d>> polys;
  for (const auto& c : cuts) {
    if (!c.closed || c.points.size() < 3) continue;
    std::vector<Eigen::Vector2d> poly;
    for (const auto& p : c.points) poly.push_back((image_T_model * p).head<2>());
    polys.push_back(std::move(poly));
  }
  // Lumen first for every polygon, then walls only where no lumen is (union of tubes).
  std::vector<char> lumen(echo.size(), 0);
  auto forBox = [&](const std::vector<Eigen::Vector2d>& poly, double margin, auto&& fn) {
    Eigen::Vector2d lo = poly[0], hi = poly[0];
    for (const auto& p : poly) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    const int c0 = std::max(0, static_cast<int>(std::floor((lo.x() - margin) / o.spacing_mm)));
    const int c1 = std::min(o.width - 1, static_cast<int>(std::ceil((hi.x() + margin) / o.spacing_mm)));
    const int r0 = std::max(0, static_cast<int>(std::floor((lo.y() - margin) / o.spacing_mm)));
    const int r1 = std::min(o.height - 1, static_cast<int>(std::ceil((hi.y() + margin) / o.spacing_mm)));
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) fn(c, r, Eigen::Vector2d(c * o.spacing_mm, r * o.spacing_mm));
    }
  };
  for (const auto& poly : polys) {
    forBox(poly, 0.0, [&](int c, int r, const Eigen::Vector2d& p) {
      if (insidePolygon(poly, p)) lumen[static_cast<std::size_t>(r) * o.width + c] = 1;
    });
  }
  for (const auto& poly : polys) {
    forBox(poly, o.wall_thickness_mm, [&](int c, int r, const Eigen::Vector2d& p) {
      const auto idx = static_cast<std::size_t>(r) * o.width + c;
      if (!lumen[idx] && distanceToPolygon(poly, p) < o.wall_thickness_mm) echo[idx] = static_cast<float>(o.wall_echo);
    });
  }
  for (std::size_t i = 0; i < echo.size(); ++i) {
    if (lumen[i]) echo[i] = static_cast<float>(o.lumen_echo);
  }
  // Speckle, resolution-cell smoothing and depth attenuation.
  std::vector<float> raw(echo.size());
  std::uniform_real_distribution<double> u(1e-12, 1.0);
  for (std::size_t i = 0; i < echo.size(); ++i) {
    const double speckle = o.speckle ? std::sqrt(-2.0 * std::log(u(rng))) / std::sqrt(std::numbers::pi / 2.0) : 1.0;
    raw[i] = static_cast<float>(echo[i] * speckle);
  }
  img.pixels.assign(echo.size(), 0.0f);
  for (int r = 0; r < o.height; ++r) {
    const double att = std::exp(-o.attenuation_per_mm * r * o.spacing_mm);
    for (int c = 0; c < o.width; ++c) {
      double sum = 0.0;
      int n = 0;
      for (int dr = -1; dr <= 1; ++dr) {
        for (int dc = -1; dc <= 1; ++dc) {
          const int rr = r + dr;
          const int cc = c + dc;
          if (rr < 0 || cc < 0 || rr >= o.height || cc >= o.width) continue;
          sum += raw[static_cast<std::size_t>(rr) * o.width + cc];
          ++n;
        }
      }
      img.pixels[static_cast<std::size_t>(r) * o.width + c] = static_cast<float>(att * sum / n);
    }
  }
  return img;
}

Eigen::Vector2d Ellipse2d::point(double angle) const {
  const Eigen::Vector2d axis2(-axis1.y(), axis1.x());
  return center + a * std::cos(angle) * axis1 + b * std::sin(angle) * axis2;
}

bool fitEllipse(std::span<const Eigen::Vector2d> points, Ellipse2d& e) {
  const auto n = static_cast<Eigen::Index>(points.size());
  if (n < 5) return false;
  // Normalise for conditioning.
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : points) mean += p;
  mean /= static_cast<double>(n);
  double scale = 0.0;
  for (const auto& p : points) scale += (p - mean).norm();
  scale = scale / static_cast<double>(n);
  if (!(scale > 0.0)) return false;
  Eigen::MatrixXd d1(n, 3), d2(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector2d q = (points[static_cast<std::size_t>(i)] - mean) / scale;
    d1.row(i) << q.x() * q.x(), q.x() * q.y(), q.y() * q.y();
    d2.row(i) << q.x(), q.y(), 1.0;
  }
  const Eigen::Matrix3d s1 = d1.transpose() * d1;
  const Eigen::Matrix3d s2 = d1.transpose() * d2;
  const Eigen::Matrix3d s3 = d2.transpose() * d2;
  const Eigen::FullPivLU<Eigen::Matrix3d> lu(s3);
  if (!lu.isInvertible()) return false;
  const Eigen::Matrix3d t = -lu.solve(s2.transpose());
  const Eigen::Matrix3d m = s1 + s2 * t;
  Eigen::Matrix3d mc;
  mc.row(0) = m.row(2) / 2.0;
  mc.row(1) = -m.row(1);
  mc.row(2) = m.row(0) / 2.0;
  const Eigen::EigenSolver<Eigen::Matrix3d> es(mc);
  int best = -1;
  for (int i = 0; i < 3; ++i) {
    const Eigen::Vector3d v = es.eigenvectors().col(i).real();
    if (4.0 * v[0] * v[2] - v[1] * v[1] > 0.0) best = i;
  }
  if (best < 0) return false;
  const Eigen::Vector3d a1 = es.eigenvectors().col(best).real();
  const Eigen::Vector3d a2 = t * a1;
  const double A = a1[0], B = a1[1], C = a1[2], D = a2[0], E = a2[1], F = a2[2];
  Eigen::Matrix2d q;
  q << 2 * A, B, B, 2 * C;
  const Eigen::Vector2d c = q.fullPivLu().solve(Eigen::Vector2d(-D, -E));
  const double f0 = A * c.x() * c.x() + B * c.x() * c.y() + C * c.y() * c.y() + D * c.x() + E * c.y() + F;
  Eigen::Matrix2d qq;
  qq << A, B / 2, B / 2, C;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> se(qq);
  const double l0 = se.eigenvalues()[0], l1 = se.eigenvalues()[1];
  if (!(-f0 / l0 > 0.0) || !(-f0 / l1 > 0.0)) return false;
  const double r0 = std::sqrt(-f0 / l0);  // smaller eigenvalue -> longer axis
  const double r1 = std::sqrt(-f0 / l1);
  e.center = mean + scale * c;
  e.axis1 = se.eigenvectors().col(0).normalized();
  e.a = scale * r0;
  e.b = scale * r1;
  return std::isfinite(e.a) && std::isfinite(e.b) && e.center.allFinite();
}

namespace {

// Radial distance of p from the ellipse along the ray from its centre.
double radialResidual(const Ellipse2d& e, const Eigen::Vector2d& p) {
  const Eigen::Vector2d d = p - e.center;
  const Eigen::Vector2d axis2(-e.axis1.y(), e.axis1.x());
  const double u = d.dot(e.axis1) / e.a;
  const double v = d.dot(axis2) / e.b;
  const double rho = std::sqrt(u * u + v * v);
  return rho > 0.0 ? d.norm() * (1.0 - 1.0 / rho) : -std::min(e.a, e.b);
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

}  // namespace

std::vector<LumenContour> segmentLumens(const BModeImage& image, std::span<const Polyline3d> seeds,
                                        const LumenSegmentationOptions& o) {
  std::vector<LumenContour> out(seeds.size());
  std::vector<Eigen::Vector2d> centres(seeds.size());
  std::vector<double> radii(seeds.size(), 0.0);
  for (std::size_t s = 0; s < seeds.size(); ++s) {
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const auto& p : seeds[s].points) c += p.head<2>();
    if (!seeds[s].points.empty()) c /= static_cast<double>(seeds[s].points.size());
    double r = 0.0;
    for (const auto& p : seeds[s].points) r += (p.head<2>() - c).norm();
    centres[s] = c;
    radii[s] = seeds[s].points.empty() ? 0.0 : r / static_cast<double>(seeds[s].points.size());
  }
  for (std::size_t s = 0; s < seeds.size(); ++s) {
    LumenContour& res = out[s];
    if (seeds[s].points.size() < 3 || !(radii[s] > 0.0)) {
      res.status = "empty seed";
      continue;
    }
    const double r0 = radii[s];
    // Near a bifurcation the model's cut is two (or three) overlapping loops
    // and the image shows their union: the part of this seed's wall that lies
    // inside another seed's disc is not seen. Rays towards it are left out.
    std::vector<char> blocked(static_cast<std::size_t>(o.rays), 0);
    int open_rays = o.rays;
    bool overlaps = false;
    for (std::size_t t = 0; t < seeds.size(); ++t) {
      if (t != s && radii[t] > 0.0 && (centres[t] - centres[s]).norm() < radii[t] + radii[s]) overlaps = true;
    }
    if (overlaps) {
      if (!o.split_overlapping) {
        res.status = "ambiguous: seed overlaps another vessel";
        continue;
      }
      constexpr double kMarginMm = 0.3;  // about the wall's smoothed edge
      for (int k = 0; k < o.rays; ++k) {
        const double a = 2.0 * std::numbers::pi * k / o.rays;
        const Eigen::Vector2d wall = centres[s] + r0 * Eigen::Vector2d(std::cos(a), std::sin(a));
        for (std::size_t t = 0; t < seeds.size(); ++t) {
          if (t != s && radii[t] > 0.0 && (wall - centres[t]).norm() < radii[t] + kMarginMm) {
            blocked[static_cast<std::size_t>(k)] = 1;
          }
        }
        open_rays -= blocked[static_cast<std::size_t>(k)];
      }
      if (open_rays < o.min_ray_fraction * o.rays) {
        res.status = "ambiguous: seed mostly inside another vessel";
        continue;
      }
      res.split = true;
    }
    auto rayBlocked = [&](double angle) {
      if (!overlaps) return false;
      const double turns = angle / (2.0 * std::numbers::pi);
      const auto k = static_cast<std::size_t>(std::lround((turns - std::floor(turns)) * o.rays)) % blocked.size();
      return blocked[k] != 0;
    };
    // The model's contour may be off by a few mm before the first updates:
    // move the seed to the darkest disc within the capture range. Not for
    // overlapping seeds: the darkest disc there is the merged lumen's middle.
    auto discMean = [&](const Eigen::Vector2d& q) {
      double sum = 0.0;
      int n = 0;
      for (int k = 0; k < 16; ++k) {
        const double a = 2.0 * std::numbers::pi * k / 16;
        for (double f : {0.0, 0.3, 0.6}) {
          sum += image.sample(q.x() + f * r0 * std::cos(a), q.y() + f * r0 * std::sin(a));
          ++n;
        }
      }
      return sum / n;
    };
    Eigen::Vector2d c = centres[s];
    double darkest = discMean(c);
    const double step = std::max(0.25, 0.2 * r0);
    const double capture = overlaps ? 0.0 : o.capture_range_mm;
    for (double dx = -capture; dx <= capture; dx += step) {
      for (double dy = -capture; dy <= capture; dy += step) {
        if (dx * dx + dy * dy > capture * capture) continue;
        const Eigen::Vector2d q = centres[s] + Eigen::Vector2d(dx, dy);
        const double v = discMean(q);
        if (v < darkest) {
          darkest = v;
          c = q;
        }
      }
    }
    // Lumen and tissue levels around the seed set the edge threshold.
    std::vector<double> inner, outer;
    for (int k = 0; k < 64; ++k) {
      const double a = 2.0 * std::numbers::pi * k / 64;
      const Eigen::Vector2d dir(std::cos(a), std::sin(a));
      for (double f : {0.1, 0.25, 0.4})
        inner.push_back(image.sample(c.x() + f * r0 * dir.x(), c.y() + f * r0 * dir.y()));
      if (rayBlocked(a)) continue;
      for (double f : {1.8, 2.1, 2.4})
        outer.push_back(image.sample(c.x() + f * r0 * dir.x(), c.y() + f * r0 * dir.y()));
    }
    const double lo = median(inner);
    const double hi = median(outer);
    if (!(hi > 2.0 * lo)) {
      res.status = "no hypoechoic lumen at the seed";
      continue;
    }
    const double threshold = 0.5 * (lo + hi);
    std::vector<Eigen::Vector2d> edge;
    for (int k = 0; k < o.rays; ++k) {
      if (blocked[static_cast<std::size_t>(k)]) continue;
      const double a = 2.0 * std::numbers::pi * k / o.rays;
      const Eigen::Vector2d dir(std::cos(a), std::sin(a));
      double prev = -1.0;
      for (double rr = o.search_min * r0; rr <= o.search_max * r0; rr += o.step_mm) {
        const Eigen::Vector2d p = c + rr * dir;
        const double v = image.sample(p.x(), p.y());
        if (v > threshold && prev > threshold) {
          edge.push_back(c + (rr - 1.5 * o.step_mm) * dir);  // first of the two samples above, mid-step
          break;
        }
        prev = v;
      }
    }
    Ellipse2d e;
    if (!fitEllipse(edge, e)) {
      res.status = "ellipse fit failed (" + std::to_string(edge.size()) + " edge points)";
      continue;
    }
    std::vector<double> abs_res;
    for (const auto& p : edge) abs_res.push_back(std::abs(radialResidual(e, p)));
    const double mad = median(abs_res);
    std::vector<Eigen::Vector2d> kept;
    for (std::size_t i = 0; i < edge.size(); ++i) {
      if (abs_res[i] <= std::max(0.4, o.outlier_mads * 1.4826 * mad)) kept.push_back(edge[i]);
    }
    if (kept.size() < edge.size() && !fitEllipse(kept, e)) {
      res.status = "ellipse refit failed";
      continue;
    }
    if ((e.center - c).norm() > o.max_center_shift * r0 || e.a > 2.0 * o.search_max * r0 || e.b < 0.2 * r0) {
      res.status = "implausible ellipse (moved or sized far from the seed)";
      continue;
    }
    double sq = 0.0;
    for (const auto& p : kept) sq += std::pow(radialResidual(e, p), 2);
    res.fit_rms_mm = std::sqrt(sq / static_cast<double>(kept.size()));
    res.inliers = static_cast<int>(kept.size());
    res.center = e.center;
    res.semi_major_mm = e.a;
    res.semi_minor_mm = e.b;
    res.contour.closed = true;
    for (int k = 0; k < o.contour_points; ++k) {
      const Eigen::Vector2d p = e.point(2.0 * std::numbers::pi * k / o.contour_points);
      res.contour.points.emplace_back(p.x(), p.y(), 0.0);
    }
    res.ok = true;
    res.status = "ok";
  }
  return out;
}

}  // namespace mrsns::deformation
