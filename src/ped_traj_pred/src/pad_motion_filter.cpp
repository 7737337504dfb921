#include "ped_traj_pred/pad_motion_filter.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <utility>

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

using Model = TurnAccelerationModel;
using MeasurementRow = Eigen::Matrix<double, 1, Model::kSize>;

/// Kalman update of one mode by a scalar measurement: row `H`, `innovation` (measured minus predicted),
/// variance `R`, Joseph form. Returns the innovation variance S.
double scalarUpdate(Model::Form form, Model::Vector& x, Model::Matrix& P, const MeasurementRow& H,
                    double innovation, double R)
{
  const double S = (H * P * H.transpose())(0, 0) + R;
  const Model::Vector K = P * H.transpose() / S;
  const Model::Matrix I_KH = Model::Matrix::Identity() - K * H;
  const Model::Matrix P_updated = I_KH * P * I_KH.transpose() + K * R * K.transpose();
  x += K * innovation;
  Model::normalise(form, x);
  P = 0.5 * (P_updated + P_updated.transpose());
  return S;
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
    { "manoeuvre_acceleration_covariance", manoeuvre_acceleration_covariance, false, "m^2/s^3" },
    { "steady_mode_duration", steady_mode_duration, false, "s" },
    { "manoeuvre_mode_duration", manoeuvre_mode_duration, false, "s" },
    { "onset_window", onset_window, true, "s" },
    { "onset_acceleration_std", onset_acceleration_std, false, "m/s^2" },
    { "onset_threshold", onset_threshold, true, "-" },
    { "stop_threshold", stop_threshold, true, "-" },
    { "observation_covariance", observation_covariance, false, "m^2" },
    { "observation_std_floor", observation_std_floor, false, "m" },
    { "observation_std_per_metre", observation_std_per_metre, true, "m/m" },
    { "gps_observation_covariance", gps_observation_covariance, false, "m^2" },
    { "gps_offset_initial_std", gps_offset_initial_std, true, "m" },
    { "gps_offset_drift", gps_offset_drift, true, "m/sqrt(s)" },
    { "gps_vision_timeout", gps_vision_timeout, true, "s" },
    { "initial_gps_height_std", initial_gps_height_std, false, "m" },
    { "max_coast_time", max_coast_time, false, "s" },
    { "gate_threshold", gate_threshold, false, "-" },
    { "initial_velocity_std", initial_velocity_std, false, "m/s" },
    { "initial_acceleration_std", initial_acceleration_std, false, "m/s^2" },
    { "initial_turn_rate_std", initial_turn_rate_std, false, "rad/s" },
    { "heading_acquisition_std", heading_acquisition_std, false, "rad" },
    { "heading_loss_std", heading_loss_std, false, "rad" },
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
  if (!(heading_loss_std > heading_acquisition_std))
    return "heading_loss_std must be > heading_acquisition_std [rad] (hysteresis), got " +
           std::to_string(heading_loss_std) + " <= " + std::to_string(heading_acquisition_std);
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
  steady.jerk = params_.model_covariance;
  steady.turn_acceleration = params_.turn_rate_covariance;
  steady.acceleration = steady.cross_acceleration = params_.velocity_covariance;
  steady.height_rate = params_.height_covariance;
  Model::Noise manoeuvre = steady;
  manoeuvre.jerk *= params_.manoeuvre_covariance_scale;
  manoeuvre.turn_acceleration *= params_.manoeuvre_covariance_scale;
  // Along the heading only: across it, this much noise would wipe out the heading of a vehicle at rest.
  manoeuvre.acceleration = params_.manoeuvre_acceleration_covariance;
  noise_ = { steady, manoeuvre };
  reset();
}

void PadMotionFilter::reset()
{
  initialised_ = false;
  onsets_.clear();
  last_vision_accepted_time_ = kNever;
  last_stamp_ = { kNever, kNever };
  consecutive_rejections_ = { 0, 0 };
  gps_offset_.setZero();
  gps_offset_variance_ = params_.gps_offset_initial_std * params_.gps_offset_initial_std;
  gps_offset_time_ = kNever;
}

bool PadMotionFilter::isTracking(double now) const
{
  return initialised_ && now - last_accepted_time_ <= params_.max_coast_time;
}

