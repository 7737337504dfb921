// The ROS-free arithmetic of the graph floor's roscpp null node (landing_bench/src/null_node.cpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <optional>
#include <utility>

namespace landing_bench {

// How many messages of a publication at `rate_hz` go out on one event of a driver at `driver_hz`: the shares
// add up, so over any span the publication keeps its rate whatever the two rates are.
class PublicationCredit {
 public:
  PublicationCredit(double rate_hz, double driver_hz) : share_(driver_hz > 0.0 ? rate_hz / driver_hz : 1.0) {}

  int onDriverEvent() {
    credit_ += share_;
    int due = 0;
    while (credit_ >= 1.0 - 1e-9) {  // (the shares' rounding must not drop a message)
      credit_ -= 1.0;
      ++due;
    }
    return due;
  }

 private:
  double share_;
  double credit_ = 0.0;
};

// (sec, nsec) of the std_msgs/Header a serialised message starts with (seq: uint32, then the stamp), or nothing
// when the message is too short to hold one.
inline std::optional<std::pair<uint32_t, uint32_t>> headerStamp(const uint8_t* data, size_t size) {
  if (size < 12) return std::nullopt;
  uint32_t sec = 0, nsec = 0;
  std::memcpy(&sec, data + 4, 4);  // little-endian on the wire, as on every machine ROS 1 runs on here
  std::memcpy(&nsec, data + 8, 4);
  return std::make_pair(sec, nsec);
}

}  // namespace landing_bench
