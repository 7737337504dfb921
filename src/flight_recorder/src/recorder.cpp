#include "flight_recorder/recorder.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <chrono>
#include <ctime>

#include <ros/callback_queue.h>
#include <ros/service_manager.h>
#include <ros/xmlrpc_manager.h>
#include <xmlrpcpp/XmlRpcValue.h>

namespace flight_recorder {
namespace {

// Per subscription, what roscpp keeps while the main thread is busy (a chunk being compressed, a slow disk):
// 1000 messages is 10 s of a 100 Hz topic. rosbag record has 100 there, but drains it into its own queue at once.
constexpr uint32_t kSubscriptionQueueSize = 1000;

// How long the main thread lets messages gather between two rounds of writing (see run()).
constexpr std::chrono::milliseconds kBatchInterval(10);

// A no-op on the global callback queue: it makes the main thread return from its wait.
class WakeUp : public ros::CallbackInterface {
 public:
  CallResult call() override { return Success; }
};

rosbag::CompressionType bagCompression(Compression compression) {
  switch (compression) {
    case Compression::Lz4:
      return rosbag::compression::LZ4;
    case Compression::Bz2:
      return rosbag::compression::BZ2;
    case Compression::None:
      break;
  }
  return rosbag::compression::Uncompressed;
}

}  // namespace

Recorder::Recorder(const RecorderOptions& options)
    : options_(options),
      selection_(options.topics, options.topics_are_regexes),
      split_schedule_(0, options.max_duration_ns) {}

int Recorder::run() {
  const int exit_code = record();
  subscribers_.clear();  // each unregistered from the master
  return exit_code;
}

int Recorder::record() {
  started_ = ros::WallTime::now();
  for (const std::string& topic : selection_.fixedTopics()) subscribe(topic);
  if (selection_.needsDiscovery()) discoverTopics();

  // Subscribed already (latched messages wait in the callback queue), but nothing is written before the
  // clock is valid: with /use_sim_time the first /clock may still be on its way.
  if (!waitForValidTime()) return exit_code_;
  split_schedule_ = SplitSchedule(static_cast<int64_t>(ros::Time::now().toNSec()), options_.max_duration_ns);
  if (!openBag()) return exit_code_;

  // A wall timer: with /use_sim_time the clock may stand still until the recorder has subscribed.
  discovery_period_s_ = discoveryPeriodS(0.0);
  discovery_timer_ = node_.createWallTimer(ros::WallDuration(discovery_period_s_), &Recorder::onDiscoveryTimer, this);

  // ros::spin(), but ending at requestStop() too (the bag is closed before ROS shuts down), and in batches:
  // after each round the main thread rests kBatchInterval while roscpp's poll thread queues what comes. Woken
  // for each message instead, the switches between the two threads cost a quarter of the recorder's CPU (at
  // 1500 msgs/s). The
  // receipt times are the poll thread's, so the rest does not shift them; when idle, callAvailable waits.
  ros::CallbackQueue& queue = *ros::getGlobalCallbackQueue();
  while (!stop_requested_ && ros::ok()) {
    queue.callAvailable(ros::WallDuration(1.0));
    std::unique_lock<std::mutex> lock(stop_mutex_);
    stop_condition_.wait_for(lock, kBatchInterval, [this] { return stop_requested_.load(); });
  }

  discovery_timer_.stop();
  // What was received before the stop but is still queued (the loop stops between two batches) is written.
  if (ros::ok()) queue.callAvailable(ros::WallDuration(0.0));
  closeBag();
  return exit_code_;
}

void Recorder::requestStop() {
  {
    std::lock_guard<std::mutex> lock(stop_mutex_);
    stop_requested_ = true;
  }
  stop_condition_.notify_all();
  ros::getGlobalCallbackQueue()->addCallback(boost::make_shared<WakeUp>());
}

bool Recorder::waitForValidTime() {
  const ros::WallDuration poll(0.005), warn_after(2.0), discovery_period(discoveryPeriodS(0.0));
  ros::WallTime next_discovery = ros::WallTime::now() + discovery_period;
  bool warned = false;
  while (!ros::Time::isValid()) {
    if (stop_requested_ || !ros::ok()) return false;
    const ros::WallTime now = ros::WallTime::now();
    if (!warned && now - started_ > warn_after) {
      ROS_WARN("/use_sim_time set to true and no clock published.  Still waiting for valid time...");
      warned = true;
    }
    if (selection_.needsDiscovery() && now >= next_discovery) {
      discoverTopics();
      next_discovery = now + discovery_period;
    }
    poll.sleep();
  }
  return true;
}

void Recorder::discoverTopics() {
  // ros::master::getTopics waits for an absent master (blocking the writing here); this call does not.
  XmlRpc::XmlRpcValue request, response, payload;
  request[0] = ros::this_node::getName();
  request[1] = "";
  if (!ros::master::execute("getPublishedTopics", request, response, payload, false) ||
      payload.getType() != XmlRpc::XmlRpcValue::TypeArray) {
    return;  // tried again at the next tick
  }
  std::vector<std::string> published;
  for (int i = 0; i < payload.size(); ++i) published.push_back(static_cast<std::string>(payload[i][0]));
  for (const std::string& topic : selection_.topicsToSubscribe(published, subscribed_topics_)) subscribe(topic);
}

void Recorder::subscribe(const std::string& topic) {
  ROS_INFO("Subscribing to %s", topic.c_str());
  ros::SubscribeOptions subscription;
  subscription.topic = topic;
  subscription.queue_size = kSubscriptionQueueSize;
  subscription.md5sum = ros::message_traits::md5sum<topic_tools::ShapeShifter>();
  subscription.datatype = ros::message_traits::datatype<topic_tools::ShapeShifter>();
  subscription.helper = boost::make_shared<
      ros::SubscriptionCallbackHelperT<const ros::MessageEvent<const topic_tools::ShapeShifter>&>>(
      [this, topic](const ros::MessageEvent<const topic_tools::ShapeShifter>& event) { onMessage(event, topic); });
  subscription.transport_hints = ros::TransportHints().tcpNoDelay();
  subscribers_.push_back(node_.subscribe(subscription));
  subscribed_topics_.insert(topic);
}

void Recorder::onMessage(const ros::MessageEvent<const topic_tools::ShapeShifter>& event, const std::string& topic) {
  // ros::Time::now() when roscpp's poll thread read it; a message read before the clock was valid (a latched
  // one, with /use_sim_time) gets the time it is written at.
  ros::Time receipt = event.getReceiptTime();
  if (receipt.isZero()) receipt = ros::Time::now();
  splitIfDue(receipt);
  if (!bag_.isOpen()) return;  // --duration over, or the bag failed
  try {
    // The publisher's connection header: the bag keeps its callerid, latching, type and definition.
    bag_.write(topic, receipt, *event.getMessage(), event.getConnectionHeaderPtr());
  } catch (const rosbag::BagException& error) {
    fail(std::string("cannot write to ") + activeBagName(bag_name_) + ": " + error.what());
  }
}

void Recorder::onDiscoveryTimer(const ros::WallTimerEvent&) {
  if (selection_.needsDiscovery()) discoverTopics();
  splitIfDue(ros::Time::now());  // also when no message comes
  const double period = discoveryPeriodS((ros::WallTime::now() - started_).toSec());
  if (period != discovery_period_s_) {
    discovery_period_s_ = period;
    discovery_timer_.setPeriod(ros::WallDuration(period));
  }
}

bool Recorder::openBag() {
  const std::time_t now = std::time(nullptr);
  std::tm local_time{};
  localtime_r(&now, &local_time);
  bag_name_ = bagName(options_, local_time, split_index_);
  const std::string active_name = activeBagName(bag_name_);
  bag_.setCompression(bagCompression(options_.compression));
  bag_.setChunkThreshold(options_.chunk_size_bytes);
  errno = 0;
  try {
    bag_.open(active_name, rosbag::bagmode::Write);
  } catch (const rosbag::BagException& error) {
    const int open_errno = errno;  // set by the failed fopen
    fail("cannot open the bag " + active_name + " for writing: " +
         (open_errno ? std::strerror(open_errno) : error.what()));
    return false;
  }
  ROS_INFO("Recording to '%s'.", bag_name_.c_str());
  return true;
}

void Recorder::closeBag() {
  if (!bag_.isOpen()) return;
  ROS_INFO("Closing '%s'.", bag_name_.c_str());
  const std::string active_name = activeBagName(bag_name_);
  try {
    bag_.close();
  } catch (const rosbag::BagException& error) {
    fail("cannot close " + active_name + ": " + error.what());
    return;
  }
  if (std::rename(active_name.c_str(), bag_name_.c_str()) != 0) {
    fail("cannot rename " + active_name + " to " + bag_name_ + ": " + std::strerror(errno));
  }
}

void Recorder::splitIfDue(const ros::Time& now) {
  if (!bag_.isOpen()) return;
  for (unsigned ends = split_schedule_.endsPassed(static_cast<int64_t>(now.toNSec())); ends > 0; --ends) {
    closeBag();
    if (!options_.split) {  // --duration without --split: the recording is complete
      requestStop();
      return;
    }
    ++split_index_;
    if (!openBag()) return;
  }
}

void Recorder::fail(const std::string& message) {
  ROS_ERROR("%s", message.c_str());
  exit_code_ = 1;
  if (bag_.isOpen()) {
    try {
      bag_.close();
    } catch (const rosbag::BagException&) {
      // the file is left as .bag.active: its complete chunks can be read after a reindex
    }
  }
  requestStop();
}

void leaveGraphAndExit(int exit_code) {
  if (ros::isStarted() && !ros::isShuttingDown()) {
    // What ros::shutdown() would unregister, without TopicManager::shutdown(), which alone took 0.2 s (it stops
    // the poll thread and waits for the XML-RPC thread's 0.1 s polls). The recorder's own subscriptions are gone
    // already; what is left is roscpp's: /rosout, and /clock under /use_sim_time (left registered, it kept the
    // next recorder of a warm graph, which has this one's name, waiting for it to go).
    XmlRpc::XmlRpcValue request, response, payload;
    request[0] = ros::this_node::getName();
    request[2] = ros::XMLRPCManager::instance()->getServerURI();
    std::vector<std::string> topics;
    ros::this_node::getSubscribedTopics(topics);
    for (const std::string& topic : topics) {
      request[1] = topic;
      ros::master::execute("unregisterSubscriber", request, response, payload, false);
    }
    topics.clear();
    ros::this_node::getAdvertisedTopics(topics);
    for (const std::string& topic : topics) {
      request[1] = topic;
      ros::master::execute("unregisterPublisher", request, response, payload, false);
    }
    ros::ServiceManager::instance()->shutdown();  // the logger services (fast)
  }
  std::fflush(nullptr);
  std::_Exit(exit_code);
}

}  // namespace flight_recorder
