#include "uav_vision/pad_detector.h"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <optional>

#include <opencv2/imgproc.hpp>

namespace uav_vision {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

std::string format(const char* fmt, ...) {
  char buffer[256];
  va_list args;
  va_start(args, fmt);
  std::vsnprintf(buffer, sizeof(buffer), fmt, args);
  va_end(args);
  return buffer;
}

bool onBorder(const cv::Point& p, const cv::Size& size, double margin) {
  return p.x <= margin || p.y <= margin || p.x >= size.width - 1 - margin || p.y >= size.height - 1 - margin;
}

// Intersection of two lines given as (vx, vy, x0, y0), as cv::fitLine returns them.
std::optional<cv::Point2d> intersect(const cv::Vec4f& a, const cv::Vec4f& b) {
  const cv::Point2d da(a[0], a[1]), db(b[0], b[1]), pa(a[2], a[3]), pb(b[2], b[3]);
  const double cross = da.x * db.y - da.y * db.x;
  if (std::abs(cross) < 1e-6) return std::nullopt;
  const cv::Point2d w = pb - pa;
  const double t = (w.x * db.y - w.y * db.x) / cross;
  return pa + t * da;
}

cv::Vec4f lineThrough(const cv::Point2d& a, const cv::Point2d& b) {
  const cv::Point2d d = b - a;
  const double n = std::max(std::hypot(d.x, d.y), 1e-9);
  return cv::Vec4f(float(d.x / n), float(d.y / n), float(a.x), float(a.y));
}

double angleBetween(const cv::Point2d& a, const cv::Point2d& b) {
  return std::acos(std::clamp(a.dot(b) / std::max(std::hypot(a.x, a.y) * std::hypot(b.x, b.y), 1e-12), -1.0, 1.0));
}

double clamp01(double x) { return std::clamp(x, 0.0, 1.0); }

// A straight piece of outline, on the pad plane.
struct PlaneSegment {
  Eigen::Vector2d centre;     // centroid of its points [m]
  Eigen::Vector2d direction;  // unit
  double length_px;           // in the image: how well it is measured [px]
};

// Straight pieces of a closed outline that are away from the image border: the outline is cut into
// runs between border points, each run into straight pieces by approxPolyDP (in ideal pixels, where a
// straight edge is straight), and a line is fitted on the plane to each piece's middle (its ends round
// off at corners). `outline` in image pixels (for the border), `ideal` and `plane` the same points.
std::vector<PlaneSegment> planeSegments(const std::vector<cv::Point>& outline, const std::vector<cv::Point2f>& ideal,
                                        const std::vector<cv::Point2f>& plane, const cv::Size& size,
                                        const PadDetectorParams& params) {
  std::vector<PlaneSegment> segments;
  const int n = static_cast<int>(outline.size());
  int first_border = -1;
  for (int i = 0; i < n && first_border < 0; ++i)
    if (onBorder(outline[i], size, params.border_margin_px)) first_border = i;
  std::vector<std::vector<int>> runs(1);
  for (int k = 1; k <= n; ++k) {
    const int i = (std::max(first_border, 0) + k) % n;
    if (first_border >= 0 && onBorder(outline[i], size, params.border_margin_px)) {
      if (!runs.back().empty()) runs.emplace_back();
    } else {
      runs.back().push_back(i);
    }
  }
  std::vector<cv::Point2f> run_points, vertices, piece;
  for (const auto& run : runs) {
    if (run.size() < params.min_edge_length_px) continue;
    run_points.clear();
    for (int i : run) run_points.push_back(ideal[i]);
    cv::approxPolyDP(run_points, vertices, 2.0, false);
    // approxPolyDP keeps a subset of the run's points in order: find their indices.
    std::vector<size_t> vertex_index;
    size_t at = 0;
    for (const auto& v : vertices) {
      while (at < run_points.size() && run_points[at] != v) ++at;
      if (at == run_points.size()) break;
      vertex_index.push_back(at);
    }
    for (size_t k = 0; k + 1 < vertex_index.size(); ++k) {
      const size_t a = vertex_index[k], b = vertex_index[k + 1];
      if (b - a < params.min_edge_length_px) continue;
      const size_t trim = std::max<size_t>(2, (b - a) / 8);
      piece.clear();
      for (size_t j = a + trim; j + trim <= b; ++j) piece.push_back(plane[run[j]]);
      if (piece.size() < 4) continue;
      cv::Vec4f line;
      cv::fitLine(piece, line, cv::DIST_L2, 0, 0.01, 0.01);
      segments.push_back({Eigen::Vector2d(line[2], line[3]), Eigen::Vector2d(line[0], line[1]).normalized(),
                          cv::norm(run_points[b] - run_points[a])});
    }
  }
  return segments;
}

// An edge of the pad or of the strip on the plane, expressed in the square's axes (u, v): the line
// `normal . p = offset`, with the region it bounds on the `interior` side (+1: larger offsets).
struct EdgeLine {
  int normal_axis;  // 0: normal along u, 1: along v
  double offset;    // [m]
  int interior;     // +1 or -1
  double weight;    // visible length in the image [px]
};

// Merges lines of the same axis closer than `merge` metres; nothing if two lines at the same place
// bound regions on opposite sides (not a convex shape).
std::optional<std::vector<EdgeLine>> clusterLines(std::vector<EdgeLine> lines, double merge) {
  std::sort(lines.begin(), lines.end(), [](const EdgeLine& a, const EdgeLine& b) {
    return a.normal_axis != b.normal_axis ? a.normal_axis < b.normal_axis : a.offset < b.offset;
  });
  std::vector<EdgeLine> merged;
  for (const auto& line : lines) {
    if (!merged.empty() && merged.back().normal_axis == line.normal_axis &&
        std::abs(merged.back().offset - line.offset) < merge) {
      EdgeLine& m = merged.back();
      if (m.interior != line.interior) return std::nullopt;
      m.offset = (m.offset * m.weight + line.offset * line.weight) / (m.weight + line.weight);
      m.weight += line.weight;
    } else {
      merged.push_back(line);
    }
  }
  return merged;
}

}  // namespace

struct PadDetector::Candidate {
  Detection detection;
  bool ok = false;
};

PadDetector::PadDetector(const PadDetectorParams& params) : params_(params) {
  const int k = std::max(1, params.morphology_kernel_px);
  kernel_ = cv::getStructuringElement(cv::MORPH_RECT, cv::Size(k, k));
}

