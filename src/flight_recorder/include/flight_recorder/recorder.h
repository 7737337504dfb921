#pragma once
// The recorder node: subscriptions whose callbacks, run by the main thread from the global callback queue,
// write each message straight into the bag. No queue and no writer thread: rosbag record hands every message
// from roscpp's poll thread to a spinner thread, a queue and a writer thread, and the switches between those
// threads cost more CPU than the writing.

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include <ros/ros.h>
#include <rosbag/bag.h>
#include <topic_tools/shape_shifter.h>

#include "flight_recorder/bag_files.h"
#include "flight_recorder/recorder_options.h"
#include "flight_recorder/topic_selection.h"

namespace flight_recorder {

class Recorder {
 public:
  explicit Recorder(const RecorderOptions& options);

  // Records until requestStop(), a ROS shutdown (rosnode kill, the master) or --duration without --split,
  // then closes the bag. Returns the exit code: 0, or 1 when the bag could not be opened or written.
  int run();

  // From any thread: stop at the next callback boundary, closing the bag. Wakes the main thread at once.
  void requestStop();

 private:
  int record();  // run() without the unsubscribing
  void discoverTopics();
  void subscribe(const std::string& topic);
  void onMessage(const ros::MessageEvent<const topic_tools::ShapeShifter>& event, const std::string& topic);
  void onDiscoveryTimer(const ros::WallTimerEvent&);
  bool waitForValidTime();
  bool openBag();
  void closeBag();
  // Closes the bag and opens the next one for each --duration that ROS time `now` has passed.
  void splitIfDue(const ros::Time& now);
  void fail(const std::string& message);

  RecorderOptions options_;
  TopicSelection selection_;
  ros::NodeHandle node_;
  std::vector<ros::Subscriber> subscribers_;
  std::set<std::string> subscribed_topics_;
  ros::WallTimer discovery_timer_;
  ros::WallTime started_;
  double discovery_period_s_ = 0.0;

  rosbag::Bag bag_;
  std::string bag_name_;  // the closed bag's name; bag_ writes activeBagName(bag_name_)
  unsigned split_index_ = 0;
  SplitSchedule split_schedule_;

  std::atomic<bool> stop_requested_{false};
  std::mutex stop_mutex_;
  std::condition_variable stop_condition_;
  int exit_code_ = 0;
};

// The end of the recorder's process, after run(): unregisters what is left of it at the master (roscpp's own
// /rosout publication and, under /use_sim_time, /clock subscription; its services) and exits without
// ros::shutdown(), which takes 0.2-0.3 s joining roscpp's threads (each wakes every 0.1 s) while the caller waits
// for the process to end.
[[noreturn]] void leaveGraphAndExit(int exit_code);

}  // namespace flight_recorder
