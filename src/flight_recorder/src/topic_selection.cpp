#include "flight_recorder/topic_selection.h"

namespace flight_recorder {

TopicSelection::TopicSelection(const std::vector<std::string>& topics, bool as_regexes) {
  if (!as_regexes) {
    fixed_topics_ = topics;
    return;
  }
  for (const std::string& expression : topics) expressions_.emplace_back(expression);
}

bool TopicSelection::matches(const std::string& topic) const {
  for (const boost::regex& expression : expressions_) {
    if (boost::regex_match(topic, expression)) return true;
  }
  return false;
}

std::vector<std::string> TopicSelection::topicsToSubscribe(const std::vector<std::string>& published,
                                                           const std::set<std::string>& subscribed) const {
  std::vector<std::string> chosen;
  std::set<std::string> seen;
  for (const std::string& topic : published) {
    if (subscribed.count(topic) || !seen.insert(topic).second) continue;
    if (matches(topic)) chosen.push_back(topic);
  }
  return chosen;
}

double discoveryPeriodS(double elapsed_s) {
  constexpr double kStartUpS = 5.0;
  return elapsed_s < kStartUpS ? 0.1 : 1.0;
}

}  // namespace flight_recorder
