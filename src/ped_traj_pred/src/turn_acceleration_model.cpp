#include "ped_traj_pred/turn_acceleration_model.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace ped_traj_pred
{
namespace
{
using Form = TurnAccelerationModel::Form;

int subSteps(double dt, double max_step)
{
  return std::max(1, static_cast<int>(std::ceil(std::abs(dt) / max_step)));
}

Eigen::Vector2d unit(double angle)
{
  return { std::cos(angle), std::sin(angle) };
}

/// 90 degrees counter-clockwise.
Eigen::Vector2d left(const Eigen::Vector2d& v)
{
  return { -v.y(), v.x() };
}
}  // namespace

double TurnAccelerationModel::wrapAngle(double angle)
{
  return angle - 2.0 * M_PI * std::floor((angle + M_PI) / (2.0 * M_PI));
}

TurnAccelerationModel::TurnAccelerationModel(double low_speed_regularisation, double max_step)
  : eps_(low_speed_regularisation), max_step_(max_step)
{
}

TurnAccelerationModel::Matrix TurnAccelerationModel::noiseDensity(Form form, const Vector& x, const Noise& noise) const
{
  Matrix Qc = Matrix::Zero();
  Qc(kPz, kPz) = noise.height_rate;
  if (form == Form::kPolar)
  {
    Qc(kSpeed, kSpeed) = noise.acceleration;
    Qc(kHeading, kHeading) = noise.cross_acceleration / (x(kSpeed) * x(kSpeed) + eps_ * eps_);
    Qc(kAcceleration, kAcceleration) = noise.jerk;
    // The turn-rate noise acts on the curvature as w / s: the same yaw-rate noise while moving.
    Qc(kCurvature, kCurvature) = noise.turn_acceleration / (x(kSpeed) * x(kSpeed) + eps_ * eps_);
  }
  else
  {
    Qc(kVx, kVx) = Qc(kVy, kVy) = noise.acceleration;
    Qc(kAx, kAx) = Qc(kAy, kAy) = noise.jerk;
  }
  return Qc;
}

TurnAccelerationModel::Vector TurnAccelerationModel::derivative(Form form, const Vector& x) const
{
  Vector dx = Vector::Zero();
  if (form == Form::kPolar)
  {
    dx.segment<2>(kPx) = x(kSpeed) * unit(x(kHeading));
    dx(kSpeed) = x(kAcceleration);
    dx(kHeading) = x(kSpeed) * x(kCurvature);
  }
  else
  {
    dx.segment<2>(kPx) = x.segment<2>(kVx);
    dx.segment<2>(kVx) = x.segment<2>(kAx);
  }
  return dx;
}

TurnAccelerationModel::Matrix TurnAccelerationModel::jacobian(Form form, const Vector& x) const
{
  Matrix A = Matrix::Zero();
  if (form == Form::kPolar)
  {
    const Eigen::Vector2d u = unit(x(kHeading));
    A.block<2, 1>(kPx, kSpeed) = u;
    A.block<2, 1>(kPx, kHeading) = x(kSpeed) * left(u);
    A(kSpeed, kAcceleration) = 1.0;
    A(kHeading, kSpeed) = x(kCurvature);
    A(kHeading, kCurvature) = x(kSpeed);
  }
  else
  {
    A.block<2, 2>(kPx, kVx) = Eigen::Matrix2d::Identity();
    A.block<2, 2>(kVx, kAx) = Eigen::Matrix2d::Identity();
  }
  return A;
}

void TurnAccelerationModel::rk4Step(Form form, Vector& x, double h) const
{
  const Vector k1 = derivative(form, x);
  const Vector k2 = derivative(form, x + 0.5 * h * k1);
  const Vector k3 = derivative(form, x + 0.5 * h * k2);
  const Vector k4 = derivative(form, x + h * k3);
  x += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
}

void TurnAccelerationModel::propagateMean(Form form, Vector& x, double dt, bool stop_at_rest) const
{
  if (dt == 0.0)
    return;
  const int steps = subSteps(dt, max_step_);
  const double h = dt / steps;
  const bool stop = stop_at_rest && form == Form::kPolar && dt > 0.0;
  for (int i = 0; i < steps; ++i)
  {
    // a is constant over a step, so the speed reaches zero exactly at -s / a.
    const double speed = x(kSpeed), acceleration = x(kAcceleration);
    if (stop && speed * acceleration < 0.0 && std::abs(speed) <= std::abs(acceleration) * h)
    {
      const double to_rest = -speed / acceleration;
      rk4Step(form, x, to_rest);
      x(kSpeed) = x(kAcceleration) = 0.0;
      rk4Step(form, x, h - to_rest);
    }
    else
    {
      rk4Step(form, x, h);
    }
  }
  normalise(form, x);
}

void TurnAccelerationModel::propagate(Form form, Vector& x, Matrix& P, const Noise& noise, double dt,
                                      bool stop_at_rest, Matrix* transition) const
{
  if (transition != nullptr)
    transition->setIdentity();
  if (dt <= 0.0)
    return;
  const int steps = subSteps(dt, max_step_);
  const double h = dt / steps;
  for (int i = 0; i < steps; ++i)
  {
    const Matrix Ah = jacobian(form, x) * h;
    const Matrix Qc = noiseDensity(form, x, noise);
    // Second-order Taylor terms of the transition matrix and of Van Loan's noise integral: accurate for
    // sub-steps this short, and far cheaper than a matrix exponential.
    const Matrix Phi = Matrix::Identity() + Ah + 0.5 * Ah * Ah;
    const Matrix AhQc = Ah * Qc;
    const Matrix Qd = h * Qc + 0.5 * h * (AhQc + AhQc.transpose()) + (h / 3.0) * AhQc * Ah.transpose();
    P = Phi * P * Phi.transpose() + Qd;
    if (transition != nullptr)
      *transition = Phi * *transition;
    propagateMean(form, x, h, stop_at_rest);
  }
  P = 0.5 * (P + P.transpose());
}

TurnAccelerationModel::Vector TurnAccelerationModel::difference(Form form, const Vector& a, const Vector& b)
{
  Vector d = a - b;
  if (form == Form::kPolar)
    d(kHeading) = wrapAngle(d(kHeading));
  return d;
}

void TurnAccelerationModel::normalise(Form form, Vector& x)
{
  if (form == Form::kPolar)
    x(kHeading) = wrapAngle(x(kHeading));
}

Eigen::Vector2d TurnAccelerationModel::velocity(Form form, const Vector& x)
{
  return form == Form::kPolar ? Eigen::Vector2d(x(kSpeed) * unit(x(kHeading))) : Eigen::Vector2d(x.segment<2>(kVx));
}

Eigen::Matrix2d TurnAccelerationModel::velocityCovariance(Form form, const Vector& x, const Matrix& P)
{
  if (form == Form::kCartesian)
    return P.block<2, 2>(kVx, kVx);
  // v = s u(theta): d(v)/d(s, theta) = [u, s * left(u)]
  Eigen::Matrix2d G;
  const Eigen::Vector2d u = unit(x(kHeading));
  G << u, x(kSpeed) * left(u);
  return G * P.block<2, 2>(kSpeed, kSpeed) * G.transpose();
}

double TurnAccelerationModel::tangentialAcceleration(Form form, const Vector& x) const
{
  if (form == Form::kPolar)  // a is along the heading, against the velocity when reversing
    return x(kSpeed) < 0.0 ? -x(kAcceleration) : x(kAcceleration);
  const Eigen::Vector2d v = x.segment<2>(kVx);
  return x.segment<2>(kAx).dot(v) / std::sqrt(v.squaredNorm() + eps_ * eps_);
}

double TurnAccelerationModel::turnRate(Form form, const Vector& x) const
{
  if (form == Form::kPolar)
    return x(kSpeed) * x(kCurvature);
  const Eigen::Vector2d v = x.segment<2>(kVx);
  return left(v).dot(x.segment<2>(kAx)) / (v.squaredNorm() + eps_ * eps_);
}

double TurnAccelerationModel::turnRateVariance(Form form, const Vector& x, const Matrix& P) const
{
  if (form == Form::kPolar)
  {
    const Eigen::Vector2d g(x(kCurvature), x(kSpeed));  // d(s kappa)/d(s, kappa)
    Eigen::Matrix2d P_s_kappa;
    P_s_kappa << P(kSpeed, kSpeed), P(kSpeed, kCurvature), P(kCurvature, kSpeed), P(kCurvature, kCurvature);
    return g.dot(P_s_kappa * g);
  }
  // omega = c / d with c = v x acc, d = |v|^2 + eps^2: gradient over (vx, vy, ax, ay).
  const Eigen::Vector2d v = x.segment<2>(kVx), acc = x.segment<2>(kAx);
  const double d = v.squaredNorm() + eps_ * eps_;
  const double omega = left(v).dot(acc) / d;
  Eigen::Vector4d g;
  g << (acc.y() - 2.0 * omega * v.x()) / d, (-acc.x() - 2.0 * omega * v.y()) / d, -v.y() / d, v.x() / d;
  return g.dot(P.block<4, 4>(kVx, kVx) * g);
}

double TurnAccelerationModel::headingStd(Form form, const Vector& x, const Matrix& P)
{
  if (form == Form::kPolar)
    return std::sqrt(P(kHeading, kHeading));
  const Eigen::Vector2d v = x.segment<2>(kVx);
  const double speed = v.norm();
  if (!(speed > 0.0))
    return std::numeric_limits<double>::infinity();
  const Eigen::Vector2d across = left(v) / speed;
  return std::sqrt(across.dot(P.block<2, 2>(kVx, kVx) * across)) / speed;
}

void TurnAccelerationModel::toPolar(Vector& x, Matrix& P, double reference_heading, double max_turn_rate_std)
{
  const Eigen::Vector2d v = x.segment<2>(kVx), acc = x.segment<2>(kAx);
  double heading = std::atan2(v.y(), v.x());
  if (std::cos(heading - reference_heading) < 0.0)
    heading = wrapAngle(heading + M_PI);
  const Eigen::Vector2d u = unit(heading), n = left(u);
  const double s = u.dot(v);  // signed: -|v| when the heading is opposite the velocity
  const double a = u.dot(acc), kappa = n.dot(acc) / (s * s);

  // Jacobian of (s, theta, a, kappa) with respect to (v, acc); the position is unchanged.
  Matrix J = Matrix::Identity();
  J.block<1, 2>(kSpeed, kVx) = u.transpose();
  J.block<1, 2>(kSpeed, kAx).setZero();
  J.block<1, 2>(kHeading, kVx) = n.transpose() / s;
  J.block<1, 2>(kHeading, kAx).setZero();
  J.block<1, 2>(kAcceleration, kVx) = (s * kappa) * n.transpose();
  J.block<1, 2>(kAcceleration, kAx) = u.transpose();
  J.block<1, 2>(kCurvature, kVx) = -(a / (s * s * s)) * n.transpose() - (2.0 * kappa / s) * u.transpose();
  J.block<1, 2>(kCurvature, kAx) = n.transpose() / (s * s);

  x(kSpeed) = s;
  x(kHeading) = heading;
  x(kAcceleration) = a;
  x(kCurvature) = kappa;
  P = J * P * J.transpose();
  // The turn rate s * kappa may be no more uncertain than max_turn_rate_std.
  const double max_curvature_variance = max_turn_rate_std * max_turn_rate_std / (s * s);
  if (!(P(kCurvature, kCurvature) <= max_curvature_variance))
  {
    x(kCurvature) = 0.0;
    P.row(kCurvature).setZero();
    P.col(kCurvature).setZero();
    P(kCurvature, kCurvature) = max_curvature_variance;
  }
  P = 0.5 * (P + P.transpose());
}

void TurnAccelerationModel::toCartesian(Vector& x, Matrix& P)
{
  const double s = x(kSpeed), a = x(kAcceleration), kappa = x(kCurvature);
  const Eigen::Vector2d u = unit(x(kHeading)), n = left(u);
  // v = s u, acc = a u + s^2 kappa n
  Matrix J = Matrix::Identity();
  J.block<2, 4>(kVx, kSpeed) << u, s * n, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero();
  J.block<2, 4>(kAx, kSpeed) << 2.0 * s * kappa * n, a * n - s * s * kappa * u, u, s * s * n;

  x.segment<2>(kVx) = s * u;
  x.segment<2>(kAx) = a * u + s * s * kappa * n;
  P = J * P * J.transpose();
  P = 0.5 * (P + P.transpose());
}

}  // namespace ped_traj_pred
