"""The ground vehicle's controller odometry, as Robotnik's controller publishes it on robotnik_base_control/odom
(nav_msgs/Odometry), without ROS: the node fills the message from a Reading.

- Pose in the controller's odom frame (summit_xl/odom): it starts where the vehicle starts and its yaw is aligned with
  ENU, as the Summit XL's odometry fused with its IMU (magnetometer-referenced) gives it; its x, y are dead-reckoned
  from the measured forward speed along the measured heading, so they drift as a real odometry does.
- Twist in the base frame (summit_xl/base_link), as REP 105 has it: linear.x the forward speed, linear.y 0 (wheel
  odometry measures no side-slip), angular.z the yaw rate (the gyro's).
- Noise (sim.yaml noise:): white, per message: vehicle_speed_std on the speed, vehicle_heading_std_deg on the yaw,
  vehicle_yaw_rate_std on the yaw rate; the covariances state those standard deviations (the dead-reckoned position's
  variance grows with what it integrated), whether or not noise is enabled, as the former vehicle report did.
"""
import math
from collections import namedtuple

PLANAR_VARIANCE = 1e-6  # covariance entry of what a planar odometry holds fixed (z, roll, pitch, side-slip)

Reading = namedtuple("Reading", "position yaw forward_speed yaw_rate pose_covariance twist_covariance")
Reading.__doc__ = """One odometry message in plain numbers: (x, y) in the odom frame [m], yaw in ENU [rad], forward
speed [m/s], yaw rate [rad/s], and the 6x6 row-major covariances of the pose and of the twist."""


def _diagonal6(values):
    matrix = [0.0] * 36
    for i, value in enumerate(values):
        matrix[7 * i] = value
    return matrix


class VehicleOdometry:
    """``noise(std)`` draws one white-noise sample of that std (0 when the world has no noise); the three stds are
    sim.yaml's noise keys: vehicle_speed_std [m/s], vehicle_heading_std_deg (here in rad), vehicle_yaw_rate_std
    [rad/s]."""

    def __init__(self, noise, speed_std, heading_std_rad, yaw_rate_std):
        self.noise = noise
        self.speed_std, self.heading_std, self.yaw_rate_std = speed_std, heading_std_rad, yaw_rate_std
        self.position = [0.0, 0.0]      # dead-reckoned, in the odom frame [m]
        self.position_variance = PLANAR_VARIANCE
        self.last = None                # (time, speed, yaw) of the previous reading

    def measure(self, t, yaw, world_velocity, yaw_rate):
        """The Reading at sim time ``t`` of the vehicle heading ``yaw`` [rad], moving at
        ``world_velocity`` (vx, vy) [m/s] and turning at ``yaw_rate`` [rad/s]."""
        speed = math.cos(yaw) * world_velocity[0] + math.sin(yaw) * world_velocity[1]
        measured_speed = speed + self.noise(self.speed_std)
        noisy_yaw = yaw + self.noise(self.heading_std)
        measured_yaw = math.atan2(math.sin(noisy_yaw), math.cos(noisy_yaw))
        measured_yaw_rate = yaw_rate + self.noise(self.yaw_rate_std)
        if self.last is not None:  # (the odom frame's origin is where the first reading was taken)
            # Trapezoidal dead reckoning over the step since the previous reading.
            t0, speed0, yaw0 = self.last
            dt = max(t - t0, 0.0)
            mean_yaw = yaw0 + 0.5 * math.atan2(math.sin(measured_yaw - yaw0), math.cos(measured_yaw - yaw0))
            step = 0.5 * (speed0 + measured_speed) * dt
            self.position[0] += step * math.cos(mean_yaw)
            self.position[1] += step * math.sin(mean_yaw)
            self.position_variance += dt * dt * (self.speed_std ** 2 + measured_speed ** 2 * self.heading_std ** 2)
        self.last = (t, measured_speed, measured_yaw)
        pose_covariance = _diagonal6((self.position_variance, self.position_variance, PLANAR_VARIANCE,
                                      PLANAR_VARIANCE, PLANAR_VARIANCE, self.heading_std ** 2))
        twist_covariance = _diagonal6((self.speed_std ** 2, PLANAR_VARIANCE, PLANAR_VARIANCE,
                                       PLANAR_VARIANCE, PLANAR_VARIANCE, self.yaw_rate_std ** 2))
        return Reading(tuple(self.position), measured_yaw, measured_speed, measured_yaw_rate, pose_covariance,
                       twist_covariance)
