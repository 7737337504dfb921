// The drone estimator's recent states and their value at an image's stamp (ROS-free).
//
// The estimate (ardrone/odom_estimate) trails the camera by the estimator's latency while the drone moves by
// metres per second, so the newest one is not the one that goes with a frame: the position is interpolated
// between the two estimates around the frame's stamp, or moved on from the nearest one with its velocity.
// Each estimate also carries its heading turn: the estimate's heading minus the IMU's yaw at its stamp, the yaw
// drift the drone estimator has learnt, which turns a vector in the IMU's world axes into the estimate's world.
#pragma once

#include <optional>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "uav_vision/stamped_window.h"

namespace uav_vision {

struct DroneEstimate {
  double stamp = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  // world frame [m]
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  // world frame [m/s]
  double heading_turn = 0.0;                           // [rad], see headingTurn
};

// Heading (about world z) of `estimate` minus that of `imu`, both world <- body, wrapped to [-pi, pi] [rad].
double headingTurn(const Eigen::Quaterniond& estimate, const Eigen::Quaterniond& imu);

class EstimateHistory {
 public:
  // `max_extrapolation`: how far from the nearest estimate a position may be moved with its velocity [s];
  // `keep`: how much history is kept [s].
  explicit EstimateHistory(double max_extrapolation, double keep = 1.0)
      : max_extrapolation_(max_extrapolation), estimates_(keep) {}

  // A stamp older than the newest one restarts the history (time jumped back).
  void add(const DroneEstimate& estimate);

  // The estimate at `stamp`: the position interpolated between the estimates around it, with the velocity and
  // heading turn of the nearer one; outside them, the nearest moved on with its velocity if at most
  // `max_extrapolation` away; else nullopt.
  std::optional<DroneEstimate> at(double stamp) const;

  bool empty() const { return estimates_.empty(); }

 private:
  double max_extrapolation_;
  StampedWindow<DroneEstimate> estimates_;
};

}  // namespace uav_vision
