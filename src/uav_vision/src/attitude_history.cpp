#include "uav_vision/attitude_history.h"

#include <algorithm>
#include <cmath>

namespace uav_vision {

void AttitudeHistory::add(double stamp, const Eigen::Quaterniond& orientation, const Eigen::Vector3d& body_rate) {
  const Eigen::Vector3d rate = body_rate.allFinite() ? body_rate : Eigen::Vector3d::Zero();
  samples_.add({stamp, orientation.normalized(), rate});
}

Eigen::Quaterniond AttitudeHistory::turned(const Sample& sample, double dt) {
  const Eigen::Vector3d rotation = sample.body_rate * dt;  // body-frame rates: the turn applies on the right
  const double angle = rotation.norm();
  if (angle < 1e-12) return sample.orientation;
  return (sample.orientation * Eigen::Quaterniond(Eigen::AngleAxisd(angle, rotation / angle))).normalized();
}

std::optional<Eigen::Quaterniond> AttitudeHistory::at(double stamp) const {
  if (samples_.empty()) return std::nullopt;
  const auto later = samples_.firstNotBefore(stamp);
  if (later != samples_.end() && later != samples_.begin()) {
    const Sample& earlier = *std::prev(later);
    const double span = later->stamp - earlier.stamp;
    if (span <= 2.0 * max_offset_) {
      const double f = span > 0.0 ? (stamp - earlier.stamp) / span : 0.0;
      return earlier.orientation.slerp(f, later->orientation);
    }
  }
  // Nearest sample, turned by its rate to the stamp (backwards too: before the first sample).
  const Sample& nearest =
      later == samples_.end() ? samples_.back()
      : (later == samples_.begin() || std::abs(later->stamp - stamp) <= std::abs(std::prev(later)->stamp - stamp))
          ? *later
          : *std::prev(later);
  const double dt = stamp - nearest.stamp;
  if (std::abs(dt) > max_offset_) return std::nullopt;
  return turned(nearest, dt);
}

}  // namespace uav_vision
