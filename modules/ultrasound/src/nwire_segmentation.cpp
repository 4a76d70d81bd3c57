// N-wire dot segmentation and pattern search. The filtering follows PLUS's
// FidSegmentation (bar openings in four directions subtracted, then a disc
// opening, then a threshold relative to the filtered range); the line and
// pattern search is our own: every collinear dot triple is a line candidate,
// and the best set of one line per pattern is chosen by the phantom's
// geometry (parallel lines, pattern-plane spacing) and total dot intensity.
#include "mrsns/ultrasound/nwire_segmentation.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "mrsns/core/error.h"
#include "mrsns/ultrasound/nwire_geometry.h"

namespace mrsns::ultrasound {
namespace {

// A bar reaching `half` pixels either side of its centre, as PLUS's
// FidSegmentation erodes and dilates (MorphologicalOpeningBarSizeMm is the
// half length): 2 * half + 1 pixels, the diagonal ones spanning as many
// rows and columns. A shorter bar eats into the laterally smeared dots deep
// in the image and moves their centroids by 1-2 px.
cv::Mat barKernel(int half, int direction_deg) {
  const int n = 2 * std::max(half, 1) + 1;
  if (direction_deg == 0) return cv::Mat::ones(1, n, CV_8U);
  if (direction_deg == 90) return cv::Mat::ones(n, 1, CV_8U);
  cv::Mat k = cv::Mat::zeros(n, n, CV_8U);
  for (int i = 0; i < n; ++i) k.at<std::uint8_t>(i, direction_deg == 45 ? n - 1 - i : i) = 1;
  return k;
}

struct Line {
  std::array<int, 3> dots{};  // ordered along the line by decreasing x (PLUS labels right to left)
  Eigen::Vector2d point = Eigen::Vector2d::Zero();
  Eigen::Vector2d direction = Eigen::Vector2d::UnitX();  // x >= 0
  double angle = 0.0;
  double length = 0.0;
  double intensity = 0.0;
};

}  // namespace

std::string segmentationStatusName(SegmentationStatus status) {
  switch (status) {
    case SegmentationStatus::Ok: return "ok";
    case SegmentationStatus::NoCandidates: return "no-candidates";
    case SegmentationStatus::TooFewCandidates: return "too-few-candidates";
    case SegmentationStatus::NoPattern: return "no-pattern";
  }
  return "unknown";
}

NWireSegmentationOptions segmentationOptionsFrom(const io::SegmentationParameters& p) {
  NWireSegmentationOptions o;
  if (p.approximate_spacing_mm_per_pixel) o.approximate_spacing_mm = *p.approximate_spacing_mm_per_pixel;
  if (p.morphological_opening_circle_radius_mm) o.opening_circle_radius_mm = *p.morphological_opening_circle_radius_mm;
  if (p.morphological_opening_bar_size_mm) o.opening_bar_size_mm = *p.morphological_opening_bar_size_mm;
  if (p.clip_rectangle_origin_px && p.clip_rectangle_size_px) {
    o.clip_x = (*p.clip_rectangle_origin_px)[0];
    o.clip_y = (*p.clip_rectangle_origin_px)[1];
    o.clip_width = (*p.clip_rectangle_size_px)[0];
    o.clip_height = (*p.clip_rectangle_size_px)[1];
  }
  if (p.threshold_image_percent) o.threshold_percent = *p.threshold_image_percent;
  if (p.collinear_points_max_distance_from_line_mm)
    o.collinear_max_distance_mm = *p.collinear_points_max_distance_from_line_mm;
  if (p.min_theta) o.min_theta = *p.min_theta;
  if (p.max_theta) o.max_theta = *p.max_theta;
  if (p.max_angle_difference) o.max_angle_difference = *p.max_angle_difference;
  if (p.max_line_pair_distance_error_percent)
    o.max_line_pair_distance_error_percent = *p.max_line_pair_distance_error_percent;
  if (p.number_of_maximum_fiducial_point_candidates) o.max_candidates = *p.number_of_maximum_fiducial_point_candidates;
  if (o.approximate_spacing_mm <= 0.0) {
    throw InvalidArgumentError("segmentation parameters: ApproximateSpacingMmPerPixel must be positive");
  }
  return o;
}

NWireSegmentation segmentNWires(const GrayImageView& image, const io::PhantomDefinition& phantom,
                                const NWireSegmentationOptions& options) {
  if (image.width <= 0 || image.height <= 0 ||
      image.pixels.size() != static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height)) {
    throw InvalidArgumentError("segmentNWires: the image holds " + std::to_string(image.pixels.size()) +
                               " bytes, not width*height of an 8-bit frame (" + std::to_string(image.width) + "x" +
                               std::to_string(image.height) + ")");
  }
  const auto geometry = nwireGeometry(phantom);
  const double spacing = options.approximate_spacing_mm;
  NWireSegmentation result;

