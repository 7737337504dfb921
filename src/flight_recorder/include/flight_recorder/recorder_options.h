#pragma once
// The recorder's command line: the subset of `rosbag record`'s options this project uses, with the same
// meanings. ROS-free, so that it is validated (and unit-tested) before anything talks to a master.

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace flight_recorder {

enum class Compression { None, Bz2, Lz4 };

struct RecorderOptions {
  // rosbag record's "prefix": the exact bag name with --output-name, the name's start with --output-prefix
  // (empty: the bag is named after the date only, in the current directory).
  std::string name_prefix;
  bool append_date = true;  // --output-prefix or neither: PREFIX_YYYY-MM-DD-HH-MM-SS.bag
  bool split = false;       // names get _0, _1, ... before .bag
  // --duration in nanoseconds of ROS time: with --split a new bag each time it passes, without it the
  // recording stops (as rosbag record does).
  std::optional<int64_t> max_duration_ns;
  Compression compression = Compression::None;
  uint32_t chunk_size_bytes = 768 * 1024;  // rosbag record's default
  bool topics_are_regexes = false;         // -e / --regex: every topic argument is a full-match regex
  std::vector<std::string> topics;         // sorted, each once (as rosbag record keeps them)
  bool show_help = false;
};

// A command line that cannot be recorded with; what() says what is wrong and what to do.
class OptionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// `args` without the program name. Arguments with ":=" are ROS remappings (__name:=..., a:=b): ros::init
// consumes them, so they are skipped here. Throws OptionError.
RecorderOptions parseOptions(const std::vector<std::string>& args);
RecorderOptions parseOptions(int argc, const char* const* argv);

// The option list, printed with --help and after an OptionError.
std::string usage(const std::string& program);

}  // namespace flight_recorder
