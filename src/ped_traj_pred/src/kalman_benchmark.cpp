// Prints the 1 s-ahead prediction error and the velocity error of the pad filter on synthetic
// trajectories (no ROS needed).
//   rosrun ped_traj_pred kalman_benchmark [key=value ...]
// Keys are the FilterParameters names (e.g. model_covariance=2.0), `seed` of the noise, `noise_std` of
// the detections [m] and `told_std`, the std the filter is told with each fix [m] (default: noise_std,
// as the node tells it from the range); unknown keys are errors.
#include "ped_traj_pred/prediction_evaluation.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>

using namespace ped_traj_pred;

namespace
{
struct Case
{
  TrajectorySpec trajectory;
  MeasurementSpec measurements;
};

TrajectorySpec path(const std::string& name, PathKind kind, double speed, double radius, double max_acceleration,
                    double max_yaw_acceleration)
{
  TrajectorySpec spec;
  spec.name = name;
  spec.kind = kind;
  spec.speed = speed;
  spec.radius = radius;
  spec.max_acceleration = max_acceleration;
  spec.max_yaw_acceleration = max_yaw_acceleration;
  spec.duration = 60.0;
  return spec;
}

std::vector<Case> suite()
{
  // Summit XL: 1 m/s^2, 3 rad/s^2; car: 3 m/s^2, 1 rad/s^2 (mujoco_sim/config/sim.yaml).
  std::vector<Case> cases = {
    { path("straight", PathKind::kStraight, 0.5, 10, 1, 3), {} },
    { path("straight", PathKind::kStraight, 3, 10, 1, 3), {} },
    { path("acceleration 1<->10", PathKind::kAcceleration, 10, 10, 2, 3), {} },
    { path("stop_and_go", PathKind::kStopAndGo, 1, 10, 1, 3), {} },
    { path("stop_and_go", PathKind::kStopAndGo, 3, 10, 1, 3), {} },
    { path("stop_and_go", PathKind::kStopAndGo, 10, 10, 3, 3), {} },
    { path("back_and_forth", PathKind::kBackAndForth, 1, 10, 1, 3), {} },
    { path("back_and_forth", PathKind::kBackAndForth, 2, 10, 1, 3), {} },
    { path("back_and_forth", PathKind::kBackAndForth, 3, 10, 1, 3), {} },
    { path("circle r10", PathKind::kCircle, 0.5, 10, 1, 3), {} },
    { path("circle r10", PathKind::kCircle, 1, 10, 1, 3), {} },
    { path("circle r10", PathKind::kCircle, 3, 10, 1, 3), {} },
    { path("circle r10", PathKind::kCircle, 5, 10, 1, 3), {} },
    { path("circle r5", PathKind::kCircle, 3, 5, 1, 3), {} },
    { path("figure8 r10", PathKind::kFigure8, 3, 10, 1, 3), {} },
    { path("figure8 r5", PathKind::kFigure8, 2, 5, 1, 3), {} },
    { path("car straight", PathKind::kStraight, 15, 50, 3, 1), {} },
    { path("car straight", PathKind::kStraight, 25, 50, 3, 1), {} },
    { path("car circle r50", PathKind::kCircle, 15, 50, 3, 1), {} },
    { path("car circle r50", PathKind::kCircle, 25, 50, 3, 1), {} },
    { path("car figure8 r50", PathKind::kFigure8, 20, 50, 3, 1), {} },
  };
  Case gaps{ path("circle r10 gaps", PathKind::kCircle, 3, 10, 1, 3), {} };
  gaps.measurements.drop_probability = 0.2;
  gaps.measurements.blackouts = { { 10.0, 1.0 }, { 25.0, 2.0 }, { 40.0, 2.5 } };
  cases.push_back(gaps);
  Case outliers{ path("circle r10 outliers", PathKind::kCircle, 3, 10, 1, 3), {} };
  outliers.measurements.outlier_probability = 0.05;
  cases.push_back(outliers);
  Case gps = gaps;
  gps.trajectory.name = "circle r10 gaps+gps";
  gps.measurements.use_gps = true;
  cases.push_back(gps);
  return cases;
}

bool setParameter(FilterParameters& p, unsigned& seed, double& noise_std, double& told_std, const std::string& key,
                  double value)
{
  const std::map<std::string, double*> doubles = {
    { "model_covariance", &p.model_covariance },
    { "turn_rate_covariance", &p.turn_rate_covariance },
    { "velocity_covariance", &p.velocity_covariance },
    { "height_covariance", &p.height_covariance },
    { "manoeuvre_covariance_scale", &p.manoeuvre_covariance_scale },
    { "manoeuvre_acceleration_covariance", &p.manoeuvre_acceleration_covariance },
    { "steady_mode_duration", &p.steady_mode_duration },
    { "manoeuvre_mode_duration", &p.manoeuvre_mode_duration },
    { "onset_window", &p.onset_window },
    { "onset_acceleration_std", &p.onset_acceleration_std },
    { "onset_threshold", &p.onset_threshold },
    { "stop_threshold", &p.stop_threshold },
    { "observation_covariance", &p.observation_covariance },
    { "observation_std_floor", &p.observation_std_floor },
    { "observation_std_per_metre", &p.observation_std_per_metre },
    { "gps_observation_covariance", &p.gps_observation_covariance },
    { "gps_offset_initial_std", &p.gps_offset_initial_std },
    { "gps_offset_drift", &p.gps_offset_drift },
    { "gps_vision_timeout", &p.gps_vision_timeout },
    { "gps_pad_height", &p.gps_pad_height },
    { "initial_gps_height_std", &p.initial_gps_height_std },
    { "max_coast_time", &p.max_coast_time },
    { "gate_threshold", &p.gate_threshold },
    { "initial_velocity_std", &p.initial_velocity_std },
    { "initial_acceleration_std", &p.initial_acceleration_std },
    { "initial_turn_rate_std", &p.initial_turn_rate_std },
    { "heading_acquisition_std", &p.heading_acquisition_std },
    { "heading_loss_std", &p.heading_loss_std },
    { "low_speed_regularisation", &p.low_speed_regularisation },
    { "max_integration_step", &p.max_integration_step },
  };
  if (key == "seed")
    seed = static_cast<unsigned>(value);
  else if (key == "noise_std")
    noise_std = value;
  else if (key == "told_std")
    told_std = value;
  else if (key == "max_consecutive_rejections")
    p.max_consecutive_rejections = static_cast<int>(value);
  else if (doubles.count(key))
    *doubles.at(key) = value;
  else
    return false;
  return true;
}
}  // namespace

