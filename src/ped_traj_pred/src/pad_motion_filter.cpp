#include "ped_traj_pred/pad_motion_filter.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace ped_traj_pred
{
namespace
{
constexpr double kNever = -std::numeric_limits<double>::infinity();

bool isPositiveFinite(double value)
{
  return std::isfinite(value) && value > 0.0;
}

bool isNonNegativeFinite(double value)
{
  return std::isfinite(value) && value >= 0.0;
}

const FilterParameters& validated(const FilterParameters& parameters)
{
  const std::string error = parameters.validate();
  if (!error.empty())
    throw std::invalid_argument(error);
  return parameters;
}
}  // namespace

std::string FilterParameters::validate() const
{
  struct Check
  {
    const char* name;
    double value;
    bool zero_allowed;
    const char* unit;
  };
  const Check checks[] = {
    { "model_covariance", model_covariance, true, "m^2/s^5" },
    { "turn_rate_covariance", turn_rate_covariance, true, "rad^2/s^3" },
    { "velocity_covariance", velocity_covariance, true, "m^2/s^3" },
    { "height_covariance", height_covariance, true, "m^2/s" },
    { "manoeuvre_covariance_scale", manoeuvre_covariance_scale, false, "-" },
    { "steady_mode_duration", steady_mode_duration, false, "s" },
    { "manoeuvre_mode_duration", manoeuvre_mode_duration, false, "s" },
    { "observation_covariance", observation_covariance, false, "m^2" },
    { "gps_observation_covariance", gps_observation_covariance, false, "m^2" },
    { "gps_vision_timeout", gps_vision_timeout, true, "s" },
    { "initial_gps_height_std", initial_gps_height_std, false, "m" },
    { "max_coast_time", max_coast_time, false, "s" },
    { "gate_threshold", gate_threshold, false, "-" },
    { "initial_velocity_std", initial_velocity_std, false, "m/s" },
    { "initial_acceleration_std", initial_acceleration_std, false, "m/s^2" },
    { "initial_turn_rate_std", initial_turn_rate_std, false, "rad/s" },
    { "low_speed_regularisation", low_speed_regularisation, false, "m/s" },
    { "max_integration_step", max_integration_step, false, "s" },
  };
  for (const Check& check : checks)
  {
    const bool valid = check.zero_allowed ? isNonNegativeFinite(check.value) : isPositiveFinite(check.value);
    if (!valid)
    {
      std::ostringstream message;
      message << check.name << " must be a finite number " << (check.zero_allowed ? ">= 0" : "> 0") << " ["
              << check.unit << "], got " << check.value;
      return message.str();
    }
  }
  if (!std::isfinite(gps_pad_height))
    return "gps_pad_height must be a finite number [m]";
  if (max_consecutive_rejections < 1)
    return "max_consecutive_rejections must be >= 1 [-], got " + std::to_string(max_consecutive_rejections);
  return "";
}

const char* toString(MeasurementOutcome outcome)
{
  switch (outcome)
  {
    case MeasurementOutcome::kInitialised:
      return "initialised";
    case MeasurementOutcome::kAccepted:
      return "accepted";
    case MeasurementOutcome::kRejected:
      return "rejected";
    case MeasurementOutcome::kReinitialised:
      return "reinitialised";
    case MeasurementOutcome::kDroppedStale:
      return "dropped (stale stamp)";
    case MeasurementOutcome::kDroppedInvalid:
      return "dropped (not finite)";
    case MeasurementOutcome::kIgnored:
      return "ignored (vision is fresh)";
  }
  return "unknown";
}

PadMotionFilter::PadMotionFilter(const FilterParameters& parameters)
  : params_(validated(parameters)), model_(params_.low_speed_regularisation, params_.max_integration_step)
{
  Model::Noise steady;
  steady.tangential_jerk = params_.model_covariance;
  steady.turn_acceleration = params_.turn_rate_covariance;
  steady.acceleration = params_.velocity_covariance;
  steady.height_rate = params_.height_covariance;
  Model::Noise manoeuvre = steady;
  manoeuvre.tangential_jerk *= params_.manoeuvre_covariance_scale;
  manoeuvre.turn_acceleration *= params_.manoeuvre_covariance_scale;
  manoeuvre.acceleration *= params_.manoeuvre_covariance_scale;
  noise_density_ = { Model::noiseDensity(steady), Model::noiseDensity(manoeuvre) };
  reset();
}

void PadMotionFilter::reset()
{
  initialised_ = false;
  last_vision_accepted_time_ = kNever;
  last_stamp_ = { kNever, kNever };
  consecutive_rejections_ = { 0, 0 };
}

bool PadMotionFilter::isTracking(double now) const
{
  return initialised_ && now - last_accepted_time_ <= params_.max_coast_time;
}

MeasurementOutcome PadMotionFilter::addVision(double stamp, const Eigen::Vector3d& position)
{
  Eigen::Matrix<double, 3, Model::kSize> H = Eigen::Matrix<double, 3, Model::kSize>::Zero();
  H(0, Model::kPx) = H(1, Model::kPy) = H(2, Model::kPz) = 1.0;
  return addFix<3>(Source::kVision, stamp, position, H, params_.observation_covariance);
}

MeasurementOutcome PadMotionFilter::addGps(double stamp, const Eigen::Vector2d& position_xy)
{
  Eigen::Matrix<double, 2, Model::kSize> H = Eigen::Matrix<double, 2, Model::kSize>::Zero();
  H(0, Model::kPx) = H(1, Model::kPy) = 1.0;
  return addFix<2>(Source::kGps, stamp, position_xy, H, params_.gps_observation_covariance);
}

template <int M>
MeasurementOutcome PadMotionFilter::addFix(Source source, double stamp, const Eigen::Matrix<double, M, 1>& z,
                                           const Eigen::Matrix<double, M, Model::kSize>& H, double variance)
{
  using MeasurementMatrix = Eigen::Matrix<double, M, M>;
  using MeasurementVector = Eigen::Matrix<double, M, 1>;
  const int s = static_cast<int>(source);
  if (!std::isfinite(stamp) || !z.allFinite())
    return MeasurementOutcome::kDroppedInvalid;
  if (stamp <= last_stamp_[s] || (initialised_ && stamp <= state_time_))
    return MeasurementOutcome::kDroppedStale;
  last_stamp_[s] = stamp;
  if (source == Source::kGps && stamp - last_vision_accepted_time_ < params_.gps_vision_timeout)
    return MeasurementOutcome::kIgnored;

  // Starts a track on this fix. A GPS fix says nothing about the height: keep the estimate, or assume
  // the configured pad height.
  const auto start_track_here = [&](MeasurementOutcome outcome, const Model::Vector* predicted) {
    Eigen::Vector3d position;
    double height_variance = variance;
    if constexpr (M == 3)
    {
      position = z;
    }
    else
    {
      const bool keep_height = predicted != nullptr;
      position << z(0), z(1), keep_height ? (*predicted)(Model::kPz) : params_.gps_pad_height;
      height_variance = params_.initial_gps_height_std * params_.initial_gps_height_std;
    }
    // After a restart the old velocity is still the best guess (the platform moved, it did not stop).
    const Eigen::Vector2d velocity =
        predicted != nullptr ? Eigen::Vector2d(predicted->segment<2>(Model::kVx)) : Eigen::Vector2d::Zero();
    startTrack(source, stamp, position, variance, height_variance, velocity);
    return outcome;
  };

  if (!isTracking(stamp))
    return start_track_here(MeasurementOutcome::kInitialised, nullptr);

  ModePrediction predicted = predictModes(stamp);
  const MeasurementMatrix R = MeasurementMatrix::Identity() * variance;
  std::array<MeasurementVector, kModes> innovation;
  std::array<MeasurementMatrix, kModes> S;
  std::array<double, kModes> mahalanobis_squared, log_likelihood;
  for (int j = 0; j < kModes; ++j)
  {
    innovation[j] = z - H * predicted.x[j];
    S[j] = H * predicted.P[j] * H.transpose() + R;
    const Eigen::LDLT<MeasurementMatrix> S_ldlt(S[j]);
    mahalanobis_squared[j] = innovation[j].dot(S_ldlt.solve(innovation[j]));
    log_likelihood[j] = -0.5 * (mahalanobis_squared[j] + std::log(S_ldlt.vectorD().prod()) + M * std::log(2.0 * M_PI));
  }

  // An outlier is a fix that no mode explains.
  if (!(*std::min_element(mahalanobis_squared.begin(), mahalanobis_squared.end()) <= params_.gate_threshold))
  {
    if (++consecutive_rejections_[s] < params_.max_consecutive_rejections)
      return MeasurementOutcome::kRejected;
    Model::Vector mean;
    Model::Matrix covariance;
    combine(predicted.x, predicted.P, predicted.probabilities, mean, covariance);
    return start_track_here(MeasurementOutcome::kReinitialised, &mean);
  }

  for (int j = 0; j < kModes; ++j)
  {
    const Model::Matrix& P = predicted.P[j];
    const Eigen::LDLT<MeasurementMatrix> S_ldlt(S[j]);
    // K = P H^T S^-1 = (S^-1 H P)^T, P and S being symmetric.
    const Eigen::Matrix<double, Model::kSize, M> K = S_ldlt.solve(H * P).transpose();
    // Joseph form: stays symmetric positive definite despite rounding.
    const Model::Matrix I_KH = Model::Matrix::Identity() - K * H;
    const Model::Matrix P_updated = I_KH * P * I_KH.transpose() + K * R * K.transpose();
    x_[j] = predicted.x[j] + K * innovation[j];
    P_[j] = 0.5 * (P_updated + P_updated.transpose());
  }
  // Mode probabilities: prior c_j times likelihood, normalised in the log domain (no underflow).
  const double max_log = std::max(log_likelihood[0], log_likelihood[1]);
  for (int j = 0; j < kModes; ++j)
    mode_probabilities_[j] = predicted.probabilities[j] * std::exp(log_likelihood[j] - max_log);
  mode_probabilities_ /= mode_probabilities_.sum();

  state_time_ = stamp;
  last_accepted_time_ = stamp;
  if (source == Source::kVision)
    last_vision_accepted_time_ = stamp;
  consecutive_rejections_[s] = 0;
  return MeasurementOutcome::kAccepted;
}

void PadMotionFilter::startTrack(Source source, double stamp, const Eigen::Vector3d& position,
                                 double position_variance, double height_variance, const Eigen::Vector2d& velocity)
{
  Model::Vector x = Model::Vector::Zero();
  x.segment<3>(Model::kPx) = position;
  x.segment<2>(Model::kVx) = velocity;
  Model::Matrix P = Model::Matrix::Zero();
  P(Model::kPx, Model::kPx) = P(Model::kPy, Model::kPy) = position_variance;
  P(Model::kPz, Model::kPz) = height_variance;
  P(Model::kVx, Model::kVx) = P(Model::kVy, Model::kVy) = params_.initial_velocity_std * params_.initial_velocity_std;
  P(Model::kAt, Model::kAt) = params_.initial_acceleration_std * params_.initial_acceleration_std;
  P(Model::kOmega, Model::kOmega) = params_.initial_turn_rate_std * params_.initial_turn_rate_std;
  x_ = { x, x };
  P_ = { P, P };
  // A new track is converging, which is what the manoeuvre mode describes best.
  mode_probabilities_ << 0.5, 0.5;
  initialised_ = true;
  state_time_ = stamp;
  last_accepted_time_ = stamp;
  if (source == Source::kVision)
    last_vision_accepted_time_ = stamp;
  consecutive_rejections_ = { 0, 0 };
}

PadMotionFilter::ModePrediction PadMotionFilter::predictModes(double time) const
{
  const double dt = std::max(0.0, time - state_time_);
  // Continuous-time Markov chain of the modes: P(switch within dt) = 1 - exp(-dt / mean duration).
  const double leave_steady = 1.0 - std::exp(-dt / params_.steady_mode_duration);
  const double leave_manoeuvre = 1.0 - std::exp(-dt / params_.manoeuvre_mode_duration);
  Eigen::Matrix2d transition;  // transition(i, j) = P(mode j at `time` | mode i at state time)
  transition << 1.0 - leave_steady, leave_steady, leave_manoeuvre, 1.0 - leave_manoeuvre;

  ModePrediction prediction;
  prediction.probabilities = transition.transpose() * mode_probabilities_;
  for (int j = 0; j < kModes; ++j)
  {
    // IMM interaction: each mode starts from the mixture of the modes it may have come from.
    Eigen::Vector2d mixing_weights;
    for (int i = 0; i < kModes; ++i)
      mixing_weights[i] = transition(i, j) * mode_probabilities_[i];
    mixing_weights /= mixing_weights.sum();
    combine(x_, P_, mixing_weights, prediction.x[j], prediction.P[j]);
    model_.propagate(prediction.x[j], prediction.P[j], noise_density_[j], dt);
  }
  return prediction;
}

void PadMotionFilter::combine(const std::array<Model::Vector, kModes>& x, const std::array<Model::Matrix, kModes>& P,
                              const Eigen::Vector2d& weights, Model::Vector& x_out, Model::Matrix& P_out)
{
  x_out = weights[0] * x[0] + weights[1] * x[1];
  P_out.setZero();
  for (int i = 0; i < kModes; ++i)
  {
    const Model::Vector spread = x[i] - x_out;
    P_out += weights[i] * (P[i] + spread * spread.transpose());
  }
}

PadMotionFilter::Model::Vector PadMotionFilter::combinedMean() const
{
  return mode_probabilities_[0] * x_[0] + mode_probabilities_[1] * x_[1];
}

std::optional<PadState> PadMotionFilter::stateAt(double time) const
{
  if (!initialised_)
    return std::nullopt;
  Model::Vector x;
  Model::Matrix P;
  double manoeuvre_probability;
  if (time >= state_time_)
  {
    const ModePrediction predicted = predictModes(time);
    combine(predicted.x, predicted.P, predicted.probabilities, x, P);
    manoeuvre_probability = predicted.probabilities[1];
  }
  else
  {
    combine(x_, P_, mode_probabilities_, x, P);
    model_.propagateMean(x, time - state_time_);
    manoeuvre_probability = mode_probabilities_[1];
  }

  PadState state;
  state.time = time;
  state.position = x.segment<3>(Model::kPx);
  state.velocity << x(Model::kVx), x(Model::kVy), 0.0;
  state.position_covariance = P.block<3, 3>(Model::kPx, Model::kPx);
  state.velocity_covariance = P.block<2, 2>(Model::kVx, Model::kVx);
  state.tangential_acceleration = x(Model::kAt);
  state.turn_rate = x(Model::kOmega);
  state.turn_rate_variance = P(Model::kOmega, Model::kOmega);
  state.manoeuvre_probability = manoeuvre_probability;
  return state;
}

std::vector<PathPoint> PadMotionFilter::predictPath(double t0, double time_step, double path_time) const
{
  if (!isPositiveFinite(time_step) || !isNonNegativeFinite(path_time) || !std::isfinite(t0))
    throw std::invalid_argument("predictPath needs a finite t0, time_step > 0 and path_time >= 0 [s]");
  std::vector<PathPoint> path;
  if (!initialised_)
    return path;
  const int last = static_cast<int>(std::lround(path_time / time_step));
  path.reserve(last + 1);
  Model::Vector x = combinedMean();
  model_.propagateMean(x, t0 - state_time_);
  for (int k = 0; k <= last; ++k)
  {
    if (k > 0)
      model_.propagateMean(x, time_step);
    PathPoint point;
    point.time = t0 + k * time_step;
    point.position = x.segment<3>(Model::kPx);
    point.velocity << x(Model::kVx), x(Model::kVy), 0.0;
    path.push_back(point);
  }
  return path;
}

}  // namespace ped_traj_pred
