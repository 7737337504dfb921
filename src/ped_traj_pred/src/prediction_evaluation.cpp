#include "ped_traj_pred/prediction_evaluation.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace ped_traj_pred
{
ErrorStatistics summarise(std::vector<double> errors)
{
  ErrorStatistics stats;
  stats.count = static_cast<int>(errors.size());
  if (errors.empty())
    return stats;
  std::sort(errors.begin(), errors.end());
  double sum = 0.0, sum_squares = 0.0;
  for (double e : errors)
  {
    sum += e;
    sum_squares += e * e;
  }
  const auto rank = [&](double fraction) {
    const auto index = static_cast<size_t>(std::ceil(fraction * errors.size())) - 1;
    return errors[std::min(index, errors.size() - 1)];
  };
  stats.mean = sum / errors.size();
  stats.rms = std::sqrt(sum_squares / errors.size());
  stats.median = rank(0.5);
  stats.p95 = rank(0.95);
  stats.max = errors.back();
  return stats;
}

EvaluationResult evaluatePrediction(const SyntheticTrajectory& trajectory, const MeasurementSpec& measurements,
                                    const FilterParameters& parameters, const EvaluationSpec& evaluation)
{
  PadMotionFilter filter(parameters);
  std::mt19937 rng(measurements.seed);
  std::normal_distribution<double> unit_normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);

  const double told_std = measurements.told_std < 0.0 ? measurements.noise_std : measurements.told_std;
  const double rate = trajectory.sampleRate();
  const int horizon_samples = static_cast<int>(std::lround(evaluation.horizon * rate));
  const int gps_period_samples = std::max(1, static_cast<int>(std::lround(rate / measurements.gps_rate_hz)));
  const auto in_blackout = [&](double t) {
    return std::any_of(measurements.blackouts.begin(), measurements.blackouts.end(),
                       [t](const MeasurementSpec::Blackout& b) { return t >= b.start && t < b.start + b.duration; });
  };

  // Sample index at which each manoeuvre's velocity is scored (the first sample at or after it + delay).
  std::vector<int> manoeuvre_samples;
  for (const double manoeuvre : trajectory.manoeuvreTimes())
  {
    const int k = static_cast<int>(std::ceil((manoeuvre + evaluation.velocity_delay) * rate - 1e-6));
    if (k < trajectory.size() && trajectory.sampleTime(k) >= evaluation.warmup)
      manoeuvre_samples.push_back(k);
  }
  auto next_manoeuvre = manoeuvre_samples.begin();

  EvaluationResult result;
  const auto count = [&](MeasurementOutcome outcome) {
    result.rejected += outcome == MeasurementOutcome::kRejected;
    result.reinitialised += outcome == MeasurementOutcome::kReinitialised;
  };

  for (int k = 0; k < trajectory.size(); ++k)
  {
    const double t = trajectory.sampleTime(k);
    const Eigen::Vector3d& truth = trajectory.position(k);
    if (measurements.use_gps && k % gps_period_samples == 0)
    {
      const Eigen::Vector2d noise(unit_normal(rng), unit_normal(rng));
      count(filter.addGps(t, truth.head<2>() + measurements.gps_noise_std * noise));
    }
    if (measurements.use_heading && k % gps_period_samples == 0)
      filter.addHeading(t, trajectory.heading(k) + measurements.heading_noise_std * unit_normal(rng),
                        measurements.heading_noise_std * measurements.heading_noise_std);
    // Draw every random number whether or not the frame is used, so a blackout does not shift the
    // noise of the frames after it (runs stay comparable).
    const bool dropped = uniform(rng) < measurements.drop_probability;
    const bool outlier = uniform(rng) < measurements.outlier_probability;
    const double outlier_angle = 2.0 * M_PI * uniform(rng);
    const Eigen::Vector3d noise(unit_normal(rng), unit_normal(rng), unit_normal(rng));
    if (!dropped && !in_blackout(t))
    {
      Eigen::Vector3d detection = truth + measurements.noise_std * noise;
      if (outlier)
        detection += measurements.outlier_distance * Eigen::Vector3d(std::cos(outlier_angle), std::sin(outlier_angle), 0.0);
      count(filter.addVision(t, detection, told_std * told_std));
    }

    const bool tracking = filter.isTracking(t);
    double velocity_error = 0.0;
    if (tracking)
      velocity_error = (filter.stateAt(t)->velocity.head<2>() - trajectory.velocity(k)).norm();
    for (; next_manoeuvre != manoeuvre_samples.end() && *next_manoeuvre == k; ++next_manoeuvre)
    {
      if (tracking)
      {
        result.manoeuvre_times.push_back(t - evaluation.velocity_delay);
        result.manoeuvre_velocity_errors.push_back(velocity_error);
      }
    }

    if (t < evaluation.warmup || k + horizon_samples >= trajectory.size())
      continue;
    if (!tracking)
    {
      ++result.untracked_ticks;
      continue;
    }
    const std::vector<PathPoint> path = filter.predictPath(t, evaluation.time_step, evaluation.horizon);
    result.times.push_back(t);
    result.errors.push_back((path.back().position - trajectory.position(k + horizon_samples)).norm());
    result.velocity_errors.push_back(velocity_error);
  }
  result.statistics = summarise(result.errors);
  result.velocity_statistics = summarise(result.velocity_errors);
  result.manoeuvre_velocity_statistics = summarise(result.manoeuvre_velocity_errors);
  return result;
}

}  // namespace ped_traj_pred
