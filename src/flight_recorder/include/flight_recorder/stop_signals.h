#pragma once
// SIGINT and SIGTERM as a call on a thread of their own, so that a recorder stops at once and cleanly. ROS-free.

#include <atomic>
#include <functional>
#include <thread>

namespace flight_recorder {

// Blocks SIGINT and SIGTERM in the calling thread and in every thread it starts from then on. Call it first in
// main, before any thread starts (roscpp's start with the first NodeHandle): a signal then reaches only the
// thread of StopSignals, not a roscpp thread in the middle of its work.
void blockStopSignals();

// While it lives, each SIGINT or SIGTERM calls `on_stop` (on its own thread, so on_stop must be thread-safe).
class StopSignals {
 public:
  explicit StopSignals(std::function<void()> on_stop);
  ~StopSignals();
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

 private:
  std::function<void()> on_stop_;
  std::atomic<bool> finished_{false};
  std::thread waiter_;
};

}  // namespace flight_recorder
