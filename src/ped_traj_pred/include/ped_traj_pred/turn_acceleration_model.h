// Motion model of a ground vehicle seen from above: a coordinated turn with tangential acceleration,
// written with a Cartesian velocity. ROS-free.
//
// State x = [px, py, pz, vx, vy, a_t, omega] (world frame; m, m/s, m/s^2, rad/s):
//   d(px, py)/dt = (vx, vy)
//   d(vx, vy)/dt = a_t * v / sqrt(|v|^2 + eps^2)  +  omega * (-vy, vx)
//   d(a_t)/dt = w_a,  d(omega)/dt = w_omega,  d(pz)/dt = w_z,  plus w_v on d(v)/dt
// with w_* continuous white noise. Straight lines and circles at any speed are exact solutions; a_t
// follows speed changes; the Cartesian velocity has no heading singularity at standstill, and the
// eps-regularised direction makes braking decay to rest instead of reversing through zero speed.
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
  enum Index { kPx = 0, kPy, kPz, kVx, kVy, kAt, kOmega };

  /// Continuous-time white-noise intensities [m^2/s^5, rad^2/s^3, m^2/s^3, m^2/s].
  struct Noise
  {
    double tangential_jerk = 0.0;
    double turn_acceleration = 0.0;
    double acceleration = 0.0;
    double height_rate = 0.0;
  };

  /// `low_speed_regularisation` is eps [m/s]; `max_step` the integration sub-step [s].
  TurnAccelerationModel(double low_speed_regularisation, double max_step);

  static Matrix noiseDensity(const Noise& noise);

  /// d(x)/dt
  Vector derivative(const Vector& x) const;
  /// d(derivative)/d(x)
  Matrix jacobian(const Vector& x) const;
  /// Advances the mean by dt [s] (negative dt integrates backwards) with RK4 sub-steps.
  void propagateMean(Vector& x, double dt) const;
  /// Advances mean and covariance by dt >= 0 [s]; `noise_density` from noiseDensity().
  void propagate(Vector& x, Matrix& P, const Matrix& noise_density, double dt) const;

private:
  double eps_;
  double max_step_;
};

}  // namespace ped_traj_pred