MeasurementOutcome PadMotionFilter::addVision(double stamp, const Eigen::Vector3d& position, double variance)
{
  if (initialised_ && std::isfinite(stamp) && !(stamp - last_vision_accepted_time_ < params_.gps_vision_timeout))
  {
    // The camera is back on a track that GPS held: the offset taken off the GPS fixes is one error shared by
    // all of them, not noise that averaged out, so the track is no surer of where the pad is than of the
    // offset (else the camera's first fixes would be outliers until ten in a row restarted the track).
    for (int j = 0; j < kModes; ++j)
      for (const int i : { Model::kPx, Model::kPy })
        P_[j](i, i) += gps_offset_variance_;
  }
  Eigen::Matrix<double, 3, Model::kSize> H = Eigen::Matrix<double, 3, Model::kSize>::Zero();
  H(0, Model::kPx) = H(1, Model::kPy) = H(2, Model::kPz) = 1.0;
  const bool given = std::isfinite(variance) && variance > 0.0;
  return addFix<3>(Source::kVision, stamp, position, H, given ? variance : params_.observation_covariance);
}

double FilterParameters::visionVariance(double range) const
{
  const double scaled = observation_std_per_metre * std::abs(range);
  return observation_std_floor * observation_std_floor + scaled * scaled;
}

MeasurementOutcome PadMotionFilter::addGps(double stamp, const Eigen::Vector2d& position_xy,
                                           const std::optional<Eigen::Vector2d>& velocity, double velocity_variance)
{
  Eigen::Matrix<double, 2, Model::kSize> H = Eigen::Matrix<double, 2, Model::kSize>::Zero();
  H(0, Model::kPx) = H(1, Model::kPy) = 1.0;
  std::optional<StartVelocity> start_velocity;
  if (velocity && velocity->allFinite() && isPositiveFinite(velocity_variance))
    start_velocity = StartVelocity{ *velocity, velocity_variance };
  if (std::isfinite(stamp) && position_xy.allFinite())
    learnGpsOffset(stamp, position_xy);
  return addFix<2>(Source::kGps, stamp, position_xy - gps_offset_, H,
                   params_.gps_observation_covariance + gps_offset_variance_, start_velocity);
}

void PadMotionFilter::learnGpsOffset(double stamp, const Eigen::Vector2d& position_xy)
{
  if (gps_offset_time_ > kNever && stamp > gps_offset_time_)
    gps_offset_variance_ += params_.gps_offset_drift * params_.gps_offset_drift * (stamp - gps_offset_time_);
  gps_offset_time_ = std::max(gps_offset_time_, stamp);
  gps_offset_variance_ = std::min(gps_offset_variance_, params_.gps_offset_initial_std * params_.gps_offset_initial_std);
  // Only against a track that vision holds now: the fix is then not needed for the track itself.
  if (!initialised_ || !(stamp - last_vision_accepted_time_ < params_.gps_vision_timeout))
    return;
  const std::optional<PadState> track = stateAt(stamp);
  if (!track)
    return;
  const Eigen::Vector2d observed = position_xy - track->position.head<2>();
  const double noise = params_.gps_observation_covariance + 0.5 * track->position_covariance.topLeftCorner<2, 2>().trace();
  const double gain = gps_offset_variance_ / (gps_offset_variance_ + noise);
  gps_offset_ += gain * (observed - gps_offset_);
  gps_offset_variance_ *= 1.0 - gain;
}

MeasurementOutcome PadMotionFilter::addHeading(double stamp, double heading, double variance)
{
  if (!std::isfinite(stamp) || !std::isfinite(heading) || !isPositiveFinite(variance))
    return MeasurementOutcome::kDroppedInvalid;
  if (!isTracking(stamp))
    return MeasurementOutcome::kIgnored;
  const double age = state_time_ - stamp;  // < 0: newer than the last fix, still close to it
  if (age > kMaxHeadingAge)
    return MeasurementOutcome::kDroppedStale;
  if (form_ == Model::Form::kCartesian)
  {
    Model::Vector x;
    Model::Matrix P;
    combine(x_, P_, mode_probabilities_, x, P);
    if (!(Model::velocity(form_, x).norm() > kHeadingMinSpeed))
      return MeasurementOutcome::kIgnored;
    enterPolarForm(x, P, heading);
  }
  Model::Matrix flip = Model::Matrix::Identity();
  flip(Model::kSpeed, Model::kSpeed) = flip(Model::kAcceleration, Model::kAcceleration) =
      flip(Model::kCurvature, Model::kCurvature) = -1.0;
  MeasurementRow H = MeasurementRow::Zero();
  H(0, Model::kHeading) = 1.0;
  for (int j = 0; j < kModes; ++j)
  {
    Model::Vector& x = x_[j];
    Model::Matrix& P = P_[j];
    // The heading at `stamp`: the state's, turned back by the turn rate over the age.
    const double turn_rate = x(Model::kSpeed) * x(Model::kCurvature);
    double innovation = Model::wrapAngle(heading - (x(Model::kHeading) - turn_rate * age));
    if (std::abs(innovation) > M_PI_2)
    {
      x(Model::kHeading) += M_PI;
      x = flip * x;
      P = flip * P * flip.transpose();
      innovation = Model::wrapAngle(innovation - M_PI);
      onsets_.clear();  // their sensitivities are in the old representation
    }
    const double turn_rate_variance = model_.turnRateVariance(form_, x, P);
    scalarUpdate(form_, x, P, H, innovation, variance + turn_rate_variance * age * age);
  }
  updateForm();
  return MeasurementOutcome::kAccepted;
}

