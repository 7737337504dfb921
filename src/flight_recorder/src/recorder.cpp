#include "flight_recorder/recorder.h"

#include <cstdio>
#include <ctime>

#include "flight_recorder/bag_names.h"

namespace flight_recorder {

namespace {

// New topics are looked for this often at first (the graph is coming up and the runner waits for the recorder),
// then less often.
const ros::WallDuration kFastDiscovery(0.1);
const ros::WallDuration kSlowDiscovery(1.0);
const double kFastDiscoveryFor = 5.0;  // [wall s]
const uint32_t kQueueSize = 100;       // messages a subscription keeps while the spinner is busy (as rosbag record)

rosbag::compression::CompressionType bagCompression(Compression compression) {
  switch (compression) {
    case Compression::kLz4: return rosbag::compression::LZ4;
    case Compression::kBz2: return rosbag::compression::BZ2;
    default: return rosbag::compression::Uncompressed;
  }
}

}  // namespace

void InlineCallbacks::addCallback(const ros::CallbackInterfacePtr& callback, uint64_t) {
  // A subscription's queue answers TryAgain only while another thread runs its callback; none does here.
  if (callback->ready()) callback->call();
}

Recorder::Recorder(const Options& options, ros::NodeHandle& node)
    : options_(options), filter_(options), node_(node), date_(dateStamp(std::time(nullptr))) {}

Recorder::~Recorder() { close(); }

void Recorder::start() {
  span_start_ = ros::Time::now();
  openBag();
  started_ = ros::WallTime::now();
  discover();
  discovery_ = node_.createWallTimer(kFastDiscovery, [this](const ros::WallTimerEvent&) { discover(); });
}

void Recorder::close() {
  discovery_.stop();
  for (ros::Subscriber& subscriber : subscribers_) subscriber.shutdown();
  subscribers_.clear();
  std::lock_guard<std::mutex> lock(bag_mutex_);
  closeBag();
}

void Recorder::openBag() {
  bag_name_ = bagName(options_, split_index_, date_);
  bag_.setCompression(bagCompression(options_.compression));
  bag_.setChunkThreshold(options_.chunk_kb * 1024);
  bag_.open(activeName(bag_name_), rosbag::bagmode::Write);
  open_ = true;
  ROS_INFO("Recording to '%s'.", bag_name_.c_str());
}

void Recorder::closeBag() {
  if (!open_) return;
  open_ = false;
  try {
    bag_.close();
  } catch (const rosbag::BagException& error) {
    ROS_ERROR("closing %s: %s", activeName(bag_name_).c_str(), error.what());
  }
  if (std::rename(activeName(bag_name_).c_str(), bag_name_.c_str()) != 0) {
    ROS_ERROR("could not rename %s to %s", activeName(bag_name_).c_str(), bag_name_.c_str());
  } else {
    ROS_INFO("Closed '%s'.", bag_name_.c_str());
  }
}

void Recorder::discover() {
  if (discovering_fast_ && (ros::WallTime::now() - started_).toSec() > kFastDiscoveryFor) {
    discovering_fast_ = false;
    discovery_.setPeriod(kSlowDiscovery);
  }
  ros::master::V_TopicInfo topics;
  if (!ros::master::getTopics(topics)) return;  // (the master is busy or gone: the next round asks again)
  for (const ros::master::TopicInfo& info : topics) {
    if (!subscribed_.count(info.name) && filter_.wanted(info.name)) subscribe(info.name);
  }
}

void Recorder::subscribe(const std::string& topic) {
  ROS_INFO("Subscribing to %s", topic.c_str());
  ros::SubscribeOptions subscription;
  subscription.topic = topic;
  subscription.queue_size = kQueueSize;
  subscription.md5sum = ros::message_traits::md5sum<topic_tools::ShapeShifter>();
  subscription.datatype = ros::message_traits::datatype<topic_tools::ShapeShifter>();
  subscription.helper = boost::make_shared<
      ros::SubscriptionCallbackHelperT<const ros::MessageEvent<topic_tools::ShapeShifter const>&>>(
      [this, topic](const ros::MessageEvent<topic_tools::ShapeShifter const>& event) { onMessage(event, topic); });
  subscription.transport_hints = ros::TransportHints().tcpNoDelay();
  subscription.callback_queue = &inline_callbacks_;
  subscribers_.push_back(node_.subscribe(subscription));
  subscribed_.insert(topic);
}

void Recorder::onMessage(const ros::MessageEvent<topic_tools::ShapeShifter const>& event, const std::string& topic) {
  std::lock_guard<std::mutex> lock(bag_mutex_);
  if (!open_) return;
  const ros::Time received = ros::Time::now();
  if (options_.duration_s > 0.0 && (received - span_start_).toSec() > options_.duration_s) {
    if (!options_.split) {
      ROS_INFO("recorded for --duration=%gs: stopping", options_.duration_s);
      closeBag();
      finished_ = true;
      return;
    }
    // As rosbag record: whole spans from the first bag's start, an empty bag for a span without messages.
    while ((received - span_start_).toSec() > options_.duration_s) {
      closeBag();
      ++split_index_;
      span_start_ += ros::Duration(options_.duration_s);
      try {
        openBag();
      } catch (const rosbag::BagException& error) {
        return fail(std::string("cannot open the next bag: ") + error.what());
      }
    }
  }
  try {
    bag_.write(topic, received, event.getMessage(), event.getConnectionHeaderPtr());
  } catch (const rosbag::BagException& error) {
    fail(std::string("cannot write to ") + activeName(bag_name_) + ": " + error.what());
  }
}

void Recorder::fail(const std::string& what) {
  failure_ = what;
  ROS_FATAL("flight recorder: %s; stopping (what was written so far is in the bag)", what.c_str());
  closeBag();
  finished_ = true;
}

}  // namespace flight_recorder