std::string PadDetector::validate(const PadDetectorParams& p) {
  auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  if (!(p.pad.side > 0.0)) return "pad side must be positive";
  if (!(p.pad.strip_length > 0.0 && p.pad.strip_width > 0.0 && p.pad.strip_length < p.pad.side))
    return "strip length and width must be positive and the strip inside the pad";
  if (!(std::abs(p.pad.strip_offset) + p.pad.strip_width / 2 < p.pad.side / 2)) return "strip_offset puts the strip off the pad";
  for (int v : {p.red_margin_min, p.green_margin_min})
    if (!in(v, 1, 255)) return "red_margin_min and green_margin_min must be in [1, 255]";
  if (!in(p.morphology_kernel_px, 1, 15)) return "morphology_kernel_px must be in [1, 15]";
  if (!in(p.min_area_px, 1, 1e6)) return "min_area_px must be in [1, 1e6]";
  if (!in(p.min_solidity, 0, 1)) return "min_solidity must be in [0, 1]";
  if (!in(p.approx_epsilon, 0.001, 0.2)) return "approx_epsilon must be in [0.001, 0.2]";
  if (!in(p.max_side_ratio, 1, 10)) return "max_side_ratio must be in [1, 10]";
  if (!in(p.max_corner_angle_error_deg, 0, 89)) return "max_corner_angle_error_deg must be in [0, 89]";
  if (!in(p.size_tolerance, 0, 0.9)) return "size_tolerance must be in [0, 0.9]";
  if (!in(p.max_edge_angle_error_deg, 0, 44)) return "max_edge_angle_error_deg must be in [0, 44]";
  if (!in(p.border_margin_px, 0, 20)) return "border_margin_px must be in [0, 20]";
  if (!in(p.min_edge_length_px, 3, 1000)) return "min_edge_length_px must be in [3, 1000]";
  if (!in(p.fit_tolerance_m, 0.001, 0.5 * p.pad.side)) return "fit_tolerance_m must be in [0.001, pad side / 2]";
  if (!in(p.min_strip_area_px, 1, 1e6)) return "min_strip_area_px must be in [1, 1e6]";
  if (!in(p.min_partial_support_px, 0.0, 1000.0)) return "min_partial_support_px must be in [0, 1000]";
  if (!in(p.min_partial_coverage, 0.0, 1.0)) return "min_partial_coverage must be in [0, 1]";
  if (!in(p.min_corner_image_share, 0.0, 1.0)) return "min_corner_image_share must be in [0, 1]";
  if (!in(p.max_off_edge_share, 0.0, 1.0)) return "max_off_edge_share must be in [0, 1]";
  if (!in(p.edge_gap_tolerance, 0.0, 0.9)) return "edge_gap_tolerance must be in [0, 0.9]";
  if (!(p.pad.marker_side > 0.0 && p.pad.marker_side / 2 < std::abs(p.pad.strip_offset) - p.pad.strip_width / 2))
    return "marker_side must be positive and the centre marker clear of the strip";
  if (!in(p.marker_chroma_max, 0, 255) || !in(p.marker_value_min, 0, 255))
    return "marker_chroma_max and marker_value_min must be in [0, 255]";
  if (!in(p.marker_min_surround, 0, 1)) return "marker_min_surround must be in [0, 1]";
  return "";
}

