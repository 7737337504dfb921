// bench_publisher RATE SECONDS: publishes small messages on 8 topics (2 each of Imu, Odometry, Twist, PoseStamped),
// one after the other at RATE messages per second in all, for SECONDS once a subscriber is on every topic; prints
// how many it published. For bench_recorder.
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/Twist.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/Imu.h>

int main(int argc, char** argv) {
  ros::init(argc, argv, "bench_publisher");
  if (argc < 3 || std::atof(argv[1]) <= 0.0 || std::atof(argv[2]) <= 0.0) {
    std::fprintf(stderr, "usage: bench_publisher RATE SECONDS (both positive)\n");
    return 2;
  }
  const double rate_hz = std::atof(argv[1]), seconds = std::atof(argv[2]);
  ros::NodeHandle node;
  std::vector<ros::Publisher> publishers;
  for (int i = 0; i < 2; ++i) {
    const std::string n = std::to_string(i);
    publishers.push_back(node.advertise<sensor_msgs::Imu>("bench/imu" + n, 100));
    publishers.push_back(node.advertise<nav_msgs::Odometry>("bench/odom" + n, 100));
    publishers.push_back(node.advertise<geometry_msgs::Twist>("bench/twist" + n, 100));
    publishers.push_back(node.advertise<geometry_msgs::PoseStamped>("bench/pose" + n, 100));
  }
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(30.0);
  auto everyone_listens = [&] {
    for (const ros::Publisher& publisher : publishers) {
      if (publisher.getNumSubscribers() == 0) return false;
    }
    return true;
  };
  while (ros::ok() && !everyone_listens()) {
    if (ros::WallTime::now() > give_up) {
      std::fprintf(stderr, "bench_publisher: no subscriber on every topic within 30 s\n");
      return 1;
    }
    ros::WallDuration(0.01).sleep();
  }
  std::printf("ready\n");  // (bench_recorder samples the recorder's CPU from here)
  std::fflush(stdout);
  sensor_msgs::Imu imu;
  nav_msgs::Odometry odom;
  geometry_msgs::Twist twist;
  geometry_msgs::PoseStamped pose;
  ros::WallRate rate(rate_hz);
  long sent = 0;
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(seconds);
  while (ros::ok() && ros::WallTime::now() < end) {
    ros::Publisher& publisher = publishers[sent % publishers.size()];
    switch (sent % 4) {
      case 0: imu.header.stamp = ros::Time::now(); publisher.publish(imu); break;
      case 1: odom.header.stamp = ros::Time::now(); publisher.publish(odom); break;
      case 2: twist.linear.x = static_cast<double>(sent); publisher.publish(twist); break;
      default: pose.header.stamp = ros::Time::now(); publisher.publish(pose); break;
    }
    ++sent;
    rate.sleep();
  }
  std::printf("%ld\n", sent);
  ros::WallDuration(0.5).sleep();  // (the last messages leave before the connections close)
  return 0;
}
