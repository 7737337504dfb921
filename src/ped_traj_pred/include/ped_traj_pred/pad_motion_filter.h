// Tracks the landing pad in the world frame from noisy position fixes and predicts its path. ROS-free.
//
// Estimator: an interacting-multiple-model (IMM) filter of two extended Kalman filters sharing the model
// of a turn with tangential acceleration on a signed speed (turn_acceleration_model.h). They differ only
// in process noise: a "steady" mode (low noise: smooth, accurate predictions on lines and circles) and a
// "manoeuvre" mode (jerk and turn noise x manoeuvre_covariance_scale: follows changes of acceleration and
// turn rate). Why:
// - A circle, a straight line, a stop, a pull-away from rest and a reversal through zero speed are all
//   exact solutions of the model, so the prediction has no model bias there, unlike a constant-
//   acceleration KF (whose bias v*omega^2*T^3/6 is 4.5 cm on a 10 m circle at 3 m/s and 1 m for a car at
//   25 m/s on a 50 m circle) or a Cartesian-velocity turn model (whose tangential acceleration vanishes
//   at rest, so it lagged every pull-away and reversal by 0.4-0.5 s).
// - One noise level cannot serve both: low noise gives centimetre predictions in steady motion but
//   lags (and then gates out) 1-3 m/s^2 speed changes; high noise follows them but makes every
//   prediction noisy. The IMM weighs the two modes by how well each explains the fixes.
// - Both modes have the same state, so mixing needs no state augmentation (only the heading's
//   wrap-around), and the cost is two 7-state EKFs and the onset hypotheses below (tens of microseconds
//   per fix).
// - The heading is unknown when a track starts and unobservable at standstill, where the polar EKF
//   cannot recover from a wrong one. So a track starts with a Cartesian velocity and acceleration, and
//   takes the direction of its velocity as heading once that is known to heading_acquisition_std; a
//   heading that becomes more uncertain than heading_loss_std (e.g. after a long stop with turn noise)
//   is given up again for the Cartesian form.
// - Manoeuvre onsets: a vehicle that pulls away, brakes or turns in changes its acceleration at once, a
//   step the IMM only takes up over some 0.3-0.5 s. So every fix also opens the hypothesis "the
//   acceleration (along or across the velocity) stepped right after this fix"; the fixes of the last
//   onset_window accumulate, on the linearised filter, the evidence for each (a generalised likelihood
//   ratio test, Willsky and Jones 1976), and the most likely step is applied to every mode once its
//   log-likelihood ratio exceeds onset_threshold.
// - Stops: the filter integrates the exact model, under which a braking vehicle reverses through zero
//   speed (right for a reversal). Where its speed crosses zero, the hypothesis "it stopped there" (a
//   step of known size) is tested the same way against stop_threshold, and applied if it wins.
//   Predictions (stateAt ahead of the state, predictPath) end a braking at rest rather than reversing,
//   the usual outcome.
//
// Measurements: vision positions (x, y, z) and, optionally, GPS-like (x, y) fixes, each with its own
// variance, applied at their own timestamps. A fix not newer than the filter state or than the previous
// fix of its source is dropped. A fix that no mode explains (squared Mahalanobis distance above
// gate_threshold in every mode) is rejected; after max_consecutive_rejections in a row the track restarts
// on the latest fix (the platform really moved, e.g. during a long blackout). GPS is fused only when
// vision has been absent for gps_vision_timeout, less the GPS offset learnt while vision was there; a
// track that starts on a GPS fix starts from the vehicle's reported velocity if given. The heading the vehicle reports with its GPS (addHeading) holds
// the track's heading where vision cannot tell it (at low speed, through reversals); its yaw rate
// (addTurnRate) and velocity (addSpeed) give the turn rate and the speed. Without accepted
// fixes the filter coasts for max_coast_time, then reports the track lost; the next fix starts a new track.
#pragma once

#include "ped_traj_pred/turn_acceleration_model.h"

