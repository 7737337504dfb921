// platform_detection: finds the landing pad in the bottom camera and publishes its position relative to
// the drone (ardrone/base_link) and in the world. See launch/platform_detection.launch.
#include <ros/ros.h>

#include "uav_vision/platform_detection_ros.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "platform_detection");
  ros::NodeHandle nh, pnh("~");
  try {
    uav_vision::PlatformDetectionRos node(nh, pnh);
    ros::spin();
  } catch (const uav_vision::ConfigError& error) {
    ROS_FATAL("platform_detection: %s", error.what());
    return 1;
  }
  return 0;
}
