"""drone_model px4_quad in the simulated world, ROS-free: the airframe, what its estimator measures, the MAVLink links.

The simulator keeps one Px4World (``sim.px4_world``) beside the firmware (``sim.autopilot``, a Px4Firmware):

- ``configure_airframe`` gives the model's quadrotor the px4_quad's mass, inertia, arms and rotors (its collision
  shape and camera stay the model's);
- ``step`` runs at every physics step before the firmware's update: the estimator's prediction and its GPS and
  barometer fixes (realism: firmware_on_estimate; else the firmware flies on true state), then the commander's
  timers; it returns the position and velocity the firmware flies on;
- set-points and commands reach the firmware over the command link (its latency and, for set-points, its losses;
  nothing while the link is lost), the pilot's RC switch directly;
- the telemetry accessors give what PX4 streams, in the local ENU frame MAVROS publishes (its origin where the
  estimate started).
"""
import math

import numpy as np

from .autopilot import FlightMode, quat_to_matrix
from .px4_firmware import Px4Estimator

GRAVITY = np.array([0.0, 0.0, 9.81])


def configure_airframe(mujoco, model, data, drone_body, rotor_actuators, params):
    """Set the drone body's mass and inertia, its rotors' positions (X configuration, ``arm_length`` from the centre)
    and their thrust range from ``params`` (the px4_quad section), and the model's derived constants."""
    model.body_mass[drone_body] = params["mass"]
    model.body_inertia[drone_body] = params["inertia"]
    half = params["arm_length"] / math.sqrt(2.0)
    for actuator in rotor_actuators:
        site = model.actuator_trnid[actuator][0]
        x, y = (float(v) for v in model.site_pos[site][:2])
        model.site_pos[site][:2] = (math.copysign(half, x), math.copysign(half, y))
        model.actuator_ctrlrange[actuator] = (0.0, params["max_rotor_thrust"])
    mujoco.mj_setConst(model, data)


class Px4World:
    """``sim``: the Simulator; ``params``: its validated px4_quad section."""

    def __init__(self, sim, params):
        self.sim = sim
        self.p = params
        self.estimator = None
        self.reset()

    def reset(self):
        self.estimator = Px4Estimator(self.p) if self.sim.realism["firmware_on_estimate"] else None
        self.gps_due = self.baro_due = 0.0
        self.last_gps = self.last_baro = None
        self.origin = None             # world position of the local frame's origin [m]
        self.setpoints_received = self.setpoints_lost = 0

    @property
    def firmware(self):
        return self.sim.autopilot

    @property
    def commander(self):
        return self.sim.autopilot.commander

    # ----- every physics step ---------------------------------------------------------------------
    def step(self, now, dt, quat):
        """The estimate the firmware flies on at ``now``: (position, velocity), world frame; the commander ticked."""
        sim = self.sim
        position, velocity = sim.drone_pose()[0], sim.drone_velocity()[0]
        valid = True
        if self.estimator is not None:
            position, velocity, valid = self._estimate(now, dt, quat, position, velocity)
        if self.origin is None:
            self.origin = np.array(position, dtype=float)
            self.firmware.local_origin = self.origin
        self.firmware.tick(now, sim.battery.level, valid)
        return position, velocity

    def _estimate(self, now, dt, quat, true_position, true_velocity):
        sim, est = self.sim, self.estimator
        sim._step_biases(now)
        specific_force = sim.data.sensordata[sim.accel_adr:sim.accel_adr + 3] + sim.accel_bias.value + \
            sim._noise("imu", (sim.noise or {}).get("imu_accel_std", 0), 3)
        est.predict(dt, quat_to_matrix(quat) @ specific_force - GRAVITY)
        if now + 1e-9 >= self.baro_due:
            self.baro_due = now + 1.0 / sim.cfg["rates"]["altimeter_hz"]
            est.baro(now - self.last_baro if self.last_baro is not None else 0.0, sim.altimeter()[0])
            self.last_baro = now
        if now + 1e-9 >= self.gps_due:
            self.gps_due = now + 1.0 / self.p["gps_rate_hz"]
            fix = sim.gps()  # (None in a dropout)
            if fix is not None:
                est.gps(now, now - self.last_gps if self.last_gps is not None else 0.0, *fix)
                self.last_gps = now
        if not est.ready:
            return true_position, true_velocity, False
        return est.position.copy(), est.velocity.copy(), est.valid(now)

    # ----- what reaches the autopilot ----------------------------------------------------------------
    def send_setpoint(self, setpoint):
        """An offboard set-point from MAVROS: over the command link (late, perhaps lost; nothing while it is lost)."""
        sim = self.sim
        if sim.link_lost() or (sim.command_link.loss > 0.0 and sim.command_link.lost_next()):
            self.setpoints_lost += 1
            return
        self.setpoints_received += 1
        firmware = self.firmware
        sim._send(lambda: firmware.receive_setpoint(setpoint, sim.time))

    def send_command(self, action, reply=None):
        """A MAVLink command (arming, mode, take-off, land): ``action(commander, now)`` runs when it reaches the
        autopilot, after the command link's latency (commands are repeated until acknowledged, so they are not lost;
        while the link is lost nothing arrives and nothing answers); ``reply(result)`` gets its answer."""
        sim = self.sim
        if sim.link_lost():
            return False
        commander = self.commander

        def deliver():
            result = action(commander, sim.time)
            if reply is not None:
                reply(result)
        sim._send(deliver)
        return True

    def pilot_mode(self, mode):
        """The pilot moved the RC mode switch (the RC link is the pilot's own: no latency)."""
        return self.commander.request_mode(mode, self.sim.time, source="pilot")

    # ----- telemetry (local ENU frame, as MAVROS publishes it) ------------------------------------------------
    def estimate(self):
        """(position, velocity) of the estimate, world frame [m, m/s], and whether the position is valid."""
        if self.estimator is not None and self.estimator.ready:
            return self.estimator.position.copy(), self.estimator.velocity.copy(), \
                self.estimator.valid(self.sim.time)
        return self.sim.drone_pose()[0], self.sim.drone_velocity()[0], self.estimator is None

    def local_position(self):
        """(position in the local frame [m], velocity [m/s], valid)."""
        position, velocity, valid = self.estimate()
        origin = self.origin if self.origin is not None else position
        return position - origin, velocity, valid

    @property
    def connected_modes(self):
        """Mode, armed, guided, manual input, system status of the heartbeat."""
        c = self.commander
        return c.mode, c.armed, c.guided, c.manual_input, c.system_status

    @property
    def landed_state(self):
        return self.firmware.landed_state

    def describe(self):
        c = self.commander
        return "%s, %s, %s%s" % (c.mode, "armed" if c.armed else "disarmed",
                                 {FlightMode.LANDED: "on the ground"}.get(self.firmware.mode, self.firmware.mode.value),
                                 ", failsafe: %s" % c.failsafe if c.failsafe else "")

