"""The AR.Drone 2.0 as it behaves behind its ROS driver ardrone_autonomy, ROS-free (drone_model: ardrone2).

What a controller gets from the real drone, the inconvenient parts included:

- ``cmd_vel`` is not a velocity. The driver clips each component to [-1, 1] and the firmware reads
  linear.x / linear.y as forward / left TILT (fractions of ``euler_angle_max``), linear.z as a climb rate
  (fraction of ``control_vz_max``) and angular.z as a yaw rate (fraction of ``control_yaw``). There is no
  velocity loop: the speed is whatever the tilt buys against the drag, so euler_angle_max bounds it.
- Only a command of six exact zeros makes the firmware hover on its own: it then holds zero velocity on its
  OWN estimate (optical flow: over the moving pad that flow sees the pad's motion) and its altitude. A
  non-zero angular.x or angular.y with everything else zero turns that off: the drone holds level and
  drifts with the wind.
- Take-off climbs on its own to ``takeoff_height`` and hovers; landing descends at the firmware's own
  rate. Neither listens to cmd_vel meanwhile.
- The driver (its SDK) sends the last command again every 25 ms until a new one comes, so a controller
  that falls silent leaves the drone flying its last command. Only when no AT command reaches the drone
  (Wi-Fi lost) does the firmware's watchdog hover, and later land.
- Navdata comes at 15 Hz (navdata_demo 1) or 200 Hz (0); the driver publishes the newest one at its
  ``looprate`` ticks, never the same one twice (or each as it arrives with realtime_navdata).
- One camera streams at a time, the front one at start; a switch takes a while.

Classes: ArdroneCommand and ArdroneDriver (the driver's side of cmd_vel), ArdroneFirmware (the flight
controller, an Autopilot), NavdataSchedule (navdata rates), CameraChannel (video channel).
"""
import logging
import math

from .autopilot import Autopilot, FlightMode, body_axes

LOG = logging.getLogger("mujoco_sim.ardrone_firmware")

# ardrone_autonomy/Navdata ``state``: the upper 16 bits of the firmware's control state.
STATE_UNKNOWN, STATE_INITED, STATE_LANDED, STATE_FLYING, STATE_HOVERING = 0, 1, 2, 3, 4
STATE_TEST, STATE_TAKING_OFF, STATE_GOTO_FIX_POINT, STATE_LANDING, STATE_LOOPING = 5, 6, 7, 8, 9
# After an impact the firmware cuts the motors (emergency, a flag of the drone's state word); its control
# state goes back to the default one, 0. The driver's documentation names no emergency state, so the crashed
# drone reports 0 ("unknown") until a reset.
NAVDATA_STATE = {FlightMode.LANDED: STATE_LANDED, FlightMode.TAKING_OFF: STATE_TAKING_OFF,
                 FlightMode.FLYING: STATE_FLYING, FlightMode.LANDING: STATE_LANDING,
                 FlightMode.CRASHED: STATE_UNKNOWN}

AT_COMMAND_PERIOD_S = 0.025  # the SDK's refresh time as ardrone_autonomy sets it: commands go out at 40 Hz


class ArdroneCommand:
    """One cmd_vel as the driver keeps it: every component clipped to [-1, 1]."""

    __slots__ = ("lx", "ly", "lz", "ax", "ay", "az")

    def __init__(self, lx=0.0, ly=0.0, lz=0.0, ax=0.0, ay=0.0, az=0.0):
        self.lx, self.ly, self.lz, self.ax, self.ay, self.az = lx, ly, lz, ax, ay, az

    @property
    def hover(self):
        """Six exact zeros: the firmware's auto-hover."""
        return self.lx == 0.0 and self.ly == 0.0 and self.lz == 0.0 and \
            self.ax == 0.0 and self.ay == 0.0 and self.az == 0.0

    def as_tuple(self):
        return (self.lx, self.ly, self.lz, self.ax, self.ay, self.az)

    def __repr__(self):
        return "ArdroneCommand(%s)" % ", ".join("%g" % v for v in self.as_tuple())


HOVER_COMMAND = ArdroneCommand()
COMPONENTS = ("linear.x", "linear.y", "linear.z", "angular.x", "angular.y", "angular.z")


