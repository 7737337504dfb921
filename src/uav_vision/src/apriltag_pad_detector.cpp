#include "uav_vision/apriltag_pad_detector.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <stdexcept>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

extern "C" {
#include <apriltag/apriltag.h>
#include <apriltag/common/image_u8.h>
#include <apriltag/common/zarray.h>
#include <apriltag/tag16h5.h>
#include <apriltag/tag25h9.h>
#include <apriltag/tag36h10.h>
#include <apriltag/tag36h11.h>
#include <apriltag/tagCircle21h7.h>
#include <apriltag/tagCircle49h12.h>
#include <apriltag/tagCustom48h12.h>
#include <apriltag/tagStandard41h12.h>
#include <apriltag/tagStandard52h13.h>
}

namespace uav_vision {

namespace {

// libapriltag puts pixel centres at +0.5 (a pixel covers [i, i + 1)); OpenCV and camera_info's K at integers.
constexpr double kApriltagPixelOffset = 0.5;

struct FamilyEntry {
  const char* name;
  apriltag_family_t* (*create)();
  void (*destroy)(apriltag_family_t*);
};

const std::vector<FamilyEntry>& familyTable() {
  static const std::vector<FamilyEntry> table = {
      {"tag16h5", tag16h5_create, tag16h5_destroy},
      {"tag25h9", tag25h9_create, tag25h9_destroy},
      {"tag36h10", tag36h10_create, tag36h10_destroy},
      {"tag36h11", tag36h11_create, tag36h11_destroy},
      {"tagCircle21h7", tagCircle21h7_create, tagCircle21h7_destroy},
      {"tagCircle49h12", tagCircle49h12_create, tagCircle49h12_destroy},
      {"tagCustom48h12", tagCustom48h12_create, tagCustom48h12_destroy},
      {"tagStandard41h12", tagStandard41h12_create, tagStandard41h12_destroy},
      {"tagStandard52h13", tagStandard52h13_create, tagStandard52h13_destroy},
  };
  return table;
}

const FamilyEntry* findFamily(const std::string& name) {
  for (const auto& entry : familyTable())
    if (name == entry.name) return &entry;
  return nullptr;
}

std::string familyList() {
  std::string out;
  for (const auto& entry : familyTable()) out += (out.empty() ? "" : ", ") + std::string(entry.name);
  return out;
}

// A family of libapriltag's, created for the duration of a scope.
struct FamilyHandle {
  explicit FamilyHandle(const FamilyEntry& entry) : entry(entry), family(entry.create()) {}
  ~FamilyHandle() { entry.destroy(family); }
  FamilyHandle(const FamilyHandle&) = delete;
  FamilyHandle& operator=(const FamilyHandle&) = delete;
  const FamilyEntry& entry;
  apriltag_family_t* family;
};

// Side of the central square of cells free of data bits inside a family's border, in cells (0: none).
int holeCells(const apriltag_family_t& f) {
  const int total = f.total_width, border = f.width_at_border, offset = (total - border) / 2;
  std::vector<char> bit(size_t(total * total), 0);
  for (uint32_t i = 0; i < f.nbits; ++i) {
    const int x = int(f.bit_x[i]) + offset, y = int(f.bit_y[i]) + offset;
    if (x >= 0 && x < total && y >= 0 && y < total) bit[size_t(y * total + x)] = 1;
  }
  for (int k = border - 2; k >= 1; k -= 2) {
    const int first = (total - k) / 2;
    if ((total - k) % 2 != 0) continue;
    bool free = true;
    for (int y = first; y < first + k && free; ++y)
      for (int x = first; x < first + k && free; ++x) free = !bit[size_t(y * total + x)];
    if (free) return k;
  }
  return 0;
}

bool finitePositive(double v) { return std::isfinite(v) && v > 0.0; }

cv::Matx33d toMatx(const cv::Mat& m) {
  cv::Matx33d out;
  cv::Mat(m).convertTo(cv::Mat(3, 3, CV_64F, out.val), CV_64F);
  return out;
}

cv::Point2d apply(const cv::Matx33d& h, const cv::Point2d& p) {
  const cv::Vec3d q = h * cv::Vec3d(p.x, p.y, 1.0);
  return {q[0] / q[2], q[1] / q[2]};
}

// `image` (8-bit grey) at (x, y), bilinear; NaN off the image.
double bilinear(const cv::Mat& image, double x, double y) {
  const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= image.cols || y0 + 1 >= image.rows) return NAN;
  const double fx = x - x0, fy = y - y0;
  const uint8_t* row0 = image.ptr<uint8_t>(y0);
  const uint8_t* row1 = image.ptr<uint8_t>(y0 + 1);
  return (1 - fy) * ((1 - fx) * row0[x0] + fx * row0[x0 + 1]) + fy * ((1 - fx) * row1[x0] + fx * row1[x0 + 1]);
}

// The quad's four edges moved to the strongest gradient across them in the light `sample(x, y)` (searched within a
// third of a bit cell), refitted as lines, and the corners put at their intersections. Corners and sample points in
// ideal pixels (centres at integers); unchanged where an edge gives too little to fit.
template <typename Sample>
void refineEdges(const Sample& bilinear, double cell_px, std::array<cv::Point2d, 4>& corners) {
  const double reach = std::clamp(cell_px / 3.0, 1.0, 6.0), step = 0.25;
  std::array<cv::Vec3d, 4> lines;  // a x + b y = c, (a, b) unit
  for (int k = 0; k < 4; ++k) {
    const cv::Point2d a = corners[size_t(k)], b = corners[size_t((k + 1) % 4)];
    const double length = cv::norm(b - a);
    if (length < 4.0) return;
    const cv::Point2d along = (b - a) / length, normal(-along.y, along.x);
    const int samples = std::clamp(int(length / 2.0), 4, 40);
    double sw = 0, sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0;
    for (int i = 0; i < samples; ++i) {
      // Away from the corners, where the other edges' gradients are.
      const cv::Point2d p = a + (b - a) * (0.15 + 0.7 * (i + 0.5) / samples);
      double best = 0.0, best_s = 0.0, before = 0.0, after = 0.0;
      double previous = bilinear(p.x - (reach + step) * normal.x, p.y - (reach + step) * normal.y);
      double current = bilinear(p.x - reach * normal.x, p.y - reach * normal.y);
      double last_gradient = NAN;
      for (double s = -reach; s <= reach + 1e-9; s += step) {
        const double next = bilinear(p.x + (s + step) * normal.x, p.y + (s + step) * normal.y);
        const double gradient = std::abs(next - previous);
        if (std::isnan(gradient)) {
          best = 0.0;
          break;
        }
        if (gradient > best) {
          best = gradient;
          best_s = s;
          before = last_gradient;
          after = std::abs(bilinear(p.x + (s + 2 * step) * normal.x, p.y + (s + 2 * step) * normal.y) - current);
        }
        last_gradient = gradient;
        previous = current;
        current = next;
      }
      if (!(best > 8.0)) continue;  // no edge here (or the image border)
      double offset = best_s;
      if (std::isfinite(before) && std::isfinite(after)) {
        const double curvature = before - 2 * best + after;
        if (curvature < 0.0) offset += step * std::clamp(0.5 * (before - after) / curvature, -0.5, 0.5);
      }
      const cv::Point2d q = p + offset * normal;
      sw += best;
      sx += best * q.x;
      sy += best * q.y;
      sxx += best * q.x * q.x;
      sxy += best * q.x * q.y;
      syy += best * q.y * q.y;
    }
    if (sw <= 0.0) return;
    const double mx = sx / sw, my = sy / sw;
    const double cxx = sxx / sw - mx * mx, cxy = sxy / sw - mx * my, cyy = syy / sw - my * my;
    // The line's direction: the principal axis of the weighted points.
    const double angle = 0.5 * std::atan2(2 * cxy, cxx - cyy);
    const cv::Point2d direction(std::cos(angle), std::sin(angle));
    if (std::abs(direction.dot(along)) < 0.9) return;  // not along the edge: keep libapriltag's
    lines[size_t(k)] = cv::Vec3d(-direction.y, direction.x, -direction.y * mx + direction.x * my);
  }
  std::array<cv::Point2d, 4> refined;
  for (int k = 0; k < 4; ++k) {
    // Corner k joins the edge before it (k - 1 -> k) and the edge from it (k -> k + 1).
    const cv::Vec3d& l1 = lines[size_t((k + 3) % 4)];
    const cv::Vec3d& l2 = lines[size_t(k)];
    const double det = l1[0] * l2[1] - l1[1] * l2[0];
    if (std::abs(det) < 1e-6) return;
    refined[size_t(k)] = {(l1[2] * l2[1] - l1[1] * l2[2]) / det, (l1[0] * l2[2] - l1[2] * l2[0]) / det};
    if (cv::norm(refined[size_t(k)] - corners[size_t(k)]) > 2.0 * reach) return;  // a wild fit: keep libapriltag's
  }
  corners = refined;
}

}  // namespace

