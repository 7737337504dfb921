// The recorder's command line: the part of `rosbag record`'s options the landing stack uses, with the same
// meanings, and which topics they select. ROS-free.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <boost/regex.hpp>

namespace flight_recorder {

// A bad or unsupported command line; what() says what is wrong and what to do.
class OptionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class Compression { kNone, kLz4, kBz2 };

struct Options {
  std::string output_name;    // -O/--output-name: the bag's name (".bag" added when missing)
  std::string output_prefix;  // -o/--output-prefix: PREFIX_DATE.bag
  bool split = false;         // --split: a new bag every duration_s (names then end in _0, _1, ...)
  double duration_s = 0.0;    // --duration: with --split the bags' span, else how long to record [s of ROS time]
  Compression compression = Compression::kNone;  // --lz4, -j/--bz2
  std::uint32_t chunk_kb = 768;                  // --chunksize: bag chunk size [kB]
  bool all = false;           // -a/--all: every topic
  bool regex = false;         // -e/--regex: the topics are regular expressions (each must match a whole name)
  std::vector<std::string> topics;  // the topics (or expressions) to record
  bool help = false;          // -h/--help
};

// Parses the arguments after the program name (ROS remappings such as __name:=x already removed by ros::init).
Options parseOptions(const std::vector<std::string>& args);

// The options' summary printed by --help and after a bad command line.
std::string usage();

// Seconds of "30", "30s", "5m" or "2h" (rosbag record's --duration forms).
double parseDuration(const std::string& text);

// Whether a topic is one the options ask to record.
class TopicFilter {
 public:
  explicit TopicFilter(const Options& options);
  bool wanted(const std::string& topic) const;

 private:
  bool all_;
  std::vector<std::string> names_;
  std::vector<boost::regex> expressions_;
};

}  // namespace flight_recorder