class ArdroneDriver:
    """The driver's side of cmd_vel: it keeps the last good command, clipped, for the SDK to send again and again.

    ``receive`` returns None when the command is taken, else why it was refused (a non-finite component: the
    whole command is refused and the previous one stays). ``clipped`` and ``refused`` count what came in."""

    def __init__(self):
        self.command = HOVER_COMMAND
        self.received = self.clipped = self.refused = 0
        self.last_problem = None

    def receive(self, values):
        self.received += 1
        values = tuple(float(v) for v in values)
        for name, value in zip(COMPONENTS, values):
            if not math.isfinite(value):
                self.refused += 1
                self.last_problem = "non-finite %s = %r: the whole command is refused and the drone keeps " \
                                    "flying the previous one %r" % (name, value, self.command)
                return self.last_problem
        clipped = tuple(max(-1.0, min(1.0, v)) for v in values)
        if clipped != values:
            self.clipped += 1
            if self.clipped == 1 or self.clipped % 100 == 0:
                LOG.warning("cmd_vel outside [-1, 1] clipped (%d so far): %s -> %s; the AR.Drone takes fractions "
                            "of euler_angle_max, control_vz_max and control_yaw, not m/s", self.clipped,
                            ", ".join("%g" % v for v in values), ", ".join("%g" % v for v in clipped))
        self.command = ArdroneCommand(*clipped)
        return None