MeasurementOutcome PadMotionFilter::addTurnRate(double stamp, double turn_rate, double variance)
{
  if (!std::isfinite(stamp) || !std::isfinite(turn_rate) || !isPositiveFinite(variance))
    return MeasurementOutcome::kDroppedInvalid;
  const double age = state_time_ - stamp;
  const MeasurementOutcome usable = vehicleMeasurementUsable(stamp, age, kHeadingMinSpeed);
  if (usable != MeasurementOutcome::kAccepted)
    return usable;
  // h(x) = s * kappa, linearised: dh/ds = kappa, dh/dkappa = s.
  modeWeightedUpdate(variance + std::pow(kYawAccelerationStd * age, 2), [&](const Model::Vector& x) {
    MeasurementRow H = MeasurementRow::Zero();
    H(0, Model::kSpeed) = x(Model::kCurvature);
    H(0, Model::kCurvature) = x(Model::kSpeed);
    return std::make_pair(H, turn_rate - x(Model::kSpeed) * x(Model::kCurvature));
  });
  return MeasurementOutcome::kAccepted;
}

MeasurementOutcome PadMotionFilter::addSpeed(double stamp, const Eigen::Vector2d& velocity_xy, double variance)
{
  if (!std::isfinite(stamp) || !velocity_xy.allFinite() || !isPositiveFinite(variance))
    return MeasurementOutcome::kDroppedInvalid;
  const double age = state_time_ - stamp;
  // At any speed: a vehicle pulling away from rest (or not stopping there) is what it is most needed for.
  const MeasurementOutcome usable = vehicleMeasurementUsable(stamp, age, 0.0);
  if (usable != MeasurementOutcome::kAccepted)
    return usable;
  // The speed along the heading at `stamp` (negative when reversing): h(x) = s - a * age. The velocity's
  // component across the heading is what addHeading and addTurnRate are for.
  modeWeightedUpdate(variance + std::pow(kSpeedJerkStd * age * age, 2), [&](const Model::Vector& x) {
    MeasurementRow H = MeasurementRow::Zero();
    H(0, Model::kSpeed) = 1.0;
    H(0, Model::kAcceleration) = -age;
    const Eigen::Vector2d heading(std::cos(x(Model::kHeading)), std::sin(x(Model::kHeading)));
    return std::make_pair(H, velocity_xy.dot(heading) - (x(Model::kSpeed) - x(Model::kAcceleration) * age));
  });
  return MeasurementOutcome::kAccepted;
}

MeasurementOutcome PadMotionFilter::vehicleMeasurementUsable(double stamp, double age, double min_speed) const
{
  if (!isTracking(stamp) || form_ != Model::Form::kPolar)
    return MeasurementOutcome::kIgnored;
  if (age > kMaxHeadingAge)
    return MeasurementOutcome::kDroppedStale;
  Model::Vector combined;
  Model::Matrix combined_P;
  combine(x_, P_, mode_probabilities_, combined, combined_P);
  if (!(std::abs(combined(Model::kSpeed)) >= min_speed))
    return MeasurementOutcome::kIgnored;
  return MeasurementOutcome::kAccepted;
}