const std::vector<std::string>& apriltagFamilies() {
  static const std::vector<std::string> names = [] {
    std::vector<std::string> out;
    for (const auto& entry : familyTable()) out.push_back(entry.name);
    return out;
  }();
  return names;
}

// ---------------------------------------------------------------------------------------------------------------
// Geometry of the layout

double AprilTagPadDetector::fullWidth(const TagSpec& tag) {
  const FamilyEntry* entry = findFamily(tag.family);
  if (!entry) throw std::invalid_argument("unknown tag family '" + tag.family + "' (built for: " + familyList() + ")");
  FamilyHandle f(*entry);
  return tag.size * f.family->total_width / f.family->width_at_border;
}

double AprilTagPadDetector::holeWidth(const TagSpec& tag) {
  const FamilyEntry* entry = findFamily(tag.family);
  if (!entry) throw std::invalid_argument("unknown tag family '" + tag.family + "' (built for: " + familyList() + ")");
  FamilyHandle f(*entry);
  return tag.size * holeCells(*f.family) / f.family->width_at_border;
}

std::array<cv::Point2d, 4> AprilTagPadDetector::tagCornersOnPad(const TagSpec& tag) {
  // Tag coordinates (u right along the tag image's columns, v down its rows, +-1 at the detection square)
  // on the pad: the tag image's top towards the pad's forward (x), its columns to the pad's right (-y).
  const double half = tag.size / 2.0;
  auto onPad = [half](double u, double v) { return cv::Point2d(-v * half, -u * half); };
  return {onPad(-1, 1), onPad(1, 1), onPad(1, -1), onPad(-1, -1)};
}