class ArdroneFirmware(Autopilot):
    """The AR.Drone 2.0's flight controller. ``drone_params``: the ``drone`` section (loop gains, motor lag);
    ``params``: the validated ``ardrone2`` section. The simulator feeds it the AT commands that reach the drone
    (``receive_command``, ``heard``), runs ``watchdog`` every step and passes the firmware's altitude above the
    surface below (``altitude`` of ``update``) for altitude_max and altitude_min."""

    def __init__(self, drone_params, params, mass, inertia, rotors, max_rotor_thrust):
        super().__init__(drone_params, mass, inertia, rotors, max_rotor_thrust)
        self.a = params
        self.euler_angle_max = params["euler_angle_max"]
        self.tan_euler_angle_max = math.tan(params["euler_angle_max"])
        self.vz_max = params["control_vz_max"] / 1000.0
        self.yaw_rate_max = params["control_yaw"]
        self.altitude_max = params["altitude_max"] / 1000.0
        self.altitude_min = params["altitude_min"] / 1000.0
        self.command = HOVER_COMMAND   # the last command that reached the drone
        self.last_heard = 0.0          # sim time of the last AT command that reached it [s]
        self.link_lost = False         # the watchdog's hover: no command for watchdog_hover_s
        self.hovering = False          # flying on the auto-hover (state 4) rather than on commands (state 3)
        self.altitude = None           # the firmware's altitude above the surface below [m] (altd)
        self.attitude_error = (0.0, 0.0)  # its attitude estimate minus the true roll, pitch [rad]

    # ----- what reaches the drone ---------------------------------------------------------------
    def heard(self, now):
        """An AT command (any: movement, take-off, land) reached the drone at ``now`` [s]."""
        self.last_heard = now
        if self.link_lost:
            self.link_lost = False
            LOG.info("commands reach the drone again: link restored")

    def receive_command(self, command, now):
        self.command = command
        self.heard(now)

    def watchdog(self, now):
        """Without any command for watchdog_hover_s the firmware hovers; after watchdog_land_s more it lands."""
        if self.mode not in (FlightMode.FLYING, FlightMode.TAKING_OFF):
            return
        silent = now - self.last_heard
        if silent >= self.a["watchdog_hover_s"] + self.a["watchdog_land_s"]:
            self.set_mode(FlightMode.LANDING, "no command for %.1f s: link lost, landing" % silent)
        elif silent >= self.a["watchdog_hover_s"] and not self.link_lost:
            self.link_lost = True
            LOG.warning("no command for %.1f s: link lost, hovering", silent)

    # ----- modes ---------------------------------------------------------------------------------
    @property
    def takeoff_height(self):
        """The AR.Drone climbs to its own take-off height (ardrone2/takeoff_height), whatever drone: says."""
        return self.a["takeoff_height"]

    def reset(self):
        super().reset()
        self.command = HOVER_COMMAND
        self.link_lost = self.hovering = False

    @property
    def navdata_state(self):
        """The state ardrone_autonomy reports (STATE_*): 4 while auto-hovering, 3 while flying on commands."""
        if self.mode == FlightMode.FLYING:
            return STATE_HOVERING if self.hovering else STATE_FLYING
        return NAVDATA_STATE[self.mode]

    # ----- control -----------------------------------------------------------------------------
    def update(self, dt, position, velocity, quat, omega, command=None, power_available=True, altitude=None):
        """As Autopilot.update; the command is the last one received, ``altitude`` the firmware's [m]."""
        self.altitude = altitude
        return super().update(dt, position, velocity, quat, omega, command, power_available)

    def _thrusts(self, dt, position, velocity, quat, omega, command):
        # Plain floats, as Autopilot._thrusts: this runs at every physics step.
        p, a, m = self.p, self.a, self.mass
        r1, r2, r3, yaw = body_axes(quat)
        z = float(position[2])
        vx, vy, vz = (float(v) for v in velocity)
        mode = self.mode
        cmd = HOVER_COMMAND if self.link_lost else self.command

        if mode == FlightMode.TAKING_OFF:
            # Slowing down into the take-off height, then holding it.
            climb = min(a["takeoff_speed"], p["altitude_gain"] * (self.takeoff_target_z - z))
            if z >= self.takeoff_target_z - 0.02:
                self.set_mode(FlightMode.FLYING, "take-off height reached")
                mode, climb = FlightMode.FLYING, 0.0
        elif mode == FlightMode.LANDING:
            climb = -a["land_speed"]
        else:
            climb = cmd.lz * self.vz_max
        # Take-off and landing hold the position on their own, whatever cmd_vel says.
        hover = mode != FlightMode.FLYING or cmd.hover
        if hover and not self.hovering:
            self.velocity_integral[0] = self.velocity_integral[1] = 0.0
        self.hovering = hover

        # Vertical: altitude hold when the climb command is 0, between altitude_min and altitude_max.
        if self.takeoff_target_z is not None and mode == FlightMode.FLYING:
            self.z_ref, self.takeoff_target_z = self.takeoff_target_z, None
        elif self.z_ref is None or mode != FlightMode.FLYING or climb != 0.0:
            self.z_ref = z
        gain = p["altitude_gain"]
        set_z = climb + gain * (self.z_ref - z)
        if mode == FlightMode.FLYING and self.altitude is not None:
            set_z = max(gain * (self.altitude_min - self.altitude),
                        min(set_z, gain * (self.altitude_max - self.altitude)))
        limit, ki = p["velocity_integral_limit"], p["velocity_integral_gain"]
        integral = self.velocity_integral
        error_z = set_z - vz
        integral[2] = max(-limit, min(limit, integral[2] + max(-0.5, min(0.5, error_z)) * dt))
        fz = max(m * (p["vertical_velocity_gain"] * error_z + ki * integral[2] + 9.81), 0.2 * m * 9.81)

        c, s = math.cos(yaw), math.sin(yaw)
        if hover:
            # Zero velocity on the drone's own estimate, tilting at most euler_angle_max.
            error_x, error_y = -vx, -vy
            integral[0] = max(-limit, min(limit, integral[0] + max(-0.5, min(0.5, error_x)) * dt))
            integral[1] = max(-limit, min(limit, integral[1] + max(-0.5, min(0.5, error_y)) * dt))
            fx = m * (p["velocity_gain"] * error_x + ki * integral[0])
            fy = m * (p["velocity_gain"] * error_y + ki * integral[1])
            max_horizontal = fz * self.tan_euler_angle_max
            horizontal = math.hypot(fx, fy)
            if horizontal > max_horizontal:
                fx, fy = fx * max_horizontal / horizontal, fy * max_horizontal / horizontal
            yaw_rate = 0.0
        else:
            # Tilt set-points in the heading frame: pitch nose down (positive about body y, which points left)
            # to go forward, roll negative (right side up) to go left. The firmware levels them on its own
            # attitude estimate, so the true tilt is off by that estimate's error (accelerometer bias).
            pitch = cmd.lx * self.euler_angle_max - self.attitude_error[1]
            roll = -cmd.ly * self.euler_angle_max - self.attitude_error[0]
            cp, sp, cr, sr = math.cos(pitch), math.sin(pitch), math.cos(roll), math.sin(roll)
            # Body z of yaw-pitch-roll in the heading frame is (sp cr, -sr, cp cr): scaled so that the
            # vertical component of the thrust is fz.
            scale = fz / (cp * cr)
            forward, left = sp * cr * scale, -sr * scale
            fx, fy = c * forward - s * left, s * forward + c * left
            yaw_rate = cmd.az * self.yaw_rate_max
        return self._attitude_thrusts(dt, fx, fy, fz, yaw, yaw_rate, r1, r2, r3, omega)


