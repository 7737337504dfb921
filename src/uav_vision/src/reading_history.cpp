#include "uav_vision/reading_history.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace uav_vision {

void ReadingHistory::add(double stamp, double value) {
  readings_.add({stamp, value});
}

double ReadingHistory::nearest(double stamp, double max_offset) const {
  return medianNear(stamp, max_offset, 1);
}

double ReadingHistory::medianNear(double stamp, double max_offset, int count) const {
  // Walk outwards from the stamp, taking the nearer of the two neighbours each time.
  auto later = readings_.firstNotBefore(stamp);
  auto earlier = later;
  std::vector<double> values;  // nearest first
  while (int(values.size()) < count) {
    const bool has_later = later != readings_.end() && later->stamp - stamp <= max_offset;
    const bool has_earlier = earlier != readings_.begin() && stamp - std::prev(earlier)->stamp <= max_offset;
    if (has_later && (!has_earlier || later->stamp - stamp <= stamp - std::prev(earlier)->stamp)) {
      values.push_back((later++)->value);
    } else if (has_earlier) {
      values.push_back((--earlier)->value);
    } else {
      break;
    }
  }
  if (values.empty()) return NAN;
  if (values.size() == 2) return values.front();
  const auto middle = values.begin() + values.size() / 2;
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

double ReadingHistory::meanNear(double stamp, double window, double max_offset) const {
  double sum = 0.0;
  int count = 0;
  for (const auto& r : readings_)
    if (std::abs(r.stamp - stamp) <= window) {
      sum += r.value;
      ++count;
    }
  return count > 0 ? sum / count : nearest(stamp, max_offset);
}

}  // namespace uav_vision