std::string AprilTagPadDetector::validate(const AprilTagPadParams& p) {
  auto in = [](double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; };
  std::vector<std::unique_ptr<FamilyHandle>> families;
  for (const auto& [key, tag] : {std::pair<const char*, const TagSpec&>{"apriltag/outer", p.layout.outer},
                                 {"apriltag/inner", p.layout.inner}}) {
    const FamilyEntry* entry = findFamily(tag.family);
    if (!entry)
      return std::string(key) + "/family: '" + tag.family + "' is not a tag family this detector is built for (" +
             familyList() + ")";
    families.push_back(std::make_unique<FamilyHandle>(*entry));
    const apriltag_family_t& f = *families.back()->family;
    if (tag.id < 0 || uint32_t(tag.id) >= f.ncodes)
      return std::string(key) + "/id: " + std::to_string(tag.id) + " is not a tag of " + tag.family + " (ids 0.." +
             std::to_string(f.ncodes - 1) + ")";
    if (!(finitePositive(tag.size) && tag.size < 20.0))
      return std::string(key) + "/size: the tag's detection square must be a positive size in metres, got " +
             std::to_string(tag.size);
    if (!in(p.max_hamming, 0, 3) || 2 * p.max_hamming >= int(f.h))
      return "apriltag/max_hamming must be in [0, 3] and below half of " + tag.family + "'s distance (" +
             std::to_string(f.h) + ")";
  }
  const auto& outer = p.layout.outer;
  const auto& inner = p.layout.inner;
  if (outer.family == inner.family && outer.id == inner.id)
    return "apriltag/inner: the same tag as apriltag/outer (" + outer.family + " id " + std::to_string(outer.id) +
           "): give the inner tag another id or family";
  const apriltag_family_t& fo = *families[0]->family;
  const apriltag_family_t& fi = *families[1]->family;
  const double hole = outer.size * holeCells(fo) / fo.width_at_border;
  if (hole <= 0.0)
    return "apriltag/outer/family: " + outer.family +
           " has no hole at its centre for the inner tag; use a family with one (tagCustom48h12)";
  const double inner_width = inner.size * fi.total_width / fi.width_at_border;
  if (inner_width > hole + 1e-9) {
    char buffer[256];
    std::snprintf(buffer, sizeof(buffer),
                  "apriltag/inner/size: a %s of %.3f m is %.3f m wide with its border, more than the %.3f m hole at "
                  "the outer tag's centre: at most %.3f m",
                  inner.family.c_str(), inner.size, inner_width, hole, hole * fi.width_at_border / fi.total_width);
    return buffer;
  }
  const double pad_half = 0.5 * outer.size * fo.total_width / fo.width_at_border;
  if (!(std::isfinite(p.heading_offset) && p.heading_offset > 0.0 && p.heading_offset <= pad_half))
    return "apriltag/heading_offset must be positive and on the pad (at most half its side)";
  if (!in(p.min_decision_margin, 0.0, 255.0)) return "apriltag/min_decision_margin must be in [0, 255]";
  if (!in(p.quad_decimate, 1.0, 8.0)) return "apriltag/quad_decimate must be in [1, 8]";
  if (!in(p.close_quad_decimate, 1.0, 8.0)) return "apriltag/close_quad_decimate must be in [1, 8]";
  if (!in(p.close_height, 0.0, 100.0)) return "apriltag/close_height must be in [0, 100] m";
  if (!in(p.quad_sigma, 0.0, 5.0)) return "apriltag/quad_sigma must be in [0, 5] px";
  if (!in(p.denoise_sigma, 0.0, 5.0)) return "apriltag/denoise_sigma must be in [0, 5] px";
  if (!in(p.shadow_lift, 0.0, 1000.0)) return "apriltag/shadow_lift must be in [0, 1000] grey levels (0: off)";
  if (!in(p.min_white_black_diff, 0, 255)) return "apriltag/min_white_black_diff must be in [0, 255]";
  if (!in(p.min_cluster_pixels, 1, 10000)) return "apriltag/min_cluster_pixels must be in [1, 10000]";
  if (!in(p.decode_sharpening, 0.0, 2.0)) return "apriltag/decode_sharpening must be in [0, 2]";
  if (!in(p.size_tolerance, 0.01, 0.9)) return "apriltag/size_tolerance must be in [0.01, 0.9]";
  if (!in(p.max_layout_error_px, 0.1, 100.0)) return "apriltag/max_layout_error_px must be in [0.1, 100]";
  if (!in(p.min_cell_px, 0.0, 100.0)) return "apriltag/min_cell_px must be in [0, 100]";
  return "";
}

