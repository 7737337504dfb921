#include "ped_traj_pred/synthetic_trajectory.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace ped_traj_pred
{
namespace
{
double moveTowards(double current, double target, double max_change)
{
  return current + std::clamp(target - current, -max_change, max_change);
}
}  // namespace

Eigen::Vector2d SyntheticTrajectory::command(const TrajectorySpec& spec, double t)
{
  const double v = spec.speed;
  switch (spec.kind)
  {
    case PathKind::kStraight:
      return { v, 0.0 };
    case PathKind::kCircle:
      return { v, v / spec.radius };
    case PathKind::kFigure8:
    {
      const double loop_time = 2.0 * M_PI * spec.radius / v;
      const bool first_loop = std::fmod(t, 2.0 * loop_time) < loop_time;
      return { v, (first_loop ? 1.0 : -1.0) * v / spec.radius };
    }
    case PathKind::kStopAndGo:
      return { std::fmod(t, 8.0) < 5.0 ? v : 0.0, 0.0 };
    case PathKind::kAcceleration:
      return { std::fmod(t, 16.0) < 8.0 ? 1.0 : v, 0.0 };
    case PathKind::kBackAndForth:
    {
      const double leg_time = 2.0 * spec.radius / v;
      return { std::fmod(t, 2.0 * leg_time) < leg_time ? v : -v, 0.0 };
    }
  }
  return { 0.0, 0.0 };
}

SyntheticTrajectory::SyntheticTrajectory(const TrajectorySpec& spec, double sample_rate_hz)
  : spec_(spec), sample_rate_hz_(sample_rate_hz)
{
  if (!(sample_rate_hz > 0.0) || !(spec.duration > 0.0) || !(spec.speed > 0.0) || !(spec.radius > 0.0))
    throw std::invalid_argument("SyntheticTrajectory needs positive rate, duration, speed and radius");
  // Fine Euler steps of the unicycle (1 ms), far below the sample period, so the truth is exact to
  // well under a millimetre.
  const int substeps = std::max(1, static_cast<int>(std::ceil(1.0 / (sample_rate_hz * 1e-3))));
  const double h = 1.0 / (sample_rate_hz * substeps);
  const int samples = static_cast<int>(std::floor(spec.duration * sample_rate_hz)) + 1;

  const Eigen::Vector2d start_command = command(spec, 0.0);
  double speed = start_command.x();
  double yaw_rate = start_command.y();
  double yaw = 0.0;
  Eigen::Vector2d xy(0.0, 0.0);
  double t = 0.0;
  // Sign (-1, 0, 1) of the speed's and the yaw rate's change in the previous sub-step: a manoeuvre starts
  // or ends where one of them changes, or where the speed changes sign.
  const auto sign = [](double value) { return (value > 0.0) - (value < 0.0); };
  int speed_ramp = 0, yaw_ramp = 0, direction = sign(speed);  // direction: of travel, last while moving
  positions_.reserve(samples);
  velocities_.reserve(samples);
  headings_.reserve(samples);
  for (int k = 0; k < samples; ++k)
  {
    const Eigen::Vector2d heading(std::cos(yaw), std::sin(yaw));
    positions_.emplace_back(xy.x(), xy.y(), spec.pad_height);
    velocities_.push_back(speed * heading);
    headings_.push_back(yaw);
    for (int i = 0; i < substeps; ++i)
    {
      const Eigen::Vector2d target = command(spec, t);
      const double previous_speed = speed, previous_yaw_rate = yaw_rate;
      speed = moveTowards(speed, target.x(), spec.max_acceleration * h);
      yaw_rate = moveTowards(yaw_rate, target.y(), spec.max_yaw_acceleration * h);
      const int new_speed_ramp = sign(speed - previous_speed), new_yaw_ramp = sign(yaw_rate - previous_yaw_rate);
      const bool reversed = sign(speed) != 0 && direction != 0 && sign(speed) != direction;
      if (new_speed_ramp != speed_ramp || new_yaw_ramp != yaw_ramp || reversed)
        manoeuvre_times_.push_back(t);
      speed_ramp = new_speed_ramp;
      yaw_ramp = new_yaw_ramp;
      if (sign(speed) != 0)
        direction = sign(speed);
      // Midpoint rule for the heading: exact for constant yaw rate up to O(h^2).
      const double mid_yaw = yaw + 0.5 * yaw_rate * h;
      xy += speed * h * Eigen::Vector2d(std::cos(mid_yaw), std::sin(mid_yaw));
      yaw += yaw_rate * h;
      t += h;
    }
  }
}

}  // namespace ped_traj_pred