class NavdataSchedule:
    """When the drone sends navdata and when ardrone_autonomy publishes which packet, stepped with sim time.

    The drone sends a packet every 1/15 s (navdata_demo 1) or 1/200 s (0): ``samples_due(now)``. A packet
    that the link delivers to the driver goes to ``received(packet)``: with realtime_navdata the driver
    publishes it there and then (it is returned), else it is kept, and at the driver's loop ticks (every
    1/looprate s) ``publish_due(now)`` returns the newest packet received since the last publication, or None:
    the driver publishes nothing when no newer packet came (it does not repeat one; ardrone_driver.cpp
    compares the id of the newest packet with the last published one). The navdata link's latency and losses
    (realism) sit between ``samples_due`` and ``received``."""

    DEMO_RATE_HZ, FULL_RATE_HZ = 15.0, 200.0

    def __init__(self, navdata_demo, looprate_hz, realtime_navdata, start=0.0):
        self.drone_rate_hz = self.DEMO_RATE_HZ if navdata_demo else self.FULL_RATE_HZ
        self.looprate_hz = float(looprate_hz)
        self.realtime = bool(realtime_navdata)
        self.start = start
        self.sent = self.loops = 0              # packets sent and loop ticks so far
        self.received_count = self.published = 0
        self._newest = None
        self._newest_id = self._published_id = 0

    def _next(self, count, rate):
        # From the start by whole periods, so that the rate does not drift with rounding.
        return self.start + count / rate

    @property
    def next_sample(self):
        return self._next(self.sent, self.drone_rate_hz)

    def samples_due(self, now):
        """How many packets the drone has sent by ``now`` [s] since the last call: 0 or 1 when called at every
        physics step (more only when called less often than the drone's rate; the state is the same for all)."""
        due = 0
        while now + 1e-9 >= self._next(self.sent, self.drone_rate_hz):
            self.sent += 1
            due += 1
        return due

    def received(self, packet):
        """A packet reached the driver. Returns it when the driver publishes it right away (realtime_navdata)."""
        self.received_count += 1
        self._newest = packet
        self._newest_id += 1
        if self.realtime:
            self._published_id = self._newest_id
            self.published += 1
            return packet
        return None

    def publish_due(self, now):
        """At a loop tick of the driver, the newest packet if newer than the last published one, else None."""
        if now + 1e-9 < self._next(self.loops, self.looprate_hz):
            return None
        while now + 1e-9 >= self._next(self.loops, self.looprate_hz):
            self.loops += 1
        if self.realtime or self._newest_id == self._published_id:
            return None
        self._published_id = self._newest_id
        self.published += 1
        return self._newest


class CameraChannel:
    """Which camera the AR.Drone 2.0 streams: 0 front (where it starts), 1 bottom; one at a time.

    ``clock`` returns sim time [s]. After a switch the drone streams nothing until ``switch_delay_s`` has
    passed (the encoder restarts and the decoder waits for the new stream's first key frame); the simulator
    renders only the bottom camera, so bottom frames are due only while ``bottom_streaming``."""

    FRONT, BOTTOM = 0, 1
    NAMES = {FRONT: "front", BOTTOM: "bottom"}

    def __init__(self, switch_delay_s, clock, channel=FRONT):
        self.switch_delay_s = float(switch_delay_s)
        self._clock = clock
        self.channel = self._checked(channel)
        self.streaming_from = -math.inf  # sim time of the first frame of the present channel [s]
        self.switches = 0

    @classmethod
    def _checked(cls, channel):
        if isinstance(channel, bool) or channel not in cls.NAMES:
            raise ValueError("camera channel %r: expected 0 (front) or 1 (bottom)" % (channel,))
        return int(channel)

    def select(self, channel):
        """Switch to ``channel`` (0 front, 1 bottom); selecting the present one changes nothing."""
        channel = self._checked(channel)
        if channel != self.channel:
            self.channel = channel
            self.streaming_from = self._clock() + self.switch_delay_s
            self.switches += 1
            LOG.info("camera channel -> %d (%s), streaming from t=%.3f s", channel, self.NAMES[channel],
                     self.streaming_from)
        return self.channel

    def toggle(self):
        return self.select(1 - self.channel)

    @property
    def streaming(self):
        """Whether the selected camera's frames are coming (the switch is over)."""
        return self._clock() + 1e-9 >= self.streaming_from

    @property
    def bottom_streaming(self):
        return self.channel == self.BOTTOM and self.streaming
