// Motion model of a ground vehicle seen from above: a turn of constant curvature with tangential
// acceleration on a signed speed (CTRA in curvature form), and the Cartesian form a track uses while
// its heading is unknown. ROS-free.
//
// Polar form (heading known), x = [px, py, pz, s, theta, a, kappa] (world frame; m, m/s, rad, m/s^2, 1/m):
//   d(px, py)/dt = s * (cos theta, sin theta),  ds/dt = a,  d(theta)/dt = s * kappa (the turn rate),
//   da/dt = w_a,  d(kappa)/dt = w_omega / s,  d(pz)/dt = w_z,  plus white accelerations along and
//   across theta,
// with w_* continuous white noise. The speed s is signed and theta is the axis the vehicle drives along,
// not its direction of travel: braking to rest, standing, pulling away and reversing leave theta alone
// while s passes through zero. So lines, circles, stops, pull-aways and reversals are all exact
// solutions. (A Cartesian velocity with the tangential acceleration along v/|v| cannot do this: at rest
// the acceleration has no direction, and the filter lagged every pull-away and reversal by 0.4-0.5 s.)
// Why curvature rather than a turn rate: a turn rate is unobservable at standstill, and whatever value
// the stop left would keep turning the heading of the standing vehicle (a 20 deg error after 2 s at
// 0.15 rad/s), so the pull-away would start in the wrong direction. The vehicles here do not turn on the
// spot. While moving the two are the same: the turn-rate noise w_omega / s on kappa is yaw-rate noise
// w_omega, and a circle at constant speed is exact in both.
//
// Cartesian form (heading unknown), x = [px, py, pz, vx, vy, ax, ay]: nearly constant acceleration.
// A track starts in it, because one fix tells nothing of the heading and at standstill the heading is
// unobservable: in polar coordinates an unknown heading at low speed is a singularity the EKF cannot
// leave (the position does not depend on theta while s = 0, so no fix corrects it).
#pragma once

#include <Eigen/Dense>

namespace ped_traj_pred
{
class TurnAccelerationModel
{
public:
  static constexpr int kSize = 7;
  using Vector = Eigen::Matrix<double, kSize, 1>;
  using Matrix = Eigen::Matrix<double, kSize, kSize>;
  enum class Form
  {
    kCartesian,
    kPolar
  };
  // Polar form: signed speed, heading, tangential acceleration, curvature.
  enum PolarIndex { kPx = 0, kPy, kPz, kSpeed, kHeading, kAcceleration, kCurvature };
  // Cartesian form: velocity and acceleration vectors (the position indices are shared).
  enum CartesianIndex { kVx = 3, kVy, kAx, kAy };

  /// Continuous-time white-noise intensities.
  struct Noise
  {
    double jerk = 0.0;               ///< on a (polar), on (ax, ay) (Cartesian) [m^2/s^5]
    double turn_acceleration = 0.0;  ///< on the turn rate s * kappa (polar only) [rad^2/s^3]
    double acceleration = 0.0;       ///< on s (polar), on (vx, vy) (Cartesian) [m^2/s^3]
    /// Across the heading (polar only): turns theta by w / s, regularised at standstill, see noiseDensity().
    double cross_acceleration = 0.0;  ///< [m^2/s^3]
    double height_rate = 0.0;         ///< on pz [m^2/s]
  };

  /// `low_speed_regularisation` is eps [m/s]; `max_step` the integration sub-step [s].
  TurnAccelerationModel(double low_speed_regularisation, double max_step);

  /// Qc at state x. Polar: the cross-track acceleration w turns the heading at w / s, the turn-rate
  /// noise the curvature at w_omega / s; s^2 + eps^2 in place of s^2 bounds both at standstill.
  Matrix noiseDensity(Form form, const Vector& x, const Noise& noise) const;

  /// d(x)/dt
  Vector derivative(Form form, const Vector& x) const;
  /// d(derivative)/d(x)
  Matrix jacobian(Form form, const Vector& x) const;
  /// Advances the mean by dt [s] (negative dt integrates backwards) with RK4 sub-steps. With
  /// `stop_at_rest` (polar form, dt > 0), a braking vehicle whose speed reaches zero stays at rest
  /// (s = a = 0) instead of reversing: how a prediction should end a braking, while the filter itself
  /// integrates the exact model and lets the fixes tell a stop from a reversal.
  void propagateMean(Form form, Vector& x, double dt, bool stop_at_rest = false) const;
  /// Advances mean and covariance by dt >= 0 [s]; `transition`, if given, receives the linearised
  /// state transition over dt.
  void propagate(Form form, Vector& x, Matrix& P, const Noise& noise, double dt, bool stop_at_rest = false,
                 Matrix* transition = nullptr) const;

  /// a - b, the heading difference wrapped to [-pi, pi).
  static Vector difference(Form form, const Vector& a, const Vector& b);
  /// Wraps the heading to [-pi, pi).
  static void normalise(Form form, Vector& x);
  /// `angle` wrapped to [-pi, pi) [rad].
  static double wrapAngle(double angle);

  /// Horizontal velocity [m/s] and its covariance [m^2/s^2].
  static Eigen::Vector2d velocity(Form form, const Vector& x);
  static Eigen::Matrix2d velocityCovariance(Form form, const Vector& x, const Matrix& P);
  /// Acceleration along the velocity, speeding up > 0 [m/s^2] (Cartesian: fading out at rest).
  double tangentialAcceleration(Form form, const Vector& x) const;
  /// Turn rate [rad/s] and its variance (polar: s * kappa; Cartesian: from the acceleration across the
  /// velocity, regularised at standstill like the noise).
  double turnRate(Form form, const Vector& x) const;
  double turnRateVariance(Form form, const Vector& x, const Matrix& P) const;
  /// Standard deviation of the heading [rad]; Cartesian: of the velocity's direction (inf at rest).
  static double headingStd(Form form, const Vector& x, const Matrix& P);

  /// Cartesian -> polar, linearised. The heading is the velocity's direction or its opposite, whichever
  /// is nearer `reference_heading` (s < 0 for the opposite). A curvature whose turn rate is more
  /// uncertain than `max_turn_rate_std` [rad/s] (slow vehicle: it is the acceleration across v divided
  /// by s^2) is replaced by 0 with that turn-rate std. Needs a nonzero velocity.
  static void toPolar(Vector& x, Matrix& P, double reference_heading, double max_turn_rate_std);
  /// Polar -> Cartesian, linearised.
  static void toCartesian(Vector& x, Matrix& P);

private:
  void rk4Step(Form form, Vector& x, double h) const;

  double eps_;
  double max_step_;
};

}  // namespace ped_traj_pred