template <class Linearise>
void PadMotionFilter::modeWeightedUpdate(double R, Linearise linearise)
{
  std::array<double, kModes> log_likelihood;
  for (int j = 0; j < kModes; ++j)
  {
    const auto [H, innovation] = linearise(x_[j]);
    const double S = scalarUpdate(form_, x_[j], P_[j], H, innovation, R);
    log_likelihood[j] = -0.5 * (innovation * innovation / S + std::log(2.0 * M_PI * S));
  }
  // A measurement the steady mode cannot explain moves the weight to the manoeuvre mode, which follows it.
  const double max_log = std::max(log_likelihood[0], log_likelihood[1]);
  for (int j = 0; j < kModes; ++j)
    mode_probabilities_[j] *= std::exp(log_likelihood[j] - max_log);
  mode_probabilities_ /= mode_probabilities_.sum();
  updateForm();
}

template <int M>
MeasurementOutcome PadMotionFilter::addFix(Source source, double stamp, const Eigen::Matrix<double, M, 1>& z,
                                           const Eigen::Matrix<double, M, Model::kSize>& H, double variance,
                                           const std::optional<StartVelocity>& start_velocity)
{
  using MeasurementMatrix = Eigen::Matrix<double, M, M>;
  using MeasurementVector = Eigen::Matrix<double, M, 1>;
  const int s = static_cast<int>(source);
  if (!std::isfinite(stamp) || !z.allFinite())
    return MeasurementOutcome::kDroppedInvalid;
  if (stamp <= last_stamp_[s])
    return MeasurementOutcome::kDroppedStale;
  last_stamp_[s] = stamp;
  // Checked before the state's time: a GPS fix stamped with the same instant as a vision fix (the
  // simulator publishes both on the same step) is not stale, just not needed.
  if (source == Source::kGps && stamp - last_vision_accepted_time_ < params_.gps_vision_timeout)
    return MeasurementOutcome::kIgnored;
  if (initialised_ && stamp <= state_time_)
    return MeasurementOutcome::kDroppedStale;

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
    // A reported velocity is the best start; after a restart the old velocity is still a good guess
    // (the platform moved, it did not stop), but as uncertain as none.
    StartVelocity velocity{ Eigen::Vector2d::Zero(), params_.initial_velocity_std * params_.initial_velocity_std };
    if (start_velocity)
      velocity = *start_velocity;
    else if (predicted != nullptr)
      velocity.velocity = Model::velocity(form_, *predicted);
    startTrack(source, stamp, position, variance, height_variance, velocity);
    return outcome;
  };

  if (!isTracking(stamp))
    return start_track_here(MeasurementOutcome::kInitialised, nullptr);

  ModePrediction predicted = predictModes(stamp, false);
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

  const double speed_before = mode_probabilities_.dot(Eigen::Vector2d(x_[0](Model::kSpeed), x_[1](Model::kSpeed)));
  std::array<Eigen::Matrix<double, Model::kSize, M>, kModes> K;
  for (int j = 0; j < kModes; ++j)
  {
    const Model::Matrix& P = predicted.P[j];
    const Eigen::LDLT<MeasurementMatrix> S_ldlt(S[j]);
    // K = P H^T S^-1 = (S^-1 H P)^T, P and S being symmetric.
    K[j] = S_ldlt.solve(H * P).transpose();
    // Joseph form: stays symmetric positive definite despite rounding.
    const Model::Matrix I_KH = Model::Matrix::Identity() - K[j] * H;
    const Model::Matrix P_updated = I_KH * P * I_KH.transpose() + K[j] * R * K[j].transpose();
    x_[j] = predicted.x[j] + K[j] * innovation[j];
    Model::normalise(form_, x_[j]);
    P_[j] = 0.5 * (P_updated + P_updated.transpose());
  }
  trackOnsets<M>(stamp, predicted, H, innovation, S, K);
  if (form_ == Model::Form::kPolar)
  {
    // A braking vehicle's speed crossed zero: it may have stopped there rather than be reversing.
    const Eigen::Vector2d& c = predicted.probabilities;
    const double speed = c.dot(Eigen::Vector2d(x_[0](Model::kSpeed), x_[1](Model::kSpeed)));
    const double acceleration = c.dot(Eigen::Vector2d(x_[0](Model::kAcceleration), x_[1](Model::kAcceleration)));
    if (speed_before * speed < 0.0 && speed * acceleration > 0.0)
    {
      OnsetMatrix directions = OnsetMatrix::Zero();
      directions(Model::kSpeed, 0) = directions(Model::kAcceleration, 1) = 1.0;
      openOnset(stamp, directions, Eigen::Vector2d(-speed, -acceleration));
    }
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
  applyOnset();
  updateForm();
  return MeasurementOutcome::kAccepted;
}

