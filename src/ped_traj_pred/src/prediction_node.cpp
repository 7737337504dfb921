#include "ped_traj_pred/prediction_node.h"

#include <nav_msgs/Path.h>
#include <tf2/utils.h>
#include <tf2_geometry_msgs/tf2_geometry_msgs.h>

#include <algorithm>
#include <cmath>
#include <tuple>

namespace ped_traj_pred
{
namespace
{
constexpr double kUnknownVariance = 1e6;  // covariance entry of a quantity the filter does not estimate
constexpr double kMinHeadingSpeed = 0.1;  // below this speed the direction of travel is meaningless [m/s]

template <typename T>
T requireParam(const ros::NodeHandle& nh, const std::string& name)
{
  T value;
  if (!nh.getParam(name, value))
    throw ParameterError("missing or mistyped required parameter " + nh.resolveName(name) +
                         " (see config/kalman.yaml)");
  return value;
}

/// An integer parameter; a non-integral number is an error rather than silently truncated.
int requireIntParam(const ros::NodeHandle& nh, const std::string& name)
{
  const double value = requireParam<double>(nh, name);
  if (!(std::isfinite(value) && value == std::floor(value) && std::abs(value) < 1e9))
    throw ParameterError("invalid parameter: " + nh.resolveName(name) + " must be an integer");
  return static_cast<int>(value);
}

FilterParameters loadFilterParameters(const ros::NodeHandle& nh)
{
  FilterParameters p;
  p.model_covariance = requireParam<double>(nh, "model_covariance");
  p.turn_rate_covariance = requireParam<double>(nh, "turn_rate_covariance");
  p.velocity_covariance = requireParam<double>(nh, "velocity_covariance");
  p.height_covariance = requireParam<double>(nh, "height_covariance");
  p.manoeuvre_covariance_scale = requireParam<double>(nh, "manoeuvre_covariance_scale");
  p.manoeuvre_acceleration_covariance = requireParam<double>(nh, "manoeuvre_acceleration_covariance");
  p.steady_mode_duration = requireParam<double>(nh, "steady_mode_duration");
  p.manoeuvre_mode_duration = requireParam<double>(nh, "manoeuvre_mode_duration");
  p.onset_window = requireParam<double>(nh, "onset_window");
  p.onset_acceleration_std = requireParam<double>(nh, "onset_acceleration_std");
  p.onset_threshold = requireParam<double>(nh, "onset_threshold");
  p.stop_threshold = requireParam<double>(nh, "stop_threshold");
  p.observation_covariance = requireParam<double>(nh, "observation_covariance");
  p.observation_std_floor = requireParam<double>(nh, "observation_std_floor");
  p.observation_std_per_metre = requireParam<double>(nh, "observation_std_per_metre");
  p.gps_observation_covariance = requireParam<double>(nh, "gps_observation_covariance");
  p.gps_offset_initial_std = requireParam<double>(nh, "gps_offset_initial_std");
  p.gps_offset_drift = requireParam<double>(nh, "gps_offset_drift");
  p.gps_vision_timeout = requireParam<double>(nh, "gps_vision_timeout");
  p.gps_pad_height = requireParam<double>(nh, "gps_pad_height");
  p.initial_gps_height_std = requireParam<double>(nh, "initial_gps_height_std");
  p.max_coast_time = requireParam<double>(nh, "max_coast_time");
  p.gate_threshold = requireParam<double>(nh, "gate_threshold");
  p.max_consecutive_rejections = requireIntParam(nh, "max_consecutive_rejections");
  p.initial_velocity_std = requireParam<double>(nh, "initial_velocity_std");
  p.initial_acceleration_std = requireParam<double>(nh, "initial_acceleration_std");
  p.initial_turn_rate_std = requireParam<double>(nh, "initial_turn_rate_std");
  p.heading_acquisition_std = requireParam<double>(nh, "heading_acquisition_std");
  p.heading_loss_std = requireParam<double>(nh, "heading_loss_std");
  p.low_speed_regularisation = requireParam<double>(nh, "low_speed_regularisation");
  p.max_integration_step = requireParam<double>(nh, "max_integration_step");
  const std::string error = p.validate();
  if (!error.empty())
    throw ParameterError("invalid parameter: " + nh.resolveName("") + "/" + error);
  return p;
}

std::string withoutLeadingSlash(const std::string& frame)
{
  return (!frame.empty() && frame[0] == '/') ? frame.substr(1) : frame;
}

/// Quaternion of a rotation by `yaw` about z.
geometry_msgs::Quaternion yawQuaternion(double yaw)
{
  geometry_msgs::Quaternion q;
  q.z = std::sin(0.5 * yaw);
  q.w = std::cos(0.5 * yaw);
  return q;
}

/// Direction of travel; identity below kMinHeadingSpeed.
geometry_msgs::Quaternion travelDirection(const Eigen::Vector3d& velocity)
{
  if (velocity.head<2>().norm() < kMinHeadingSpeed)
    return yawQuaternion(0.0);
  return yawQuaternion(std::atan2(velocity.y(), velocity.x()));
}

double requirePositive(const ros::NodeHandle& nh, const std::string& name, const char* unit)
{
  const double value = requireParam<double>(nh, name);
  if (!(std::isfinite(value) && value > 0.0))
    throw ParameterError("invalid parameter: " + nh.resolveName(name) + " must be > 0 [" + unit + "]");
  return value;
}
}  // namespace

PredictionNode::PredictionNode(ros::NodeHandle& nh, ros::NodeHandle& private_nh)
  : filter_(loadFilterParameters(private_nh), requirePositive(private_nh, "fusion_horizon", "s"))
{
  world_frame_ = withoutLeadingSlash(requireParam<std::string>(private_nh, "world_frame"));
  time_step_ = requireParam<double>(private_nh, "time_step");
  path_time_ = requireParam<double>(private_nh, "path_time");
  pub_freq_ = requireParam<double>(private_nh, "pub_freq");
  gps_pad_offset_ << requireParam<double>(private_nh, "gps_pad_offset_x"),
      requireParam<double>(private_nh, "gps_pad_offset_y");
  const std::string pose_topic = requireParam<std::string>(private_nh, "pose_topic");
  const std::string gps_topic = requireParam<std::string>(private_nh, "gps_topic");
  const std::string relative_topic = requireParam<std::string>(private_nh, "relative_pose_topic");
  const std::string path_topic = requireParam<std::string>(private_nh, "future_path_topic");
  const std::string odom_topic = requireParam<std::string>(private_nh, "odom_topic");
  if (!(std::isfinite(time_step_) && time_step_ > 0.0))
    throw ParameterError("invalid parameter: " + private_nh.resolveName("time_step") + " must be > 0 [s]");
  if (!(std::isfinite(path_time_) && path_time_ >= 0.0))
    throw ParameterError("invalid parameter: " + private_nh.resolveName("path_time") + " must be >= 0 [s]");
  if (!(std::isfinite(pub_freq_) && pub_freq_ > 0.0))
    throw ParameterError("invalid parameter: " + private_nh.resolveName("pub_freq") + " must be > 0 [Hz]");
  if (!gps_pad_offset_.allFinite())
    throw ParameterError("invalid parameter: " + private_nh.resolveName("gps_pad_offset_x/y") + " is not finite");
  if (pose_topic.empty() || path_topic.empty() || odom_topic.empty())
    throw ParameterError("pose_topic, future_path_topic and odom_topic must not be empty");

  path_pub_ = nh.advertise<nav_msgs::Path>(path_topic, 10);
  odom_pub_ = nh.advertise<nav_msgs::Odometry>(odom_topic, 10);
  // Low latency matters more than bandwidth: every detection is used at its own stamp.
  detection_sub_ = nh.subscribe(pose_topic, 30, &PredictionNode::onDetection, this, ros::TransportHints().tcpNoDelay());
  if (!relative_topic.empty())
    relative_sub_ = nh.subscribe(relative_topic, 30, &PredictionNode::onRelativeDetection, this,
                                 ros::TransportHints().tcpNoDelay());
  if (!gps_topic.empty())
    gps_sub_ = nh.subscribe(gps_topic, 10, &PredictionNode::onGps, this, ros::TransportHints().tcpNoDelay());
  lockstep_.emplace(nh, ros::Duration(1.0 / pub_freq_));
  timer_ = nh.createTimer(ros::Duration(1.0 / pub_freq_), &PredictionNode::onTimer, this);
  ROS_INFO("Predicting the pad from %s%s%s: %s (nav_msgs/Path, %.1f s ahead every %.2f s) and %s at %.1f Hz",
           detection_sub_.getTopic().c_str(), gps_topic.empty() ? "" : " and ",
           gps_topic.empty() ? "" : gps_sub_.getTopic().c_str(), path_pub_.getTopic().c_str(), path_time_,
           time_step_, odom_pub_.getTopic().c_str(), pub_freq_);
}

ros::Time PredictionNode::stampOf(const std_msgs::Header& header) const
{
  return header.stamp.isZero() ? ros::Time::now() : header.stamp;
}

void PredictionNode::onDetection(const geometry_msgs::PointStamped::ConstPtr& msg)
{
  const Eigen::Vector3d position(msg->point.x, msg->point.y, msg->point.z);
  if (!position.allFinite())
  {
    ROS_WARN_THROTTLE(5.0, "Dropping a detection with NaN or inf on %s", detection_sub_.getTopic().c_str());
    return;
  }
  const std::string frame = withoutLeadingSlash(msg->header.frame_id);
  if (!frame.empty() && frame != world_frame_)
  {
    ROS_WARN_THROTTLE(5.0, "Dropping detections on %s in frame '%s': expected '%s'",
                      detection_sub_.getTopic().c_str(), frame.c_str(), world_frame_.c_str());
    return;
  }
  if (auto problem = inputProblem(msg->header, {{"point.x", position.x()}, {"point.y", position.y()},
                                                {"point.z", position.z()}}, landing_msgs::kMaxPositionM))
    return rejections_.reject(detection_sub_.getTopic(), *problem);
  const ros::Time stamp = stampOf(msg->header);
  logOutcome(filter_.addVision(stamp.toSec(), position, visionVariance(stamp)), detection_sub_.getTopic(), stamp);
}

void PredictionNode::onRelativeDetection(const geometry_msgs::PointStamped::ConstPtr& msg)
{
  // Relative to the drone: its height above the pad at most, and a camera's view across.
  if (auto problem = inputProblem(msg->header, {{"point.x", msg->point.x}, {"point.y", msg->point.y},
                                                {"point.z", msg->point.z}}, landing_msgs::kMaxAltitudeM))
    return rejections_.reject(relative_sub_.getTopic(), *problem);
  const double range = std::sqrt(msg->point.x * msg->point.x + msg->point.y * msg->point.y + msg->point.z * msg->point.z);
  last_range_ = std::make_pair(stampOf(msg->header), range);
}

double PredictionNode::visionVariance(const ros::Time& stamp) const
{
  // The relative fix of the same frame gives the range; the previous frame's is close enough.
  constexpr double kMaxRangeAge = 0.2;  // [s]
  if (last_range_ && std::abs((stamp - last_range_->first).toSec()) <= kMaxRangeAge)
    return filter_.parameters().visionVariance(last_range_->second);
  return filter_.parameters().observation_covariance;
}

void PredictionNode::onGps(const nav_msgs::Odometry::ConstPtr& msg)
{
  const geometry_msgs::Point& p = msg->pose.pose.position;
  const geometry_msgs::Quaternion& q = msg->pose.pose.orientation;
  if (auto problem = landing_msgs::frameProblem(msg->header.frame_id, world_frame_))
    return rejections_.reject(gps_sub_.getTopic(), *problem);
  if (auto problem = landing_msgs::stampProblem(msg->header.stamp, ros::Time::now()))
    return rejections_.reject(gps_sub_.getTopic(), *problem);
  // A NaN is dropped field by field below (a report without that part); a finite value must be plausible.
  const geometry_msgs::Vector3& v = msg->twist.twist.linear;
  for (const auto& [name, value, limit] : {std::tuple<const char*, double, double>{"position.x", p.x, landing_msgs::kMaxPositionM},
                                           {"position.y", p.y, landing_msgs::kMaxPositionM},
                                           {"twist.linear.x", v.x, landing_msgs::kMaxSpeedMps},
                                           {"twist.linear.y", v.y, landing_msgs::kMaxSpeedMps},
                                           {"twist.angular.z", msg->twist.twist.angular.z, landing_msgs::kMaxRateRadps}})
    if (std::isfinite(value))
      if (auto problem = landing_msgs::numberProblem(name, value, limit))
        return rejections_.reject(gps_sub_.getTopic(), *problem);
  VehicleReport report;
  // Without a fix (a receiver in a dropout) the report still carries the vehicle's odometry; its position
  // variance then says "unknown".
  if (msg->pose.covariance[0] < kUnknownVariance)
  {
    Eigen::Vector2d pad(p.x, p.y);
    // The receiver sits at the vehicle origin; the pad centre is offset in the vehicle frame.
    pad += Eigen::Rotation2Dd(tf2::getYaw(q)) * gps_pad_offset_;
    if (!pad.allFinite())
    {
      ROS_WARN_THROTTLE(5.0, "Dropping a GPS fix with NaN or inf on %s", gps_sub_.getTopic().c_str());
      return;
    }
    report.pad_position = pad;
  }
  // The reported velocity (world frame) starts a track with a heading when vision is absent, and is the
  // pad's speed. The pad's offset from the receiver adds omega x offset, unknown here and at most a few cm/s.
  const Eigen::Vector2d reported(msg->twist.twist.linear.x, msg->twist.twist.linear.y);
  const double velocity_variance = std::max(msg->twist.covariance[0], msg->twist.covariance[7]);
  if (velocity_variance > 0.0 && velocity_variance < kUnknownVariance)
  {
    if (reported.allFinite())
    {
      report.velocity = reported;
      report.velocity_variance = velocity_variance;
    }
    else
      ROS_WARN_THROTTLE(5.0, "Dropping a velocity with NaN or inf on %s", gps_sub_.getTopic().c_str());
  }
  // The vehicle's heading and yaw rate, if reported (their variances given).
  const double yaw_variance = msg->pose.covariance[35];
  if (std::isfinite(yaw_variance) && yaw_variance > 0.0 && yaw_variance < kUnknownVariance)
  {
    if (std::isfinite(tf2::getYaw(q)))
    {
      report.heading = tf2::getYaw(q);
      report.heading_variance = yaw_variance;
    }
    else
      ROS_WARN_THROTTLE(5.0, "Dropping a heading with NaN or inf on %s", gps_sub_.getTopic().c_str());
  }
  const double yaw_rate_variance = msg->twist.covariance[35];
  if (std::isfinite(yaw_rate_variance) && yaw_rate_variance > 0.0 && yaw_rate_variance < kUnknownVariance)
  {
    if (std::isfinite(msg->twist.twist.angular.z))
    {
      report.yaw_rate = msg->twist.twist.angular.z;
      report.yaw_rate_variance = yaw_rate_variance;
    }
    else
      ROS_WARN_THROTTLE(5.0, "Dropping a yaw rate with NaN or inf on %s", gps_sub_.getTopic().c_str());
  }
  const ros::Time stamp = stampOf(msg->header);
  logOutcome(filter_.addVehicleReport(stamp.toSec(), report), gps_sub_.getTopic(), stamp);
}

std::optional<landing_msgs::InputProblem> PredictionNode::inputProblem(
    const std_msgs::Header& header, std::initializer_list<std::pair<const char*, double>> values, double limit) const
{
  if (auto problem = landing_msgs::stampProblem(header.stamp, ros::Time::now()))
    return problem;
  for (const auto& [name, value] : values)
    if (auto problem = landing_msgs::numberProblem(name, value, limit))
      return problem;
  return std::nullopt;
}

void PredictionNode::logOutcome(MeasurementOutcome outcome, const std::string& topic, const ros::Time& stamp)
{
  switch (outcome)
  {
    case MeasurementOutcome::kInitialised:
      ROS_INFO("Pad track started from %s at t = %.3f s", topic.c_str(), stamp.toSec());
      break;
    case MeasurementOutcome::kReinitialised:
      // Throttled: garbage fixes (the fuzz scenario) restarted the track 4 times in a second.
      ROS_WARN_THROTTLE(5.0, "Pad track restarted from %s at t = %.3f s: %d fixes in a row outside the gate",
               topic.c_str(), stamp.toSec(), filter_.parameters().max_consecutive_rejections);
      break;
    case MeasurementOutcome::kRejected:
      ROS_INFO_THROTTLE(5.0, "Rejecting outliers on %s (outside the gate)", topic.c_str());
      break;
    case MeasurementOutcome::kDroppedStale:
      ROS_WARN_THROTTLE(5.0, "Dropping fixes on %s older than the fusion horizon (%.2f s) or than the last fix "
                        "of their source (t = %.3f s)", topic.c_str(), filter_.horizon(), stamp.toSec());
      break;
    case MeasurementOutcome::kDroppedInvalid:
      ROS_WARN_THROTTLE(5.0, "Dropping a fix with a non-finite stamp on %s", topic.c_str());
      break;
    case MeasurementOutcome::kAccepted:
    case MeasurementOutcome::kIgnored:
      break;
  }
}

void PredictionNode::onTimer(const ros::TimerEvent&)
{
  const ros::Time now = ros::Time::now();
  if (now < last_tick_)
  {
    // The clock went backwards (simulation restarted): the old track and stamps mean nothing now.
    ROS_WARN("Time jumped back from %.3f s to %.3f s: resetting the pad track", last_tick_.toSec(), now.toSec());
    filter_.reset();
  }
  last_tick_ = now;
  step(now);
  lockstep_->ack(now);
}

void PredictionNode::step(const ros::Time& now)
{
  const bool tracking = filter_.isTracking(now.toSec());
  if (tracking != tracking_)
  {
    if (tracking)
      ROS_INFO_THROTTLE(2.0, "Tracking the pad: publishing %s and %s", path_pub_.getTopic().c_str(),
                        odom_pub_.getTopic().c_str());
    else
      ROS_WARN_THROTTLE(2.0, "Pad track lost (no accepted fix for %.1f s): not publishing until it is found again",
                        filter_.parameters().max_coast_time);
    tracking_ = tracking;
  }
  if (!tracking)
    return;
  const std::optional<PadState> state = filter_.stateAt(now.toSec());
  if (state)
    publish(now, *state);
}

void PredictionNode::publish(const ros::Time& now, const PadState& state)
{
  nav_msgs::Path path;
  path.header.stamp = now;
  path.header.frame_id = world_frame_;
  for (const PathPoint& point : filter_.predictPath(now.toSec(), time_step_, path_time_))
  {
    geometry_msgs::PoseStamped pose;
    pose.header.stamp = ros::Time(point.time);
    pose.header.frame_id = world_frame_;
    pose.pose.position.x = point.position.x();
    pose.pose.position.y = point.position.y();
    pose.pose.position.z = point.position.z();
    pose.pose.orientation = travelDirection(point.velocity);
    path.poses.push_back(pose);
  }
  path_pub_.publish(path);

  nav_msgs::Odometry odom;
  odom.header = path.header;
  // The twist is expressed in the world frame (conventions.md), so the child frame is the world too.
  odom.child_frame_id = world_frame_;
  odom.pose.pose.position = path.poses.front().pose.position;
  odom.pose.pose.orientation = travelDirection(state.velocity);
  odom.twist.twist.linear.x = state.velocity.x();
  odom.twist.twist.linear.y = state.velocity.y();
  odom.twist.twist.linear.z = 0.0;
  odom.twist.twist.angular.z = state.turn_rate;

  // Row-major 6x6 (x, y, z, rot x, rot y, rot z). Unestimated entries get kUnknownVariance.
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      odom.pose.covariance[i * 6 + j] = state.position_covariance(i, j);
  const double speed = state.velocity.head<2>().norm();
  double heading_variance = kUnknownVariance;
  if (speed >= kMinHeadingSpeed)
  {
    // Heading = atan2(vy, vx): gradient (-vy, vx) / speed^2.
    const Eigen::Vector2d gradient = Eigen::Vector2d(-state.velocity.y(), state.velocity.x()) / (speed * speed);
    heading_variance = std::min(kUnknownVariance, gradient.dot(state.velocity_covariance * gradient));
  }
  odom.pose.covariance[3 * 6 + 3] = odom.pose.covariance[4 * 6 + 4] = kUnknownVariance;
  odom.pose.covariance[5 * 6 + 5] = heading_variance;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      odom.twist.covariance[i * 6 + j] = state.velocity_covariance(i, j);
  odom.twist.covariance[2 * 6 + 2] = kUnknownVariance;
  odom.twist.covariance[3 * 6 + 3] = odom.twist.covariance[4 * 6 + 4] = kUnknownVariance;
  odom.twist.covariance[5 * 6 + 5] = state.turn_rate_variance;
  odom_pub_.publish(odom);
}

}  // namespace ped_traj_pred
