// The recent readings of a scalar sensor (sonar range, barometric altitude) and their value at an image's
// stamp (ROS-free).
//
// Frames arrive 100-200 ms after they were taken, so the newest reading is not the one that goes with a
// frame: the drone may have descended 10 cm since, or crossed the pad's edge. The readings are kept for a
// second and looked up at the frame's capture time. No interpolation: between a reading on the pad and
// one on the ground it would give a height that is neither. The sonar takes the median of the readings
// nearest to the stamp, which drops a single spurious echo (2-5 % of the readings); the barometer the mean
// of those close to it, against its noise.
#pragma once

#include "uav_vision/stamped_window.h"

namespace uav_vision {

class ReadingHistory {
 public:
  // `keep`: how much history is kept [s].
  explicit ReadingHistory(double keep = 1.0) : readings_(keep) {}

  // A reading (any value: +inf is "nothing in range" for a sonar). A stamp older than the newest one
  // restarts the history (time jumped back).
  void add(double stamp, double value);

  // The reading nearest to `stamp`, if at most `max_offset` from it; NaN otherwise.
  double nearest(double stamp, double max_offset) const;
  // The median of the (up to) `count` readings nearest to `stamp` within `max_offset` of it (of two, the
  // nearer one); NaN when none.
  double medianNear(double stamp, double max_offset, int count = 3) const;

  // The mean of the readings within `window` of `stamp` (the barometer: white noise of 0.1 m, while the
  // drone climbs or sinks a few centimetres over a tenth of a second, evenly on both sides); without any,
  // nearest(stamp, max_offset).
  double meanNear(double stamp, double window, double max_offset) const;

  bool empty() const { return readings_.empty(); }

 private:
  struct Reading {
    double stamp, value;
  };
  StampedWindow<Reading> readings_;
};

}  // namespace uav_vision
