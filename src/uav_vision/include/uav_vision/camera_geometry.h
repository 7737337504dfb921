// Camera looking at a horizontal plane: pixel <-> point on the pad plane, and the lens (ROS-free).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

namespace uav_vision {

// The camera as in sensor_msgs/CameraInfo: pinhole intrinsics K [px] and the lens distortion D.
struct CameraIntrinsics {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  int width = 0, height = 0;
  // plumb_bob lens distortion (k1, k2, p1, p2, k3), as camera_info D; all zero: a perfect pinhole lens.
  std::array<double, 5> distortion{};

  // Empty when usable, else what is wrong (e.g. "zero focal length").
  std::string problem() const;
  bool distorted() const;
  bool operator==(const CameraIntrinsics& other) const;
  bool operator!=(const CameraIntrinsics& other) const { return !(*this == other); }
};

// Image pixel of an ideal pixel: the lens model forwards (e.g. to draw a detection on the image).
cv::Point2d distortPixel(const CameraIntrinsics& intrinsics, const cv::Point2d& ideal);

// Where the lens put each pixel: the image pixel <-> the pixel of the ideal pinhole image with the same K
// ("undistorted" or "ideal" pixels; PlaneView works in those). Only the points that matter are moved, not
// the image: a lookup table of every pixel's ideal position, computed once per camera (about 20 ms), makes
// a contour point cost one memory read (remapping the whole image costs more than the detector: see
// detector_benchmark).
class LensUndistortion {
 public:
  explicit LensUndistortion(const CameraIntrinsics& intrinsics);

  const CameraIntrinsics& intrinsics() const { return intrinsics_; }
  // Ideal pixel of an image pixel (inside the image: the caller's contour points are).
  const cv::Point2f& undistort(const cv::Point& pixel) const { return table_[pixel.y * intrinsics_.width + pixel.x]; }
  void undistort(const std::vector<cv::Point>& pixels, std::vector<cv::Point2f>& ideal) const;
  cv::Point2d distort(const cv::Point2d& ideal) const { return distortPixel(intrinsics_, ideal); }

 private:
  CameraIntrinsics intrinsics_;
  std::vector<cv::Point2f> table_;  // row-major, one per pixel
};

// Pose of the camera's optical frame (x right, y down, z out of the lens) on the drone.
struct CameraMount {
  Eigen::Matrix3d optical_in_body = Eigen::Matrix3d::Identity();  // columns: optical axes in base_link
  Eigen::Vector3d position_in_body = Eigen::Vector3d::Zero();      // optical centre in base_link [m]

  // The bottom camera of docs/conventions.md: `below_base_link` under base_link, looking along body -z,
  // image up = body forward, image right = body right.
  static CameraMount bottomCamera(double below_base_link);
};

// The camera above the horizontal pad plane, at a known height and attitude. Points on the plane are
// given as their horizontal offset (east, north in world-aligned axes) from the optical centre; the
// plane lies `camera_height` below the optical centre. Pixels are ideal (pinhole) pixels: for a distorted
// lens, undistorted first (LensUndistortion).
class PlaneView {
 public:
  // world_from_body: drone attitude (IMU orientation, world <- base_link); camera_height above the plane [m].
  PlaneView(const CameraIntrinsics& intrinsics, const CameraMount& mount,
            const Eigen::Quaterniond& world_from_body, double camera_height);

  // Empty when usable, else what is wrong (bad intrinsics, non-finite attitude, height <= 0).
  const std::string& problem() const { return problem_; }

  // Where the pixel's ray meets the plane; nothing if the ray does not point down enough to meet it
  // within `max_range` metres horizontally.
  std::optional<Eigen::Vector2d> pixelToPlane(const cv::Point2d& pixel, double max_range = 100.0) const;
  // Pixel of a plane point; nothing if the point is behind the camera.
  std::optional<cv::Point2d> planeToPixel(const Eigen::Vector2d& offset) const;

  // A plane point as a vector from base_link: in world-aligned axes, and in the base_link frame.
  Eigen::Vector3d fromBaseWorldAligned(const Eigen::Vector2d& offset) const;
  Eigen::Vector3d fromBaseInBody(const Eigen::Vector2d& offset) const;

  const CameraIntrinsics& intrinsics() const { return intrinsics_; }
  double cameraHeight() const { return camera_height_; }
  const Eigen::Matrix3d& worldFromBody() const { return world_from_body_; }
  // Metres on the plane per pixel near the image centre (for tolerances given in pixels).
  double metresPerPixel() const;

 private:
  CameraIntrinsics intrinsics_;
  Eigen::Matrix3d world_from_body_;
  Eigen::Vector3d camera_from_base_world_;  // optical centre - base_link, world-aligned [m]
  Eigen::Matrix3d pixel_to_ray_;            // (u, v, 1) -> ray direction, world-aligned
  Eigen::Matrix3d ray_to_pixel_;            // inverse: world-aligned vector -> homogeneous pixel
  double camera_height_;
  std::string problem_;
};

}  // namespace uav_vision