#include <Eigen/Dense>

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace ped_traj_pred
{
/// Tuning of PadMotionFilter. Units in brackets; validate() names the first invalid value.
/// The defaults are the tuned values of config/kalman.yaml.
struct FilterParameters
{
  // Process noise of the steady mode, as continuous-time white-noise intensities.
  double model_covariance = 1e-5;       ///< jerk, drives the tangential acceleration a [m^2/s^5]
  double turn_rate_covariance = 2e-6;  ///< turn-rate acceleration, drives omega [rad^2/s^3]
  /// Unmodelled acceleration on the horizontal velocity, along and across the heading, in both modes
  /// (across, it turns the heading; a large value would make a vehicle at rest forget its heading).
  double velocity_covariance = 1e-5;   ///< [m^2/s^3]
  double height_covariance = 1e-4;      ///< random walk of the pad height pz [m^2/s]
  // Manoeuvre mode and mode switching.
  double manoeuvre_covariance_scale = 5e4;  ///< manoeuvre-mode jerk and turn noise / steady-mode ones [-]
  /// Manoeuvre-mode white acceleration along the heading (on the whole velocity while the heading is
  /// unknown): lets the speed follow the first frames of a braking or a pull-away before a has.
  double manoeuvre_acceleration_covariance = 0.1;  ///< [m^2/s^3]
  double steady_mode_duration = 100.0;          ///< mean time before the steady mode ends [s]
  double manoeuvre_mode_duration = 4.0;       ///< mean time before a manoeuvre ends [s]
  // Manoeuvre onsets: a step in the acceleration, along or across the velocity, searched over the last
  // onset_window, with this prior std, applied when its log-likelihood ratio exceeds onset_threshold.
  double onset_window = 1.0;             ///< [s]
  double onset_acceleration_std = 0.8;   ///< [m/s^2]
  double onset_threshold = 8.0;          ///< [-]
  /// A braking vehicle whose speed crossed zero is taken as stopped there, rather than reversing, once
  /// the log-likelihood ratio of the two exceeds this (the filter itself assumes a reversal).
  double stop_threshold = 1.5;             ///< [-]
  // Measurement noise.
  double observation_covariance = 9e-4;      ///< vision position variance per axis when the range is unknown [m^2]
  // With the camera's range to the pad known, the vision std is sqrt(floor^2 + (per_metre * range)^2): pixel
  // noise grows with the range, the drone's own position jitter (in every world fix) does not.
  double observation_std_floor = 0.03;       ///< [m]
  double observation_std_per_metre = 0.0075; ///< [m/m]
  double gps_observation_covariance = 0.09;  ///< GPS position variance, per axis [m^2]
  /// A receiver's error drifts slowly (metres, over a minute), and the vision fixes carry the drone's own
  /// GPS error too: GPS and vision disagree by an offset that white noise does not describe. It is learnt
  /// from the GPS fixes that arrive while vision is fresh (a random walk per axis, Kalman-estimated) and
  /// taken off every fix the track uses.
  double gps_offset_initial_std = 1.5;  ///< offset std before any vision, per axis [m]
  double gps_offset_drift = 0.2;        ///< random-walk density of the offset [m/sqrt(s)]
  double gps_vision_timeout = 0.5;  ///< GPS is fused only when vision has been absent this long [s]
  double gps_pad_height = 0.497;    ///< pad height assumed when GPS starts a track [m]
  double initial_gps_height_std = 1.0;  ///< its standard deviation [m]
  // Track management.
  double max_coast_time = 3.0;          ///< lost after this long without an accepted fix [s]
  double gate_threshold = 25.0;         ///< squared Mahalanobis distance of an outlier [-] (5 sigma)
  int max_consecutive_rejections = 10;  ///< restart the track after this many outliers in a row [-]
  // Initial uncertainty of what one position fix cannot tell.
  double initial_velocity_std = 10.0;     ///< per axis [m/s]
  double initial_acceleration_std = 2.0;  ///< per axis [m/s^2]
  /// Also the turn rate's std when the heading is acquired, if the velocity told it less well, and the
  /// bound on a sudden turn-rate change of a slow vehicle (onsets) [rad/s].
  double initial_turn_rate_std = 0.5;
  // Heading: acquired (polar form) once the velocity's direction is known to this std, given up again
  // (Cartesian form) beyond heading_loss_std.
  double heading_acquisition_std = 0.1;  ///< [rad]
  double heading_loss_std = 0.5;         ///< > heading_acquisition_std [rad]
  // Numerics of the model.
  /// eps: the cross-track noise turns the heading by intensity / (s^2 + eps^2), bounded at rest [m/s]
  double low_speed_regularisation = 0.1;
  double max_integration_step = 0.01;     ///< RK4 / covariance sub-step [s]

  /// Empty if valid, else "<name> must be ..." for the first invalid value.
  std::string validate() const;
  /// Vision variance per axis [m^2] of a fix taken from `range` metres away.
  double visionVariance(double range) const;
};

/// Estimated pad state at one instant, world frame.
struct PadState
{
  double time = 0.0;                                               ///< [s]
  Eigen::Vector3d position = Eigen::Vector3d::Zero();              ///< [m]
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();              ///< [m/s]; z is 0 by the model
  Eigen::Matrix3d position_covariance = Eigen::Matrix3d::Zero();   ///< [m^2]
  Eigen::Matrix2d velocity_covariance = Eigen::Matrix2d::Zero();   ///< of (vx, vy) [m^2/s^2]
  double tangential_acceleration = 0.0;  ///< along the velocity (speeding up > 0) [m/s^2]
  double turn_rate = 0.0;                                          ///< [rad/s], counter-clockwise > 0
  double turn_rate_variance = 0.0;                                 ///< [rad^2/s^2]
  double manoeuvre_probability = 0.0;                              ///< [-]
  bool heading_known = false;  ///< polar form; else the track has not (or no longer) a heading
};

/// One point of a predicted path.
struct PathPoint
{
  double time = 0.0;                                   ///< [s]
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< [m]
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();  ///< [m/s]
};

enum class MeasurementOutcome
{
  kInitialised,     ///< started a new track
  kAccepted,        ///< fused
  kRejected,        ///< outside the gate of every mode, not fused
  kReinitialised,   ///< too many consecutive rejections: restarted the track on this fix
  kDroppedStale,    ///< stamp not newer than the state or the previous fix of its source
  kDroppedInvalid,  ///< NaN or inf in the stamp or the position
  kIgnored,         ///< GPS while vision is fresh: vision is far more accurate
};

const char* toString(MeasurementOutcome outcome);

class PadMotionFilter
{
public:
  using Model = TurnAccelerationModel;

  /// Throws std::invalid_argument if parameters.validate() finds an invalid value.
  explicit PadMotionFilter(const FilterParameters& parameters);

  /// Vision fix of the pad centre at `stamp` [s], world frame [m], with its variance per axis [m^2]
  /// (observation_covariance when not given).
  MeasurementOutcome addVision(double stamp, const Eigen::Vector3d& position, double variance = -1.0);
  /// GPS-like fix of the pad centre's horizontal position at `stamp` [s] [m] (the caller moves it from
  /// the receiver to the pad centre), with the vehicle's velocity [m/s] and its variance per axis
  /// [m^2/s^2] if the receiver reports them: a track that starts on this fix starts from that velocity
  /// (and so, when moving, with a heading) instead of an unknown one.
  MeasurementOutcome addGps(double stamp, const Eigen::Vector2d& position_xy,
                            const std::optional<Eigen::Vector2d>& velocity = std::nullopt,
                            double velocity_variance = -1.0);

  /// The vehicle's own heading [rad] at `stamp` [s] (the yaw its GPS/odometry reports: the axis it drives
  /// along, whichever way it goes) with its variance [rad^2]. Vision alone cannot tell the heading of a
  /// slow pad: after every stop or reversal its noise turned the heading (up to 2.8 rad/s of phantom turn
  /// rate, paths bent by metres). Applied to the current state, corrected for the turn since `stamp`; a
  /// polar track whose heading is the opposite axis flips to it (theta + pi with -s, -a, -kappa: the same
  /// motion). A Cartesian track moving faster than kHeadingMinSpeed takes it as its heading. Not a fix:
  /// the track is not kept alive by it. kIgnored without a track (or too slow to take it), kDroppedStale
  /// more than kMaxHeadingAge older than the state.
  MeasurementOutcome addHeading(double stamp, double heading, double variance);
  static constexpr double kHeadingMinSpeed = 0.3;  ///< [m/s]
  static constexpr double kMaxHeadingAge = 0.5;    ///< [s]

  /// The vehicle's own yaw rate [rad/s] at `stamp` [s] (its odometry's twist.angular.z) with its variance
  /// [rad^2/s^2]: the turn rate s * kappa of a polar track. From the fixes alone the turn rate followed a
  /// corner 0.3-0.4 s late, in and out (square path at 3 m/s: 0.5 rad/s at the truth's peak of 1.4, and
  /// still 1 rad/s 0.3 s after the corner). Applied to the current state: the yaw rate may have changed
  /// since `stamp` by kYawAccelerationStd per second, which widens its variance. Not a fix: the track is
  /// not kept alive by it. kIgnored without a polar track or below kHeadingMinSpeed (a pad at rest has no
  /// curvature), kDroppedStale more than kMaxHeadingAge older than the state.
  MeasurementOutcome addTurnRate(double stamp, double turn_rate, double variance);
  static constexpr double kYawAccelerationStd = 1.0;  ///< [rad/s^2]

  /// The vehicle's own velocity [m/s] (world x, y; its GPS or odometry twist) at `stamp` [s], with the
  /// variance per axis [m^2/s^2]: its component along the track's heading is the speed s. The fixes see a
  /// change of speed (braking, pulling away) only once it has moved the pad, and not at all while the pad
  /// is out of the camera's view; this sees it at once. Applied to the current state through the
  /// acceleration over the age, widened by kSpeedJerkStd. Not a fix. kIgnored without a polar track (the
  /// velocity is projected on its heading), at any speed; kDroppedStale as addTurnRate.
  MeasurementOutcome addSpeed(double stamp, const Eigen::Vector2d& velocity_xy, double variance);
  static constexpr double kSpeedJerkStd = 2.0;  ///< [m/s^3]

  /// A track exists and its last accepted fix is at most max_coast_time older than `now` [s].
  bool isTracking(double now) const;
  bool hasTrack() const { return initialised_; }
  /// Time of the filter state, i.e. of the last fused fix [s].
  double stateTime() const { return state_time_; }
  /// What is taken off each GPS fix (GPS minus vision track) [m], and its variance per axis [m^2].
  const Eigen::Vector2d& gpsOffset() const { return gps_offset_; }
  double gpsOffsetVariance() const { return gps_offset_variance_; }
  /// Forget the track, the stamps seen and the GPS offset (e.g. after the clock jumped back).
  void reset();

  /// State predicted to `time` [s] without consuming a fix; nullopt without a track. Times before the
  /// state time are extrapolated backwards for the mean only.
  std::optional<PadState> stateAt(double time) const;
  /// Positions at t0 + k*time_step for k = 0 .. round(path_time / time_step) [s]; empty without a track.
  /// Throws std::invalid_argument unless time_step > 0 and path_time >= 0.
  std::vector<PathPoint> predictPath(double t0, double time_step, double path_time) const;

  const FilterParameters& parameters() const { return params_; }

private:
  static constexpr int kModes = 2;  // 0: steady, 1: manoeuvre
  enum class Source { kVision = 0, kGps = 1 };

  /// The modes after the IMM interaction and prediction to a later time.
  struct ModePrediction
  {
    std::array<Model::Vector, kModes> x;
    std::array<Model::Matrix, kModes> P;
    Eigen::Vector2d probabilities;  ///< predicted mode probabilities c_j
    Eigen::Matrix2d mixing;         ///< mixing(i, j): weight of mode i in mode j's start
    std::array<Model::Matrix, kModes> transition;  ///< linearised, over the prediction
  };
  using OnsetMatrix = Eigen::Matrix<double, Model::kSize, 2>;
  /// A hypothetical manoeuvre onset right after the fix at `time`: a step of unknown size in the
  /// acceleration along and across the velocity, or, for a stop, the known step in (s, a) that brings a
  /// braking vehicle to rest where its speed crossed zero. How a unit step along each column would have
  /// moved the true state (`truth`) and each mode's estimate since, and what the fixes since say about
  /// it: a generalised likelihood ratio test (Willsky and Jones 1976) on the linearised IMM.
  struct OnsetHypothesis
  {
    double time = 0.0;
    OnsetMatrix truth;
    std::array<OnsetMatrix, kModes> estimate;
    Eigen::Matrix2d information = Eigen::Matrix2d::Zero();  ///< sum of Gamma^T S^-1 Gamma
    Eigen::Vector2d score = Eigen::Vector2d::Zero();        ///< sum of Gamma^T S^-1 innovation
    std::optional<Eigen::Vector2d> known_step;  ///< a stop; else unknown, std onset_acceleration_std
  };

  /// A velocity to start a track from, with its variance per axis.
  struct StartVelocity
  {
    Eigen::Vector2d velocity;
    double variance;
  };

  template <int M>
  MeasurementOutcome addFix(Source source, double stamp, const Eigen::Matrix<double, M, 1>& z,
                            const Eigen::Matrix<double, M, Model::kSize>& H, double variance,
                            const std::optional<StartVelocity>& start_velocity = std::nullopt);
  /// Propagates the GPS offset's variance to `stamp` and, while vision holds the track, updates the offset
  /// with this fix's difference to the track at `stamp`.
  void learnGpsOffset(double stamp, const Eigen::Vector2d& position_xy);
  /// Starts a track in the Cartesian form (heading unknown), then acquires the heading if `velocity`
  /// already tells it.
  void startTrack(Source source, double stamp, const Eigen::Vector3d& position, double position_variance,
                  double height_variance, const StartVelocity& velocity);
  /// Acquires or gives up the heading (polar / Cartesian form) by its uncertainty.
  void updateForm();
  /// addTurnRate and addSpeed: kAccepted if a vehicle measurement at `stamp`, `age` older than the state,
  /// can be fused now, the track's speed being at least `min_speed` [m/s].
  MeasurementOutcome vehicleMeasurementUsable(double stamp, double age, double min_speed) const;
  /// Scalar update of each mode with (H, innovation) = linearise(mode state) and variance R; each mode's
  /// likelihood of it re-weights the modes.
  template <class Linearise>
  void modeWeightedUpdate(double R, Linearise linearise);
  /// Cartesian -> polar form, every mode with `heading` or its opposite; `combined`: the modes' mixture.
  void enterPolarForm(const Model::Vector& combined, const Model::Matrix& combined_covariance, double heading);
  /// Opens a hypothesis of a step along `directions` right after the fix at `stamp`.
  void openOnset(double stamp, const OnsetMatrix& directions, const std::optional<Eigen::Vector2d>& known_step);
  /// Advances every onset hypothesis over a fix that updated the modes with gains K, and opens one
  /// at this fix.
  template <int M>
  void trackOnsets(double stamp, const ModePrediction& predicted, const Eigen::Matrix<double, M, Model::kSize>& H,
                   const std::array<Eigen::Matrix<double, M, 1>, kModes>& innovation,
                   const std::array<Eigen::Matrix<double, M, M>, kModes>& S,
                   const std::array<Eigen::Matrix<double, Model::kSize, M>, kModes>& K);
  /// Applies the most likely stop if it passes stop_threshold, else the most likely onset if it passes
  /// onset_threshold, to every mode.
  void applyOnset();
  /// `for_output`: the prediction ends a braking at rest (Model::propagateMean).
  ModePrediction predictModes(double time, bool for_output) const;
  /// Moment-matched mean and covariance of the mode mixture (heading averaged on the circle).
  void combine(const std::array<Model::Vector, kModes>& x, const std::array<Model::Matrix, kModes>& P,
               const Eigen::Vector2d& weights, Model::Vector& x_out, Model::Matrix& P_out) const;
  /// Combined mean and covariance at `time` as published, and the manoeuvre probability.
  void combinedAt(double time, Model::Vector& x, Model::Matrix& P, double& manoeuvre_probability) const;

  FilterParameters params_;
  Model model_;
  std::array<Model::Noise, kModes> noise_;

  bool initialised_ = false;
  Model::Form form_ = Model::Form::kCartesian;
  std::vector<OnsetHypothesis> onsets_;  // oldest first
  std::array<Model::Vector, kModes> x_;
  std::array<Model::Matrix, kModes> P_;
  Eigen::Vector2d mode_probabilities_;
  double state_time_ = 0.0;
  double last_accepted_time_ = 0.0;
  Eigen::Vector2d gps_offset_ = Eigen::Vector2d::Zero();
  double gps_offset_variance_ = 0.0;
  double gps_offset_time_ = 0.0;  ///< time the offset's variance was last propagated to [s]
  double last_vision_accepted_time_ = 0.0;
  std::array<double, 2> last_stamp_{};
  std::array<int, 2> consecutive_rejections_{};
  std::array<bool, 2> seen_{};
};

}  // namespace ped_traj_pred
