#include "uav_vision/estimate_history.h"

#include <algorithm>
#include <cmath>

namespace uav_vision {

namespace {
double yawOf(const Eigen::Quaterniond& q) {
  return std::atan2(2.0 * (q.w() * q.z() + q.x() * q.y()), 1.0 - 2.0 * (q.y() * q.y() + q.z() * q.z()));
}
}  // namespace

double headingTurn(const Eigen::Quaterniond& estimate, const Eigen::Quaterniond& imu) {
  return std::remainder(yawOf(estimate) - yawOf(imu), 2.0 * M_PI);
}

void EstimateHistory::add(const DroneEstimate& estimate) {
  estimates_.add(estimate);
}

std::optional<DroneEstimate> EstimateHistory::at(double stamp) const {
  if (estimates_.empty()) return std::nullopt;
  const auto later = estimates_.firstNotBefore(stamp);
  if (later != estimates_.end() && later != estimates_.begin()) {
    const DroneEstimate& earlier = *std::prev(later);
    const double span = later->stamp - earlier.stamp;
    const double f = span > 0.0 ? (stamp - earlier.stamp) / span : 0.0;
    DroneEstimate result = f < 0.5 ? earlier : *later;
    result.stamp = stamp;
    result.position = earlier.position + f * (later->position - earlier.position);
    return result;
  }
  DroneEstimate result = later == estimates_.end() ? estimates_.back() : *later;
  const double offset = stamp - result.stamp;
  if (std::abs(offset) > max_extrapolation_) return std::nullopt;
  result.stamp = stamp;
  result.position += offset * result.velocity;
  return result;
}

}  // namespace uav_vision
