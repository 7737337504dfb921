#pragma once
// Which topics the recorder subscribes to. ROS-free: the master's topic list comes in as names.

#include <set>
#include <string>
#include <vector>

#include <boost/regex.hpp>

namespace flight_recorder {

class TopicSelection {
 public:
  // `topics` as RecorderOptions holds them: regular expressions with `as_regexes`, else topic names.
  TopicSelection(const std::vector<std::string>& topics, bool as_regexes);

  // Plain names are subscribed at start, whether advertised yet or not (as rosbag record does); regular
  // expressions are matched against the master's topic list, again and again.
  bool needsDiscovery() const { return !expressions_.empty(); }
  const std::vector<std::string>& fixedTopics() const { return fixed_topics_; }

  // Whether one of the expressions matches the whole name (boost::regex_match, rosbag record's semantics).
  bool matches(const std::string& topic) const;

  // Of the master's published topics, those to subscribe to now: matching and not yet in `subscribed`, in
  // the master's order, each once.
  std::vector<std::string> topicsToSubscribe(const std::vector<std::string>& published,
                                             const std::set<std::string>& subscribed) const;

 private:
  std::vector<std::string> fixed_topics_;
  std::vector<boost::regex> expressions_;
};

// How often to ask the master for new topics, `elapsed_s` after the recorder started: often while the graph
// is coming up (a topic missed is its first messages missed), then once a second as rosbag record does.
double discoveryPeriodS(double elapsed_s);

}  // namespace flight_recorder
