// Red landing-pad detector for the bottom camera (ROS-free).
//
// Pipeline (thesis ch. 3.3.2, made robust): colour masks from the channels' differences (red: R well above
// G and B, also in a shadow; the green heading strip is added to the pad mask so it does not cut the
// outline), a majority vote over each pixel's 3x3 neighbourhood against sensor noise, morphological
// opening, outer contours, then per contour:
//  - whole pad (not touching the image border): polygon approximation to 4 corners, corners refined
//    by fitting lines to the contour's edges, centre = intersection of the diagonals (the projection
//    of the square's centre, exact under perspective); shape checks (convexity, solidity, side ratio,
//    corner angles) and, when the view geometry is known, the metric size and right angles;
//  - pad cut by the image border: the visible edges (and the strip's) are back-projected onto the pad
//    plane and a 1 m square with its strip is fitted to them, which needs the view geometry;
//  - close range (no whole pad): the white centre marker, wholly in view and surrounded by red, is the
//    pad centre. In the last half metre above the pad the red fills the image and has no edge in view.
//    Cut by the image border (the drone 0.1-0.25 m off the centre), a square of the marker's size is fitted
//    to its sides in view (both of their directions needed), checked white inside and red around.
// The green strip's centre gives the pad's forward direction.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "uav_vision/camera_geometry.h"

namespace uav_vision {

enum class ColorOrder { kRgb, kBgr };

// The physical target [m] (docs/conventions.md).
struct PadModel {
  double side = 1.0;           // side of the red square
  double strip_length = 0.7;   // green strip, across the pad (along the pad's left axis)
  double strip_width = 0.12;   // green strip, along the pad's forward axis
  double strip_offset = 0.36;  // strip centre ahead of the pad centre
  double marker_side = 0.14;   // white square at the pad centre
};

struct PadDetectorParams {
  PadModel pad;
  // Colours by the channels' differences, which a shadow or the exposure scales but does not change in
  // kind: the pad's red in the drone's shadow (about 65, 8, 8) is as red as in the sun (217, 38, 38),
  // and the grey ground never has one channel this far above both others. Channels 0..255.
  int red_margin_min = 20;     // red: R - max(G, B) at least this
  int green_margin_min = 20;   // the heading strip: G - max(R, B) at least this
  int marker_chroma_max = 40;  // the white marker: max - min of the channels at most this (grey-white) ...
  int marker_value_min = 40;   // ... and its darkest channel at least this (in the drone's shadow it is about 70)
  int morphology_kernel_px = 3;          // opening removes specks smaller than this [px]; 1 = off
  double min_area_px = 60.0;             // smaller blobs are not considered [px^2]
  double min_solidity = 0.9;             // contour area / convex hull area
  double approx_epsilon = 0.04;          // approxPolyDP tolerance, fraction of the perimeter
  double max_side_ratio = 1.8;           // longest / shortest side in the image (perspective)
  double max_corner_angle_error_deg = 25.0;  // image corners' deviation from 90 deg
  double size_tolerance = 0.3;           // relative error of the measured side allowed vs pad.side
  double max_edge_angle_error_deg = 10.0;    // pad edges' deviation from right angles on the plane
  double border_margin_px = 1.5;         // outline this close to the image edge is the frame, not the pad
  double min_edge_length_px = 10.0;      // shorter straight pieces of outline are ignored
  double fit_tolerance_m = 0.06;         // partial pads: outline may stray this far from the fitted square
  double min_partial_support_px = 30.0;  // partial pads: visible edge needed to place the centre along each axis [px]
  double min_partial_coverage = 0.8;     // partial pads: share of the fitted square's part in view that must be pad-coloured
  double min_corner_image_share = 0.03;  // partial pads seen by one corner only (no strip, no opposite edges): of the image
  double max_off_edge_share = 0.05;      // partial pads: share of the outline (away from the border) off the fitted square's edges
  double edge_gap_tolerance = 0.07;      // partial pads: opposite edges' distance may differ from pad.side by this fraction
  double min_strip_area_px = 10.0;       // smaller green blobs are not the strip [px^2]
  double marker_min_surround = 0.6;      // share of red in a band around a white blob for it to be the marker
};

// Pixel positions are ideal (undistorted pinhole) pixels of the camera's K, except `outline`, which is in the
// image as it came (to draw on it). Without lens distortion the two are the same.
struct Detection {
  bool found = false;
  std::string reason;               // why nothing was found (the best candidate's rejection)
  cv::Point2d centre_px;            // projection of the pad centre, subpixel; outside the image possibly when partial
  double side_px = 0.0;             // mean side length in the image [px]
  std::array<cv::Point2d, 4> corners_px{};  // pad corners, in order around the square (fitted ones when partial)
  bool partial = false;             // pad cut by the image border; centre completed from edges, corners, strip
  bool marker = false;              // found by the centre marker (close range); corners_px are the marker's
  bool strip_found = false;         // green heading strip seen inside the pad
  cv::Point2d strip_centre_px;      // its centre (moments centroid; the fitted centre when the strip is cut)
  double expected_side_px = 0.0;    // pad side expected from the camera height, 0 when unknown [px]
  double quality = 0.0;             // 0..1: shape, size and fit agreement
  double optical_axis_margin_px = 0.0;  // signed distance of the principal point to the pad outline (+ inside)
  std::vector<cv::Point> outline;   // pad outline in the image (image pixels, not undistorted)
  // AprilTag pad (AprilTagPadDetector) only: the pad's pose from the tags' known sizes and K, no height needed.
  bool pose_found = false;
  cv::Vec3d pad_in_camera;          // pad centre in the camera's optical frame (x right, y down, z out) [m]
  cv::Matx33d pad_axes_in_camera;   // columns: the pad's forward, left and up axes in the optical frame
};

// Not thread-safe: keeps its work images between calls (one detector per thread).
class PadDetector {
 public:
  explicit PadDetector(const PadDetectorParams& params = PadDetectorParams());

