#include "flight_recorder/bag_names.h"

#include <vector>

namespace flight_recorder {

std::string dateStamp(std::time_t when) {
  std::tm local{};
  localtime_r(&when, &local);
  char text[32];
  std::strftime(text, sizeof(text), "%Y-%m-%d-%H-%M-%S", &local);
  return text;
}

std::string bagName(const Options& options, int split_index, const std::string& date) {
  // As rosbag record: the parts joined by '_', then ".bag".
  std::string prefix = options.output_name.empty() ? options.output_prefix : options.output_name;
  if (prefix.size() >= 4 && prefix.compare(prefix.size() - 4, 4, ".bag") == 0) prefix.erase(prefix.size() - 4);
  std::vector<std::string> parts;
  if (!prefix.empty()) parts.push_back(prefix);
  if (options.output_name.empty()) parts.push_back(date);
  if (options.split) parts.push_back(std::to_string(split_index));
  std::string name = parts[0];
  for (std::size_t i = 1; i < parts.size(); ++i) name += "_" + parts[i];
  return name + ".bag";
}

std::string activeName(const std::string& bag_name) { return bag_name + ".active"; }

}  // namespace flight_recorder