  const int bar = std::max(1, static_cast<int>(std::lround(options.opening_bar_size_mm / spacing)));
  const cv::Rect image_rect(0, 0, image.width, image.height);
  cv::Rect roi = image_rect;
  if (options.clip_width > 0 && options.clip_height > 0) {
    roi &= cv::Rect(options.clip_x, options.clip_y, options.clip_width, options.clip_height);
  }
  if (roi.width < 3 || roi.height < 3) {
    result.status = SegmentationStatus::NoCandidates;
    result.reason = "the clip rectangle leaves no image";
    return result;
  }
  // The openings also see the real pixels up to a bar length around the
  // region of interest (as PLUS's do), so a dot near its edge is not cut by
  // a replicated border.
  const cv::Rect padded = cv::Rect(roi.x - bar, roi.y - bar, roi.width + 2 * bar, roi.height + 2 * bar) & image_rect;
  const cv::Mat full(image.height, image.width, CV_8U, const_cast<std::uint8_t*>(image.pixels.data()));
  cv::Mat working = full(padded).clone();

  // Bars longer than a wire dot are bright lines (reverberation, the
  // phantom's walls): their opening is subtracted so only compact blobs stay.
  cv::Mat opened;
  for (const int direction : {0, 45, 90, 135}) {
    cv::morphologyEx(working, opened, cv::MORPH_OPEN, barKernel(bar, direction), cv::Point(-1, -1), 1,
                     cv::BORDER_REPLICATE);
    cv::subtract(working, opened, working);
  }
  // Speckle smaller than a wire cross-section goes with a disc opening (the
  // pixels within the radius, PLUS's disc).
  const int radius = std::max(1, static_cast<int>(std::lround(options.opening_circle_radius_mm / spacing)));
  cv::Mat disc = cv::Mat::zeros(2 * radius + 1, 2 * radius + 1, CV_8U);
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      if (dx * dx + dy * dy <= radius * radius) disc.at<std::uint8_t>(dy + radius, dx + radius) = 1;
    }
  }
  cv::morphologyEx(working, working, cv::MORPH_OPEN, disc, cv::Point(-1, -1), 1, cv::BORDER_REPLICATE);
  working = working(roi - padded.tl()).clone();

  double min_value = 0.0, max_value = 0.0;
  cv::minMaxLoc(working, &min_value, &max_value);
  if (max_value <= min_value) {
    result.status = SegmentationStatus::NoCandidates;
    result.reason = "nothing bright and compact left after the morphological filtering";
    return result;
  }
  const double threshold = min_value + std::floor((max_value - min_value) * options.threshold_percent / 100.0 + 0.5);
  cv::Mat mask = working >= threshold;
  cv::Mat labels, stats, centroids;
  const int count = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);

  // Centroids weighted by the filtered intensities over each component, as
  // PLUS's: on PLUS's fCal recording the dots then land 0.08 px from PLUS's
  // own (0.4 px with the original intensities as weights, whose speckle
  // pulls the smeared deep dots sideways), and the score is the same sum.
  std::vector<double> sum(count, 0.0), sx(count, 0.0), sy(count, 0.0);
  for (int y = 0; y < labels.rows; ++y) {
    const int* lrow = labels.ptr<int>(y);
    const std::uint8_t* wrow = working.ptr<std::uint8_t>(y);
    for (int x = 0; x < labels.cols; ++x) {
      const int l = lrow[x];
      if (l == 0) continue;
      const double w = wrow[x];
      sum[l] += w;
      sx[l] += w * x;
      sy[l] += w * y;
    }
  }
  for (int l = 1; l < count; ++l) {
    if (sum[l] <= 0.0) continue;
    DotCandidate dot;
    dot.position_px = {sx[l] / sum[l] + roi.x, sy[l] / sum[l] + roi.y};
    dot.intensity = sum[l] / 255.0;
    dot.area_px = stats.at<int>(l, cv::CC_STAT_AREA);
    result.candidates.push_back(dot);
  }
  std::sort(result.candidates.begin(), result.candidates.end(),
            [](const DotCandidate& a, const DotCandidate& b) { return a.intensity > b.intensity; });
  if (result.candidates.size() > static_cast<std::size_t>(std::max(options.max_candidates, 3))) {
    result.candidates.resize(static_cast<std::size_t>(std::max(options.max_candidates, 3)));
  }
  const std::size_t wires = 3 * geometry.size();
  if (result.candidates.empty()) {
    result.status = SegmentationStatus::NoCandidates;
    result.reason = "no dot candidate above the threshold";
    return result;
  }
  if (result.candidates.size() < wires) {
    result.status = SegmentationStatus::TooFewCandidates;
    result.reason = std::to_string(result.candidates.size()) + " dot candidates, the phantom has " +
                    std::to_string(wires) + " wires";
    return result;
  }

  // Line candidates: dot triples within the collinearity tolerance.
  const auto& c = result.candidates;
  const double collinear_px = options.collinear_max_distance_mm / spacing;
  double min_outer_mm = geometry.front().outer_distance_mm, max_outer_mm = min_outer_mm;
  for (const auto& g : geometry) {
    min_outer_mm = std::min(min_outer_mm, g.outer_distance_mm);
    max_outer_mm = std::max(max_outer_mm, g.outer_distance_mm);
  }
  const double min_length_px = 0.85 * min_outer_mm / spacing;
  const double max_length_px = options.max_line_length_ratio * max_outer_mm / spacing;
  std::vector<Line> lines;
  const int n = static_cast<int>(c.size());
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      for (int k = j + 1; k < n; ++k) {
        std::array<int, 3> idx{i, j, k};
        std::sort(idx.begin(), idx.end(), [&](int a, int b) { return c[a].position_px.x() > c[b].position_px.x(); });
        const Eigen::Vector2d a = c[idx[0]].position_px, b = c[idx[1]].position_px, e = c[idx[2]].position_px;
        const Eigen::Vector2d d = e - a;
        const double length = d.norm();
        if (length < min_length_px || length > max_length_px) continue;
        const Eigen::Vector2d u = d / length;
        const Eigen::Vector2d normal(-u.y(), u.x());
        const double offset = normal.dot(b - a);
        // The middle dot must lie between the outer two, away from both.
        const double along = u.dot(b - a);
        if (std::abs(offset) > collinear_px || along < 0.05 * length || along > 0.95 * length) continue;
        Line line;
        line.dots = idx;
        line.point = (a + b + e) / 3.0;
        line.direction = u.x() < 0 ? Eigen::Vector2d(-u) : u;
        line.angle = std::atan2(line.direction.y(), line.direction.x());
        if (line.angle < options.min_theta || line.angle > options.max_theta) continue;
        line.length = length;
        line.intensity = c[i].intensity + c[j].intensity + c[k].intensity;
        lines.push_back(line);
      }
    }
  }
  if (lines.size() < geometry.size()) {
    result.status = SegmentationStatus::NoPattern;
    result.reason = std::to_string(lines.size()) + " collinear dot triples found, " + std::to_string(geometry.size()) +
                    " N patterns needed";
    return result;
  }

  // One line per pattern: lines are sorted top to bottom (the pattern nearest
  // the transducer first, as PLUS labels them), disjoint, parallel, and spaced
  // like the pattern planes.
  std::sort(lines.begin(), lines.end(), [](const Line& a, const Line& b) { return a.point.y() < b.point.y(); });
  // The absolute spacing check also absorbs the error of the approximate
  // pixel spacing; the pair distances relative to each other are checked
  // with the configured tolerance alone.
  const double tolerance = options.max_line_pair_distance_error_percent / 100.0;
  const double absolute_tolerance = tolerance + options.spacing_uncertainty_percent / 100.0;
  std::vector<int> chosen(geometry.size(), -1), best;
  std::vector<double> pair_distance_mm(geometry.size(), 0.0);
  double best_intensity = -1.0;
  const auto search = [&](auto&& self, std::size_t level, int start) -> void {
    if (level == geometry.size()) {
      double total = 0.0;
      for (const int l : chosen) total += lines[l].intensity;
      if (total > best_intensity) {
        best_intensity = total;
        best = chosen;
      }
      return;
    }
    for (int l = start; l < static_cast<int>(lines.size()); ++l) {
      const Line& cand = lines[l];
      bool ok = true;
      for (std::size_t p = 0; p < level && ok; ++p) {
        const Line& other = lines[chosen[p]];
        for (const int d1 : cand.dots) {
          for (const int d2 : other.dots) ok = ok && d1 != d2;
        }
        ok = ok && std::abs(cand.angle - other.angle) <= options.max_angle_difference;
      }
      if (ok && level > 0) {
        const Line& prev = lines[chosen[level - 1]];
        const Eigen::Vector2d normal(-prev.direction.y(), prev.direction.x());
        const double distance_mm = std::abs(normal.dot(cand.point - prev.point)) * spacing;
        const double expected = geometry[level].distance_to_previous_mm;
        ok = std::abs(distance_mm - expected) <= absolute_tolerance * expected && cand.point.y() > prev.point.y();
        if (ok && level > 1) {
          const double ratio = distance_mm / pair_distance_mm[level - 1];
          const double expected_ratio = expected / geometry[level - 1].distance_to_previous_mm;
          ok = std::abs(ratio / expected_ratio - 1.0) <= tolerance;
        }
        pair_distance_mm[level] = distance_mm;
      }
      if (!ok) continue;
      chosen[level] = l;
      self(self, level + 1, l + 1);
    }
  };
  search(search, 0, 0);
  if (best.empty()) {
    result.status = SegmentationStatus::NoPattern;
    result.reason = std::to_string(lines.size()) + " line candidates but no " + std::to_string(geometry.size()) +
                    " parallel lines spaced like the phantom's patterns";
    return result;
  }
  result.status = SegmentationStatus::Ok;
  result.pattern_intensity = best_intensity;
  for (const int l : best) {
    for (const int d : lines[l].dots) result.wire_points_px.push_back(c[d].position_px);
  }
  return result;
}

}  // namespace mrsns::ultrasound
