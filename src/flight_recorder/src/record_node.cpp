// rosrun flight_recorder record [options] TOPIC... | -e REGEX... | -a   (the options of rosbag record it supports:
// flight_recorder/options.h). SIGINT and SIGTERM end it with 0 once every message received is in the bag and the
// bag is closed; a bad command line ends it with 2, a bag that cannot be written with 1.
#include <atomic>
#include <csignal>
#include <iostream>

#include <ros/callback_queue.h>
#include <ros/ros.h>

#include "flight_recorder/recorder.h"

namespace {
std::atomic<bool> stop_requested(false);
void requestStop(int) { stop_requested = true; }
}  // namespace

int main(int argc, char** argv) {
  // Our own SIGINT handler: roscpp's would shut down at once and drop the messages still in the callback queue.
  ros::init(argc, argv, "record", ros::init_options::AnonymousName | ros::init_options::NoSigintHandler);
  std::signal(SIGINT, requestStop);
  std::signal(SIGTERM, requestStop);
  flight_recorder::Options options;
  try {
    options = flight_recorder::parseOptions(std::vector<std::string>(argv + 1, argv + argc));
  } catch (const flight_recorder::OptionError& error) {
    std::cerr << "record: " << error.what() << "\n" << flight_recorder::usage();
    return 2;
  }
  if (options.help) {
    std::cout << flight_recorder::usage();
    return 0;
  }
  ros::NodeHandle node;
  // Receipt times are ROS time: under /use_sim_time nothing is recorded before the clock runs.
  while (!stop_requested && ros::ok() && !ros::Time::isValid()) ros::WallDuration(0.005).sleep();
  flight_recorder::Recorder recorder(options, node);
  try {
    recorder.start();
  } catch (const rosbag::BagException& error) {
    std::cerr << "record: cannot open the bag: " << error.what()
              << " (does the directory exist, and may this user write there?)\n";
    return 1;
  }
  ros::CallbackQueue& queue = *ros::getGlobalCallbackQueue();
  while (!stop_requested && ros::ok() && !recorder.finished()) queue.callAvailable(ros::WallDuration(0.02));
  queue.callAvailable();  // what arrived before the stop
  recorder.close();
  ros::shutdown();
  return recorder.failure().empty() ? 0 : 1;
}
