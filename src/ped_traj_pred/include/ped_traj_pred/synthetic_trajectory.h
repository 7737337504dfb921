// Ground-vehicle trajectories for testing and benchmarking the pad filter, free of ROS.
//
// Like summit_moves/paths.py, each path is a (speed, yaw-rate) command; like the simulator, the vehicle
// follows it through acceleration and yaw-acceleration limits, so steps become realistic ramps.
#pragma once

#include <Eigen/Dense>

#include <string>
#include <vector>

namespace ped_traj_pred
{
enum class PathKind
{
  kStraight,      ///< constant speed
  kCircle,        ///< constant speed and yaw rate speed/radius
  kFigure8,       ///< circles of alternating direction, one full loop each
  kStopAndGo,     ///< speed for 5 s, stopped for 3 s (as summit_moves)
  kAcceleration,  ///< 1 m/s for 8 s, then `speed` for 8 s, repeated
  kBackAndForth,  ///< 2*radius forward, then the same backward (as summit_moves): the speed reverses through 0
};

struct TrajectorySpec
{
  std::string name;
  PathKind kind = PathKind::kStraight;
  double speed = 3.0;          ///< nominal speed [m/s]
  double radius = 10.0;        ///< circle / figure-8 radius [m]
  double max_acceleration = 2.0;      ///< speed-change limit [m/s^2]
  double max_yaw_acceleration = 3.0;  ///< yaw-rate-change limit [rad/s^2]
  double pad_height = 0.497;   ///< pad top above the ground [m]
  double duration = 30.0;      ///< [s]
};

/// The pad's true path sampled every 1/sample_rate s from t = 0 to duration (inclusive).
class SyntheticTrajectory
{
public:
  SyntheticTrajectory(const TrajectorySpec& spec, double sample_rate_hz);

  int size() const { return static_cast<int>(positions_.size()); }
  double sampleTime(int index) const { return index / sample_rate_hz_; }
  double sampleRate() const { return sample_rate_hz_; }
  const Eigen::Vector3d& position(int index) const { return positions_.at(index); }
  const Eigen::Vector2d& velocity(int index) const { return velocities_.at(index); }
  /// Yaw of the vehicle [rad]: the axis it drives along (a reversal keeps it).
  double heading(int index) const { return headings_.at(index); }
  const TrajectorySpec& spec() const { return spec_; }
  /// Instants [s] at which the motion changes character: a speed or yaw-rate ramp starts or ends, or the
  /// speed passes through zero. A filter lags most right after them.
  const std::vector<double>& manoeuvreTimes() const { return manoeuvre_times_; }

  /// Commanded (speed [m/s], yaw rate [rad/s]) at time t, before the vehicle's limits.
  static Eigen::Vector2d command(const TrajectorySpec& spec, double t);

private:
  TrajectorySpec spec_;
  double sample_rate_hz_;
  std::vector<Eigen::Vector3d> positions_;
  std::vector<Eigen::Vector2d> velocities_;
  std::vector<double> headings_;
  std::vector<double> manoeuvre_times_;
};

}  // namespace ped_traj_pred
