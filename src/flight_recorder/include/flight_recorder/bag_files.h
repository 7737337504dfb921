#pragma once
// The bags' names and when to start the next one, as rosbag record does it. ROS-free: times are nanoseconds
// of ROS time, the date is a local calendar time.

#include <cstdint>
#include <ctime>
#include <optional>
#include <string>

#include "flight_recorder/recorder_options.h"

namespace flight_recorder {

// rosbag record's date part of a name: YYYY-MM-DD-HH-MM-SS.
std::string dateForName(const std::tm& local_time);

// The name a bag gets when closed: the prefix without a trailing ".bag", the date (when appended) and the
// split index (with --split), joined by '_', then ".bag". The date is taken when each bag is opened, so
// with --output-prefix and --split every bag has its own date (as with rosbag record).
std::string bagName(const RecorderOptions& options, const std::tm& local_time, unsigned split_index);

// The name while it is written (renamed to bagName at a clean close).
std::string activeBagName(const std::string& bag_name);

// Why a bag could not be created at `bag_path` (its directory missing, not a directory, not writable), or
// nothing: checked before the recorder waits for the clock, so that a wrong path fails at once.
std::optional<std::string> outputDirectoryProblem(const std::string& bag_path);

// When the recording passes --duration: rosbag record's rule. The first bag starts at the first valid ROS
// time; a message at t is past the bag when t - start > duration, and then start advances by whole
// durations while start + duration < t, one new bag for each (empty ones included after a gap).
class SplitSchedule {
 public:
  SplitSchedule(int64_t start_ns, std::optional<int64_t> duration_ns);
  // How many bag ends `t_ns` has passed since the last call; advances the schedule by as many.
  unsigned endsPassed(int64_t t_ns);
  int64_t currentStartNs() const { return start_ns_; }

 private:
  int64_t start_ns_;
  std::optional<int64_t> duration_ns_;
};

}  // namespace flight_recorder
