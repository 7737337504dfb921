#include "flight_recorder/recorder_options.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include <boost/regex.hpp>

namespace flight_recorder {
namespace {

// Options rosbag record has and this recorder does not: named, so that the error says so instead of
// "unknown option" (use rosbag record for these).
const char* const kUnsupportedOptions[] = {"--all", "-a", "--exclude", "-x", "--quiet", "-q", "--publish", "-p",
                                           "--buffsize", "-b", "--limit", "-l", "--min-space", "-L", "--max-splits",
                                           "--size", "--node", "--udp", "--repeat-latched"};

bool isUnsupported(const std::string& name) {
  return std::find(std::begin(kUnsupportedOptions), std::end(kUnsupportedOptions), name) !=
         std::end(kUnsupportedOptions);
}

uint32_t parseChunkSizeKb(const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const long long kb = std::strtoll(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || errno == ERANGE || kb < 0 || kb > 4 * 1024 * 1024) {
    throw OptionError("--chunksize must be a whole number of kB between 0 and 4194304, got '" + text + "'");
  }
  return static_cast<uint32_t>(kb * 1024);
}

// rosbag record's form: a number, optionally followed by a unit s, m or h ("30", "30s", "1.5m").
int64_t parseDurationNs(const std::string& text) {
  std::istringstream in(text);
  double value = 0.0;
  std::string unit;
  if ((in >> value).fail()) {
    throw OptionError("--duration must start with a number (seconds, or with a unit s, m or h), got '" + text + "'");
  }
  if (!in.eof() && (in >> unit).fail()) unit = "?";
  if (!in.eof()) unit = "?";  // anything after the unit
  double seconds_per_unit = 1.0;
  if (unit == "" || unit == "s") {
    seconds_per_unit = 1.0;
  } else if (unit == "m") {
    seconds_per_unit = 60.0;
  } else if (unit == "h") {
    seconds_per_unit = 3600.0;
  } else {
    throw OptionError("--duration's unit must be s, m or h, got '" + text + "'");
  }
  const double seconds = value * seconds_per_unit;
  if (!(seconds > 0.0) || !std::isfinite(seconds) || seconds > 1e9) {
    throw OptionError("--duration must be positive (and below 1e9 s), got '" + text + "'");
  }
  return static_cast<int64_t>(std::llround(seconds * 1e9));
}

void checkRegex(const std::string& expression) {
  try {
    boost::regex compiled(expression);
  } catch (const boost::regex_error& error) {
    throw OptionError("'" + expression + "' is not a valid regular expression: " + error.what());
  }
}

}  // namespace

RecorderOptions parseOptions(const std::vector<std::string>& args) {
  RecorderOptions options;
  std::optional<std::string> output_name, output_prefix;
  bool bz2 = false, lz4 = false;
  bool only_positionals = false;  // after "--"

  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (only_positionals || arg.empty() || arg[0] != '-' || arg == "-") {
      if (arg.find(":=") != std::string::npos) continue;  // a ROS remapping, ros::init's
      if (arg.empty()) throw OptionError("an empty topic argument was given");
      options.topics.push_back(arg);
      continue;
    }
    if (arg == "--") {
      only_positionals = true;
      continue;
    }
    // --name=value, or --name value / -X value for options that take one
    std::string name = arg;
    std::optional<std::string> inline_value;
    const size_t equals = arg.find('=');
    if (arg.rfind("--", 0) == 0 && equals != std::string::npos) {
      name = arg.substr(0, equals);
      inline_value = arg.substr(equals + 1);
    }
    auto value = [&]() -> std::string {
      if (inline_value) return *inline_value;
      if (i + 1 >= args.size()) throw OptionError(name + " needs a value");
      return args[++i];
    };
    auto noValue = [&]() {
      if (inline_value) throw OptionError(name + " takes no value, got '" + arg + "'");
    };

    if (name == "--help" || name == "-h") {
      noValue();
      options.show_help = true;
    } else if (name == "--output-name" || name == "-O") {
      output_name = value();
      // rosbag record refuses a name that is empty once ".bag" is taken off it
      if (output_name->empty() || *output_name == ".bag") throw OptionError(name + " needs a non-empty bag name");
    } else if (name == "--output-prefix" || name == "-o") {
      output_prefix = value();
    } else if (name == "--split") {
      // rosbag record's deprecated --split=MB form is not supported: it splits by size
      if (inline_value) throw OptionError("--split takes no value here (use --split --duration=SECONDS)");
      options.split = true;
    } else if (name == "--duration") {
      options.max_duration_ns = parseDurationNs(value());
    } else if (name == "--lz4") {
      noValue();
      lz4 = true;
    } else if (name == "--bz2" || name == "-j") {
      noValue();
      bz2 = true;
    } else if (name == "--chunksize") {
      options.chunk_size_bytes = parseChunkSizeKb(value());
    } else if (name == "--regex" || name == "-e") {
      noValue();
      options.topics_are_regexes = true;
    } else if (name == "--tcpnodelay") {
      noValue();  // accepted for compatibility: every subscription asks for TCP_NODELAY anyway
    } else if (isUnsupported(name)) {
      throw OptionError("rosbag record's option " + name + " is not supported by this recorder (use rosbag record)");
    } else {
      throw OptionError("unknown option '" + arg + "'");
    }
  }

  if (output_name && output_prefix) {
    throw OptionError("give either --output-name or --output-prefix, not both");
  }
  if (bz2 && lz4) throw OptionError("give only one compression, --lz4 or --bz2");
  options.compression = lz4 ? Compression::Lz4 : bz2 ? Compression::Bz2 : Compression::None;
  if (output_name) {
    options.name_prefix = *output_name;
    options.append_date = false;
  } else if (output_prefix) {
    options.name_prefix = *output_prefix;
  }
  if (options.show_help) return options;

  if (options.topics.empty()) {
    throw OptionError(options.topics_are_regexes ? "-e/--regex needs a regular expression of the topics to record"
                                                 : "no topics to record were given (topic names, or -e REGEX)");
  }
  std::sort(options.topics.begin(), options.topics.end());
  options.topics.erase(std::unique(options.topics.begin(), options.topics.end()), options.topics.end());
  if (options.topics_are_regexes) {
    for (const std::string& expression : options.topics) checkRegex(expression);
  }
  return options;
}

RecorderOptions parseOptions(int argc, const char* const* argv) {
  return parseOptions(std::vector<std::string>(argv + std::min(argc, 1), argv + argc));
}

std::string usage(const std::string& program) {
  return "Usage: " + program +
         " [OPTIONS] (-e REGEX | TOPIC...) [ROS remappings such as __name:=flight_recorder]\n"
         "Records the topics into a bag, as rosbag record does (a subset of its options):\n"
         "  -O, --output-name=NAME    record to NAME.bag exactly ('.bag' appended if missing)\n"
         "  -o, --output-prefix=PRE   record to PRE_YYYY-MM-DD-HH-MM-SS.bag (default: the date alone)\n"
         "      --split               a new bag at every --duration; names get _0, _1, ... before .bag\n"
         "      --duration=N[s|m|h]   with --split: length of each bag in ROS time; without: stop after it\n"
         "      --lz4 | -j, --bz2     compress the chunks (default: none)\n"
         "      --chunksize=KB        chunk size in kB (default 768); a killed recorder loses its open chunk\n"
         "  -e, --regex               the topic arguments are regular expressions matching whole topic names\n"
         "      --tcpnodelay          accepted; subscriptions always ask for TCP_NODELAY\n"
         "  -h, --help                this list\n";
}

}  // namespace flight_recorder
