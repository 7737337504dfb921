// Fiducial landing pad: AprilTags on the pad, found with libapriltag (ROS-free).
//
// The pad carries two tags, both centred on the pad centre with their axes along the pad's: a large outer tag
// that fills the pad (seen whole from about 1.1 m up to 6 m and beyond) and a small inner tag in a hole at the
// outer tag's centre (seen whole in the last metre, down to 0.3 m above the pad). The shipped layout is a
// tagCustom48h12 whose detection square is 0.6 m (the whole tag with its outer ring of data bits: 1 m, the pad)
// with a tag36h11 of 0.16 m (0.2 m with its white ring) in its 2x2-cell hole. Each tag's family, id and size are
// parameters; the detector is given a dictionary of the pad's codes only, so a tag of another family or id cannot
// decode (a foreign tag is never reported), and a decoded tag must also have the pad's size at the camera height
// and, when both are seen, sit where the layout puts it.
//
// Conventions. Pad coordinates: x forward (the vehicle's front), y left, metres from the pad centre. A tag lies
// with its image's top row (libapriltag's apriltag_to_image) towards the pad's forward and its image's columns
// running to the pad's right. Pixels are ideal (undistorted pinhole) pixels of the camera's K, as in Detection:
// an image from a distorted lens is undistorted whole (grey, one remap) before libapriltag sees it.
//
// What a detection gives (Detection, the same struct as the red-square detector's, so the localizer, the node and
// the topics are the same): the pad centre's pixel, the pad's square (corners), the heading point (the point
// `heading_offset` ahead of the centre, in place of the red pad's green strip) and, from the tags' known sizes and
// K alone, the pad's pose in the camera (pose_found, pad_in_camera, pad_axes_in_camera).
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "uav_vision/camera_geometry.h"
#include "uav_vision/pad_detector.h"

namespace uav_vision {

// One tag of the pad. size: edge of the tag's detection square (libapriltag's tag size: the black border of a
// classic family such as tag36h11, the inner white border of a "reversed" one such as tagCustom48h12) [m].
struct TagSpec {
  std::string family;
  int id = -1;
  double size = 0.0;
};

struct AprilTagPadLayout {
  TagSpec outer{"tagCustom48h12", 5, 0.6};  // fills the pad (its full width with the data ring: 1.0 m)
  TagSpec inner{"tag36h11", 7, 0.16};       // in the outer tag's central hole (0.2 m with its white ring)
};

struct AprilTagPadParams {
  AprilTagPadLayout layout;
  double heading_offset = 0.36;       // the heading point (Detection::strip_centre_px) ahead of the pad centre [m]
  int max_hamming = 3;                // bit errors corrected in a decoded tag (0..3; the families' distance is >= 11,
                                      // and the dictionary holds the pad's two codes only)
  double min_decision_margin = 25.0;  // decodes less sure than this are dropped (libapriltag's decision_margin) [-]
  double shadow_lift = 25.0;          // the grey levels go through v -> log(1 + v / shadow_lift) (0 = not): a shadow
                                      // scales the light, which a logarithm turns into an offset, so the drone's shadow
                                      // on white bits no longer reads as black (realistic frames with the shadow on
                                      // the pad: 38 of 93 found without, 86 with) [grey levels]
  double denoise_sigma = 0.8;         // Gaussian blur of the grey image against the sensor noise, before libapriltag
                                      // sees it (0 = none): the noise's specks made its quad search 3 times slower [px]
  double quad_decimate = 2.0;         // quads are looked for on an image shrunk this much (1 = full size) [-] ...
  double close_quad_decimate = 4.0;   // ... and this much with the camera below close_height (the view's height): the
                                      // inner tag is large there (realistic close views: 98.7 % found, 1.3 ms, at 4;
                                      // 97.1 %, 2.0 ms, at 2) [-]
  double close_height = 0.7;          // [m]
  double quad_sigma = 0.0;            // Gaussian blur of the shrunk image before the quad search (0 = none) [px]
  int min_white_black_diff = 30;      // regions whose brightest and darkest pixel differ less are not segmented [0..255]
  int min_cluster_pixels = 35;        // edge clusters with fewer pixels are not fitted with quads [px]
  double decode_sharpening = 0.25;    // sharpening of the decoded bits (libapriltag's default) [-]
  double size_tolerance = 0.15;       // a tag's measured size on the pad plane may differ from its size by this
                                      // fraction (the camera height from the sonar or barometer) [-]
  double max_layout_error_px = 4.0;   // both tags seen: each tag's corners within this of where the other puts them [px]
  double min_cell_px = 2.5;           // a tag whose bit cells are smaller than this in the image is not used: decoded
                                      // from so few pixels its corners are too rough to check its size or place the pad
                                      // [px]
};

// A tag of the pad decoded in the last frame (ideal pixels).
struct TagSighting {
  bool outer = true;                          // the outer tag, else the inner one
  double cell_px = 0.0;                       // side of its bit cells in the image [px]
  int hamming = 0;                            // bits corrected
  double decision_margin = 0.0;
  std::array<cv::Point2d, 4> corners_px{};    // libapriltag's order: tag (-1,1), (1,1), (1,-1), (-1,-1)
  bool accepted = false;                      // used for the pad (else `rejection` says why)
  std::string rejection;
};

// The tag families this detector is built for (libapriltag 3's): a family not in it is refused by validate().
const std::vector<std::string>& apriltagFamilies();

// Not thread-safe: keeps libapriltag's detector and its work images between calls (one detector per thread).
// Not copyable (it owns libapriltag's objects); share it through a pointer.
class AprilTagPadDetector {
 public:
  // Throws std::invalid_argument with validate()'s message.
  explicit AprilTagPadDetector(const AprilTagPadParams& params = AprilTagPadParams());
  ~AprilTagPadDetector();
  AprilTagPadDetector(const AprilTagPadDetector&) = delete;
  AprilTagPadDetector& operator=(const AprilTagPadDetector&) = delete;

