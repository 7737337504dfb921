// bench_recorder's load: small messages (IMU, odometry, tf, twist, pose, range, GPS) on 16 topics, each at its
// own rate on its own wall timer so that they come spread in time, as a simulator's sensors do, plus a latched
// /tf_static. It waits for `--subscribers` subscribers on every topic, publishes for `--duration` seconds,
// then prints the counts and stays (its connections open) until SIGINT.
//
// stdout, one line each: "READY", "START", then "END" and one "COUNT topic n" per topic (the latched one too).
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/Twist.h>
#include <nav_msgs/Odometry.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/NavSatFix.h>
#include <sensor_msgs/Range.h>
#include <tf2_msgs/TFMessage.h>

namespace {

struct BenchTopic {
  std::string name;
  double rate_hz;
  ros::Publisher publisher;
  std::function<void(ros::Publisher&, uint64_t)> publish;
  uint64_t published = 0;
  ros::WallTimer timer;
};

template <class M>
BenchTopic makeTopic(ros::NodeHandle& node, const std::string& name, double rate_hz,
                     std::function<void(M&, uint64_t)> fill) {
  BenchTopic topic;
  topic.name = name;
  topic.rate_hz = rate_hz;
  topic.publisher = node.advertise<M>(name, 100);
  topic.publish = [fill](ros::Publisher& publisher, uint64_t sequence) {
    M message;
    fill(message, sequence);
    publisher.publish(message);
  };
  return topic;
}

void stamp(std_msgs::Header& header, const char* frame) {
  header.stamp = ros::Time::now();
  header.frame_id = frame;
}

double argument(int argc, char** argv, const std::string& name, double fallback) {
  for (int i = 1; i + 1 < argc; ++i) {
    if (argv[i] == name) return std::atof(argv[i + 1]);
  }
  return fallback;
}

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "bench_publisher");
  const double duration_s = argument(argc, argv, "--duration", 20.0);
  const int subscribers = static_cast<int>(argument(argc, argv, "--subscribers", 1));
  ros::NodeHandle node;

  auto imu = [](sensor_msgs::Imu& m, uint64_t n) {
    stamp(m.header, "imu");
    m.orientation.w = 1.0;
    m.angular_velocity.z = 0.001 * n;
    m.linear_acceleration.z = 9.81;
  };
  auto odometry = [](nav_msgs::Odometry& m, uint64_t n) {
    stamp(m.header, "odom");
    m.child_frame_id = "base_link";
    m.pose.pose.position.x = 0.01 * n;
    m.pose.pose.orientation.w = 1.0;
    m.twist.twist.linear.x = 1.0;
  };
  auto twist = [](geometry_msgs::Twist& m, uint64_t n) { m.linear.x = 0.001 * n; };
  auto pose = [](geometry_msgs::PoseStamped& m, uint64_t n) {
    stamp(m.header, "map");
    m.pose.position.x = 0.01 * n;
    m.pose.orientation.w = 1.0;
  };
  auto range = [](sensor_msgs::Range& m, uint64_t n) {
    stamp(m.header, "sonar");
    m.range = 1.0f + 0.001f * (n % 100);
    m.max_range = 6.0f;
  };
  auto gps = [](sensor_msgs::NavSatFix& m, uint64_t n) {
    stamp(m.header, "gps");
    m.latitude = 48.0 + 1e-7 * n;
    m.longitude = 11.0;
  };
  auto tf = [](tf2_msgs::TFMessage& m, uint64_t n) {
    geometry_msgs::TransformStamped transform;
    stamp(transform.header, "odom");
    transform.child_frame_id = "base_link";
    transform.transform.translation.x = 0.01 * n;
    transform.transform.rotation.w = 1.0;
    m.transforms.push_back(transform);
  };

  // 14 topics at 100 Hz and 2 at 50 Hz: 1500 messages a second.
  std::vector<BenchTopic> topics;
  topics.push_back(makeTopic<sensor_msgs::Imu>(node, "/bench/imu", 100, imu));
  topics.push_back(makeTopic<sensor_msgs::Imu>(node, "/bench/imu_raw", 100, imu));
  topics.push_back(makeTopic<nav_msgs::Odometry>(node, "/bench/odom", 100, odometry));
  topics.push_back(makeTopic<nav_msgs::Odometry>(node, "/bench/odom_estimate", 100, odometry));
  topics.push_back(makeTopic<nav_msgs::Odometry>(node, "/bench/ground_truth", 100, odometry));
  topics.push_back(makeTopic<tf2_msgs::TFMessage>(node, "/tf", 100, tf));
  topics.push_back(makeTopic<geometry_msgs::Twist>(node, "/bench/cmd_vel", 100, twist));
  topics.push_back(makeTopic<geometry_msgs::Twist>(node, "/bench/cmd_vel_mux", 100, twist));
  topics.push_back(makeTopic<geometry_msgs::Twist>(node, "/bench/flow_velocity", 100, twist));
  topics.push_back(makeTopic<geometry_msgs::PoseStamped>(node, "/bench/pose", 100, pose));
  topics.push_back(makeTopic<geometry_msgs::PoseStamped>(node, "/bench/target_pose", 100, pose));
  topics.push_back(makeTopic<geometry_msgs::PoseStamped>(node, "/bench/pad_pose", 100, pose));
  topics.push_back(makeTopic<sensor_msgs::Range>(node, "/bench/sonar", 100, range));
  topics.push_back(makeTopic<sensor_msgs::Range>(node, "/bench/altimeter", 100, range));
  topics.push_back(makeTopic<sensor_msgs::NavSatFix>(node, "/bench/gps", 50, gps));
  topics.push_back(makeTopic<sensor_msgs::NavSatFix>(node, "/bench/gps_platform", 50, gps));

  ros::Publisher tf_static = node.advertise<tf2_msgs::TFMessage>("/tf_static", 1, true);
  tf2_msgs::TFMessage static_transforms;
  tf(static_transforms, 0);
  tf_static.publish(static_transforms);

  std::printf("READY\n");
  std::fflush(stdout);
  // Every recorder subscribed first, so that each of them gets every message.
  const ros::WallTime give_up = ros::WallTime::now() + ros::WallDuration(120.0);
  for (;;) {
    bool all = tf_static.getNumSubscribers() >= static_cast<uint32_t>(subscribers);
    for (const BenchTopic& topic : topics) all = all && topic.publisher.getNumSubscribers() >= uint32_t(subscribers);
    if (all) break;
    if (!ros::ok() || ros::WallTime::now() > give_up) {
      std::fprintf(stderr, "bench_publisher: the recorder did not subscribe to every topic\n");
      return 1;
    }
    ros::WallDuration(0.01).sleep();
  }

  std::printf("START\n");
  std::fflush(stdout);
  bool publishing = true;
  for (size_t i = 0; i < topics.size(); ++i) {
    BenchTopic& topic = topics[i];
    // Each timer on its own phase: 16 timers at 100 Hz would otherwise fire together.
    ros::WallDuration(0.0007).sleep();
    topic.timer = node.createWallTimer(ros::WallDuration(1.0 / topic.rate_hz),
                                       [&topic, &publishing](const ros::WallTimerEvent&) {
                                         if (publishing) topic.publish(topic.publisher, topic.published++);
                                       });
  }
  ros::WallTimer stop = node.createWallTimer(ros::WallDuration(duration_s), [&](const ros::WallTimerEvent&) {
    publishing = false;
  }, true);
  while (ros::ok() && publishing) ros::getGlobalCallbackQueue()->callAvailable(ros::WallDuration(0.01));
  for (BenchTopic& topic : topics) topic.timer.stop();

  std::printf("END\n");
  for (const BenchTopic& topic : topics) {
    std::printf("COUNT %s %llu\n", topic.name.c_str(), static_cast<unsigned long long>(topic.published));
  }
  std::printf("COUNT /tf_static 1\n");
  std::fflush(stdout);
  ros::spin();  // until SIGINT: the messages in flight still reach the recorders
  return 0;
}
