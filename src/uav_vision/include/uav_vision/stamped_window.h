// The last seconds of stamped samples, oldest first (ROS-free): what the attitude, reading and estimate histories
// keep to look a measurement up at an image's capture stamp.
#pragma once

#include <algorithm>
#include <deque>

namespace uav_vision {

// `Sample` has a `double stamp` [s].
template <typename Sample>
class StampedWindow {
 public:
  using const_iterator = typename std::deque<Sample>::const_iterator;

  // `keep`: how much history is kept [s] (at least the newest sample).
  explicit StampedWindow(double keep) : keep_(keep) {}

  // A stamp older than the newest one restarts the window (time jumped back).
  void add(const Sample& sample) {
    if (!samples_.empty() && sample.stamp < samples_.back().stamp) samples_.clear();
    samples_.push_back(sample);
    while (samples_.size() > 1 && sample.stamp - samples_.front().stamp > keep_) samples_.pop_front();
  }

  // The first sample stamped at or after `stamp` (end() when none).
  const_iterator firstNotBefore(double stamp) const {
    return std::lower_bound(samples_.begin(), samples_.end(), stamp,
                            [](const Sample& s, double t) { return s.stamp < t; });
  }

  const_iterator begin() const { return samples_.begin(); }
  const_iterator end() const { return samples_.end(); }
  const Sample& back() const { return samples_.back(); }
  bool empty() const { return samples_.empty(); }

 private:
  double keep_;
  std::deque<Sample> samples_;
};

}  // namespace uav_vision
