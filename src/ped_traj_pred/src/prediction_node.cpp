#include "ped_traj_pred/prediction_node.h"

#include <nav_msgs/Path.h>
#include <ros/names.h>
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
  return p;  // validated with the rest (PredictionSettings::validate)
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

/// A topic name parameter: empty, or a name roscpp accepts.
std::string requireTopicParam(const ros::NodeHandle& nh, const std::string& name)
{
  const std::string topic = requireParam<std::string>(nh, name);
  std::string error;
  if (!topic.empty() && !ros::names::validate(topic, error))
    throw ParameterError("invalid parameter: " + nh.resolveName(name) + " = '" + topic + "': " + error);
  return topic;
}
}  // namespace

PredictionSettings loadSettings(const ros::NodeHandle& private_nh)
{
  PredictionSettings s;
  s.filter = loadFilterParameters(private_nh);
  s.fusion_horizon = requireParam<double>(private_nh, "fusion_horizon");
  s.world_frame = withoutLeadingSlash(requireParam<std::string>(private_nh, "world_frame"));
  s.time_step = requireParam<double>(private_nh, "time_step");
  s.path_time = requireParam<double>(private_nh, "path_time");
  s.pub_freq = requireParam<double>(private_nh, "pub_freq");
  s.gps_pad_offset << requireParam<double>(private_nh, "gps_pad_offset_x"),
      requireParam<double>(private_nh, "gps_pad_offset_y");
  s.pose_topic = requireTopicParam(private_nh, "pose_topic");
  s.relative_pose_topic = requireTopicParam(private_nh, "relative_pose_topic");
  s.gps_topic = requireTopicParam(private_nh, "gps_topic");
  s.future_path_topic = requireTopicParam(private_nh, "future_path_topic");
  s.odom_topic = requireTopicParam(private_nh, "odom_topic");
  const std::string problem = s.validate();
  if (!problem.empty())
    throw ParameterError("invalid parameter: " + private_nh.resolveName("") + "/" + problem);
  return s;
}

PredictionNode::PredictionNode(ros::NodeHandle& nh, ros::NodeHandle& private_nh)
  : nh_(nh), private_nh_(private_nh), settings_(loadSettings(private_nh)), track_(settings_)
{
  rejections_.emplace();
  connect(settings_, nullptr);
  reset_service_ = private_nh_.advertiseService("reset", &PredictionNode::onReset, this);
}

void PredictionNode::connect(const PredictionSettings& settings, const PredictionSettings* previous)
{
  // Kept when unchanged: a re-made subscription would lose the connections and what is in flight on them.
  auto changed = [&settings, previous](std::string PredictionSettings::*topic) {
    return previous == nullptr || previous->*topic != settings.*topic;
  };
  // Low latency matters more than bandwidth: every detection is used at its own stamp.
  const ros::TransportHints no_delay = ros::TransportHints().tcpNoDelay();
  if (changed(&PredictionSettings::future_path_topic))
    path_pub_ = nh_.advertise<nav_msgs::Path>(settings.future_path_topic, 10);
  if (changed(&PredictionSettings::odom_topic))
    odom_pub_ = nh_.advertise<nav_msgs::Odometry>(settings.odom_topic, 10);
  if (changed(&PredictionSettings::pose_topic))
    detection_sub_ = nh_.subscribe(settings.pose_topic, 30, &PredictionNode::onDetection, this, no_delay);
  if (changed(&PredictionSettings::relative_pose_topic))
    relative_sub_ = settings.relative_pose_topic.empty() ?
                        ros::Subscriber() :
                        nh_.subscribe(settings.relative_pose_topic, 30, &PredictionNode::onRelativeDetection, this,
                                      no_delay);
  if (changed(&PredictionSettings::gps_topic))
    gps_sub_ = settings.gps_topic.empty() ?
                   ros::Subscriber() :
                   nh_.subscribe(settings.gps_topic, 10, &PredictionNode::onGps, this, no_delay);
  if (previous == nullptr || previous->pub_freq != settings.pub_freq)
  {
    lockstep_.reset();  // its publisher let go before the new one advertises the same topic
    lockstep_.emplace(nh_, ros::Duration(1.0 / settings.pub_freq));
    timer_ = nh_.createTimer(ros::Duration(1.0 / settings.pub_freq), &PredictionNode::onTimer, this);
  }
  ROS_INFO("Predicting the pad from %s%s%s: %s (nav_msgs/Path, %.1f s ahead every %.2f s) and %s at %.1f Hz",
           detection_sub_.getTopic().c_str(), settings.gps_topic.empty() ? "" : " and ",
           settings.gps_topic.empty() ? "" : gps_sub_.getTopic().c_str(), path_pub_.getTopic().c_str(),
           settings.path_time, settings.time_step, odom_pub_.getTopic().c_str(), settings.pub_freq);
}