void PadMotionFilter::startTrack(Source source, double stamp, const Eigen::Vector3d& position,
                                 double position_variance, double height_variance, const StartVelocity& velocity)
{
  Model::Vector x = Model::Vector::Zero();
  x.segment<3>(Model::kPx) = position;
  x.segment<2>(Model::kVx) = velocity.velocity;
  Model::Matrix P = Model::Matrix::Zero();
  P(Model::kPx, Model::kPx) = P(Model::kPy, Model::kPy) = position_variance;
  P(Model::kPz, Model::kPz) = height_variance;
  P(Model::kVx, Model::kVx) = P(Model::kVy, Model::kVy) = velocity.variance;
  const double acceleration_variance = params_.initial_acceleration_std * params_.initial_acceleration_std;
  P(Model::kAx, Model::kAx) = P(Model::kAy, Model::kAy) = acceleration_variance;
  form_ = Model::Form::kCartesian;
  onsets_.clear();
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
  updateForm();
}

void PadMotionFilter::enterPolarForm(const Model::Vector& combined, const Model::Matrix& combined_covariance,
                                     double heading)
{
  // Each mode keeps its own velocity, on the side of `heading` (its direction or the opposite).
  for (int j = 0; j < kModes; ++j)
  {
    if (!(Model::velocity(form_, x_[j]).norm() > 0.0))  // degenerate mode: take the combined one
    {
      x_[j] = combined;
      P_[j] = combined_covariance;
    }
    Model::toPolar(x_[j], P_[j], heading, params_.initial_turn_rate_std);
  }
  form_ = Model::Form::kPolar;
  onsets_.clear();
}

void PadMotionFilter::updateForm()
{
  Model::Vector x;
  Model::Matrix P;
  combine(x_, P_, mode_probabilities_, x, P);
  const double heading_std = Model::headingStd(form_, x, P);
  if (form_ == Model::Form::kCartesian && heading_std <= params_.heading_acquisition_std)
  {
    const Eigen::Vector2d v = Model::velocity(form_, x);
    enterPolarForm(x, P, std::atan2(v.y(), v.x()));
  }
  else if (form_ == Model::Form::kPolar && !(heading_std <= params_.heading_loss_std))
  {
    for (int j = 0; j < kModes; ++j)
      Model::toCartesian(x_[j], P_[j]);
    form_ = Model::Form::kCartesian;
    onsets_.clear();
  }
}

template <int M>
void PadMotionFilter::trackOnsets(double stamp, const ModePrediction& predicted,
                                  const Eigen::Matrix<double, M, Model::kSize>& H,
                                  const std::array<Eigen::Matrix<double, M, 1>, kModes>& innovation,
                                  const std::array<Eigen::Matrix<double, M, M>, kModes>& S,
                                  const std::array<Eigen::Matrix<double, Model::kSize, M>, kModes>& K)
{
  using MeasurementMatrix = Eigen::Matrix<double, M, M>;
  using MeasurementVector = Eigen::Matrix<double, M, 1>;
  using Signature = Eigen::Matrix<double, M, 2>;
  // The statistic uses the moment-matched innovation of the modes (their prior weights c_j).
  const Eigen::Vector2d& c = predicted.probabilities;
  MeasurementVector mean_innovation = MeasurementVector::Zero();
  for (int j = 0; j < kModes; ++j)
    mean_innovation += c[j] * innovation[j];
  MeasurementMatrix mean_S = MeasurementMatrix::Zero();
  for (int j = 0; j < kModes; ++j)
  {
    const MeasurementVector spread = innovation[j] - mean_innovation;
    mean_S += c[j] * (S[j] + spread * spread.transpose());
  }
  const Eigen::LDLT<MeasurementMatrix> S_ldlt(mean_S);

  onsets_.erase(std::remove_if(onsets_.begin(), onsets_.end(),
                               [&](const OnsetHypothesis& h) { return h.time < stamp - params_.onset_window; }),
                onsets_.end());
  for (OnsetHypothesis& h : onsets_)
  {
    // The truth moves by the model; each estimate is mixed, predicted, then corrected by its gain.
    h.truth = predicted.transition[0] * h.truth;
    std::array<OnsetMatrix, kModes> estimate;
    Signature signature = Signature::Zero();
    for (int j = 0; j < kModes; ++j)
    {
      estimate[j] = predicted.transition[j] *
                    (predicted.mixing(0, j) * h.estimate[0] + predicted.mixing(1, j) * h.estimate[1]);
      const Signature mode_signature = H * (h.truth - estimate[j]);
      signature += c[j] * mode_signature;
      estimate[j] += K[j] * mode_signature;
    }
    h.estimate = estimate;
    const Eigen::Matrix<double, M, 2> weighted = S_ldlt.solve(signature);
    h.information += signature.transpose() * weighted;
    h.score += weighted.transpose() * mean_innovation;
  }

  OnsetMatrix directions = OnsetMatrix::Zero();
  if (form_ == Model::Form::kPolar)
  {
    // Per m/s^2 across the velocity: a curvature step of 1 / s^2, the same acceleration turning a fast
    // vehicle far less. Below the speed at which a step of onset_acceleration_std would change the turn
    // rate by more than initial_turn_rate_std, the turn-rate step is what is bounded: slow vehicles do not
    // spin up at 1 m/s^2 / s.
    const double speed =
        std::abs(mode_probabilities_.dot(Eigen::Vector2d(x_[0](Model::kSpeed), x_[1](Model::kSpeed))));
    const double slow = params_.onset_acceleration_std / params_.initial_turn_rate_std;
    directions(Model::kAcceleration, 0) = 1.0;
    directions(Model::kCurvature, 1) =
        1.0 / (std::max(speed, params_.low_speed_regularisation) * std::max(speed, slow));
  }
  else
  {
    directions(Model::kAx, 0) = directions(Model::kAy, 1) = 1.0;
  }
  openOnset(stamp, directions, std::nullopt);
}