  // Empty when the parameters make sense, else the first problem, naming the parameter.
  static std::string validate(const PadDetectorParams& params);

  // image: 8-bit, 3 channels, in `order`. view: camera intrinsics (with the lens distortion: the outlines
  // are undistorted point by point), attitude and height above the pad plane; without it, the size cannot
  // be checked against the height and a pad cut by the image border is rejected (its centre cannot be
  // completed without metric scale).
  Detection detect(const cv::Mat& image, ColorOrder order, const PlaneView* view = nullptr) const;

  const PadDetectorParams& params() const { return params_; }
  // The last frame's masks (for debugging and tests).
  const cv::Mat& padMask() const { return pad_mask_; }
  const cv::Mat& stripMask() const { return strip_mask_; }
  const cv::Mat& markerMask() const { return marker_mask_; }

 private:
  struct Candidate;
  // max_marker_area_px: white blobs larger than this are not the centre marker [px^2].
  void computeMasks(const cv::Mat& image, ColorOrder order, double max_marker_area_px) const;
  // Whether a white blob is at least about as bright in the R channel as the red pixels around it.
  bool brighterThanTheRedAround(const std::vector<cv::Point>& blob, const cv::Mat& red_channel) const;
  // Share of red pixels in a band around a blob (clipped by the image border) [0..1].
  double redShareAround(const std::vector<cv::Point>& blob, const cv::Size& size) const;
  // The lens of `view` (built on first use and kept), or null for a perfect lens or no view.
  const LensUndistortion* lensOf(const PlaneView* view) const;
  // Image points -> ideal pixels.
  void toIdeal(const std::vector<cv::Point>& pixels, std::vector<cv::Point2f>& ideal) const;
  // `outline` in image pixels, `ideal` the same points undistorted.
  Candidate evaluate(const std::vector<cv::Point>& outline, const std::vector<cv::Point2f>& ideal, const cv::Size& size,
                     const PlaneView* view) const;
  bool evaluateWhole(const std::vector<cv::Point>& outline, const std::vector<cv::Point2f>& ideal,
                     const PlaneView* view, Candidate& candidate) const;
  bool evaluatePartial(const std::vector<cv::Point>& outline, const std::vector<cv::Point2f>& ideal,
                       const cv::Size& size, const PlaneView& view, Candidate& candidate) const;
  // The share of a square of the pad's size (centre and axes on the plane) that is pad-coloured, of its part
  // in view [0..1].
  double redCoverage(const PlaneView& view, const Eigen::Vector2d& centre, const Eigen::Vector2d (&axes)[2]) const;
  // `point` on the plane looked up in `mask` (image-sized): 1 set, 0 not, -1 not in view (off the image or within
  // border_margin_px of its edge).
  int maskAt(const PlaneView& view, const Eigen::Vector2d& point, const cv::Mat& mask) const;
  // Index in strip_outlines_ of the largest strip inside `outline`, or -1.
  int findStrip(const std::vector<cv::Point>& outline) const;
  // The centre marker (a white blob of computeMasks) inside one of the red `outlines`; false (with
  // d.reason) when none qualifies.
  bool findMarker(const std::vector<std::vector<cv::Point>>& outlines, const cv::Size& size, const PlaneView& view,
                  Detection& d) const;
  // The centre marker cut by the image border (close range, the drone 0.1-0.25 m off the centre): a square of
  // the marker's size fitted to its sides in view, which must show both of its directions; false (with
  // d.reason) when none qualifies.
  bool findCutMarker(const cv::Size& size, const PlaneView& view, Detection& d) const;
  // Of a marker-sized square (centre and axes on the plane): the share of its part in view that is white, and of
  // a band around it that is red [0..1].
  std::pair<double, double> markerColours(const PlaneView& view, const Eigen::Vector2d& centre,
                                          const Eigen::Vector2d (&axes)[2]) const;

  PadDetectorParams params_;
  cv::Mat kernel_;
  mutable cv::Mat planes_[3], max_of_two_, margin_, channel_max_, channel_min_, red_colour_, pad_mask_, strip_mask_,
      marker_mask_;
  mutable std::vector<std::vector<cv::Point>> strip_outlines_, white_blobs_;
  mutable std::vector<std::vector<cv::Point2f>> strip_ideal_;  // strip_outlines_ undistorted
  mutable std::vector<cv::Point2f> ideal_;                     // work buffer
  mutable std::shared_ptr<const LensUndistortion> lens_;      // of the last distorted camera seen
  mutable const LensUndistortion* frame_lens_ = nullptr;       // of the frame in work (null: no distortion)
  mutable std::vector<double> white_blob_red_share_;  // per white blob, redShareAround
  mutable int red_plane_ = 0;                          // index of the red channel in planes_
};

}  // namespace uav_vision