cv::Mat AprilTagPadDetector::topView(const AprilTagPadLayout& layout, int pixels) {
  AprilTagPadParams params;
  params.layout = layout;
  if (const std::string problem = validate(params); !problem.empty()) throw std::invalid_argument(problem);
  if (pixels < 16) throw std::invalid_argument("topView: at least 16 pixels");
  struct Bitmap {
    cv::Mat cells;  // total_width square, 0 black, 255 white
    double width;   // [m]
  };
  auto bitmap = [](const TagSpec& tag) {
    FamilyHandle f(*findFamily(tag.family));
    image_u8_t* im = apriltag_to_image(f.family, tag.id);
    cv::Mat cells(im->height, im->width, CV_8U);
    for (int y = 0; y < im->height; ++y)
      for (int x = 0; x < im->width; ++x) cells.at<uint8_t>(y, x) = im->buf[y * im->stride + x] ? 255 : 0;
    image_u8_destroy(im);
    return Bitmap{cells, tag.size * f.family->total_width / f.family->width_at_border};
  };
  const Bitmap outer = bitmap(layout.outer), inner = bitmap(layout.inner);
  cv::Mat view(pixels, pixels, CV_8U);
  for (int row = 0; row < pixels; ++row) {
    for (int col = 0; col < pixels; ++col) {
      // The pad point under the pixel's centre: image up = forward, image right = the pad's right.
      const double forward = outer.width * (0.5 - (row + 0.5) / pixels);
      const double left = outer.width * (0.5 - (col + 0.5) / pixels);
      const Bitmap& b = (std::abs(forward) < inner.width / 2 && std::abs(left) < inner.width / 2) ? inner : outer;
      // Tag image: its top row forward, its columns to the right.
      const int n = b.cells.cols;
      const int tag_col = std::clamp(int(std::floor((b.width / 2 - left) / b.width * n)), 0, n - 1);
      const int tag_row = std::clamp(int(std::floor((b.width / 2 - forward) / b.width * n)), 0, n - 1);
      view.at<uint8_t>(row, col) = b.cells.at<uint8_t>(tag_row, tag_col);
    }
  }
  return view;
}

// ---------------------------------------------------------------------------------------------------------------
// Detector

