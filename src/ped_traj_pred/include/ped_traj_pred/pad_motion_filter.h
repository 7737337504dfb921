// Tracks the landing pad in the world frame from noisy position fixes and predicts its path. ROS-free.
//
// Estimator: an interacting-multiple-model (IMM) filter of two extended Kalman filters sharing the
// coordinated-turn-with-tangential-acceleration model (turn_acceleration_model.h). They differ only in
// process noise: a "steady" mode (low noise: smooth, accurate predictions on lines and circles) and a
// "manoeuvre" mode (noise x manoeuvre_covariance_scale: follows the onset of braking, accelerating and
// turn reversals within a few frames). Why:
// - A circle and a straight line are exact solutions of the model, so the 1 s-ahead prediction has no
//   model bias there, unlike a constant-acceleration KF (whose bias v*omega^2*T^3/6 is 4.5 cm on a
//   10 m circle at 3 m/s and 1 m for a car at 25 m/s on a 50 m circle).
// - One noise level cannot serve both: low noise gives centimetre predictions in steady motion but
//   lags (and then gates out) 1-3 m/s^2 speed changes; high noise follows them but makes every
//   prediction noisy. The IMM weighs the two modes by how well each explains the fixes.
// - Both modes have the same state, so mixing needs no state augmentation, and the cost is two 7-state
//   EKFs (microseconds per fix).
//
// Measurements: vision positions (x, y, z) and, optionally, GPS-like (x, y) fixes, each with its own
// variance, applied at their own timestamps. A fix not newer than the filter state or than the previous
// fix of its source is dropped. A fix that no mode explains (squared Mahalanobis distance above
// gate_threshold in every mode) is rejected; after max_consecutive_rejections in a row the track restarts
// on the latest fix (the platform really moved, e.g. during a long blackout). GPS is fused only when
// vision has been absent for gps_vision_timeout. Without accepted fixes the filter coasts for
// max_coast_time, then reports the track lost; the next fix starts a new track.
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
  double model_covariance = 1e-4;       ///< tangential jerk, drives a_t [m^2/s^5]
  double turn_rate_covariance = 1e-5;  ///< turn-rate acceleration, drives omega [rad^2/s^3]
  double velocity_covariance = 1e-5;   ///< unmodelled acceleration on vx, vy [m^2/s^3]
  double height_covariance = 1e-4;      ///< random walk of the pad height pz [m^2/s]
  // Manoeuvre mode and mode switching.
  double manoeuvre_covariance_scale = 1e4;  ///< manoeuvre-mode noise / steady-mode noise [-]
  double steady_mode_duration = 60.0;          ///< mean time before the steady mode ends [s]
  double manoeuvre_mode_duration = 4.0;       ///< mean time before a manoeuvre ends [s]
  // Measurement noise.
  double observation_covariance = 9e-4;      ///< vision position variance, per axis [m^2]
  double gps_observation_covariance = 0.09;  ///< GPS position variance, per axis [m^2]
  double gps_vision_timeout = 0.5;  ///< GPS is fused only when vision has been absent this long [s]
  double gps_pad_height = 0.497;    ///< pad height assumed when GPS starts a track [m]
  double initial_gps_height_std = 1.0;  ///< its standard deviation [m]
  // Track management.
  double max_coast_time = 3.0;          ///< lost after this long without an accepted fix [s]
  double gate_threshold = 25.0;         ///< squared Mahalanobis distance of an outlier [-] (5 sigma)
  int max_consecutive_rejections = 10;  ///< restart the track after this many outliers in a row [-]
  // Initial uncertainty of what one position fix cannot tell.
  double initial_velocity_std = 10.0;     ///< [m/s]
  double initial_acceleration_std = 2.0;  ///< [m/s^2]
  double initial_turn_rate_std = 0.5;     ///< [rad/s]
  // Numerics of the model.
  double low_speed_regularisation = 0.1;  ///< eps: below this speed a_t fades out [m/s]
  double max_integration_step = 0.01;     ///< RK4 / covariance sub-step [s]

  /// Empty if valid, else "<name> must be ..." for the first invalid value.
  std::string validate() const;
};

/// Estimated pad state at one instant, world frame.
struct PadState
{
  double time = 0.0;                                               ///< [s]
  Eigen::Vector3d position = Eigen::Vector3d::Zero();              ///< [m]
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();              ///< [m/s]; z is 0 by the model
  Eigen::Matrix3d position_covariance = Eigen::Matrix3d::Zero();   ///< [m^2]
  Eigen::Matrix2d velocity_covariance = Eigen::Matrix2d::Zero();   ///< of (vx, vy) [m^2/s^2]
  double tangential_acceleration = 0.0;                            ///< [m/s^2]
  double turn_rate = 0.0;                                          ///< [rad/s], counter-clockwise > 0
  double turn_rate_variance = 0.0;                                 ///< [rad^2/s^2]
  double manoeuvre_probability = 0.0;                              ///< [-]
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

  /// Vision fix of the pad centre at `stamp` [s], world frame [m].
  MeasurementOutcome addVision(double stamp, const Eigen::Vector3d& position);
  /// GPS-like fix of the pad centre's horizontal position at `stamp` [s] [m] (the caller moves it from
  /// the receiver to the pad centre).
  MeasurementOutcome addGps(double stamp, const Eigen::Vector2d& position_xy);

  /// A track exists and its last accepted fix is at most max_coast_time older than `now` [s].
  bool isTracking(double now) const;
  bool hasTrack() const { return initialised_; }
  /// Time of the filter state, i.e. of the last fused fix [s].
  double stateTime() const { return state_time_; }
  /// Forget the track and the stamps seen (e.g. after the clock jumped back).
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
  };

  template <int M>
  MeasurementOutcome addFix(Source source, double stamp, const Eigen::Matrix<double, M, 1>& z,
                            const Eigen::Matrix<double, M, Model::kSize>& H, double variance);
  void startTrack(Source source, double stamp, const Eigen::Vector3d& position, double position_variance,
                  double height_variance, const Eigen::Vector2d& velocity);
  ModePrediction predictModes(double time) const;
  /// Moment-matched mean and covariance of the mode mixture.
  static void combine(const std::array<Model::Vector, kModes>& x, const std::array<Model::Matrix, kModes>& P,
                      const Eigen::Vector2d& weights, Model::Vector& x_out, Model::Matrix& P_out);
  Model::Vector combinedMean() const;

  FilterParameters params_;
  Model model_;
  std::array<Model::Matrix, kModes> noise_density_;

  bool initialised_ = false;
  std::array<Model::Vector, kModes> x_;
  std::array<Model::Matrix, kModes> P_;
  Eigen::Vector2d mode_probabilities_;
  double state_time_ = 0.0;
  double last_accepted_time_ = 0.0;
  double last_vision_accepted_time_ = 0.0;
  std::array<double, 2> last_stamp_{};
  std::array<int, 2> consecutive_rejections_{};
  std::array<bool, 2> seen_{};
};

}  // namespace ped_traj_pred
