// PadMotionFilter fed in the order its measurements were taken, though they arrive late and out of that
// order. ROS-free.
//
// A real drone's camera frames arrive 0.1-0.2 s after they were taken (H.264 over Wi-Fi), the vehicle's
// GPS reports 0.2-0.4 s after its fix; each is stamped with the instant it was taken. PadMotionFilter
// fuses in time order and drops what is older than its state. This wrapper keeps, for the last
// `horizon` seconds, every measurement with a copy of the filter from just before it. A measurement
// older than the newest one fused is fused at its own time: the filter goes back to the copy before it
// and fuses it and every later one again, in order (re-filtering; exact, unlike applying the old
// innovation to the present state). What is older than the newest one by more than the horizon is
// dropped as stale.
//
// Cost: one filter copy per measurement, and for a late one the re-fusion of what came after it (about
// 6 vision fixes behind a 0.2 s-late GPS report, tens of microseconds each).
#pragma once

#include "ped_traj_pred/pad_motion_filter.h"

#include <deque>
#include <functional>
#include <optional>

namespace ped_traj_pred
{
/// One report of the vehicle's GPS receiver / odometry: the pad position (moved from the receiver to the
/// pad centre; nullopt while the receiver has no fix) and, where reported (nullopt otherwise), its
/// velocity, heading and yaw rate, with variances.
struct VehicleReport
{
  std::optional<Eigen::Vector2d> pad_position;             ///< [m]
  std::optional<Eigen::Vector2d> velocity;                 ///< world [m/s]
  double velocity_variance = -1.0;                         ///< per axis [m^2/s^2]
  std::optional<double> heading;                           ///< [rad]
  double heading_variance = -1.0;                          ///< [rad^2]
  std::optional<double> yaw_rate;                          ///< [rad/s]
  double yaw_rate_variance = -1.0;                         ///< [rad^2/s^2]
};

class DelayedFusion
{
public:
  /// Throws std::invalid_argument for invalid parameters or a horizon that is not positive and finite.
  DelayedFusion(const FilterParameters& parameters, double horizon);

  /// Vision fix taken at `stamp` [s]; see PadMotionFilter::addVision.
  MeasurementOutcome addVision(double stamp, const Eigen::Vector3d& position, double variance = -1.0);
  /// A vehicle report taken at `stamp` [s]: its GPS fix, then speed, heading and yaw rate (those reported),
  /// fused as one measurement. Returns the outcome of the GPS fix (kIgnored without one).
  MeasurementOutcome addVehicleReport(double stamp, const VehicleReport& report);

  /// The filter with everything received fused in stamp order.
  const PadMotionFilter& filter() const { return filter_; }
  const FilterParameters& parameters() const { return filter_.parameters(); }
  bool isTracking(double now) const { return filter_.isTracking(now); }
  std::optional<PadState> stateAt(double time) const { return filter_.stateAt(time); }
  std::vector<PathPoint> predictPath(double t0, double time_step, double path_time) const
  {
    return filter_.predictPath(t0, time_step, path_time);
  }
  /// Forget everything (e.g. after the clock jumped back).
  void reset();

  /// How many measurements were fused again because an older one arrived after them.
  long replayed() const { return replayed_; }
  double horizon() const { return horizon_; }

private:
  using Fusion = std::function<MeasurementOutcome(PadMotionFilter&)>;
  struct Entry
  {
    double stamp;
    Fusion fuse;
    PadMotionFilter before;  ///< the filter just before this measurement
  };
  MeasurementOutcome add(double stamp, Fusion fuse);

  PadMotionFilter filter_;
  double horizon_;
  std::deque<Entry> history_;  ///< oldest first, stamps not decreasing
  long replayed_ = 0;
};

}  // namespace ped_traj_pred