bool PredictionNode::onReset(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response)
{
  const std::string node = ros::this_node::getName();
  // Everything new is built before anything is let go of: a refused reset leaves the node as it was.
  std::optional<PredictionSettings> settings;
  std::optional<Track> track;
  try
  {
    settings.emplace(loadSettings(private_nh_));
    track.emplace(*settings);
  }
  catch (const std::exception& error)  // ParameterError; std::invalid_argument from the filter
  {
    response.success = false;
    response.message = node + " not reset (it goes on as it was): " + error.what();
    ROS_ERROR("%s", response.message.c_str());
    return true;
  }
  connect(*settings, &settings_);
  settings_ = std::move(*settings);
  track_ = std::move(*track);
  rejections_.emplace();
  response.success = true;
  response.message = node + " reset";
  ROS_INFO("%s", response.message.c_str());
  return true;
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
  if (!frame.empty() && frame != settings_.world_frame)
  {
    ROS_WARN_THROTTLE(5.0, "Dropping detections on %s in frame '%s': expected '%s'",
                      detection_sub_.getTopic().c_str(), frame.c_str(), settings_.world_frame.c_str());
    return;
  }
  if (auto problem = inputProblem(msg->header, {{"point.x", position.x()}, {"point.y", position.y()},
                                                {"point.z", position.z()}}, landing_runtime::kMaxPositionM))
    return rejections_->reject(detection_sub_.getTopic(), *problem);
  const ros::Time stamp = stampOf(msg->header);
  logOutcome(track_.filter.addVision(stamp.toSec(), position, visionVariance(stamp)), detection_sub_.getTopic(), stamp);
}

void PredictionNode::onRelativeDetection(const geometry_msgs::PointStamped::ConstPtr& msg)
{
  // Relative to the drone: its height above the pad at most, and a camera's view across.
  if (auto problem = inputProblem(msg->header, {{"point.x", msg->point.x}, {"point.y", msg->point.y},
                                                {"point.z", msg->point.z}}, landing_runtime::kMaxAltitudeM))
    return rejections_->reject(relative_sub_.getTopic(), *problem);
  const double range = std::sqrt(msg->point.x * msg->point.x + msg->point.y * msg->point.y + msg->point.z * msg->point.z);
  track_.last_range = std::make_pair(stampOf(msg->header), range);
}

double PredictionNode::visionVariance(const ros::Time& stamp) const
{
  // The relative fix of the same frame gives the range; the previous frame's is close enough.
  constexpr double kMaxRangeAge = 0.2;  // [s]
  if (track_.last_range && std::abs((stamp - track_.last_range->first).toSec()) <= kMaxRangeAge)
    return track_.filter.parameters().visionVariance(track_.last_range->second);
  return track_.filter.parameters().observation_covariance;
}