struct AprilTagPadDetector::Impl {
  // A dictionary of the pad's codes of one family: libapriltag decodes nothing else.
  struct Dictionary {
    std::unique_ptr<FamilyHandle> base;
    apriltag_family_t restricted{};
    std::vector<uint64_t> codes;
    std::vector<bool> outer;  // per code: the outer tag, else the inner one
    std::string name;
  };
  apriltag_detector_t* detector = nullptr;
  std::vector<std::unique_ptr<Dictionary>> dictionaries;
  cv::Mat grey, lifted, smooth, ideal, map1, map2;
  cv::Mat shadow_table;  // 256 entries: params.shadow_lift's logarithm
  cv::Mat linear;        // the frame's grey image as the camera gave it, smoothed (the edges are refined on it)
  CameraIntrinsics map_camera;  // of map1/map2
  int margin_left = 0, margin_top = 0;  // the pinhole canvas's margins beyond the K-sized ideal frame [px]
  bool have_map = false;

  ~Impl() {
    if (detector) apriltag_detector_destroy(detector);  // frees the dictionaries' decode tables
  }
};

AprilTagPadDetector::AprilTagPadDetector(const AprilTagPadParams& params) : params_(params), impl_(new Impl) {
  if (const std::string problem = validate(params); !problem.empty()) throw std::invalid_argument(problem);
  for (const TagSpec* tag : {&params.layout.outer, &params.layout.inner}) {
    Impl::Dictionary* dictionary = nullptr;
    for (auto& d : impl_->dictionaries)
      if (d->name == tag->family) dictionary = d.get();
    if (!dictionary) {
      impl_->dictionaries.push_back(std::make_unique<Impl::Dictionary>());
      dictionary = impl_->dictionaries.back().get();
      dictionary->base = std::make_unique<FamilyHandle>(*findFamily(tag->family));
      dictionary->name = tag->family;
    }
    dictionary->codes.push_back(dictionary->base->family->codes[tag->id]);
    dictionary->outer.push_back(tag == &params.layout.outer);
  }
  if (params.shadow_lift > 0.0) {
    impl_->shadow_table.create(1, 256, CV_8U);
    const double k = params.shadow_lift;
    for (int v = 0; v < 256; ++v)
      impl_->shadow_table.at<uint8_t>(v) = cv::saturate_cast<uint8_t>(255.0 * std::log1p(v / k) / std::log1p(255.0 / k));
  }
  impl_->detector = apriltag_detector_create();
  apriltag_detector_t* td = impl_->detector;
  td->nthreads = 1;
  td->quad_decimate = float(params.quad_decimate);
  td->quad_sigma = float(params.quad_sigma);
  td->refine_edges = true;
  td->decode_sharpening = params.decode_sharpening;
  td->debug = false;
  td->qtp.min_white_black_diff = params.min_white_black_diff;
  td->qtp.min_cluster_pixels = params.min_cluster_pixels;
  for (auto& d : impl_->dictionaries) {
    // The family's geometry (bit positions, border) with the pad's codes only.
    d->restricted = *d->base->family;
    d->restricted.codes = d->codes.data();
    d->restricted.ncodes = uint32_t(d->codes.size());
    d->restricted.name = d->name.data();
    d->restricted.impl = nullptr;
    apriltag_detector_add_family_bits(td, &d->restricted, params.max_hamming);
  }
}

AprilTagPadDetector::~AprilTagPadDetector() = default;

Detection AprilTagPadDetector::detect(const cv::Mat& image, ColorOrder order, const PlaneView* view) const {
  return run(image, order, view ? &view->intrinsics() : nullptr, view);
}

Detection AprilTagPadDetector::detect(const cv::Mat& image, ColorOrder order, const CameraIntrinsics& intrinsics) const {
  return run(image, order, &intrinsics, nullptr);
}