int main(int argc, char** argv)
{
  FilterParameters parameters;
  unsigned seed = 1;
  double noise_std = 0.03, told_std = -1.0;
  for (int i = 1; i < argc; ++i)
  {
    const std::string arg = argv[i];
    const auto equals = arg.find('=');
    if (equals == std::string::npos || !setParameter(parameters, seed, noise_std, told_std, arg.substr(0, equals),
                                                       std::atof(arg.substr(equals + 1).c_str())))
    {
      std::fprintf(stderr, "usage: kalman_benchmark [key=value ...]; bad argument '%s'\n", arg.c_str());
      return 2;
    }
  }
  const std::string error = parameters.validate();
  if (!error.empty())
  {
    std::fprintf(stderr, "kalman_benchmark: %s\n", error.c_str());
    return 2;
  }

  std::printf("1 s-ahead 3-D prediction error [m], 30 Hz detections, noise %.0f mm per axis (filter told %.0f mm),\n"
              "60 s per run, "
"scored at every frame after the first 3 s (p95 = 95th percentile). Velocity error [m/s]: p95 over\n"
              "the same frames (v p95), and 0.3 s after each manoeuvre: a speed or turn ramp starts or ends, or\n"
              "the speed passes through zero (n of them, p95 and max)\n\n",
              1000.0 * noise_std, 1000.0 * (told_std < 0.0 ? noise_std : told_std));
  std::printf("%-22s %6s %7s %7s %7s %7s %7s | %6s | %3s %6s %6s | %4s %4s %6s\n", "trajectory", "v[m/s]", "mean",
              "rms", "median", "p95", "max", "v p95", "n", "p95", "max", "lost", "rej", "reinit");
  double sum_p95 = 0.0, sum_manoeuvre_p95 = 0.0;
  int manoeuvre_cases = 0;
  const std::vector<Case> cases = suite();
  for (Case c : cases)
  {
    c.measurements.seed = seed;
    c.measurements.noise_std = noise_std;
    c.measurements.told_std = told_std;
    const SyntheticTrajectory trajectory(c.trajectory, 30.0);
    const EvaluationResult r = evaluatePrediction(trajectory, c.measurements, parameters);
    const ErrorStatistics& s = r.statistics;
    const ErrorStatistics& m = r.manoeuvre_velocity_statistics;
    std::printf("%-22s %6.1f %7.3f %7.3f %7.3f %7.3f %7.3f | %6.3f | %3d %6.3f %6.3f | %4d %4d %6d\n",
                c.trajectory.name.c_str(), c.trajectory.speed, s.mean, s.rms, s.median, s.p95, s.max,
                r.velocity_statistics.p95, m.count, m.p95, m.max, r.untracked_ticks, r.rejected, r.reinitialised);
    sum_p95 += s.p95;
    if (m.count > 0)
    {
      sum_manoeuvre_p95 += m.p95;
      ++manoeuvre_cases;
    }
  }
  std::printf("\nmean p95 over the %zu runs: %.3f m; mean p95 of the velocity error 0.3 s after a manoeuvre over "
              "the %d runs with manoeuvres: %.3f m/s\n",
              cases.size(), sum_p95 / cases.size(), manoeuvre_cases, sum_manoeuvre_p95 / std::max(1, manoeuvre_cases));
  return 0;
}