void PredictionNode::onGps(const nav_msgs::Odometry::ConstPtr& msg)
{
  const geometry_msgs::Point& p = msg->pose.pose.position;
  const geometry_msgs::Quaternion& q = msg->pose.pose.orientation;
  if (auto problem = landing_runtime::frameProblem(msg->header.frame_id, settings_.world_frame))
    return rejections_->reject(gps_sub_.getTopic(), *problem);
  if (auto problem = landing_runtime::stampProblem(msg->header.stamp, ros::Time::now()))
    return rejections_->reject(gps_sub_.getTopic(), *problem);
  // A NaN is dropped field by field below (a report without that part); a finite value must be plausible.
  const geometry_msgs::Vector3& v = msg->twist.twist.linear;
  for (const auto& [name, value, limit] : {std::tuple<const char*, double, double>{"position.x", p.x, landing_runtime::kMaxPositionM},
                                           {"position.y", p.y, landing_runtime::kMaxPositionM},
                                           {"twist.linear.x", v.x, landing_runtime::kMaxSpeedMps},
                                           {"twist.linear.y", v.y, landing_runtime::kMaxSpeedMps},
                                           {"twist.angular.z", msg->twist.twist.angular.z, landing_runtime::kMaxRateRadps}})
    if (std::isfinite(value))
      if (auto problem = landing_runtime::numberProblem(name, value, limit))
        return rejections_->reject(gps_sub_.getTopic(), *problem);
  VehicleReport report;
  // Without a fix (a receiver in a dropout) the report still carries the vehicle's odometry; its position
  // variance then says "unknown".
  if (msg->pose.covariance[0] < kUnknownVariance)
  {
    Eigen::Vector2d pad(p.x, p.y);
    // The receiver sits at the vehicle origin; the pad centre is offset in the vehicle frame.
    pad += Eigen::Rotation2Dd(tf2::getYaw(q)) * settings_.gps_pad_offset;
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
  logOutcome(track_.filter.addVehicleReport(stamp.toSec(), report), gps_sub_.getTopic(), stamp);
}

std::optional<landing_runtime::InputProblem> PredictionNode::inputProblem(
    const std_msgs::Header& header, std::initializer_list<std::pair<const char*, double>> values, double limit) const
{
  if (auto problem = landing_runtime::stampProblem(header.stamp, ros::Time::now()))
    return problem;
  for (const auto& [name, value] : values)
    if (auto problem = landing_runtime::numberProblem(name, value, limit))
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
               topic.c_str(), stamp.toSec(), track_.filter.parameters().max_consecutive_rejections);
      break;
    case MeasurementOutcome::kRejected:
      ROS_INFO_THROTTLE(5.0, "Rejecting outliers on %s (outside the gate)", topic.c_str());
      break;
    case MeasurementOutcome::kDroppedStale:
      ROS_WARN_THROTTLE(5.0, "Dropping fixes on %s older than the fusion horizon (%.2f s) or than the last fix "
                        "of their source (t = %.3f s)", topic.c_str(), track_.filter.horizon(), stamp.toSec());
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
  if (now < track_.last_tick)
  {
    // The clock went backwards (simulation restarted): the old track and stamps mean nothing now.
    ROS_WARN("Time jumped back from %.3f s to %.3f s: resetting the pad track", track_.last_tick.toSec(), now.toSec());
    track_.filter.reset();
  }
  track_.last_tick = now;
  step(now);
  lockstep_->ack(now);
}

void PredictionNode::step(const ros::Time& now)
{
  const bool tracking = track_.filter.isTracking(now.toSec());
  if (tracking != track_.tracking)
  {
    if (tracking)
      ROS_INFO_THROTTLE(2.0, "Tracking the pad: publishing %s and %s", path_pub_.getTopic().c_str(),
                        odom_pub_.getTopic().c_str());
    else
      ROS_WARN_THROTTLE(2.0, "Pad track lost (no accepted fix for %.1f s): not publishing until it is found again",
                        track_.filter.parameters().max_coast_time);
    track_.tracking = tracking;
  }
  if (!tracking)
    return;
  const std::optional<PadState> state = track_.filter.stateAt(now.toSec());
  if (state)
    publish(now, *state);
}

void PredictionNode::publish(const ros::Time& now, const PadState& state)
{
  nav_msgs::Path path;
  path.header.stamp = now;
  path.header.frame_id = settings_.world_frame;
  for (const PathPoint& point : track_.filter.predictPath(now.toSec(), settings_.time_step, settings_.path_time))
  {
    geometry_msgs::PoseStamped pose;
    pose.header.stamp = ros::Time(point.time);
    pose.header.frame_id = settings_.world_frame;
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
  odom.child_frame_id = settings_.world_frame;
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
