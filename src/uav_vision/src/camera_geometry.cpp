#include "uav_vision/camera_geometry.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/calib3d.hpp>

namespace uav_vision {

std::string CameraIntrinsics::problem() const {
  std::ostringstream out;
  if (!(std::isfinite(fx) && std::isfinite(fy) && std::isfinite(cx) && std::isfinite(cy)))
    out << "non-finite intrinsics";
  else if (fx <= 0.0 || fy <= 0.0)
    out << "focal length must be positive (fx=" << fx << ", fy=" << fy << ")";
  else if (width <= 0 || height <= 0)
    out << "image size must be positive (" << width << "x" << height << ")";
  else if (!std::all_of(distortion.begin(), distortion.end(), [](double v) { return std::isfinite(v); }))
    out << "non-finite lens distortion";
  return out.str();
}

bool CameraIntrinsics::distorted() const {
  return std::any_of(distortion.begin(), distortion.end(), [](double v) { return v != 0.0; });
}

bool CameraIntrinsics::operator==(const CameraIntrinsics& o) const {
  return fx == o.fx && fy == o.fy && cx == o.cx && cy == o.cy && width == o.width && height == o.height &&
         distortion == o.distortion;
}

LensUndistortion::LensUndistortion(const CameraIntrinsics& intrinsics) : intrinsics_(intrinsics) {
  const int w = intrinsics.width, h = intrinsics.height;
  table_.resize(size_t(std::max(w, 0)) * size_t(std::max(h, 0)));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) table_[size_t(y) * w + x] = cv::Point2f(float(x), float(y));
  if (!intrinsics.distorted() || table_.empty() || !intrinsics.problem().empty()) return;
  const cv::Matx33d k(intrinsics.fx, 0.0, intrinsics.cx, 0.0, intrinsics.fy, intrinsics.cy, 0.0, 0.0, 1.0);
  // Iterated to convergence: OpenCV's default 5 iterations leave tenths of a pixel in the corners.
  std::vector<cv::Point2f> ideal;
  cv::undistortPoints(table_, ideal, k, intrinsics.distortion, cv::noArray(), k,
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-6));
  table_.swap(ideal);
}

void LensUndistortion::undistort(const std::vector<cv::Point>& pixels, std::vector<cv::Point2f>& ideal) const {
  ideal.resize(pixels.size());
  for (size_t i = 0; i < pixels.size(); ++i) ideal[i] = undistort(pixels[i]);
}

cv::Point2d distortPixel(const CameraIntrinsics& k, const cv::Point2d& ideal) {
  const auto& [k1, k2, p1, p2, k3] = k.distortion;
  const double x = (ideal.x - k.cx) / k.fx, y = (ideal.y - k.cy) / k.fy;
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x);
  const double yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y;
  return {k.fx * xd + k.cx, k.fy * yd + k.cy};
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
