// Everything prediction_kalman_node reads from its parameters (config/kalman.yaml and the topic names of
// launch/prediction_kalman_node.launch), and their validation. ROS-free: the node fills it from the parameter
// server at start-up and at each ~reset, the same way, and builds its filter from it.
#pragma once

#include "ped_traj_pred/pad_motion_filter.h"

#include <Eigen/Core>

#include <string>

namespace ped_traj_pred
{
struct PredictionSettings
{
  FilterParameters filter;
  double fusion_horizon = 1.0;  ///< how late a measurement may be fused at its own stamp [s]
  std::string world_frame = "world";  ///< frame of detections, GPS and outputs (no leading '/')
  double time_step = 0.1;  ///< between consecutive poses of the predicted path [s]
  double path_time = 2.0;  ///< the path covers now .. now + path_time [s]
  double pub_freq = 20.0;  ///< rate of paths and odometry [Hz]
  Eigen::Vector2d gps_pad_offset = Eigen::Vector2d::Zero();  ///< pad centre from the GPS point, vehicle frame [m]
  // Topic names, relative to the node's namespace; an empty optional one disables that input.
  std::string pose_topic, relative_pose_topic, gps_topic, future_path_topic, odom_topic;

  /// Empty when usable, else the first problem, starting with the parameter's name ("pub_freq must be > 0 [Hz]").
  std::string validate() const;
};

}  // namespace ped_traj_pred