void PadMotionFilter::openOnset(double stamp, const OnsetMatrix& directions,
                                const std::optional<Eigen::Vector2d>& known_step)
{
  OnsetHypothesis opened;
  opened.time = stamp;
  opened.truth = directions;
  opened.estimate = { OnsetMatrix::Zero(), OnsetMatrix::Zero() };
  opened.known_step = known_step;
  onsets_.push_back(opened);
}

void PadMotionFilter::applyOnset()
{
  // A stop: the step is known, so the log-likelihood ratio against no step is d^T step - 0.5 step^T J step.
  const OnsetHypothesis* stop = nullptr;
  double stop_ratio = params_.stop_threshold;
  for (const OnsetHypothesis& h : onsets_)
  {
    if (!h.known_step)
      continue;
    const Eigen::Vector2d& step = *h.known_step;
    const double ratio = h.score.dot(step) - 0.5 * step.dot(h.information * step);
    if (ratio > stop_ratio)
    {
      stop_ratio = ratio;
      stop = &h;
    }
  }
  if (stop != nullptr)
  {
    for (int j = 0; j < kModes; ++j)
    {
      x_[j] += (stop->truth - stop->estimate[j]) * *stop->known_step;
      Model::normalise(form_, x_[j]);
    }
    // Standing still is no manoeuvre: back to the modes' long-run odds.
    mode_probabilities_ << params_.steady_mode_duration, params_.manoeuvre_mode_duration;
    mode_probabilities_ /= mode_probabilities_.sum();
    onsets_.clear();
    return;
  }

  // An onset: a step ~ N(0, sigma^2 I) in the selected components. Marginal log-likelihood ratio against
  // no step: 0.5 d^T A^-1 d - 0.5 log det(I + sigma^2 J), A = J + I / sigma^2; the step's posterior is
  // N(A^-1 d, A^-1). A step along the velocity alone, across it alone, or both (which pays for its extra
  // freedom in the determinant).
  const double prior_variance = params_.onset_acceleration_std * params_.onset_acceleration_std;
  const OnsetHypothesis* best = nullptr;
  double best_ratio = params_.onset_threshold;
  Eigen::Vector2d best_step;
  Eigen::Matrix2d best_covariance;
  for (const OnsetHypothesis& h : onsets_)
  {
    if (h.known_step)
      continue;
    for (int selection = 0; selection < 3; ++selection)
    {
      Eigen::Vector2d step = Eigen::Vector2d::Zero();
      Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
      double ratio;
      if (selection < 2)
      {
        const int i = selection;
        const double A = h.information(i, i) + 1.0 / prior_variance;
        ratio = 0.5 * h.score(i) * h.score(i) / A - 0.5 * std::log(1.0 + prior_variance * h.information(i, i));
        step(i) = h.score(i) / A;
        covariance(i, i) = 1.0 / A;
      }
      else
      {
        covariance = (h.information + Eigen::Matrix2d::Identity() / prior_variance).inverse();
        step = covariance * h.score;
        ratio = 0.5 * h.score.dot(step) -
                0.5 * std::log((Eigen::Matrix2d::Identity() + prior_variance * h.information).determinant());
      }
      if (ratio > best_ratio)
      {
        best_ratio = ratio;
        best = &h;
        best_step = step;
        best_covariance = covariance;
      }
    }
  }
  if (best == nullptr)
    return;
  // Each mode's error is (truth - estimate) * step.
  for (int j = 0; j < kModes; ++j)
  {
    const OnsetMatrix error = best->truth - best->estimate[j];
    x_[j] += error * best_step;
    Model::normalise(form_, x_[j]);
    P_[j] += error * best_covariance * error.transpose();
    P_[j] = 0.5 * (P_[j] + P_[j].transpose());
  }
  // The fixes since the onset now explain the state: the other hypotheses are void.
  onsets_.clear();
}