  // Empty when the parameters make sense, else the first problem, naming the parameter and what is expected
  // (an unknown family lists the ones built for; an inner tag too large for the outer tag's hole says how large
  // it may be).
  static std::string validate(const AprilTagPadParams& params);

  // image: 8-bit, 3 channels in `order` (or 1 channel, grey). view: the camera (intrinsics with the lens
  // distortion), its attitude and height above the pad plane; with it, each tag's size is checked against the
  // height (a wrong height hypothesis, or another tag with a pad tag's code, is rejected). Without it, the image
  // is taken as from a perfect lens and only the intrinsics-free part is filled (no pose, no size check).
  Detection detect(const cv::Mat& image, ColorOrder order, const PlaneView* view = nullptr) const;
  // The same with the intrinsics alone (no height, no size check): centre, heading and the pose from the tags.
  Detection detect(const cv::Mat& image, ColorOrder order, const CameraIntrinsics& intrinsics) const;

  const AprilTagPadParams& params() const { return params_; }
  // The pad's tags decoded in the last frame, accepted or not.
  const std::vector<TagSighting>& lastTags() const { return tags_; }

  // Side of the outer tag's whole square (with its outer ring) and of the inner tag's, and the side of the
  // outer tag's central hole [m], from the families' geometry.
  static double fullWidth(const TagSpec& tag);
  static double holeWidth(const TagSpec& tag);

  // The pad seen from above, `pixels` square: the vehicle's front up, the pad's right to the right; 8-bit grey.
  // The texture the simulator puts on the pad, and the synthetic frames of the tests, are made from it.
  // Throws std::invalid_argument for invalid parameters.
  static cv::Mat topView(const AprilTagPadLayout& layout, int pixels);
  // Corners of a tag on the pad (pad coordinates, metres), in libapriltag's corner order.
  static std::array<cv::Point2d, 4> tagCornersOnPad(const TagSpec& tag);

 private:
  struct Impl;
  Detection run(const cv::Mat& image, ColorOrder order, const CameraIntrinsics* intrinsics,
                const PlaneView* view) const;

  AprilTagPadParams params_;
  std::unique_ptr<Impl> impl_;
  mutable std::vector<TagSighting> tags_;
};

}  // namespace uav_vision
