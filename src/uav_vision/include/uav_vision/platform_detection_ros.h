// ROS wrapper of the pad localizer: the platform_detection node (thin: sensor plumbing, checks of the
// incoming messages, publishing). The algorithm lives in the ROS-free uav_vision_detector library.
// Service ~reset (std_srvs/Trigger): the parameters are read again as they are at the call and every history is
// emptied, as after a restart; a missing or invalid parameter refuses it and the node goes on as it was.
#pragma once

#include <deque>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include <Eigen/Geometry>
#include <image_transport/image_transport.h>
#include <landing_msgs/Altimeter.h>
#include <landing_runtime/input_check.h>
#include <landing_runtime/lockstep_acker.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/Range.h>
#include <std_srvs/Trigger.h>

#include "uav_vision/attitude_history.h"
#include "uav_vision/estimate_history.h"
#include "uav_vision/pad_localizer.h"
#include "uav_vision/reading_history.h"

namespace uav_vision {

// A missing or invalid parameter; the message names it.
struct ConfigError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

struct PlatformDetectionConfig {
  PadLocalizerParams localizer;
  std::string base_frame, world_frame;
  double odom_timeout = 0.5;       // [s]
  double imu_max_offset = 0.05;    // [s]
  double sonar_timeout = 0.2;      // [s]
  double altimeter_timeout = 0.5;  // [s]
  double altimeter_window = 0.1;   // [s]
  double warn_period = 5.0;        // [s]

  // Reads every key of config/platform_detection.yaml from `pnh`; throws ConfigError naming the first
  // missing or invalid one.
  static PlatformDetectionConfig load(const ros::NodeHandle& pnh);
};

// What the node builds up from its configuration and the sensors; a fresh start and a reset make it the same
// way, from the configuration alone.
struct DetectionState {
  explicit DetectionState(const PlatformDetectionConfig& config);

  PlatformDetectionConfig config;
  PadLocalizer localizer;
  std::optional<CameraIntrinsics> intrinsics;  // from the last valid camera_info
  AttitudeHistory attitudes;  // the last second of IMU attitudes and rates
  ReadingHistory sonar_ranges, altitudes;  // the last second of sonar ranges and barometric altitudes
  double sonar_half_angle = 0.0;  // half the sonar's field_of_view [rad]
  EstimateHistory estimates;  // the last second of ardrone/odom_estimate
};

class PlatformDetectionRos {
 public:
  // Subscribes and advertises on `nh` (relative names); parameters from `pnh`, and the ~reset service there.
  // Throws ConfigError.
  PlatformDetectionRos(ros::NodeHandle nh, ros::NodeHandle pnh);

 private:
  // ~reset: a new state from the parameters as they are, or (a bad parameter) nothing changed.
  bool onReset(std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);
  void onImage(const sensor_msgs::ImageConstPtr& msg);
  void processImage(const sensor_msgs::ImageConstPtr& msg);
  void onCameraInfo(const sensor_msgs::CameraInfoConstPtr& msg);
  void onImu(const sensor_msgs::ImuConstPtr& msg);
  void onSonar(const sensor_msgs::RangeConstPtr& msg);
  void onAltimeter(const landing_msgs::AltimeterConstPtr& msg);
  void onOdomEstimate(const nav_msgs::OdometryConstPtr& msg);

  // A stamp too far from the clock, or (``frame`` not empty) a frame other than ``frame``.
  std::optional<landing_runtime::InputProblem> inputProblem(const std_msgs::Header& header, const std::string& frame) const;
  void publish(const std_msgs::Header& image_header, const PadObservation& observation);
  void publishDebugImage(const sensor_msgs::ImageConstPtr& msg, const cv::Mat& image, const PadObservation& observation,
                         const CameraIntrinsics& intrinsics);

  // The topics are fixed names (remapped by the launch file), so a reset keeps the subscriptions and publishers
  // (none latched). Callbacks and ~reset all run on the one spinner thread of main(): never on the state at once.
  ros::NodeHandle pnh_;
  DetectionState state_;
  image_transport::ImageTransport image_transport_;
  image_transport::Subscriber image_sub_;
  image_transport::Publisher debug_pub_;
  ros::Subscriber camera_info_sub_, imu_sub_, sonar_sub_, altimeter_sub_, odom_sub_;
  ros::Publisher platform_in_base_pub_, platform_in_world_pub_, indicator_in_base_pub_;
  landing_runtime::LockstepAcker lockstep_;
  // Garbage on the inputs: what was wrong, once per topic and kind (optional: a reset makes a new one).
  std::optional<landing_runtime::RejectionLog> rejections_;
  ros::ServiceServer reset_service_;
};

}  // namespace uav_vision
