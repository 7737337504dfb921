#include "flight_recorder/options.h"

#include <cmath>
#include <sstream>

namespace flight_recorder {

namespace {

bool startsWith(const std::string& text, const std::string& prefix) {
  return text.compare(0, prefix.size(), prefix) == 0;
}

// The value of an option given as --name=VALUE or as --name VALUE (then the next argument, consumed).
std::string valueOf(const std::vector<std::string>& args, std::size_t& i, const std::string& name) {
  const std::string& arg = args[i];
  if (arg.size() > name.size() && arg[name.size()] == '=') return arg.substr(name.size() + 1);
  if (i + 1 >= args.size() || startsWith(args[i + 1], "-")) {
    throw OptionError("option " + name + " needs a value, e.g. " + name + "=VALUE");
  }
  return args[++i];
}

bool isOption(const std::string& arg, const std::string& name) {
  return arg == name || startsWith(arg, name + "=");
}

}  // namespace

double parseDuration(const std::string& text) {
  std::size_t used = 0;
  double value = 0.0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  const std::string unit = text.substr(used);
  const double scale = unit.empty() || unit == "s" ? 1.0 : unit == "m" ? 60.0 : unit == "h" ? 3600.0 : 0.0;
  if (used == 0 || scale == 0.0 || !std::isfinite(value) || value <= 0.0) {
    throw OptionError("--duration must be a positive number of seconds, optionally with s, m or h (e.g. 30, 5m), "
                      "got '" + text + "'");
  }
  return value * scale;
}

Options parseOptions(const std::vector<std::string>& args) {
  Options options;
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg == "-h" || arg == "--help") {
      options.help = true;
    } else if (isOption(arg, "--output-name") || arg == "-O") {
      options.output_name = valueOf(args, i, arg == "-O" ? "-O" : "--output-name");
    } else if (isOption(arg, "--output-prefix") || arg == "-o") {
      options.output_prefix = valueOf(args, i, arg == "-o" ? "-o" : "--output-prefix");
    } else if (arg == "--split") {
      options.split = true;
    } else if (isOption(arg, "--duration")) {
      options.duration_s = parseDuration(valueOf(args, i, "--duration"));
    } else if (arg == "--lz4") {
      options.compression = Compression::kLz4;
    } else if (arg == "-j" || arg == "--bz2") {
      options.compression = Compression::kBz2;
    } else if (isOption(arg, "--chunksize")) {
      const std::string value = valueOf(args, i, "--chunksize");
      std::size_t used = 0;
      long kb = 0;
      try {
        kb = std::stol(value, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used == 0 || used != value.size() || kb < 1 || kb > 1024 * 1024) {
        throw OptionError("--chunksize must be a whole number of kB in 1..1048576, got '" + value + "'");
      }
      options.chunk_kb = static_cast<std::uint32_t>(kb);
    } else if (arg == "-a" || arg == "--all") {
      options.all = true;
    } else if (arg == "-e" || arg == "--regex") {
      options.regex = true;
    } else if (arg == "--tcpnodelay") {
      // (always: every subscription asks for TCP_NODELAY)
    } else if (startsWith(arg, "-")) {
      throw OptionError("unknown option '" + arg + "'");
    } else {
      options.topics.push_back(arg);
    }
  }
  if (options.help) return options;
  if (!options.output_name.empty() && !options.output_prefix.empty()) {
    throw OptionError("give --output-name or --output-prefix, not both");
  }
  if (options.split && options.duration_s <= 0.0) {
    throw OptionError("--split needs --duration=SECONDS (the span of each bag; splitting by size is not supported)");
  }
  if (!options.all && options.topics.empty()) {
    throw OptionError("no topics to record: give topic names, -e REGEX, or -a for every topic");
  }
  if (options.regex) {
    for (const std::string& expression : options.topics) {
      try {
        boost::regex compiled(expression);
      } catch (const boost::regex_error& error) {
        throw OptionError("bad regular expression '" + expression + "': " + error.what());
      }
    }
  }
  return options;
}

std::string usage() {
  return "usage: record [options] TOPIC... | -e REGEX... | -a\n"
         "  -O, --output-name=NAME     record to NAME (.bag added when missing)\n"
         "  -o, --output-prefix=PREFIX record to PREFIX_YYYY-MM-DD-HH-MM-SS.bag\n"
         "  --split --duration=SPAN    a new bag every SPAN of ROS time (30, 30s, 5m, 2h): NAME_0.bag, NAME_1.bag ...\n"
         "  --duration=SPAN            without --split: stop after SPAN\n"
         "  --lz4 | -j, --bz2          compress the chunks\n"
         "  --chunksize=KB             chunk size (default 768)\n"
         "  -e, --regex                the topics are regular expressions, each matching whole topic names\n"
         "  -a, --all                  every topic\n"
         "  --tcpnodelay               accepted (every subscription asks for it)\n";
}

TopicFilter::TopicFilter(const Options& options) : all_(options.all) {
  for (const std::string& topic : options.topics) {
    if (options.regex) {
      expressions_.emplace_back(topic);
    } else {
      names_.push_back(topic.empty() || topic[0] == '/' ? topic : "/" + topic);
    }
  }
}

bool TopicFilter::wanted(const std::string& topic) const {
  if (all_) return true;
  for (const std::string& name : names_) {
    if (name == topic) return true;
  }
  for (const boost::regex& expression : expressions_) {
    if (boost::regex_match(topic, expression)) return true;
  }
  return false;
}

}  // namespace flight_recorder
