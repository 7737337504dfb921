"""Wind with gusts and the drone battery: the parts of the world that the conditions set."""
import math

import numpy as np


class Wind:
    """Mean wind plus gusts. ``direction_deg`` is where the wind blows towards, counter-clockwise
    from the world x axis. Gusts are a first-order (Ornstein-Uhlenbeck) process per horizontal axis
    whose standard deviation is ``gust_mps``, correlated over ``gust_time_constant`` seconds."""

    def __init__(self, rng, speed=0.0, direction_deg=0.0, gust_mps=0.0, gust_time_constant=2.0):
        self.rng = rng
        self.speed, self.direction_deg, self.gust_mps = speed, direction_deg, gust_mps
        self.gust_time_constant = gust_time_constant
        self.gust = np.zeros(2)

    def step(self, dt):
        if self.gust_mps <= 0.0:
            self.gust[:] = 0.0
            return
        decay = math.exp(-dt / self.gust_time_constant)
        self.gust = decay * self.gust + self.gust_mps * math.sqrt(1 - decay * decay) * self.rng.standard_normal(2)

    def velocity(self):
        angle = math.radians(self.direction_deg)
        return np.array([self.speed * math.cos(angle) + self.gust[0],
                         self.speed * math.sin(angle) + self.gust[1], 0.0])


def aerodynamic_force(air_velocity, body_velocity, drag_area, air_density=1.225):
    """Quadratic drag from the velocity of the air relative to the body, per axis.
    ``drag_area`` is Cd*A [m^2] for (x, y, z) in the world frame."""
    relative = np.asarray(air_velocity) - np.asarray(body_velocity)
    return 0.5 * air_density * np.asarray(drag_area) * np.abs(relative) * relative


class Battery:
    """State of charge [%] that drains with time, with thrust and faster in the cold."""

    def __init__(self, level, idle_drain, thrust_drain, cold_reference_temp, cold_factor_per_deg):
        self.level = level
        self.idle_drain, self.thrust_drain = idle_drain, thrust_drain
        self.cold_reference_temp, self.cold_factor_per_deg = cold_reference_temp, cold_factor_per_deg

    def drain_rate(self, thrust_fraction, temperature, motors_on):
        """Drain [%/s] at the given thrust (fraction of maximum) and temperature [deg C]."""
        rate = self.idle_drain + (self.thrust_drain * thrust_fraction if motors_on else 0.0)
        cold = max(0.0, self.cold_reference_temp - temperature)
        return rate * (1.0 + self.cold_factor_per_deg * cold)

    def step(self, dt, thrust_fraction, temperature, motors_on):
        self.level = max(0.0, self.level - dt * self.drain_rate(thrust_fraction, temperature, motors_on))
        return self.level

    @property
    def empty(self):
        return self.level <= 0.0
