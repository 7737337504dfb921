// Checks of incoming messages for the C++ nodes' ROS wrappers: the same limits and log lines as the Python
// nodes' landing_runtime.input_check.
//   landing_runtime::RejectionLog rejections;
//   if (auto problem = landing_runtime::stampProblem(msg->header.stamp, ros::Time::now()))
//     return rejections.reject(topic, *problem);
// Each kind of problem on each topic is logged once per period of the node's clock (sim time under the simulator,
// as ROS_WARN_THROTTLE) with what was wrong and how many more were dropped since the last line.
#pragma once

#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <utility>

#include <ros/ros.h>

namespace landing_runtime {

// Limits of a plausible value (see input_check.py for the reasons).
constexpr double kMaxPositionM = 1e5;
constexpr double kMaxAltitudeM = 1e4;
constexpr double kMaxSpeedMps = 100.0;
constexpr double kMaxRateRadps = 100.0;
constexpr double kMaxFutureS = 0.5;
constexpr double kMaxAgeS = 2.0;

struct InputProblem {
  std::string kind;    // non-finite, out of range, stamp from the future, stamp from the past, wrong frame, ...
  std::string detail;  // what was wrong, in words
};

inline std::string formatNumber(const char* format, double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof(buffer), format, value);
  return buffer;
}

/// A problem when ``value`` (named ``name``) is not finite or beyond +-limit.
inline std::optional<InputProblem> numberProblem(const std::string& name, double value, double limit) {
  if (!std::isfinite(value)) return InputProblem{"non-finite", name + " is " + formatNumber("%g", value)};
  if (std::abs(value) > limit)
    return InputProblem{"out of range", name + " = " + formatNumber("%.3g", value) + " is beyond +-" +
                                            formatNumber("%g", limit)};
  return std::nullopt;
}

/// A problem when a header stamp is too far from the node's clock ``now``; a zero stamp (meaning "now") and
/// anything before the clock runs pass.
inline std::optional<InputProblem> stampProblem(const ros::Time& stamp, const ros::Time& now,
                                                double max_age = kMaxAgeS, double max_future = kMaxFutureS) {
  if (stamp.isZero() || now.isZero()) return std::nullopt;
  const double offset = (stamp - now).toSec();
  if (offset > max_future)
    return InputProblem{"stamp from the future", "stamped " + formatNumber("%.3f", stamp.toSec()) + " s, " +
                                                     formatNumber("%.2f", offset) + " s after the clock"};
  if (-offset > max_age)
    return InputProblem{"stamp from the past", "stamped " + formatNumber("%.3f", stamp.toSec()) + " s, " +
                                                   formatNumber("%.2f", -offset) + " s before the clock"};
  return std::nullopt;
}

/// A problem when ``frame`` (a leading '/' ignored) is neither ``expected`` nor, if allowed, empty.
inline std::optional<InputProblem> frameProblem(const std::string& frame, const std::string& expected,
                                                bool empty_ok = true) {
  const std::string bare = !frame.empty() && frame[0] == '/' ? frame.substr(1) : frame;
  if (bare == expected || (empty_ok && bare.empty())) return std::nullopt;
  return InputProblem{"wrong frame", "frame '" + frame.substr(0, 60) + "', expected '" + expected + "'"};
}

class RejectionLog {
 public:
  explicit RejectionLog(double period_s = 5.0) : period_s_(period_s) {}

  /// Drop a message on ``topic`` for ``problem``: logged at once, then once per period with the count.
  void reject(const std::string& topic, const InputProblem& problem) {
    const auto key = std::make_pair(topic, problem.kind);
    const double now = ros::Time::now().toSec();
    int more = 0;
    double since = 0.0;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      Entry& entry = entries_[key];
      if (entry.logged && now >= entry.last && now - entry.last < period_s_) {  // a clock gone back logs at once
        ++entry.dropped;
        return;
      }
      more = entry.dropped;
      since = now - entry.last;
      entry = Entry{true, now, 0};
    }
    if (more > 0)
      ROS_WARN("rejected input on %s [%s]: %s; %d more like it in the last %.0f s", topic.c_str(),
               problem.kind.c_str(), problem.detail.c_str(), more, since);
    else
      ROS_WARN("rejected input on %s [%s]: %s", topic.c_str(), problem.kind.c_str(), problem.detail.c_str());
  }

 private:
  struct Entry {
    bool logged = false;
    double last = 0.0;
    int dropped = 0;
  };
  double period_s_;
  std::mutex mutex_;
  std::map<std::pair<std::string, std::string>, Entry> entries_;
};

}  // namespace landing_runtime
