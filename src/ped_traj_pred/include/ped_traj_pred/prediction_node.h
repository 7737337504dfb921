// ROS wrapper of PadMotionFilter: detections in, predicted path and filtered odometry out.
//
// Every measurement is fused at its own stamp, however late it arrives (DelayedFusion, fusion_horizon).
// Subscribes (relative names, from parameters):
//   pose_topic  geometry_msgs/PointStamped  pad centre detections in world_frame
//   relative_pose_topic  geometry_msgs/PointStamped  the same detections relative to the drone (optional;
//               their range sets each fix's variance, see FilterParameters::visionVariance)
//   gps_topic   nav_msgs/Odometry           vehicle GPS fix and world-frame velocity (optional; empty name
//               disables it; the velocity, if its covariance is given, starts a track from GPS with a heading)
// Publishes at pub_freq [Hz] in ROS (sim) time while the track is alive:
//   future_path_topic  nav_msgs/Path      pad positions at now + k*time_step, k = 0..path_time/time_step
//   odom_topic         nav_msgs/Odometry  filtered pad position and world-frame velocity, with covariances
// Nothing is published while there is no track or it is lost; consumers detect that from the stamps.
// Service ~reset (std_srvs/Trigger): the parameters are read again as they are at the call and the track starts
// afresh, as after a restart; a missing or invalid parameter refuses it and the node goes on as it was.
#pragma once

#include "ped_traj_pred/delayed_fusion.h"
#include "ped_traj_pred/prediction_settings.h"

#include <geometry_msgs/PointStamped.h>
#include <landing_runtime/input_check.h>
#include <landing_runtime/lockstep_acker.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>

#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

namespace ped_traj_pred
{
/// A parameter is missing or invalid; the message names it.
class ParameterError : public std::runtime_error
{
public:
  using std::runtime_error::runtime_error;
};

/// Every parameter of the node from `private_nh`, validated. Throws ParameterError naming the first missing or
/// invalid one. Start-up and ~reset both read them through this.
PredictionSettings loadSettings(const ros::NodeHandle& private_nh);

class PredictionNode
{
public:
  /// Reads the parameters from `private_nh` and wires the topics relative to `nh`.
  /// Throws ParameterError naming the first missing or invalid parameter.
  PredictionNode(ros::NodeHandle& nh, ros::NodeHandle& private_nh);

private:
  /// What a scenario builds up; a fresh start and a reset make it from the settings alone.
  struct Track
  {
    explicit Track(const PredictionSettings& settings) : filter(settings.filter, settings.fusion_horizon) {}
    DelayedFusion filter;  // frames and GPS reports arrive late: fused in the order they were taken
    std::optional<std::pair<ros::Time, double>> last_range;  // stamp and camera range of the latest relative fix
    bool tracking = false;  // as of the last timer tick, for logging the transitions once
    ros::Time last_tick;
  };

  /// (Re)creates the subscribers, publishers and timer whose topic or rate differs from `previous` (all of them
  /// without one). Topic names are valid (loadSettings checked them).
  void connect(const PredictionSettings& settings, const PredictionSettings* previous);
  /// ~reset: new settings and an empty track, or (bad parameters) nothing changed.
  bool onReset(std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);
  void onDetection(const geometry_msgs::PointStamped::ConstPtr& msg);
  void onGps(const nav_msgs::Odometry::ConstPtr& msg);
  void onRelativeDetection(const geometry_msgs::PointStamped::ConstPtr& msg);
  /// A stamp too far from the clock, or a named value that is not finite or beyond +-limit.
  std::optional<landing_runtime::InputProblem> inputProblem(const std_msgs::Header& header,
                                                         std::initializer_list<std::pair<const char*, double>> values,
                                                         double limit) const;
  /// Variance of a world fix stamped `stamp`, from the range of the relative fix of the same frame.
  double visionVariance(const ros::Time& stamp) const;
  void onTimer(const ros::TimerEvent& event);
  /// One tick: log track changes, publish the prediction while tracking.
  void step(const ros::Time& now);
  /// The message's stamp, or now when it is zero (a publisher that does not stamp).
  ros::Time stampOf(const std_msgs::Header& header) const;
  void logOutcome(MeasurementOutcome outcome, const std::string& topic, const ros::Time& stamp);
  void publish(const ros::Time& now, const PadState& state);

  // Callbacks, timer and ~reset all run on the one spinner thread of main(): they never touch this at once.
  ros::NodeHandle nh_, private_nh_;
  PredictionSettings settings_;
  Track track_;
  ros::Subscriber detection_sub_, gps_sub_, relative_sub_;
  ros::Publisher path_pub_, odom_pub_;
  ros::Timer timer_;
  std::optional<landing_runtime::LockstepAcker> lockstep_;  // created once pub_freq is known
  // Garbage on the inputs: what was wrong, once per topic and kind (optional: a reset makes a new one).
  std::optional<landing_runtime::RejectionLog> rejections_;
  ros::ServiceServer reset_service_;
};

}  // namespace ped_traj_pred
