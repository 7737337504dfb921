// Lock-step acknowledgements to the simulator (see landing_msgs/LockstepAck), for C++ nodes:
//   LockstepAcker ack(nh, "ardrone/bottom/image_raw");   // a topic: ack.ack(msg->header.stamp) once processed
//   LockstepAcker ack(nh, ros::Duration(1.0 / rate));    // a timer: ack.ack(event.current_real) each step
// Outside the simulator nobody listens and nothing is sent.
#pragma once

#include <string>

#include <landing_msgs/LockstepAck.h>
#include <ros/ros.h>

namespace landing_runtime {

class LockstepAcker {
 public:
  LockstepAcker(ros::NodeHandle& nh, const std::string& input_topic) { init(nh, nh.resolveName(input_topic), {}); }
  LockstepAcker(ros::NodeHandle& nh, const ros::Duration& period) { init(nh, "/clock", period); }

  void ack(const ros::Time& stamp) {
    if (publisher_.getNumSubscribers() == 0) return;
    msg_.stamp = stamp;
    publisher_.publish(msg_);
  }

 private:
  void init(ros::NodeHandle& nh, const std::string& input, const ros::Duration& period) {
    msg_.node = ros::this_node::getName();
    msg_.input = input;
    msg_.period = period;
    publisher_ = nh.advertise<landing_msgs::LockstepAck>("lockstep_ack", 10);
  }

  ros::Publisher publisher_;
  landing_msgs::LockstepAck msg_;
};

}  // namespace landing_runtime