void PadDetector::computeMasks(const cv::Mat& image, ColorOrder order, double max_marker_area_px) const {
  const auto& p = params_;
  cv::split(image, planes_);
  red_plane_ = order == ColorOrder::kRgb ? 0 : 2;
  const cv::Mat& r = planes_[red_plane_];
  const cv::Mat& g = planes_[1];
  const cv::Mat& b = planes_[order == ColorOrder::kRgb ? 2 : 0];
  // Saturating 8-bit arithmetic: a margin below zero is zero.
  cv::max(g, b, max_of_two_);
  cv::subtract(r, max_of_two_, margin_);
  cv::threshold(margin_, red_colour_, p.red_margin_min - 1, 255, cv::THRESH_BINARY);
  cv::max(max_of_two_, r, channel_max_);
  cv::max(r, b, max_of_two_);
  cv::subtract(g, max_of_two_, margin_);
  cv::threshold(margin_, strip_mask_, p.green_margin_min - 1, 255, cv::THRESH_BINARY);
  // The strip lies inside the pad: counting it as pad keeps the outline a square when the strip is cut
  // by the image border.
  cv::bitwise_or(red_colour_, strip_mask_, pad_mask_);
  // A pixel takes the class of most of its 3x3 neighbourhood: the sensor noise's specks go, and so do
  // the pinholes it leaves in a dark (shadowed, under-exposed) part of the pad. The pad's vote counts
  // the strip as pad: where red and green meet, neither alone has the majority.
  cv::medianBlur(pad_mask_, pad_mask_, 3);
  cv::medianBlur(red_colour_, red_colour_, 3);
  cv::medianBlur(strip_mask_, strip_mask_, 3);
  if (p.morphology_kernel_px > 1) {
    cv::morphologyEx(pad_mask_, pad_mask_, cv::MORPH_OPEN, kernel_);
    cv::morphologyEx(strip_mask_, strip_mask_, cv::MORPH_OPEN, kernel_);
  }
  // The white centre marker lies inside the pad too: where the image border cuts it, filled in, it leaves
  // no notch whose straight sides would pass for pad edges (a hole inside does not change the outline).
  cv::min(g, b, channel_min_);
  cv::min(channel_min_, r, channel_min_);
  cv::subtract(channel_max_, channel_min_, margin_);  // the chroma
  cv::threshold(margin_, marker_mask_, p.marker_chroma_max, 255, cv::THRESH_BINARY_INV);
  cv::threshold(channel_min_, channel_min_, p.marker_value_min - 1, 255, cv::THRESH_BINARY);
  cv::bitwise_and(marker_mask_, channel_min_, marker_mask_);
  cv::medianBlur(marker_mask_, marker_mask_, 3);
  if (p.morphology_kernel_px > 1) cv::morphologyEx(marker_mask_, marker_mask_, cv::MORPH_OPEN, kernel_);
  cv::findContours(marker_mask_, white_blobs_, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  white_blob_red_share_.assign(white_blobs_.size(), 0.0);
  for (size_t i = 0; i < white_blobs_.size(); ++i) {
    const auto& blob = white_blobs_[i];
    const double area = cv::contourArea(blob);
    // Grey ground (as grey-white as the marker in some light) is larger than the marker's image.
    white_blob_red_share_[i] = area <= max_marker_area_px ? redShareAround(blob, image.size()) : 0.0;
    // A marker cut by the image border meets one side of the image. Ground between a convex pad and the
    // border, as grey-white as the marker in some light, meets two (it holds a corner of the image), as
    // does a marker in a corner of the image: that one is the brighter, white beside the red in the
    // same light (the ground's grey is about half as bright as the red's R channel).
    const double m = p.border_margin_px;
    int sides = 0;
    sides += std::any_of(blob.begin(), blob.end(), [&](const cv::Point& q) { return q.x <= m; });
    sides += std::any_of(blob.begin(), blob.end(), [&](const cv::Point& q) { return q.y <= m; });
    sides += std::any_of(blob.begin(), blob.end(), [&](const cv::Point& q) { return q.x >= image.cols - 1 - m; });
    sides += std::any_of(blob.begin(), blob.end(), [&](const cv::Point& q) { return q.y >= image.rows - 1 - m; });
    if (sides == 0 || white_blob_red_share_[i] < p.marker_min_surround) continue;
    if (sides == 1 || (sides == 2 && brighterThanTheRedAround(blob, r)))
      cv::drawContours(pad_mask_, white_blobs_, int(i), cv::Scalar(255), cv::FILLED);
  }
}

bool PadDetector::brighterThanTheRedAround(const std::vector<cv::Point>& blob, const cv::Mat& red_channel) const {
  const cv::Rect inner = cv::boundingRect(blob) & cv::Rect(cv::Point(), red_channel.size());
  const int margin = std::max(2, int(std::round(0.3 * std::sqrt(std::max(double(inner.area()), 1.0)))));
  const cv::Rect band = (inner + cv::Size(2 * margin, 2 * margin) - cv::Point(margin, margin)) &
                        cv::Rect(cv::Point(), red_channel.size());
  cv::Mat inside(band.size(), CV_8U, cv::Scalar(0));
  cv::drawContours(inside, std::vector<std::vector<cv::Point>>{blob}, 0, cv::Scalar(255), cv::FILLED, cv::LINE_8,
                   cv::noArray(), 0, -band.tl());
  const double blob_r = cv::mean(red_channel(band), inside)[0];
  const double red_r = cv::mean(red_channel(band), red_colour_(band))[0];
  return blob_r >= 0.8 * red_r;
}

double PadDetector::redShareAround(const std::vector<cv::Point>& blob, const cv::Size& size) const {
  const double area = cv::contourArea(blob);
  const cv::Rect inner = cv::boundingRect(blob);
  const int margin = std::max(2, int(std::round(0.3 * std::sqrt(std::max(area, 1.0)))));
  const cv::Rect band = (inner + cv::Size(2 * margin, 2 * margin) - cv::Point(margin, margin)) & cv::Rect(cv::Point(), size);
  const double band_area = band.area() - std::min(area, 0.9 * band.area());
  return band_area > 0 ? std::min(1.0, cv::countNonZero(red_colour_(band)) / band_area) : 0.0;
}

Detection PadDetector::detect(const cv::Mat& image, ColorOrder order, const PlaneView* view) const {
  Detection result;
  if (image.empty()) {
    result.reason = "empty image";
    return result;
  }
  if (image.depth() != CV_8U || image.channels() != 3) {
    result.reason = format("expected an 8-bit 3-channel image, got depth %d with %d channels", image.depth(),
                           image.channels());
    return result;
  }
  if (image.cols < 8 || image.rows < 8) {
    result.reason = format("image too small (%dx%d)", image.cols, image.rows);
    return result;
  }
  if (view) {
    if (!view->problem().empty()) {
      result.reason = "bad view geometry: " + view->problem();
      return result;
    }
    const auto& k = view->intrinsics();
    if (image.cols != k.width || image.rows != k.height) {
      result.reason = format("image is %dx%d but the camera intrinsics are for %dx%d", image.cols, image.rows,
                             k.width, k.height);
      return result;
    }
  }
  frame_lens_ = lensOf(view);
  // The marker's image is at most about this large (a tilt enlarges it by tens of per cent); without the
  // view its size is unknown, and a marker is not looked for.
  const double marker_px =
      view ? 1.3 * std::max(view->intrinsics().fx, view->intrinsics().fy) * params_.pad.marker_side / view->cameraHeight()
           : 0.0;
  computeMasks(image, order, marker_px * marker_px);
  std::vector<std::vector<cv::Point>> outlines;
  cv::findContours(pad_mask_, outlines, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  cv::findContours(strip_mask_, strip_outlines_, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  strip_ideal_.resize(strip_outlines_.size());
  for (size_t i = 0; i < strip_outlines_.size(); ++i) toIdeal(strip_outlines_[i], strip_ideal_[i]);

  result.reason = "no red region";
  double rejected_area = 0.0;
  const cv::Size size = image.size();
  for (const auto& outline : outlines) {
    const double area = cv::contourArea(outline);
    if (area < params_.min_area_px) continue;
    toIdeal(outline, ideal_);
    Candidate candidate = evaluate(outline, ideal_, size, view);
    const Detection& d = candidate.detection;
    if (candidate.ok) {
      if (!result.found || d.quality > result.quality) result = d;
    } else if (!result.found && area > rejected_area) {
      rejected_area = area;
      result.reason = d.reason;
    }
  }
  if (view && (!result.found || result.partial)) {
    // Close range: the marker is smaller and wholly in view, so it beats a pad completed from edges.
    Detection marker;
    if (findMarker(outlines, size, *view, marker)) {
      if (result.found && result.strip_found) {  // the partial fit's heading still holds
        marker.strip_found = true;
        marker.strip_centre_px = result.strip_centre_px;
      }
      result = marker;
    }
    else if (!result.found && findCutMarker(size, *view, marker))
      result = marker;
    else if (!result.found && marker.reason != "no centre marker in view")
      result.reason += "; " + marker.reason;
  }
  if (!result.found) return result;

  const cv::Point2d axis = view ? cv::Point2d(view->intrinsics().cx, view->intrinsics().cy)
                                : cv::Point2d((size.width - 1) / 2.0, (size.height - 1) / 2.0);
  result.optical_axis_margin_px = cv::pointPolygonTest(result.outline, cv::Point2f(axis), true);
  result.expected_side_px = view ? view->intrinsics().fx * params_.pad.side / view->cameraHeight() : 0.0;
  result.reason.clear();
  return result;
}

const LensUndistortion* PadDetector::lensOf(const PlaneView* view) const {
  if (!view || !view->intrinsics().distorted()) return nullptr;
  if (!lens_ || lens_->intrinsics() != view->intrinsics()) lens_ = std::make_shared<const LensUndistortion>(view->intrinsics());
  return lens_.get();
}

void PadDetector::toIdeal(const std::vector<cv::Point>& pixels, std::vector<cv::Point2f>& ideal) const {
  if (frame_lens_) {
    frame_lens_->undistort(pixels, ideal);
  } else {
    ideal.resize(pixels.size());
    for (size_t i = 0; i < pixels.size(); ++i) ideal[i] = cv::Point2f(float(pixels[i].x), float(pixels[i].y));
  }
}

PadDetector::Candidate PadDetector::evaluate(const std::vector<cv::Point>& outline,
                                             const std::vector<cv::Point2f>& ideal, const cv::Size& size,
                                             const PlaneView* view) const {
  Candidate candidate;
  const bool touches_border = std::any_of(outline.begin(), outline.end(), [&](const cv::Point& p) {
    return onBorder(p, size, params_.border_margin_px);
  });
  if (!touches_border) {
    candidate.ok = evaluateWhole(outline, ideal, view, candidate);
  } else if (!view) {
    candidate.detection.reason = "pad cut by the image border and no camera geometry to complete it";
  } else {
    candidate.ok = evaluatePartial(outline, ideal, size, *view, candidate);
  }
  if (candidate.ok) {
    candidate.detection.found = true;
    candidate.detection.outline = outline;
  }
  return candidate;
}

int PadDetector::findStrip(const std::vector<cv::Point>& outline) const {
  int best = -1;
  double best_area = params_.min_strip_area_px;
  for (size_t i = 0; i < strip_outlines_.size(); ++i) {
    const cv::Moments m = cv::moments(strip_outlines_[i]);
    if (m.m00 < best_area) continue;
    const cv::Point2f centroid(float(m.m10 / m.m00), float(m.m01 / m.m00));
    if (cv::pointPolygonTest(outline, centroid, false) < 0) continue;
    best = int(i);
    best_area = m.m00;
  }
  return best;
}

bool PadDetector::evaluateWhole(const std::vector<cv::Point>& outline, const std::vector<cv::Point2f>& ideal,
                                const PlaneView* view, Candidate& candidate) const {
  const auto& p = params_;
  Detection& d = candidate.detection;
  const double area = cv::contourArea(ideal);
  std::vector<cv::Point2f> hull;
  cv::convexHull(ideal, hull);
  const double solidity = area / std::max(cv::contourArea(hull), 1e-9);
  if (solidity < p.min_solidity) {
    d.reason = format("red region not convex (solidity %.2f < %.2f)", solidity, p.min_solidity);
    return false;
  }
  std::vector<cv::Point2f> quad;
  cv::approxPolyDP(hull, quad, p.approx_epsilon * cv::arcLength(hull, true), true);
  if (quad.size() != 4 || !cv::isContourConvex(quad)) {
    d.reason = format("red region has %d corners, not 4", int(quad.size()));
    return false;
  }
  // Refine each side with a line through the outline points along its middle.
  std::array<cv::Vec4f, 4> lines;
  std::vector<cv::Point2f> support;
  for (int k = 0; k < 4; ++k) {
    const cv::Point2d a = quad[k], b = quad[(k + 1) % 4];
    const cv::Point2d side = b - a;
    const double length = std::hypot(side.x, side.y);
    const cv::Point2d dir = side / std::max(length, 1e-9);
    const double max_distance = std::max(2.0, 0.05 * length);
    support.clear();
    for (const auto& q : ideal) {
      const cv::Point2d w = cv::Point2d(q) - a;
      const double t = w.dot(dir) / length;
      if (t > 0.15 && t < 0.85 && std::abs(w.x * dir.y - w.y * dir.x) <= max_distance) support.emplace_back(q);
    }
    if (support.size() >= 5)
      cv::fitLine(support, lines[k], cv::DIST_L2, 0, 0.01, 0.01);
    else
      lines[k] = lineThrough(a, b);
  }
  for (int k = 0; k < 4; ++k) {
    const auto corner = intersect(lines[(k + 3) % 4], lines[k]);
    d.corners_px[k] = corner ? *corner : cv::Point2d(quad[k]);
  }
  const auto& c = d.corners_px;
  std::array<double, 4> sides;
  double worst_angle = 0.0;
  for (int k = 0; k < 4; ++k) {
    const cv::Point2d s = c[(k + 1) % 4] - c[k];
    sides[k] = std::hypot(s.x, s.y);
    worst_angle = std::max(worst_angle, std::abs(angleBetween(c[(k + 3) % 4] - c[k], s) / kDeg - 90.0));
  }
  const double side_ratio = *std::max_element(sides.begin(), sides.end()) /
                            std::max(*std::min_element(sides.begin(), sides.end()), 1e-9);
  d.side_px = (sides[0] + sides[1] + sides[2] + sides[3]) / 4.0;
  const auto centre = intersect(lineThrough(c[0], c[2]), lineThrough(c[1], c[3]));
  if (!centre) {
    d.reason = "degenerate quadrilateral";
    return false;
  }
  d.centre_px = *centre;

  double size_term = 1.0, shape_term;
  if (view) {
    // On the plane the corners must make a square of the pad's size: this checks shape and size at once.
    std::array<Eigen::Vector2d, 4> q;
    for (int k = 0; k < 4; ++k) {
      const auto hit = view->pixelToPlane(c[k]);
      if (!hit) {
        d.reason = "pad corner above the horizon";
        return false;
      }
      q[k] = *hit;
    }
    double worst_size = 0.0, worst_right = 0.0;
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d s = q[(k + 1) % 4] - q[k], r = q[(k + 3) % 4] - q[k];
      worst_size = std::max(worst_size, std::abs(s.norm() / p.pad.side - 1.0));
      worst_right = std::max(worst_right, std::abs(std::acos(std::clamp(s.normalized().dot(r.normalized()), -1.0, 1.0)) / kDeg - 90.0));
    }
    if (worst_size > p.size_tolerance) {
      d.reason = format("red square of the wrong size (a side is %.0f%% off %.2f m at %.2f m camera height)",
                        100.0 * worst_size, p.pad.side, view->cameraHeight());
      return false;
    }
    if (worst_right > p.max_edge_angle_error_deg) {
      d.reason = format("red quadrilateral is not a square (corner %.0f deg off 90)", worst_right);
      return false;
    }
    size_term = 1.0 - worst_size / std::max(p.size_tolerance, 1e-9);
    shape_term = 1.0 - worst_right / std::max(p.max_edge_angle_error_deg, 1e-9);
  } else {
    if (side_ratio > p.max_side_ratio) {
      d.reason = format("red quadrilateral too elongated (side ratio %.2f > %.2f)", side_ratio, p.max_side_ratio);
      return false;
    }
    if (worst_angle > p.max_corner_angle_error_deg) {
      d.reason = format("red quadrilateral is not a square (corner %.0f deg off 90)", worst_angle);
      return false;
    }
    shape_term = 1.0 - worst_angle / std::max(p.max_corner_angle_error_deg, 1e-9);
  }
  const double solidity_term = (solidity - p.min_solidity) / std::max(1.0 - p.min_solidity, 1e-9);
  d.quality = clamp01(0.4 + 0.6 * std::min({clamp01(size_term), clamp01(shape_term), clamp01(solidity_term)}));

  if (const int strip = findStrip(outline); strip >= 0) {
    const cv::Moments m = cv::moments(strip_ideal_[strip]);
    d.strip_found = true;
    d.strip_centre_px = cv::Point2d(m.m10 / m.m00, m.m01 / m.m00);
  }
  return true;
}

bool PadDetector::evaluatePartial(const std::vector<cv::Point>& outline, const std::vector<cv::Point2f>& ideal,
                                  const cv::Size& size, const PlaneView& view, Candidate& candidate) const {
  const auto& p = params_;
  const PadModel& pad = p.pad;
  Detection& d = candidate.detection;
  d.partial = true;
  auto toPlane = [&](const std::vector<cv::Point2f>& pixels, std::vector<cv::Point2f>& plane, Eigen::Vector2d& centroid) {
    plane.clear();
    plane.reserve(pixels.size());
    for (const auto& q : pixels) {
      const auto hit = view.pixelToPlane(q);
      if (!hit) return false;
      plane.emplace_back(float(hit->x()), float(hit->y()));
    }
    const cv::Moments m = cv::moments(plane);
    if (std::abs(m.m00) < 1e-9) return false;
    centroid = Eigen::Vector2d(m.m10 / m.m00, m.m01 / m.m00);
    return true;
  };
  std::vector<cv::Point2f> pad_plane, strip_plane;
  Eigen::Vector2d pad_centroid, strip_centroid;
  if (!toPlane(ideal, pad_plane, pad_centroid)) {
    d.reason = "red region reaches above the horizon";
    return false;
  }
  std::vector<PlaneSegment> pad_segments = planeSegments(outline, ideal, pad_plane, size, p);
  std::vector<PlaneSegment> strip_segments;  // filled below when the strip is in view
  const int strip = findStrip(outline);
  if (strip >= 0 && toPlane(strip_ideal_[strip], strip_plane, strip_centroid))
    strip_segments = planeSegments(strip_outlines_[strip], strip_ideal_[strip], strip_plane, size, p);
  if (pad_segments.empty() && strip_segments.empty()) {
    d.reason = "pad cut by the image border with no straight edge in view";
    return false;
  }

  // Orientation of the square modulo 90 deg: length-weighted mean of the edges' angles times 4.
  double c4 = 0.0, s4 = 0.0;
  for (const std::vector<PlaneSegment>* set : {&pad_segments, &strip_segments})
    for (const auto& s : *set) {
      const double a = std::atan2(s.direction.y(), s.direction.x());
      c4 += s.length_px * std::cos(4.0 * a);
      s4 += s.length_px * std::sin(4.0 * a);
    }
  const double theta = std::atan2(s4, c4) / 4.0;
  const Eigen::Vector2d axes[2] = {{std::cos(theta), std::sin(theta)}, {-std::sin(theta), std::cos(theta)}};

  // Pieces longer than must_fit_px must be at right angles; shorter ones may be where an edge meets
  // the border.
  auto toLines = [&](const std::vector<PlaneSegment>& segments, const Eigen::Vector2d& centroid, double must_fit_px,
                     std::vector<EdgeLine>& lines) {
    for (const auto& s : segments) {
      const double deviation = std::remainder(std::atan2(s.direction.y(), s.direction.x()) - theta, kPi / 2.0);
      if (std::abs(deviation) > p.max_edge_angle_error_deg * kDeg) {
        if (s.length_px > must_fit_px) {
          d.reason = format("red region's edges are not at right angles (%.0f deg off)", std::abs(deviation) / kDeg);
          return false;
        }
        continue;
      }
      // An edge along u fixes the coordinate along v, and vice versa.
      const int normal_axis = std::abs(s.direction.dot(axes[0])) > std::abs(s.direction.dot(axes[1])) ? 1 : 0;
      const double offset = axes[normal_axis].dot(s.centre);
      const double side = axes[normal_axis].dot(centroid) - offset;
      if (std::abs(side) < 1e-4) continue;
      lines.push_back({normal_axis, offset, side > 0 ? 1 : -1, s.length_px});
    }
    return true;
  };
  std::vector<EdgeLine> pad_raw, strip_raw;
  const double side_px = view.intrinsics().fx * pad.side / view.cameraHeight();
  if (!toLines(pad_segments, pad_centroid, 0.15 * side_px, pad_raw) ||
      !toLines(strip_segments, strip_centroid, 0.5 * pad.strip_length / pad.side * side_px, strip_raw))
    return false;
  const auto pad_lines = clusterLines(pad_raw, 0.1 * pad.side);
  const auto strip_lines = clusterLines(strip_raw, 0.3 * pad.strip_width);
  if (!pad_lines || !strip_lines) {
    d.reason = "red region's outline is not convex";
    return false;
  }
  for (int axis = 0; axis < 2; ++axis) {
    std::vector<EdgeLine> parallel;
    for (const auto& l : *pad_lines)
      if (l.normal_axis == axis) parallel.push_back(l);
    if (parallel.size() > 2) {
      d.reason = format("%d parallel red edges: not a square", int(parallel.size()));
      return false;
    }
    if (parallel.size() == 2) {
      const double gap = parallel[1].offset - parallel[0].offset;
      if (parallel[0].interior != 1 || parallel[1].interior != -1 ||
          std::abs(gap / pad.side - 1.0) > p.edge_gap_tolerance) {
        d.reason = format("opposite red edges %.2f m apart, the pad is %.2f m", gap, pad.side);
        return false;
      }
    }
  }

  // Hypotheses on the pad's forward axis (which the strip's position reveals): none (pad edges only),
  // or +-u, +-v. Each gives the centre by weighted least squares per axis; it must explain every
  // edge, and every outline point must lie within the square (and the strip's within the strip).
  struct Hypothesis {
    int forward_axis;  // -1: strip not used
    int forward_sign;
    bool observable = false, consistent = false;
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    double rms = 0.0, outside = 1.0;
  };
  std::vector<Hypothesis> hypotheses{{-1, 0}};
  if (!strip_lines->empty())
    for (int axis = 0; axis < 2; ++axis)
      for (int sign : {1, -1}) hypotheses.push_back({axis, sign});
  const double tolerance = p.fit_tolerance_m + 2.0 * view.metresPerPixel();
  for (auto& h : hypotheses) {
    std::vector<std::pair<int, std::pair<double, double>>> estimates;  // axis, (value, weight)
    for (const auto& l : *pad_lines) estimates.push_back({l.normal_axis, {l.offset + l.interior * pad.side / 2, l.weight}});
    if (h.forward_axis >= 0)
      for (const auto& l : *strip_lines) {
        const bool along_forward = l.normal_axis == h.forward_axis;
        const double strip_centre = l.offset + l.interior * (along_forward ? pad.strip_width : pad.strip_length) / 2;
        estimates.push_back(
            {l.normal_axis, {strip_centre - (along_forward ? h.forward_sign * pad.strip_offset : 0.0), l.weight}});
      }
    double sum_w[2] = {0, 0}, sum_we[2] = {0, 0};
    for (const auto& [axis, e] : estimates) {
      sum_w[axis] += e.second;
      sum_we[axis] += e.second * e.first;
    }
    // Short pieces of edge give poor directions, and a centre half a metre away amplifies that.
    h.observable = sum_w[0] >= p.min_partial_support_px && sum_w[1] >= p.min_partial_support_px;
    if (!h.observable) continue;
    const double c[2] = {sum_we[0] / sum_w[0], sum_we[1] / sum_w[1]};
    double worst = 0.0, sum_sq = 0.0, total_w = 0.0;
    for (const auto& [axis, e] : estimates) {
      worst = std::max(worst, std::abs(e.first - c[axis]));
      sum_sq += e.second * (e.first - c[axis]) * (e.first - c[axis]);
      total_w += e.second;
    }
    h.rms = std::sqrt(sum_sq / total_w);
    h.centre = c[0] * axes[0] + c[1] * axes[1];
    int outside = 0, checked = 0;
    const double half = pad.side / 2 + tolerance;
    for (const auto& q : pad_plane) {
      const Eigen::Vector2d r = Eigen::Vector2d(q.x, q.y) - h.centre;
      outside += std::abs(r.dot(axes[0])) > half || std::abs(r.dot(axes[1])) > half;
      ++checked;
    }
    if (h.forward_axis >= 0) {
      const Eigen::Vector2d forward = h.forward_sign * axes[h.forward_axis], left = axes[1 - h.forward_axis];
      const Eigen::Vector2d strip_centre = h.centre + pad.strip_offset * forward;
      for (const auto& q : strip_plane) {
        const Eigen::Vector2d r = Eigen::Vector2d(q.x, q.y) - strip_centre;
        outside += std::abs(r.dot(forward)) > pad.strip_width / 2 + tolerance ||
                   std::abs(r.dot(left)) > pad.strip_length / 2 + tolerance;
        ++checked;
      }
    }
    h.outside = double(outside) / std::max(checked, 1);
    h.consistent = worst <= tolerance && h.outside <= 0.02;
  }
  const Hypothesis* chosen = nullptr;
  const Hypothesis& edges_only = hypotheses.front();
  auto better = [](const Hypothesis* a, const Hypothesis& b) {
    return !a || b.outside + b.rms < a->outside + a->rms;
  };
  if (edges_only.observable) {
    if (!edges_only.consistent) {
      d.reason = format("red edges do not fit a %.2f m square (%.0f%% of the outline outside)", pad.side,
                        100.0 * edges_only.outside);
      return false;
    }
    chosen = &edges_only;
    // The strip adds support (and the heading) when some placement of it agrees with the edges.
    const Hypothesis* with_strip = nullptr;
    for (size_t i = 1; i < hypotheses.size(); ++i) {
      const auto& h = hypotheses[i];
      if (h.consistent && (h.centre - edges_only.centre).norm() <= tolerance && better(with_strip, h)) with_strip = &h;
    }
    if (with_strip) chosen = with_strip;
  } else {
    for (size_t i = 1; i < hypotheses.size(); ++i)
      if (hypotheses[i].consistent && better(chosen, hypotheses[i])) chosen = &hypotheses[i];
    if (!chosen) {
      d.reason = "pad cut by the image border: too little of it in view to place its centre";
      return false;
    }
    for (size_t i = 1; i < hypotheses.size(); ++i) {
      const auto& h = hypotheses[i];
      if (&h != chosen && h.consistent && (h.centre - chosen->centre).norm() > tolerance) {
        d.reason = "pad cut by the image border: its centre is ambiguous from what is in view";
        return false;
      }
    }
  }

  // Away from the image border, the outline must run along the square's edges: a smaller red thing (the
  // corner of the false target beside the vehicle, its far ends in view) lies inside the square but turns
  // off before the square's corners.
  {
    const double half = pad.side / 2;
    int off_edge = 0, checked = 0;
    for (size_t i = 0; i < outline.size(); ++i) {
      if (onBorder(outline[i], size, p.border_margin_px)) continue;
      const Eigen::Vector2d r = Eigen::Vector2d(pad_plane[i].x, pad_plane[i].y) - chosen->centre;
      off_edge += std::abs(std::max(std::abs(r.dot(axes[0])), std::abs(r.dot(axes[1]))) - half) > tolerance;
      ++checked;
    }
    const double share = double(off_edge) / std::max(checked, 1);
    if (share > p.max_off_edge_share) {
      d.reason = format("%.0f%% of the red outline runs inside the %.2f m square fitted to its edges, not along them",
                        100.0 * share, pad.side);
      return false;
    }
  }
  // The square must be red wherever it is in view: the outline lying inside the square is not enough, as
  // the corner or the edge of another red thing (on the ground beside the vehicle) fits a square too.
  const double coverage = redCoverage(view, chosen->centre, axes);
  if (coverage < p.min_partial_coverage) {
    d.reason = format("the %.2f m square fitted to the red edges is red in only %.0f%% of its part in view", pad.side,
                      100.0 * coverage);
    return false;
  }
  // A corner of red alone could belong to anything red and square-cornered (the false target on the ground
  // beside the vehicle): with neither two opposite edges nor the strip to confirm the pad, some of its area
  // must show.
  bool opposite_edges = false;
  for (int axis = 0; axis < 2; ++axis)
    opposite_edges |= std::count_if(pad_lines->begin(), pad_lines->end(),
                                    [&](const EdgeLine& l) { return l.normal_axis == axis; }) == 2;
  const double image_share = std::abs(cv::contourArea(ideal)) / size.area();
  if (chosen->forward_axis < 0 && !opposite_edges && image_share < p.min_corner_image_share) {
    d.reason = format("pad cut by the image border: a corner alone, covering %.1f%% of the image (no strip, no "
                      "opposite edges)", 100.0 * image_share);
    return false;
  }

  const auto centre_px = view.planeToPixel(chosen->centre);
  if (!centre_px) {
    d.reason = "pad centre behind the camera";
    return false;
  }
  d.centre_px = *centre_px;
  const double half = pad.side / 2;
  const Eigen::Vector2d corner_offsets[4] = {half * (axes[0] + axes[1]), half * (-axes[0] + axes[1]),
                                             half * (-axes[0] - axes[1]), half * (axes[0] - axes[1])};
  for (int k = 0; k < 4; ++k) {
    const auto corner = view.planeToPixel(chosen->centre + corner_offsets[k]);
    d.corners_px[k] = corner ? *corner : d.centre_px;
  }
  d.side_px = 0.0;
  for (int k = 0; k < 4; ++k) {
    const cv::Point2d s = d.corners_px[(k + 1) % 4] - d.corners_px[k];
    d.side_px += std::hypot(s.x, s.y) / 4.0;
  }
  if (chosen->forward_axis >= 0) {
    const auto strip_px = view.planeToPixel(chosen->centre + pad.strip_offset * chosen->forward_sign * axes[chosen->forward_axis]);
    d.strip_found = strip_px.has_value();
    if (strip_px) d.strip_centre_px = *strip_px;
  }
  double support = 0.0;
  for (const auto& l : *pad_lines) support += l.weight;
  if (chosen->forward_axis >= 0)
    for (const auto& l : *strip_lines) support += l.weight;
  // Partial pads rank below whole ones; more visible edge and a tighter fit raise the quality.
  d.quality = clamp01(0.8 * std::min(1.0, support / (2.0 * side_px)) * std::exp(-chosen->rms / p.fit_tolerance_m) *
                      (1.0 - 10.0 * chosen->outside));
  return true;
}

int PadDetector::maskAt(const PlaneView& view, const Eigen::Vector2d& point, const cv::Mat& mask) const {
  const cv::Size size = mask.size();
  const double margin = params_.border_margin_px + 1.0;
  const auto ideal = view.planeToPixel(point);
  // Far outside the image the lens model means nothing (a polynomial): such points are not in view.
  if (!ideal || std::abs(ideal->x - size.width / 2.0) > size.width || std::abs(ideal->y - size.height / 2.0) > size.height)
    return -1;
  const cv::Point2d pixel = frame_lens_ ? frame_lens_->distort(*ideal) : *ideal;
  if (pixel.x < margin || pixel.y < margin || pixel.x > size.width - 1 - margin || pixel.y > size.height - 1 - margin)
    return -1;
  return mask.at<uint8_t>(cvRound(pixel.y), cvRound(pixel.x)) > 0 ? 1 : 0;
}

double PadDetector::redCoverage(const PlaneView& view, const Eigen::Vector2d& centre,
                                const Eigen::Vector2d (&axes)[2]) const {
  // A grid over the square (short of its edges, which the image blurs), each point looked up in the mask.
  constexpr int kGrid = 15;
  const double reach = 0.45 * params_.pad.side;
  int in_view = 0, red = 0;
  for (int i = 0; i < kGrid; ++i)
    for (int j = 0; j < kGrid; ++j) {
      const double u = reach * (2.0 * i / (kGrid - 1) - 1.0), v = reach * (2.0 * j / (kGrid - 1) - 1.0);
      const int set = maskAt(view, centre + u * axes[0] + v * axes[1], pad_mask_);
      if (set < 0) continue;
      ++in_view;
      red += set;
    }
  return in_view > 0 ? double(red) / in_view : 0.0;
}

std::pair<double, double> PadDetector::markerColours(const PlaneView& view, const Eigen::Vector2d& centre,
                                                     const Eigen::Vector2d (&axes)[2]) const {
  // A grid over the square (short of its edges, which the image blurs) looked up in the marker mask, and a band
  // around it (from 0.75 to 1.25 sides wide) in the red mask; only what is in view counts.
  constexpr int kGrid = 9;
  const double side = params_.pad.marker_side;
  int inside_seen = 0, white = 0, around_seen = 0, red = 0;
  for (int i = 0; i < kGrid; ++i)
    for (int j = 0; j < kGrid; ++j) {
      const double u = 2.0 * i / (kGrid - 1) - 1.0, v = 2.0 * j / (kGrid - 1) - 1.0;  // -1..1
      const int inside = maskAt(view, centre + 0.4 * side * (u * axes[0] + v * axes[1]), marker_mask_);
      if (inside >= 0) {
        ++inside_seen;
        white += inside;
      }
      if (std::max(std::abs(u), std::abs(v)) < 0.99) continue;  // the band: the grid's outer ring, scaled
      for (const double scale : {0.75, 1.25}) {
        const int outside = maskAt(view, centre + scale * side * (u * axes[0] + v * axes[1]), red_colour_);
        if (outside >= 0) {
          ++around_seen;
          red += outside;
        }
      }
    }
  // Too little of the square in view to tell: not white.
  return {inside_seen >= kGrid * kGrid / 5 ? double(white) / inside_seen : 0.0,
          around_seen > 0 ? double(red) / around_seen : 0.0};
}

bool PadDetector::findMarker(const std::vector<std::vector<cv::Point>>& outlines, const cv::Size& size,
                             const PlaneView& view, Detection& d) const {
  const auto& p = params_;
  d.reason = "no centre marker in view";
  double best_size_error = p.size_tolerance;
  for (size_t i = 0; i < white_blobs_.size(); ++i) {
    const auto& blob = white_blobs_[i];
    const double area = cv::contourArea(blob);
    if (area < p.min_strip_area_px || white_blob_red_share_[i] == 0.0) continue;  // a speck, or ground
    if (std::any_of(blob.begin(), blob.end(), [&](const cv::Point& q) { return onBorder(q, size, p.border_margin_px); })) {
      d.reason = "centre marker cut by the image border";
      continue;
    }
    // Corners of the marker's image (a small square: the rotated bounding box is close enough), on the plane.
    cv::Point2f box[4];
    toIdeal(blob, ideal_);
    cv::minAreaRect(ideal_).points(box);
    std::array<Eigen::Vector2d, 4> corners;
    bool on_plane = true;
    for (int k = 0; k < 4 && on_plane; ++k) {
      const auto q = view.pixelToPlane(box[k]);
      on_plane = q.has_value();
      if (q) corners[k] = *q;
    }
    if (!on_plane) continue;
    double side = 0.0;
    for (int k = 0; k < 4; ++k) side += (corners[(k + 1) % 4] - corners[k]).norm() / 4.0;
    const double size_error = std::abs(side / p.pad.marker_side - 1.0);
    if (size_error > best_size_error) {
      d.reason = format("white blob of %.2f m is not the %.2f m centre marker", side, p.pad.marker_side);
      continue;
    }
    // It must lie on the pad: red all around it.
    const double red_share = white_blob_red_share_[i];
    if (red_share < p.marker_min_surround) {
      d.reason = format("white blob with only %.0f%% red around it is not the centre marker", 100 * red_share);
      continue;
    }
    const Eigen::Vector2d centre = (corners[0] + corners[1] + corners[2] + corners[3]) / 4.0;
    const auto centre_px = view.planeToPixel(centre);
    if (!centre_px) continue;
    const cv::Moments m = cv::moments(blob);
    const cv::Point2f centroid(float(m.m10 / m.m00), float(m.m01 / m.m00));
    const auto enclosing = std::find_if(outlines.begin(), outlines.end(), [&](const std::vector<cv::Point>& o) {
      return cv::contourArea(o) >= p.min_area_px && cv::pointPolygonTest(o, centroid, false) >= 0;
    });
    best_size_error = size_error;
    d = Detection();
    d.found = true;
    d.marker = true;
    d.centre_px = *centre_px;
    for (int k = 0; k < 4; ++k) d.corners_px[k] = box[k];
    d.side_px = std::sqrt(area);
    d.quality = clamp01(0.9 * (1.0 - size_error));
    d.outline = enclosing != outlines.end() ? *enclosing : blob;
  }
  return d.found;
}

bool PadDetector::findCutMarker(const cv::Size& size, const PlaneView& view, Detection& d) const {
  const auto& p = params_;
  const double side = p.pad.marker_side;
  for (size_t i = 0; i < white_blobs_.size(); ++i) {
    const auto& blob = white_blobs_[i];
    if (cv::contourArea(blob) < p.min_strip_area_px || white_blob_red_share_[i] < p.marker_min_surround) continue;
    // The blob's outline away from the image border, on the plane: pieces of the marker's sides.
    std::vector<cv::Point> inner;
    for (const auto& q : blob)
      if (!onBorder(q, size, p.border_margin_px + 1.0)) inner.push_back(q);
    if (inner.size() == blob.size() || inner.size() < 8) continue;  // not cut (findMarker's), or hardly in view
    toIdeal(inner, ideal_);
    std::vector<Eigen::Vector2d> points;
    points.reserve(ideal_.size());
    for (const auto& q : ideal_)
      if (const auto on_plane = view.pixelToPlane(q)) points.push_back(*on_plane);
    if (points.size() < inner.size()) continue;
    toIdeal(blob, ideal_);
    Eigen::Vector2d inside = Eigen::Vector2d::Zero();  // where the white is: the mean of its outline, border included
    int inside_count = 0;
    for (const auto& q : ideal_) {
      if (const auto on_plane = view.pixelToPlane(q)) {
        inside += *on_plane;
        ++inside_count;
      }
    }
    if (inside_count == 0) continue;
    inside /= double(inside_count);
    // The sides' direction (modulo 90 deg) from the outline's local directions, 5 points apart.
    const int step = 5;
    double c4 = 0.0, s4 = 0.0;
    int directions = 0;
    for (size_t k = 0; k + step < points.size(); ++k) {
      const Eigen::Vector2d along = points[k + step] - points[k];
      if (along.norm() > 2.0 * step * view.metresPerPixel()) continue;  // across a gap where the border was
      const double angle = 4.0 * std::atan2(along.y(), along.x());
      c4 += std::cos(angle);
      s4 += std::sin(angle);
      ++directions;
    }
    // Their mean resultant (modulo 90 deg) at least 0.5: mostly straight and square, a few rounded corners.
    if (directions == 0 || std::hypot(c4, s4) < 0.5 * directions) {
      d.reason = "cut centre marker: its sides are not straight";
      continue;
    }
    const double theta = 0.25 * std::atan2(s4, c4);
    const Eigen::Rotation2Dd to_square(-theta), to_plane(theta);
    // Each outline point on a side across u (its u is cu +- side/2) or across v, by its local direction.
    std::vector<double> us, vs;
    for (size_t k = 0; k < points.size(); ++k) {
      const size_t a = k >= 2 ? k - 2 : 0, b = std::min(points.size() - 1, k + 2);
      const Eigen::Vector2d along = to_square * (points[b] - points[a]);
      const Eigen::Vector2d q = to_square * points[k];
      if (std::abs(along.y()) > 2.0 * std::abs(along.x())) us.push_back(q.x());  // runs along v: a side at fixed u
      else if (std::abs(along.x()) > 2.0 * std::abs(along.y())) vs.push_back(q.y());
    }
    const Eigen::Vector2d inside_square = to_square * inside;
    // A centre coordinate from the sides seen across one axis: both (their mid-point) or one (half a side
    // inwards, towards the white).
    auto place = [&](std::vector<double> values, double inside_value, double& centre) {
      if (values.size() < 6) return false;
      std::sort(values.begin(), values.end());
      const double low = values[values.size() / 10], high = values[values.size() - 1 - values.size() / 10];
      if (high - low > (1.0 + p.size_tolerance) * side) return false;
      if (high - low > 0.5 * side) {  // both sides: their distance must be the marker's
        if (std::abs(high - low - side) > p.size_tolerance * side) return false;
        centre = 0.5 * (low + high);
      } else {
        const double at = values[values.size() / 2];
        centre = inside_value > at ? at + 0.5 * side : at - 0.5 * side;
      }
      return true;
    };
    double cu = 0.0, cv_ = 0.0;
    if (!place(us, inside_square.x(), cu) || !place(vs, inside_square.y(), cv_)) {
      d.reason = "cut centre marker: too little of it in view to place its centre";
      continue;
    }
    // Every outline point must lie on the fitted square's boundary, the square's part in view must be white
    // and a band around it red: grey ground between the pad's edge and a corner of the image is as grey-white
    // in some light, and its outline has straight pieces too.
    const double tolerance = 0.25 * side;
    int off = 0;
    for (const auto& point : points) {
      const Eigen::Vector2d q = to_square * point - Eigen::Vector2d(cu, cv_);
      const double outside = std::max(std::abs(q.x()), std::abs(q.y())) - 0.5 * side;
      if (std::abs(outside) > tolerance) ++off;
    }
    if (off > int(0.1 * double(points.size()))) {
      d.reason = format("cut centre marker: %d of %d outline points off the fitted square", off, int(points.size()));
      continue;
    }
    const Eigen::Vector2d centre = to_plane * Eigen::Vector2d(cu, cv_);
    const Eigen::Vector2d axes[2] = {to_plane * Eigen::Vector2d::UnitX(), to_plane * Eigen::Vector2d::UnitY()};
    const auto [white_share, red_share] = markerColours(view, centre, axes);
    if (!(white_share >= p.min_partial_coverage && red_share >= p.marker_min_surround) ||
        !brighterThanTheRedAround(blob, planes_[red_plane_])) {
      d.reason = format("cut centre marker: the fitted square is %.0f%% white, %.0f%% red around", 100 * white_share,
                        100 * red_share);
      continue;
    }
    const auto centre_px = view.planeToPixel(centre);
    if (!centre_px) continue;
    d = Detection();
    d.found = true;
    d.marker = true;
    d.partial = true;
    d.centre_px = *centre_px;
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d corner(cu + ((k == 1 || k == 2) ? 0.5 : -0.5) * side, cv_ + (k >= 2 ? 0.5 : -0.5) * side);
      if (const auto px = view.planeToPixel(to_plane * corner)) d.corners_px[k] = *px;
    }
    d.side_px = side / view.metresPerPixel();
    d.quality = clamp01(0.6 * (1.0 - double(off) / double(points.size())));
    d.outline = blob;
    return true;
  }
  return false;
}

}  // namespace uav_vision