PadMotionFilter::ModePrediction PadMotionFilter::predictModes(double time, bool for_output) const
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
    prediction.mixing.col(j) = mixing_weights;
    combine(x_, P_, mixing_weights, prediction.x[j], prediction.P[j]);
    model_.propagate(form_, prediction.x[j], prediction.P[j], noise_[j], dt, for_output, &prediction.transition[j]);
  }
  return prediction;
}

void PadMotionFilter::combine(const std::array<Model::Vector, kModes>& x, const std::array<Model::Matrix, kModes>& P,
                              const Eigen::Vector2d& weights, Model::Vector& x_out, Model::Matrix& P_out) const
{
  // Mean of the differences to mode 0, so that headings near +-pi average correctly.
  x_out = x[0];
  for (int i = 1; i < kModes; ++i)
    x_out += weights[i] * Model::difference(form_, x[i], x[0]);
  Model::normalise(form_, x_out);
  P_out.setZero();
  for (int i = 0; i < kModes; ++i)
  {
    const Model::Vector spread = Model::difference(form_, x[i], x_out);
    P_out += weights[i] * (P[i] + spread * spread.transpose());
  }
}

void PadMotionFilter::combinedAt(double time, Model::Vector& x, Model::Matrix& P, double& manoeuvre_probability) const
{
  if (time >= state_time_)
  {
    const ModePrediction predicted = predictModes(time, true);
    combine(predicted.x, predicted.P, predicted.probabilities, x, P);
    manoeuvre_probability = predicted.probabilities[1];
  }
  else
  {
    combine(x_, P_, mode_probabilities_, x, P);
    model_.propagateMean(form_, x, time - state_time_);
    manoeuvre_probability = mode_probabilities_[1];
  }
}

std::optional<PadState> PadMotionFilter::stateAt(double time) const
{
  if (!initialised_)
    return std::nullopt;
  Model::Vector x;
  Model::Matrix P;
  PadState state;
  combinedAt(time, x, P, state.manoeuvre_probability);
  state.time = time;
  state.position = x.segment<3>(Model::kPx);
  state.velocity << Model::velocity(form_, x), 0.0;
  state.position_covariance = P.block<3, 3>(Model::kPx, Model::kPx);
  state.velocity_covariance = Model::velocityCovariance(form_, x, P);
  state.tangential_acceleration = model_.tangentialAcceleration(form_, x);
  state.turn_rate = model_.turnRate(form_, x);
  state.turn_rate_variance = model_.turnRateVariance(form_, x, P);
  state.heading_known = form_ == Model::Form::kPolar;
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
  // Starts from the state that stateAt(t0) reports.
  Model::Vector x;
  Model::Matrix P;
  double manoeuvre_probability;
  combinedAt(t0, x, P, manoeuvre_probability);
  for (int k = 0; k <= last; ++k)
  {
    if (k > 0)
      model_.propagateMean(form_, x, time_step, true);
    PathPoint point;
    point.time = t0 + k * time_step;
    point.position = x.segment<3>(Model::kPx);
    point.velocity << Model::velocity(form_, x), 0.0;
    path.push_back(point);
  }
  return path;
}

}  // namespace ped_traj_pred
