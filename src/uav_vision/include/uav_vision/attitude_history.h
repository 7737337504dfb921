// The drone's attitude at an image's timestamp, from the recent IMU samples (ROS-free).
//
// A frame is processed as soon as it arrives, usually before the IMU sample that follows it: the attitude
// then comes from the latest earlier sample, turned on by that sample's angular velocity over the gap.
// Taking the earlier sample as it was put the pad tens of centimetres off at 4-6 m while the drone rolled
// (20 ms at 1 rad/s is 0.02 rad: 11 cm at 5.7 m), and the tracker chased that noise. Between two samples
// the attitude is interpolated (slerp).
#pragma once

#include <optional>

#include <Eigen/Geometry>

#include "uav_vision/stamped_window.h"

namespace uav_vision {

class AttitudeHistory {
 public:
  // `max_offset`: how far from the nearest sample an attitude may be propagated [s];
  // `keep`: how much history is kept [s].
  explicit AttitudeHistory(double max_offset = 0.05, double keep = 1.0) : max_offset_(max_offset), samples_(keep) {}

  // One IMU sample: `orientation` = rotation world <- body (unit), `body_rate` = angular velocity in the
  // body frame [rad/s]. A stamp older than the newest one restarts the history (time jumped back).
  void add(double stamp, const Eigen::Quaterniond& orientation, const Eigen::Vector3d& body_rate);

  // The attitude at `stamp`; nullopt when no sample is within `max_offset` of it.
  std::optional<Eigen::Quaterniond> at(double stamp) const;

  bool empty() const { return samples_.empty(); }

 private:
  struct Sample {
    double stamp;
    Eigen::Quaterniond orientation;
    Eigen::Vector3d body_rate;
  };
  static Eigen::Quaterniond turned(const Sample& sample, double dt);

  double max_offset_;
  StampedWindow<Sample> samples_;
};

}  // namespace uav_vision
