#include "ped_traj_pred/turn_acceleration_model.h"

#include <algorithm>
#include <cmath>

namespace ped_traj_pred
{
namespace
{
int subSteps(double dt, double max_step)
{
  return std::max(1, static_cast<int>(std::ceil(std::abs(dt) / max_step)));
}
}  // namespace

TurnAccelerationModel::TurnAccelerationModel(double low_speed_regularisation, double max_step)
  : eps_(low_speed_regularisation), max_step_(max_step)
{
}

TurnAccelerationModel::Matrix TurnAccelerationModel::noiseDensity(const Noise& noise)
{
  Matrix Qc = Matrix::Zero();
  Qc(kPz, kPz) = noise.height_rate;
  Qc(kVx, kVx) = Qc(kVy, kVy) = noise.acceleration;
  Qc(kAt, kAt) = noise.tangential_jerk;
  Qc(kOmega, kOmega) = noise.turn_acceleration;
  return Qc;
}

TurnAccelerationModel::Vector TurnAccelerationModel::derivative(const Vector& x) const
{
  const Eigen::Vector2d v = x.segment<2>(kVx);
  const Eigen::Vector2d direction = v / std::sqrt(v.squaredNorm() + eps_ * eps_);
  const Eigen::Vector2d v_rotated(-v.y(), v.x());

  Vector dx = Vector::Zero();
  dx.segment<2>(kPx) = v;
  dx.segment<2>(kVx) = x(kAt) * direction + x(kOmega) * v_rotated;
  return dx;
}

TurnAccelerationModel::Matrix TurnAccelerationModel::jacobian(const Vector& x) const
{
  const Eigen::Vector2d v = x.segment<2>(kVx);
  const double norm = std::sqrt(v.squaredNorm() + eps_ * eps_);
  const Eigen::Vector2d direction = v / norm;
  Eigen::Matrix2d rotate_90;
  rotate_90 << 0.0, -1.0, 1.0, 0.0;
  // d(v / norm)/dv = I / norm - v v^T / norm^3
  const Eigen::Matrix2d d_direction_dv =
      Eigen::Matrix2d::Identity() / norm - v * v.transpose() / (norm * norm * norm);

  Matrix A = Matrix::Zero();
  A.block<2, 2>(kPx, kVx) = Eigen::Matrix2d::Identity();
  A.block<2, 2>(kVx, kVx) = x(kAt) * d_direction_dv + x(kOmega) * rotate_90;
  A.block<2, 1>(kVx, kAt) = direction;
  A.block<2, 1>(kVx, kOmega) = rotate_90 * v;
  return A;
}

void TurnAccelerationModel::propagateMean(Vector& x, double dt) const
{
  if (dt == 0.0)
    return;
  const int steps = subSteps(dt, max_step_);
  const double h = dt / steps;
  for (int i = 0; i < steps; ++i)
  {
    const Vector k1 = derivative(x);
    const Vector k2 = derivative(x + 0.5 * h * k1);
    const Vector k3 = derivative(x + 0.5 * h * k2);
    const Vector k4 = derivative(x + h * k3);
    x += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
  }
}

void TurnAccelerationModel::propagate(Vector& x, Matrix& P, const Matrix& Qc, double dt) const
{
  if (dt <= 0.0)
    return;
  const int steps = subSteps(dt, max_step_);
  const double h = dt / steps;
  for (int i = 0; i < steps; ++i)
  {
    const Matrix Ah = jacobian(x) * h;
    // Second-order Taylor terms of the transition matrix and of Van Loan's noise integral: accurate for
    // sub-steps this short, and far cheaper than a matrix exponential.
    const Matrix Phi = Matrix::Identity() + Ah + 0.5 * Ah * Ah;
    const Matrix AhQc = Ah * Qc;
    const Matrix Qd = h * Qc + 0.5 * h * (AhQc + AhQc.transpose()) + (h / 3.0) * AhQc * Ah.transpose();
    P = Phi * P * Phi.transpose() + Qd;
    propagateMean(x, h);
  }
  P = 0.5 * (P + P.transpose());
}

}  // namespace ped_traj_pred
