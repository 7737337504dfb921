#include "uav_vision/camera_geometry.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace uav_vision {

std::string CameraIntrinsics::problem() const {
  std::ostringstream out;
  if (!(std::isfinite(fx) && std::isfinite(fy) && std::isfinite(cx) && std::isfinite(cy)))
    out << "non-finite intrinsics";
  else if (fx <= 0.0 || fy <= 0.0)
    out << "focal length must be positive (fx=" << fx << ", fy=" << fy << ")";
  else if (width <= 0 || height <= 0)
    out << "image size must be positive (" << width << "x" << height << ")";
  return out.str();
}

CameraMount CameraMount::bottomCamera(double below_base_link) {
  CameraMount mount;
  // x_opt = -y_body, y_opt = -x_body, z_opt = -z_body (docs/conventions.md).
  mount.optical_in_body << 0.0, -1.0, 0.0,
                           -1.0, 0.0, 0.0,
                           0.0, 0.0, -1.0;
  mount.position_in_body = Eigen::Vector3d(0.0, 0.0, -below_base_link);
  return mount;
}

PlaneView::PlaneView(const CameraIntrinsics& intrinsics, const CameraMount& mount,
                     const Eigen::Quaterniond& world_from_body, double camera_height)
    : intrinsics_(intrinsics), camera_height_(camera_height) {
  problem_ = intrinsics.problem();
  const Eigen::Vector4d q = world_from_body.coeffs();
  if (problem_.empty() && !(q.allFinite() && q.norm() > 0.5))
    problem_ = "attitude quaternion is not finite or not unit";
  if (problem_.empty() && !(std::isfinite(camera_height) && camera_height > 0.0))
    problem_ = "camera height above the pad must be positive";
  if (!problem_.empty()) {
    world_from_body_.setIdentity();
    camera_from_base_world_.setZero();
    pixel_to_ray_.setIdentity();
    ray_to_pixel_.setIdentity();
    return;
  }
  world_from_body_ = world_from_body.normalized().toRotationMatrix();
  camera_from_base_world_ = world_from_body_ * mount.position_in_body;
  Eigen::Matrix3d k;
  k << intrinsics.fx, 0.0, intrinsics.cx, 0.0, intrinsics.fy, intrinsics.cy, 0.0, 0.0, 1.0;
  const Eigen::Matrix3d world_from_optical = world_from_body_ * mount.optical_in_body;
  pixel_to_ray_ = world_from_optical * k.inverse();
  ray_to_pixel_ = k * world_from_optical.transpose();
}

std::optional<Eigen::Vector2d> PlaneView::pixelToPlane(const cv::Point2d& pixel, double max_range) const {
  const Eigen::Vector3d ray = pixel_to_ray_ * Eigen::Vector3d(pixel.x, pixel.y, 1.0);
  // The ray must descend: t = h / -ray.z must be positive and the hit not absurdly far.
  if (!(ray.z() < 0.0)) return std::nullopt;
  const double t = camera_height_ / -ray.z();
  const Eigen::Vector2d offset = t * ray.head<2>();
  if (!(offset.norm() <= max_range)) return std::nullopt;
  return offset;
}

std::optional<cv::Point2d> PlaneView::planeToPixel(const Eigen::Vector2d& offset) const {
  const Eigen::Vector3d p = ray_to_pixel_ * Eigen::Vector3d(offset.x(), offset.y(), -camera_height_);
  if (!(p.z() > 1e-9)) return std::nullopt;
  return cv::Point2d(p.x() / p.z(), p.y() / p.z());
}

Eigen::Vector3d PlaneView::fromBaseWorldAligned(const Eigen::Vector2d& offset) const {
  return camera_from_base_world_ + Eigen::Vector3d(offset.x(), offset.y(), -camera_height_);
}

Eigen::Vector3d PlaneView::fromBaseInBody(const Eigen::Vector2d& offset) const {
  return world_from_body_.transpose() * fromBaseWorldAligned(offset);
}

double PlaneView::metresPerPixel() const {
  return camera_height_ / std::max(intrinsics_.fx, intrinsics_.fy);
}

}  // namespace uav_vision
