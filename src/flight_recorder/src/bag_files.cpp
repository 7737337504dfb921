#include "flight_recorder/bag_files.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <vector>

namespace flight_recorder {

std::string dateForName(const std::tm& local_time) {
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%d-%H-%M-%S", &local_time);
  return text;
}

std::string bagName(const RecorderOptions& options, const std::tm& local_time, unsigned split_index) {
  std::string prefix = options.name_prefix;
  const std::string extension = ".bag";
  if (prefix.size() >= extension.size() &&
      prefix.compare(prefix.size() - extension.size(), extension.size(), extension) == 0) {
    prefix.erase(prefix.size() - extension.size());
  }
  std::vector<std::string> parts;
  if (!prefix.empty()) parts.push_back(prefix);
  if (options.append_date) parts.push_back(dateForName(local_time));
  if (options.split) parts.push_back(std::to_string(split_index));
  std::string name;
  for (const std::string& part : parts) name += (name.empty() ? "" : "_") + part;
  return name + extension;
}

std::string activeBagName(const std::string& bag_name) { return bag_name + ".active"; }

std::optional<std::string> outputDirectoryProblem(const std::string& bag_path) {
  const size_t slash = bag_path.rfind('/');
  const std::string directory = slash == std::string::npos ? "." : slash == 0 ? "/" : bag_path.substr(0, slash);
  struct stat status;
  if (stat(directory.c_str(), &status) != 0) {
    return "directory " + directory + " of " + bag_path + ": " + std::strerror(errno);
  }
  if (!S_ISDIR(status.st_mode)) return directory + " (of " + bag_path + ") is not a directory";
  if (access(directory.c_str(), W_OK | X_OK) != 0) {
    return "directory " + directory + " of " + bag_path + " is not writable: " + std::strerror(errno);
  }
  return std::nullopt;
}

SplitSchedule::SplitSchedule(int64_t start_ns, std::optional<int64_t> duration_ns)
    : start_ns_(start_ns), duration_ns_(duration_ns) {}

unsigned SplitSchedule::endsPassed(int64_t t_ns) {
  if (!duration_ns_ || t_ns - start_ns_ <= *duration_ns_) return 0;
  unsigned ends = 0;
  while (start_ns_ + *duration_ns_ < t_ns) {
    start_ns_ += *duration_ns_;
    ++ends;
  }
  return ends;
}

}  // namespace flight_recorder
