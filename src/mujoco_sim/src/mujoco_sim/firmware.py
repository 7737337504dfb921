"""The drone's own on-board estimate of its velocity and height, ROS-free (realism: firmware_on_estimate).

A real AR.Drone flies its velocity and altitude loops on what it measures, not on the truth:

- Horizontal velocity: the accelerometer (biased, noisy) integrated and pulled towards the optical flow of
  the bottom camera (``flow_gain`` per second). The flow measures the motion relative to what the camera
  sees: over the ground, the drone's velocity; over the moving vehicle, its velocity relative to the
  vehicle (the simulator blends the two by how much of the view the vehicle's textured part, the pad,
  covers: landing_runtime.camera_footprint).
- Height and climb rate: the accelerometer, less its estimated vertical bias, pulled towards the sonar
  height, i.e. the height above whatever surface is below (the drone follows gentle terrain). A sonar
  height far from the estimate is an outlier unless it persists ``surface_step_time``: then the surface
  changed (the vehicle's edge passed under) and the estimate takes the new height, while the altitude hold
  keeps the drone where it is (the step is returned for the autopilot's reference; diving 1.7 m off a
  car's roof crashed it on the pad).
  Out of the sonar's range, and while a sonar height far from the estimate is not yet taken for a new
  surface, the barometer's changes carry the height on.

Velocities are in the world frame here; the firmware works in its heading frame, which it knows exactly
relative to its own body, so this is the same estimate (its yaw drift does not enter).
"""
import numpy as np


class FirmwareEstimator:
    """``params``: the validated ``firmware`` section of the simulator configuration."""

    def __init__(self, params):
        self.p = params
        self.velocity = np.zeros(2)  # horizontal, world frame [m/s]
        self.climb = 0.0             # [m/s]
        self.climb_bias = 0.0        # vertical accelerometer bias [m/s^2]
        self.height = None           # base_link above the surface below [m]
        self._step_since = None      # when a sonar height first disagreed by more than surface_step
        self._baro_offset = None     # barometric altitude minus height, followed slowly while the sonar agrees

    @property
    def ready(self):
        return self.height is not None

    def predict(self, dt, acceleration_world):
        """Integrate the measured acceleration (world frame, gravity removed) [m/s^2] over ``dt`` [s]."""
        self.velocity += np.asarray(acceleration_world[:2]) * dt
        self.climb += (float(acceleration_world[2]) - self.climb_bias) * dt
        if self.height is not None:
            self.height += self.climb * dt

    def flow(self, dt, measured_velocity_xy):
        """One optical-flow velocity (world frame) [m/s], ``dt`` [s] after the previous one."""
        gain = min(1.0, self.p["flow_gain"] * dt)
        self.velocity += gain * (np.asarray(measured_velocity_xy, dtype=float) - self.velocity)

    def sonar(self, t, dt, height, baro_altitude):
        """A sonar height of base_link above the surface below [m] at ``t`` [s] (None when out of range or
        invalid), ``dt`` [s] after the previous call, and the barometric altitude [m]. Returns the step of a
        surface change [m] (new height minus estimate), else 0."""
        step = 0.0
        if height is None:
            self._correct_by_barometer(dt, baro_altitude)
            return step
        if self.height is None:
            self.height, self.climb = height, 0.0
            self._baro_offset = baro_altitude - height
        elif abs(height - self.height) > self.p["surface_step"]:
            if self._step_since is None:
                self._step_since = t
            if t - self._step_since < self.p["surface_step_time"]:
                # An outlier, unless it persists. Meanwhile the barometer holds the climb estimate: at the pad's
                # edge the sonar reads pad and ground by turns, and the accelerometer's bias would run away.
                self._correct_by_barometer(dt, baro_altitude)
                return step
            step = height - self.height
            self.height = height  # the surface below changed: a new reference, and the barometer's with it
            self._baro_offset -= step
        else:
            self._correct(dt, height)
            # Slowly, so that the height's drift while the sonar was not trusted stays visible to the barometer.
            self._baro_offset += min(1.0, self.p["baro_offset_gain"] * dt) * \
                (baro_altitude - self.height - self._baro_offset)
        self._step_since = None
        return step

    def _correct_by_barometer(self, dt, baro_altitude):
        """Without a sonar height to trust, the barometer's change carries the height on."""
        if self.height is not None:
            self._correct(dt, baro_altitude - self._baro_offset)

    def _correct(self, dt, height):
        innovation = height - self.height
        self.height += min(1.0, self.p["height_gain"] * dt) * innovation
        self.climb += self.p["climb_gain"] * dt * innovation
        self.climb_bias -= self.p["climb_bias_gain"] * dt * innovation
