// Runs PadMotionFilter on a synthetic trajectory with simulated detections and measures how far its
// predicted path lands from the truth `horizon` seconds later, and how far its velocity estimate is
// from the truth, especially shortly after each manoeuvre. Shared by the gtest and the benchmark.
#pragma once

#include "ped_traj_pred/pad_motion_filter.h"
#include "ped_traj_pred/synthetic_trajectory.h"

#include <string>
#include <vector>

namespace ped_traj_pred
{
/// How the simulated camera (and optional GPS) sees the pad.
struct MeasurementSpec
{
  double noise_std = 0.03;           ///< vision noise per axis [m]
  /// Std the filter is told with each fix, as the node tells it from the range [m]; negative: noise_std.
  double told_std = -1.0;
  double drop_probability = 0.0;     ///< each frame independently missing [-]
  struct Blackout
  {
    double start;     ///< [s]
    double duration;  ///< [s]
  };
  std::vector<Blackout> blackouts;   ///< camera loses the pad entirely
  double outlier_probability = 0.0;  ///< a frame is a false detection [-]
  double outlier_distance = 3.0;     ///< horizontal offset of a false detection [m]
  bool use_gps = false;              ///< GPS fixes of the vehicle at gps_rate_hz
  double gps_rate_hz = 5.0;          ///< [Hz]
  double gps_noise_std = 0.3;        ///< per axis [m]
  bool use_heading = false;          ///< the vehicle's heading (yaw) at gps_rate_hz, as its GPS/odometry reports it
  double heading_noise_std = 0.035;  ///< [rad] (2 deg, as the simulator's vehicle_heading_std_deg)
  unsigned seed = 1;
};

struct EvaluationSpec
{
  double horizon = 1.0;    ///< how far ahead the prediction is scored [s]
  double warmup = 3.0;     ///< no scoring before this time [s]
  double time_step = 0.1;  ///< path time step [s]
  /// The velocity is scored this long after each manoeuvre (SyntheticTrajectory::manoeuvreTimes) [s].
  double velocity_delay = 0.3;
};

struct ErrorStatistics
{
  int count = 0;
  double mean = 0.0, rms = 0.0, median = 0.0, p95 = 0.0, max = 0.0;  ///< [m] or [m/s]
};

/// Statistics of a set of errors; percentiles by nearest rank.
ErrorStatistics summarise(std::vector<double> errors);

struct EvaluationResult
{
  std::vector<double> times;   ///< prediction instants t0 [s]
  std::vector<double> errors;  ///< |predicted(t0 + horizon) - true(t0 + horizon)|, 3-D [m]
  ErrorStatistics statistics;
  /// |estimated - true| horizontal velocity at the same instants as `errors` [m/s].
  std::vector<double> velocity_errors;
  ErrorStatistics velocity_statistics;
  /// The same, velocity_delay after each manoeuvre (manoeuvre time + velocity_delay, at or after the
  /// warm-up, while tracked) [s], [m/s].
  std::vector<double> manoeuvre_times;
  std::vector<double> manoeuvre_velocity_errors;
  ErrorStatistics manoeuvre_velocity_statistics;
  int untracked_ticks = 0;     ///< scored instants at which the filter reported the track lost
  int rejected = 0;            ///< measurements rejected by the gate
  int reinitialised = 0;       ///< track restarts after consecutive rejections
};

/// At every sample of `trajectory` (one per camera frame): feed the frame's detection if any, then, if
/// t0 >= warmup and the filter tracks, predict the path from t0 and score its point at t0 + horizon, and
/// score the velocity estimate at t0.
EvaluationResult evaluatePrediction(const SyntheticTrajectory& trajectory, const MeasurementSpec& measurements,
                                    const FilterParameters& parameters, const EvaluationSpec& evaluation = {});

}  // namespace ped_traj_pred
