// The flight recorder: every wanted topic into a bag, each message written in the callback that receives it.
//
// Each message is written in roscpp's network thread as it is read off its connection (InlineCallbacks): no
// spinner thread, no queue, no writer thread. rosbag record hands each message from that thread through a
// MultiThreadedSpinner of ten threads and a queue to its writer thread; on a loaded 2-core machine those hand-offs
// (a thread woken for each message) were most of its CPU.
#pragma once

#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include <ros/callback_queue_interface.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <topic_tools/shape_shifter.h>

#include "flight_recorder/options.h"

namespace flight_recorder {

// A callback "queue" that runs each callback at once, in the thread that adds it: for a subscription, roscpp's
// network thread, as the message arrives.
class InlineCallbacks : public ros::CallbackQueueInterface {
 public:
  void addCallback(const ros::CallbackInterfacePtr& callback, uint64_t owner_id) override;
  void removeByID(uint64_t) override {}
};

class Recorder {
 public:
  Recorder(const Options& options, ros::NodeHandle& node);
  ~Recorder();

  // Opens the first bag and subscribes to the wanted topics advertised now, then looks for more on a wall
  // timer (sim time may stand still until the recorder has subscribed). Throws rosbag::BagException when the
  // bag cannot be opened.
  void start();
  // Closes the bag (NAME.bag.active becomes NAME.bag); a second call does nothing.
  void close();
  // Whether recording is over by itself: --duration reached (without --split), or a bag could not be written.
  bool finished() const { return finished_; }
  // Why recording stopped early (a bag that could not be written), or "".
  const std::string& failure() const { return failure_; }

 private:
  void discover();
  void subscribe(const std::string& topic);
  void onMessage(const ros::MessageEvent<topic_tools::ShapeShifter const>& event, const std::string& topic);
  void openBag();
  void closeBag();
  void fail(const std::string& what);

  Options options_;
  TopicFilter filter_;
  InlineCallbacks inline_callbacks_;
  std::mutex bag_mutex_;     // the network thread writes, the main thread (discovery, the stop) closes
  ros::NodeHandle& node_;
  rosbag::Bag bag_;
  bool open_ = false;
  std::string bag_name_;
  std::string date_;         // the recording's start (local time), in a prefixed bag's name
  int split_index_ = 0;
  ros::Time span_start_;     // ROS time the current bag's span began (--split, --duration)
  std::set<std::string> subscribed_;
  std::vector<ros::Subscriber> subscribers_;
  ros::WallTimer discovery_;
  ros::WallTime started_;
  bool discovering_fast_ = true;
  bool finished_ = false;
  std::string failure_;
};

}  // namespace flight_recorder