Detection AprilTagPadDetector::run(const cv::Mat& image, ColorOrder order, const CameraIntrinsics* intrinsics,
                                   const PlaneView* view) const {
  Detection d;
  tags_.clear();
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 3 && image.channels() != 1)) {
    d.reason = "the image must be 8-bit with 3 channels (or grey)";
    return d;
  }
  if (intrinsics && (intrinsics->width != image.cols || intrinsics->height != image.rows)) {
    d.reason = "the image is not the size of the camera's intrinsics";
    return d;
  }
  Impl& m = *impl_;
  if (image.channels() == 3)
    cv::cvtColor(image, m.grey, order == ColorOrder::kRgb ? cv::COLOR_RGB2GRAY : cv::COLOR_BGR2GRAY);
  else
    m.grey = image;
  if (params_.shadow_lift > 0.0) {
    // The light as the camera gave it, smoothed as libapriltag's image is (the edges are refined on it).
    if (params_.denoise_sigma > 0.0)
      cv::GaussianBlur(m.grey, m.linear, cv::Size(0, 0), params_.denoise_sigma);
    else
      m.linear = m.grey;
    // The logarithm of the light, into a buffer of its own (m.grey may be the caller's image).
    cv::LUT(m.grey, m.shadow_table, m.lifted);
    m.grey = m.lifted;
  }
  if (params_.denoise_sigma > 0.0) {
    cv::GaussianBlur(m.grey, m.smooth, cv::Size(0, 0), params_.denoise_sigma);
    m.grey = m.smooth;
  }
  const cv::Mat* ideal = &m.grey;
  cv::Point2d canvas_offset(0.0, 0.0);  // ideal pixel = canvas pixel - this
  if (intrinsics && intrinsics->distorted()) {
    // The whole grey image through the lens once: libapriltag's straight-edge quads need a pinhole image. The
    // pinhole canvas is larger than the image by what the lens pulled in at its border (a barrel lens shows more
    // than a pinhole of the same K would: a tag in an image corner lies partly outside the K-sized ideal frame).
    if (!m.have_map || m.map_camera != *intrinsics) {
      const auto& k = *intrinsics;
      const cv::Matx33d camera(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
      std::vector<cv::Point2f> border, undistorted;
      for (int x = 0; x < k.width; x += 4) border.insert(border.end(), {{float(x), 0.0f}, {float(x), float(k.height - 1)}});
      for (int y = 0; y < k.height; y += 4) border.insert(border.end(), {{0.0f, float(y)}, {float(k.width - 1), float(y)}});
      border.emplace_back(float(k.width - 1), float(k.height - 1));
      cv::undistortPoints(border, undistorted, camera, k.distortion, cv::noArray(), camera);
      double low_x = 0.0, high_x = k.width - 1, low_y = 0.0, high_y = k.height - 1;
      for (const auto& p : undistorted) {
        low_x = std::min(low_x, double(p.x));
        high_x = std::max(high_x, double(p.x));
        low_y = std::min(low_y, double(p.y));
        high_y = std::max(high_y, double(p.y));
      }
      // At most half the image on each side (a lens that bends more is not one this detector is for).
      m.margin_left = std::min(int(std::ceil(-low_x)) + 1, k.width / 2);
      m.margin_top = std::min(int(std::ceil(-low_y)) + 1, k.height / 2);
      const int right = std::min(int(std::ceil(high_x - (k.width - 1))) + 1, k.width / 2);
      const int bottom = std::min(int(std::ceil(high_y - (k.height - 1))) + 1, k.height / 2);
      const cv::Matx33d canvas(k.fx, 0, k.cx + m.margin_left, 0, k.fy, k.cy + m.margin_top, 0, 0, 1);
      const cv::Size size(k.width + m.margin_left + right, k.height + m.margin_top + bottom);
      cv::initUndistortRectifyMap(camera, k.distortion, cv::noArray(), canvas, size, CV_16SC2, m.map1, m.map2);
      m.map_camera = k;
      m.have_map = true;
    }
    cv::remap(m.grey, m.ideal, m.map1, m.map2, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    ideal = &m.ideal;
    canvas_offset = cv::Point2d(m.margin_left, m.margin_top);
  }
  image_u8_t im{ideal->cols, ideal->rows, int32_t(ideal->step[0]), ideal->data};
  m.detector->quad_decimate =
      float(view && view->cameraHeight() < params_.close_height ? params_.close_quad_decimate : params_.quad_decimate);
  zarray_t* found = apriltag_detector_detect(m.detector, &im);
  for (int i = 0; i < zarray_size(found); ++i) {
    apriltag_detection_t* det = nullptr;
    zarray_get(found, i, &det);
    const Impl::Dictionary* dictionary = nullptr;
    for (const auto& dict : m.dictionaries)
      if (&dict->restricted == det->family) dictionary = dict.get();
    if (!dictionary || det->id < 0 || size_t(det->id) >= dictionary->codes.size()) continue;  // not the pad's
    TagSighting s;
    s.outer = dictionary->outer[size_t(det->id)];
    double perimeter = 0.0;
    for (int k = 0; k < 4; ++k) perimeter += std::hypot(det->p[k][0] - det->p[(k + 1) % 4][0], det->p[k][1] - det->p[(k + 1) % 4][1]);
    s.cell_px = perimeter / 4.0 / dictionary->restricted.width_at_border;
    s.hamming = det->hamming;
    s.decision_margin = det->decision_margin;
    std::array<cv::Point2d, 4> corners;
    for (int k = 0; k < 4; ++k)
      corners[size_t(k)] = cv::Point2d(det->p[k][0] - kApriltagPixelOffset, det->p[k][1] - kApriltagPixelOffset);
    for (int k = 0; k < 4; ++k) corners[size_t(k)] -= canvas_offset;
    if (params_.shadow_lift > 0.0) {
      // The logarithm moved the edges towards the dark side (by a fraction of the blur): back to the light's, on the
      // camera's image (through the lens: each ideal sample point's pixel).
      if (intrinsics && intrinsics->distorted())
        refineEdges([&](double x, double y) {
          const cv::Point2d p = distortPixel(*intrinsics, {x, y});
          return bilinear(m.linear, p.x, p.y);
        }, s.cell_px, corners);
      else
        refineEdges([&](double x, double y) { return bilinear(m.linear, x, y); }, s.cell_px, corners);
    }
    s.corners_px = corners;
    tags_.push_back(s);
  }
  apriltag_detections_destroy(found);

  // Which of the decoded tags are the pad's: sure enough, the right size at the camera height, one of each.
  const AprilTagPadLayout& layout = params_.layout;
  char buffer[256];
  for (TagSighting& s : tags_) {
    const TagSpec& spec = s.outer ? layout.outer : layout.inner;
    const char* which = s.outer ? "outer" : "inner";
    if (s.cell_px < params_.min_cell_px) {
      std::snprintf(buffer, sizeof(buffer), "the %s tag's bit cells are %.1f px, under %.1f px", which, s.cell_px,
                    params_.min_cell_px);
      s.rejection = buffer;
      continue;
    }
    if (s.decision_margin < params_.min_decision_margin) {
      std::snprintf(buffer, sizeof(buffer), "the %s tag decoded with too small a margin (%.0f < %.0f)", which,
                    s.decision_margin, params_.min_decision_margin);
      s.rejection = buffer;
      continue;
    }
    if (view) {
      double sum = 0.0;
      bool on_plane = true;
      std::array<Eigen::Vector2d, 4> plane;
      for (int k = 0; k < 4 && on_plane; ++k) {
        const auto p = view->pixelToPlane(s.corners_px[size_t(k)]);
        on_plane = bool(p);
        if (p) plane[size_t(k)] = *p;
      }
      if (!on_plane) {
        s.rejection = std::string("the ") + which + " tag does not project onto the pad plane";
        continue;
      }
      for (int k = 0; k < 4; ++k) sum += (plane[size_t(k)] - plane[size_t((k + 1) % 4)]).norm();
      const double measured = sum / 4.0;
      if (std::abs(measured / spec.size - 1.0) > params_.size_tolerance) {
        std::snprintf(buffer, sizeof(buffer),
                      "the %s tag measures %.3f m at the camera height %.2f m, not %.3f m (a wrong height, or "
                      "another tag with the pad's code)",
                      which, measured, view->cameraHeight(), spec.size);
        s.rejection = buffer;
        continue;
      }
    }
    s.accepted = true;
  }
  const std::array<cv::Point2d, 4> outer_on_pad = tagCornersOnPad(layout.outer);
  const std::array<cv::Point2d, 4> inner_on_pad = tagCornersOnPad(layout.inner);
  auto rejectCopies = [this](bool outer) {
    int count = 0;
    for (const TagSighting& s : tags_) count += s.accepted && s.outer == outer;
    if (count < 2) return;
    for (TagSighting& s : tags_)
      if (s.accepted && s.outer == outer) {
        s.accepted = false;
        s.rejection = std::string("two copies of the ") + (outer ? "outer" : "inner") + " tag in view: ambiguous";
      }
  };
  rejectCopies(true);
  TagSighting* outer_tag = nullptr;
  for (TagSighting& s : tags_)
    if (s.accepted && s.outer) outer_tag = &s;
  if (outer_tag) {
    // An inner tag must lie where the outer one puts the hole (else it is another print of its code).
    const cv::Matx33d h = toMatx(cv::getPerspectiveTransform(
        std::vector<cv::Point2f>(outer_on_pad.begin(), outer_on_pad.end()),
        std::vector<cv::Point2f>(outer_tag->corners_px.begin(), outer_tag->corners_px.end())));
    for (TagSighting& s : tags_) {
      if (!s.accepted || s.outer) continue;
      double worst = 0.0;
      for (int k = 0; k < 4; ++k)
        worst = std::max(worst, cv::norm(apply(h, inner_on_pad[size_t(k)]) - s.corners_px[size_t(k)]));
      if (worst > params_.max_layout_error_px) {
        std::snprintf(buffer, sizeof(buffer), "the inner tag is %.1f px from where the outer tag puts it", worst);
        s.accepted = false;
        s.rejection = buffer;
      }
    }
  }
  rejectCopies(false);
  TagSighting* inner_tag = nullptr;
  for (TagSighting& s : tags_)
    if (s.accepted && !s.outer) inner_tag = &s;
  if (!outer_tag && !inner_tag) {
    if (tags_.empty()) {
      d.reason = "no tag of the pad in view";
    } else {
      // The outer tag's reason first: it is the one that should have been seen.
      d.reason = tags_.front().rejection;
      for (const TagSighting& t : tags_)
        if (t.outer) d.reason = t.rejection;
    }
    return d;
  }

  // The pad plane (metres, pad coordinates) -> ideal pixels, from every corner of the tags used.
  std::vector<cv::Point2f> on_pad, in_image;
  std::vector<cv::Point3f> object;
  double margin_sum = 0.0;
  int used = 0;
  for (const TagSighting* s : {outer_tag, inner_tag}) {
    if (!s) continue;
    const auto& corners = s->outer ? outer_on_pad : inner_on_pad;
    for (int k = 0; k < 4; ++k) {
      on_pad.emplace_back(corners[size_t(k)]);
      in_image.emplace_back(s->corners_px[size_t(k)]);
      object.emplace_back(float(corners[size_t(k)].x), float(corners[size_t(k)].y), 0.0f);
    }
    margin_sum += s->decision_margin;
    ++used;
  }
  const cv::Mat homography =
      on_pad.size() == 4 ? cv::getPerspectiveTransform(on_pad, in_image) : cv::findHomography(on_pad, in_image, 0);
  if (homography.rows != 3 || homography.cols != 3) {
    d.reason = "the tags' corners give no homography (degenerate)";
    return d;
  }
  const cv::Matx33d h = toMatx(homography);
  const double half = fullWidth(layout.outer) / 2.0;
  d.found = true;
  d.centre_px = apply(h, {0.0, 0.0});
  d.strip_found = true;
  d.strip_centre_px = apply(h, {params_.heading_offset, 0.0});
  const cv::Point2d square[4] = {{half, half}, {-half, half}, {-half, -half}, {half, -half}};
  double sides = 0.0;
  std::vector<cv::Point2f> square_px;
  for (int k = 0; k < 4; ++k) {
    d.corners_px[size_t(k)] = apply(h, square[k]);
    square_px.emplace_back(d.corners_px[size_t(k)]);
  }
  for (int k = 0; k < 4; ++k) sides += cv::norm(d.corners_px[size_t(k)] - d.corners_px[size_t((k + 1) % 4)]);
  d.side_px = sides / 4.0;
  d.marker = !outer_tag;  // the inner tag alone: the last metre
  d.partial = false;
  d.quality = std::clamp(margin_sum / used / 100.0, 0.0, 1.0);
  if (intrinsics) {
    d.optical_axis_margin_px = cv::pointPolygonTest(square_px, cv::Point2f(float(intrinsics->cx), float(intrinsics->cy)),
                                                    true);
    // The outline to draw: the pad's square through the lens (image pixels).
    for (int k = 0; k < 4; ++k)
      for (int j = 0; j < 8; ++j) {
        const cv::Point2d a = square[k], b = square[(k + 1) % 4];
        const cv::Point2d p = distortPixel(*intrinsics, apply(h, a + (b - a) * (j / 8.0)));
        d.outline.emplace_back(int(std::lround(p.x)), int(std::lround(p.y)));
      }
    // The pose from the tags' known sizes and K (no height needed).
    const cv::Matx33d camera(intrinsics->fx, 0, intrinsics->cx, 0, intrinsics->fy, intrinsics->cy, 0, 0, 1);
    cv::Vec3d rvec, tvec;
    if (cv::solvePnP(object, in_image, camera, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_IPPE) &&
        tvec[2] > 0.0) {
      d.pose_found = true;
      d.pad_in_camera = tvec;
      cv::Rodrigues(rvec, d.pad_axes_in_camera);
    }
  } else {
    d.optical_axis_margin_px = cv::pointPolygonTest(square_px, cv::Point2f(float((image.cols - 1) / 2.0),
                                                                            float((image.rows - 1) / 2.0)), true);
  }
  if (view) d.expected_side_px = 2.0 * half * view->intrinsics().fx / view->cameraHeight();
  return d;
}

}  // namespace uav_vision
