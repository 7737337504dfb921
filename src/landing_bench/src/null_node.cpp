// A null node of the graph floor (landing_bench.graph_floor), roscpp: the transport of one roscpp node of the
// landing graph without its work. Reads ~null_spec (see landing_bench/null_node.py, its rospy twin), subscribes to
// every topic without deserialising (topic_tools::ShapeShifter), publishes the default message of each publication
// at its rate on the events of its driver (a timer, or an input: graph_floor.NodeShape.driver), and acknowledges
// what the real node acknowledges.
#include <landing_bench/null_node_core.h>
#include <landing_runtime/lockstep_acker.h>
#include <ros/ros.h>
#include <topic_tools/shape_shifter.h>

#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

std::string member(XmlRpc::XmlRpcValue& value, const char* key) {
  if (value.getType() != XmlRpc::XmlRpcValue::TypeStruct || !value.hasMember(key) ||
      value[key].getType() != XmlRpc::XmlRpcValue::TypeString)
    throw std::runtime_error(std::string("an entry lacks the text field '") + key + "'");
  return static_cast<std::string>(value[key]);
}

double number(XmlRpc::XmlRpcValue& value, const char* key, double fallback) {
  if (!value.hasMember(key)) return fallback;
  XmlRpc::XmlRpcValue& field = value[key];
  if (field.getType() == XmlRpc::XmlRpcValue::TypeDouble) return static_cast<double>(field);
  if (field.getType() == XmlRpc::XmlRpcValue::TypeInt) return static_cast<int>(field);
  throw std::runtime_error(std::string("field '") + key + "' is not a number");
}

XmlRpc::XmlRpcValue& list(XmlRpc::XmlRpcValue& spec, const char* key) {
  static XmlRpc::XmlRpcValue empty;
  empty.setSize(0);
  if (!spec.hasMember(key)) return empty;
  if (spec[key].getType() != XmlRpc::XmlRpcValue::TypeArray)
    throw std::runtime_error(std::string("'") + key + "' is not a list");
  return spec[key];
}

struct Publication {
  Publication(double rate_hz, double driver_hz) : credit(rate_hz, driver_hz) {}
  ros::Publisher publisher;
  topic_tools::ShapeShifter message;
  landing_bench::PublicationCredit credit;
};

class NullNode {
 public:
  NullNode(ros::NodeHandle& nh, XmlRpc::XmlRpcValue& spec) {
    if (!spec.hasMember("driver")) throw std::runtime_error("it lacks its 'driver'");
    XmlRpc::XmlRpcValue& driver = spec["driver"];
    driver_ = member(driver, "input");
    const double timer_hz = number(driver, "timer_hz", 0.0), driver_hz = number(driver, "hz", 0.0);
    XmlRpc::XmlRpcValue& acks = list(spec, "acks");
    for (int i = 0; i < acks.size(); ++i) {
      const std::string input = member(acks[i], "input");
      const double period = number(acks[i], "period", 0.0);
      if (period <= 0.0)
        input_acks_.emplace(input, std::make_unique<landing_runtime::LockstepAcker>(nh, input));
      else if (!timer_ack_)
        timer_ack_ = std::make_unique<landing_runtime::LockstepAcker>(nh, ros::Duration(period));
    }
    XmlRpc::XmlRpcValue& publishes = list(spec, "publishes");
    for (int i = 0; i < publishes.size(); ++i) addPublication(nh, publishes[i], driver_hz);
    XmlRpc::XmlRpcValue& subscribes = list(spec, "subscribes");
    for (int i = 0; i < subscribes.size(); ++i) {
      const std::string topic = member(subscribes[i], "topic");
      subscribers_.push_back(nh.subscribe<topic_tools::ShapeShifter>(
          topic, 10, [this, topic](const topic_tools::ShapeShifter::ConstPtr& msg) { received(topic, *msg); },
          ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
    }
    if (timer_hz > 0.0) timer_ = nh.createTimer(ros::Duration(1.0 / timer_hz), &NullNode::tick, this);
  }

 private:
  void addPublication(ros::NodeHandle& nh, XmlRpc::XmlRpcValue& spec, double driver_hz) {
    const std::string topic = member(spec, "topic");
    if (!spec.hasMember("data") || spec["data"].getType() != XmlRpc::XmlRpcValue::TypeBase64)
      throw std::runtime_error("publication " + topic + " lacks its serialised message 'data'");
    XmlRpc::XmlRpcValue::BinaryData& data = spec["data"];
    auto publication = std::make_unique<Publication>(number(spec, "rate_hz", 0.0), driver_hz);
    publication->message.morph(member(spec, "md5sum"), member(spec, "type"), member(spec, "definition"), "");
    std::vector<uint8_t> bytes(data.begin(), data.end());
    ros::serialization::IStream stream(bytes.data(), static_cast<uint32_t>(bytes.size()));
    publication->message.read(stream);
    publication->publisher = publication->message.advertise(nh, topic, 10);
    publications_.push_back(std::move(publication));
  }

  void received(const std::string& topic, const topic_tools::ShapeShifter& msg) {
    auto acker = input_acks_.find(topic);
    if (acker != input_acks_.end()) {
      std::vector<uint8_t> bytes(msg.size());
      ros::serialization::OStream stream(bytes.data(), static_cast<uint32_t>(bytes.size()));
      msg.write(stream);
      if (auto stamp = landing_bench::headerStamp(bytes.data(), bytes.size()))
        acker->second->ack(ros::Time(stamp->first, stamp->second));
    }
    if (topic == driver_) publishDue();  // ("" for a timer: no topic)
  }

  void publishDue() {
    for (auto& publication : publications_)
      for (int due = publication->credit.onDriverEvent(); due > 0; --due)
        publication->publisher.publish(publication->message);
  }

  void tick(const ros::TimerEvent& event) {
    publishDue();
    if (timer_ack_) timer_ack_->ack(event.current_real);
  }

  std::map<std::string, std::unique_ptr<landing_runtime::LockstepAcker>> input_acks_;
  std::unique_ptr<landing_runtime::LockstepAcker> timer_ack_;
  std::vector<std::unique_ptr<Publication>> publications_;
  std::vector<ros::Subscriber> subscribers_;
  std::string driver_;
  ros::Timer timer_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "null_node_cpp");
  ros::NodeHandle nh, private_nh("~");
  XmlRpc::XmlRpcValue spec;
  if (!private_nh.getParam("null_spec", spec) || spec.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
    ROS_FATAL("%s: required parameter ~null_spec (set by landing_bench.graph_floor) is missing",
              ros::this_node::getName().c_str());
    return 2;
  }
  try {
    NullNode node(nh, spec);
    ros::spin();
  } catch (const std::exception& err) {
    ROS_FATAL("%s: bad ~null_spec: %s", ros::this_node::getName().c_str(), err.what());
    return 2;
  }
  return 0;
}
