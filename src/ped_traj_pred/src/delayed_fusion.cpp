#include "ped_traj_pred/delayed_fusion.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ped_traj_pred
{
DelayedFusion::DelayedFusion(const FilterParameters& parameters, double horizon)
  : filter_(parameters), horizon_(horizon)
{
  if (!(std::isfinite(horizon) && horizon > 0.0))
    throw std::invalid_argument("fusion horizon must be a finite number > 0 [s]");
}

void DelayedFusion::reset()
{
  filter_.reset();
  history_.clear();
}

MeasurementOutcome DelayedFusion::addVision(double stamp, const Eigen::Vector3d& position, double variance)
{
  return add(stamp, [=](PadMotionFilter& f) { return f.addVision(stamp, position, variance); });
}

MeasurementOutcome DelayedFusion::addVehicleReport(double stamp, const VehicleReport& report)
{
  return add(stamp, [=](PadMotionFilter& f) {
    const MeasurementOutcome outcome = report.pad_position
                                           ? f.addGps(stamp, *report.pad_position, report.velocity, report.velocity_variance)
                                           : MeasurementOutcome::kIgnored;
    // The velocity is the pad's speed, seen before the fixes show a change of it; the heading holds the
    // track's heading through stops and reversals; the yaw rate is the turn rate through the corners.
    if (report.velocity)
      f.addSpeed(stamp, *report.velocity, report.velocity_variance);
    if (report.heading)
      f.addHeading(stamp, *report.heading, report.heading_variance);
    if (report.yaw_rate)
      f.addTurnRate(stamp, *report.yaw_rate, report.yaw_rate_variance);
    return outcome;
  });
}

MeasurementOutcome DelayedFusion::add(double stamp, Fusion fuse)
{
  if (!std::isfinite(stamp))
    return MeasurementOutcome::kDroppedInvalid;
  if (history_.empty() || stamp >= history_.back().stamp)
  {
    history_.push_back({ stamp, fuse, filter_ });
    const MeasurementOutcome outcome = fuse(filter_);
    while (!history_.empty() && history_.front().stamp < stamp - horizon_)
      history_.pop_front();
    return outcome;
  }
  if (stamp < history_.back().stamp - horizon_)
    return MeasurementOutcome::kDroppedStale;  // beyond the horizon
  // Back to just before the first later measurement, this one, then the later ones again.
  auto later = std::upper_bound(history_.begin(), history_.end(), stamp,
                                [](double t, const Entry& e) { return t < e.stamp; });
  filter_ = later->before;
  const std::ptrdiff_t index = later - history_.begin();
  history_.insert(later, Entry{ stamp, fuse, filter_ });
  const MeasurementOutcome outcome = fuse(filter_);
  for (auto it = history_.begin() + index + 1; it != history_.end(); ++it)
  {
    it->before = filter_;
    it->fuse(filter_);
    ++replayed_;
  }
  return outcome;
}

}  // namespace ped_traj_pred
