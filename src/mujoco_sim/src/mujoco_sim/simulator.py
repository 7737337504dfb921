"""The simulated world, ROS-free: physics, autopilot, vehicle drive, wind, battery, sensors, camera.

Everything random draws from generators derived from one seed, so a run is reproducible. How real the
sensors and the drone's own firmware are is the realism profile (realism.py, config/sim.yaml): biases,
drifting GPS errors, sonar outliers, lens, light and exposure, the firmware flying on its own estimate
and the command link's latency and losses are modelled here; the latency of what the drone sends (camera,
navdata, GPS) is the node's, which publishes late.
"""
import logging
import math
import os

import numpy as np

from landing_runtime import camera_footprint
from landing_runtime.geometry import yaw_from_quaternion

from .ardrone_firmware import ArdroneDriver, ArdroneFirmware, CameraChannel, NavdataSchedule
from .ardrone_navdata import navdata_fields
from .autopilot import HOLD, Autopilot, FlightMode, VelocityCommand, quat_to_matrix
from .config import ConfigError
from .environment import Battery, Wind, aerodynamic_force
from .firmware import FirmwareEstimator
from .frame_renderer import FRAME_TIMEOUT_S, FrameRenderer
from .pads import FOREIGN_PAD_BODY, FOREIGN_PAD_OFFSET, check_pad, compile_world
from .px4_firmware import Px4Firmware
from .px4_world import Px4World, configure_airframe
from .realism import DelayLine, Dropouts, GaussMarkov, RandomWalk

LOG = logging.getLogger("mujoco_sim.simulator")

SURFACE_PAD, SURFACE_GROUND, SURFACE_VEHICLE = 1, 2, 3
SURFACE_NAMES = {SURFACE_PAD: "pad", SURFACE_GROUND: "ground", SURFACE_VEHICLE: "vehicle"}
# Optical frame (x right, y down, z forward) of the MuJoCo bottom camera, in the drone body frame.
CAMERA_OPTICAL_IN_BODY = np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
FOOT_CLEARANCE = 0.065  # base_link height above the surface the drone stands on [m]
SONAR_FIELD_OF_VIEW_RAD = 0.35  # the beam published in sensor_msgs/Range (the AR.Drone's 40 kHz sonar, about 20 deg);
#                                 the range itself is of the first surface along the body's -z axis
DRONE_GEOM_GROUP = 3    # the drone's own geoms, hidden from its bottom camera (it cannot see them) unless they
                        # must cast their shadow
# Random processes, each with its own generator derived from the seed (the first eight are the original ones).
RNG_STREAMS = ("imu", "sonar", "altimeter", "gps", "camera", "wind", "vehicle_gps", "flow",
               "imu_bias", "gps_error", "vehicle_gps_error", "gps_dropouts", "sonar_outlier", "command_link",
               "light", "exposure", "flow_scale", "camera_link", "navdata_link", "gps_link", "vehicle_odom")


def classify_touchdown(surface, impact_speed, tilt_deg, crash_speed, crash_tilt_deg):
    """(surface, crashed) for a first contact: a crash when it hit too fast or too tilted."""
    return surface, bool(impact_speed > crash_speed or tilt_deg > crash_tilt_deg)


class Touchdown:
    """What the simulator measured at the first contact of a landing (ground truth, for scoring)."""

    def __init__(self, time, surface, crashed, impact_speed, tilt_deg, position, pad_error):
        self.time, self.surface, self.crashed = time, surface, crashed
        self.impact_speed, self.tilt_deg = impact_speed, tilt_deg
        self.position, self.pad_error = position, pad_error

    def describe(self):
        return "%s on the %s at t=%.2f s: impact %.2f m/s, tilt %.1f deg, %.3f m from the pad centre" % (
            "crash" if self.crashed else "touchdown", SURFACE_NAMES[self.surface], self.time,
            self.impact_speed, self.tilt_deg, self.pad_error)


def load_model(model_file, pad="red_square"):
    """Load an MJCF file with the landing pad's face ``pad`` (pads.PADS: red_square as in the file, or apriltag);
    a missing or malformed file, or an unknown pad, raises ConfigError naming it."""
    import mujoco
    if not os.path.isfile(model_file):
        raise ConfigError("%s: model file not found" % model_file)
    check_pad(pad, "%s: pad" % model_file)
    try:
        model = compile_world(model_file, pad)
    except ValueError as err:
        raise ConfigError("%s: cannot load the MuJoCo model: %s" % (model_file, err)) from err
    required = {"body": ["ardrone", "vehicle"], "geom": ["landing_pad", "ground"],
                "site": ["landing_pad_centre", "ardrone_imu"], "camera": ["bottom_camera"],
                "actuator": ["rotor_fl", "rotor_fr", "rotor_rl", "rotor_rr", "vehicle_vx", "vehicle_vy", "vehicle_wz"]}
    for kind, names in required.items():
        for name in names:
            if mujoco.mj_name2id(model, getattr(mujoco.mjtObj, "mjOBJ_" + kind.upper()), name) < 0:
                raise ConfigError("%s: the model has no %s named '%s', which the simulator needs" % (
                    model_file, kind, name))
    return model


class Simulator:
    """One world. ``config`` is the validated simulator configuration (see config/sim.yaml)."""

    def __init__(self, config, model_file, vehicle, seed):
        import mujoco
        self._mj = mujoco
        self.cfg = config
        self.pad = config.get("pad", "red_square")  # the pad's face (pads.PADS)
        self.model = load_model(model_file, self.pad)
        self.data = mujoco.MjData(self.model)
        self.vehicle_cfg = config["vehicles"][vehicle]
        m = self.model
        name2id = lambda kind, name: mujoco.mj_name2id(m, kind, name)  # noqa: E731
        obj = mujoco.mjtObj
        self.drone_body = name2id(obj.mjOBJ_BODY, "ardrone")
        self.vehicle_body = name2id(obj.mjOBJ_BODY, "vehicle")
        self.pad_geom = name2id(obj.mjOBJ_GEOM, "landing_pad")
        self.ground_geom = name2id(obj.mjOBJ_GEOM, "ground")
        self.pad_site = name2id(obj.mjOBJ_SITE, "landing_pad_centre")
        self.camera = name2id(obj.mjOBJ_CAMERA, "bottom_camera")
        self.rotor_actuators = [name2id(obj.mjOBJ_ACTUATOR, n) for n in ("rotor_fl", "rotor_fr", "rotor_rl", "rotor_rr")]
        self.vehicle_actuators = [name2id(obj.mjOBJ_ACTUATOR, n) for n in ("vehicle_vx", "vehicle_vy", "vehicle_wz")]
        self.rotor_ctrl = _as_slice(self.rotor_actuators)      # slices write faster than index lists
        self.vehicle_ctrl = _as_slice(self.vehicle_actuators)
        self.drone_qpos = m.jnt_qposadr[m.body_jntadr[self.drone_body]]
        self.drone_qvel = m.jnt_dofadr[m.body_jntadr[self.drone_body]]
        self.vehicle_qpos = m.jnt_qposadr[m.body_jntadr[self.vehicle_body]]  # x, y, yaw in a row
        self.vehicle_qvel = m.jnt_dofadr[m.body_jntadr[self.vehicle_body]]
        self.accel_adr = m.sensor_adr[name2id(obj.mjOBJ_SENSOR, "ardrone_accel")]
        self.gyro_adr = m.sensor_adr[name2id(obj.mjOBJ_SENSOR, "ardrone_gyro")]
        self.pad_size = 2.0 * float(m.geom_size[self.pad_geom][0])
        false_target = name2id(obj.mjOBJ_BODY, "false_target")
        self.false_target_mocap = int(m.body_mocapid[false_target]) if false_target >= 0 else -1
        self.false_target_until = -1.0
        # The AprilTag pad's world also has a foreign pad (other tag ids), beside the vehicle with the false target.
        foreign_pad = name2id(obj.mjOBJ_BODY, FOREIGN_PAD_BODY)
        self.foreign_pad_mocap = int(m.body_mocapid[foreign_pad]) if foreign_pad >= 0 else -1
        self.camera_blackout_until = -1.0

        # One generator per process, so that a new effect never shifts the draws of an older one.
        streams = np.random.SeedSequence(seed).spawn(len(RNG_STREAMS))
        self.rng = {name: np.random.default_rng(s) for name, s in zip(RNG_STREAMS, streams)}
        self.noise = config["noise"] if config["noise"]["enabled"] else None
        self.realism_profile = config["realism"]["profile"]
        self.realism = config["realism"]["values"]

        drone = config["drone"]
        if config["drone_model"] == "px4_quad":  # a 1.5-2 kg airframe: mass, inertia, arms and rotors from px4_quad:
            configure_airframe(mujoco, m, self.data, self.drone_body, self.rotor_actuators, config["px4_quad"])
        rotors = []
        for act in self.rotor_actuators:
            site = m.actuator_trnid[act][0]
            x, y = m.site_pos[site][:2]
            rotors.append((float(x), float(y), float(m.actuator_gear[act][5])))
        mass = float(m.body_mass[self.drone_body])
        max_rotor_thrust = float(m.actuator_ctrlrange[self.rotor_actuators[0]][1])
        # The drone model: the velocity-commanded quadrotor, or the AR.Drone 2.0 behind its driver (tilt commands,
        # auto-hover, watchdog, navdata and camera channel as the real one has them).
        self.drone_model = config["drone_model"]
        self.ardrone = self.drone_model == "ardrone2"
        self.px4 = self.drone_model == "px4_quad"  # PX4 behind MAVROS (px4_firmware, px4_world)
        self.px4_world = None
        self.ardrone_driver = self.camera_channel = self.navdata_schedule = None
        if self.ardrone:
            a = config["ardrone2"]
            self.autopilot = ArdroneFirmware(drone, a, mass, m.body_inertia[self.drone_body].copy(), rotors,
                                             max_rotor_thrust)
            self.ardrone_driver = ArdroneDriver()
            self.camera_channel = CameraChannel(a["camera_switch_delay_s"], lambda: self.time, a["video_channel"])
            self.navdata_schedule = NavdataSchedule(a["navdata_demo"], a["looprate"], a["realtime_navdata"])
            self.rotor_drag = a["rotor_drag"]
            self.altd_scale = 1000.0 if a["altd_unit"] == "mm" else 100.0  # navdata altd per metre
            self.next_at_command = 0.0   # when the driver's SDK sends the stored command again [s]
            self.surface_z = 0.0         # height of the surface below (ideal firmware's altitude) [m]
            self.surface_due = 0.0
        elif self.px4:
            self.autopilot = Px4Firmware(drone, config["px4_quad"], mass, m.body_inertia[self.drone_body].copy(),
                                         rotors, max_rotor_thrust)
            self.rotor_drag = config["px4_quad"]["rotor_drag"]
        else:
            self.autopilot = Autopilot(drone, mass, m.body_inertia[self.drone_body].copy(), rotors, max_rotor_thrust)
        self.link_lost_until = -1.0
        self.max_total_thrust = 4 * self.autopilot.max_rotor_thrust
        self.command = HOLD
        self.command_time = -1e9
        self.wind = Wind(self.rng["wind"], gust_time_constant=config["wind"]["gust_time_constant"])
        bat = config["battery"]
        self.battery = Battery(bat["initial_percent"], bat["idle_drain"], bat["thrust_drain"],
                               bat["cold_reference_temp"], bat["cold_factor_per_deg"])
        self.temperature = config["conditions"]["temp"]
        self.drag_area = np.array([drone["drag_area_horizontal"]] * 2 + [drone["drag_area_vertical"]])
        if self.px4:
            px4 = config["px4_quad"]
            self.drag_area = np.array([px4["drag_area_horizontal"]] * 2 + [px4["drag_area_vertical"]])

        self.vehicle_target = (0.0, 0.0)      # commanded (v, omega)
        self.vehicle_command = [0.0, 0.0]     # after acceleration limits
        self.vehicle_command_time = -1e9
        self.wheel_angles = [0.0, 0.0, 0.0, 0.0]
        self.touchdown = None                 # last Touchdown
        self.touchdowns = []
        self._takeoff_z = None
        self._renderer = None
        self.camera_frame = None
        self.camera_fovy = float(m.cam_fovy[self.camera])  # of the published image; the render may be wider
        self.vehicle_rectangle = _textured_top_rectangle(m, self.pad_geom)
        self._init_realism()
        if self.px4:
            self.px4_world = Px4World(self, config["px4_quad"])
        self._place_at_start()

    def _init_realism(self):
        r, rng = self.realism, self.rng
        self.gyro_bias = RandomWalk(rng["imu_bias"], r["gyro_bias_initial_std"], r["gyro_bias_walk"], 3)
        self.accel_bias = RandomWalk(rng["imu_bias"], r["accel_bias_initial_std"], r["accel_bias_walk"], 3)
        self.yaw_drift_rate = r["yaw_drift_rate_std"] * rng["imu_bias"].standard_normal()
        self.yaw_drift_walk = RandomWalk(rng["imu_bias"], 0.0, r["yaw_drift_walk"])
        self.biases_time = 0.0
        self.gps_error = GaussMarkov(rng["gps_error"], r["gps_error_std"], r["gps_error_time_constant_s"], 3)
        self.vehicle_gps_error = GaussMarkov(rng["vehicle_gps_error"], r["gps_error_std"],
                                             r["gps_error_time_constant_s"], 2)
        self.gps_error_time = self.vehicle_gps_error_time = 0.0
        self.gps_outage = Dropouts(rng["gps_dropouts"], r["gps_dropouts_per_min"], r["gps_dropout_duration_s"])
        self.vehicle_gps_outage = Dropouts(rng["gps_dropouts"], r["gps_dropouts_per_min"], r["gps_dropout_duration_s"])
        self.command_link = DelayLine(rng["command_link"], r["command_latency_s"], r["command_latency_jitter_s"],
                                      r["command_loss_rate"])
        # What the drone sends: the node publishes through these (stamped when measured, released late).
        self.camera_link = DelayLine(rng["camera_link"], r["camera_latency_s"], r["camera_latency_jitter_s"],
                                     r["camera_drop_rate"])
        self.navdata_link = DelayLine(rng["navdata_link"], r["navdata_latency_s"], r["navdata_latency_jitter_s"],
                                      r["navdata_drop_rate"])
        self.gps_link = DelayLine(rng["gps_link"], r["gps_latency_s"])
        self.flow_scale = 1.0 + r["flow_scale_error_std"] * rng["flow_scale"].standard_normal()
        # (px4_quad flies on its own estimator: px4_world)
        self.firmware = FirmwareEstimator(self.cfg["firmware"]) if r["firmware_on_estimate"] and not self.px4 else None
        self.firmware_schedule = {"flow": 0.0, "sonar": 0.0}
        self.surface_weight = 0.0  # how much the optical flow follows the vehicle (flow_surface_coupling)
        # The sun: direction from its elevation and azimuth, each drawn within its spread from the seed.
        light = rng["light"]
        elevation = math.radians(min(90.0, r["sun_elevation_deg"] + r["sun_elevation_spread_deg"] *
                                     light.uniform(-1.0, 1.0)))
        azimuth = math.radians(r["sun_azimuth_deg"] + r["sun_azimuth_spread_deg"] * light.uniform(-1.0, 1.0))
        towards_sun = np.array([math.cos(elevation) * math.cos(azimuth), math.cos(elevation) * math.sin(azimuth),
                                math.sin(elevation)])
        self.sun_direction = -towards_sun
        m, sun = self.model, self._mj.mj_name2id(self.model, self._mj.mjtObj.mjOBJ_LIGHT, "sun")
        if sun >= 0:
            # A light of mode 'track' is placed from light_dir0 and light_pos0 (its offset from the body), the
            # others from light_dir and light_pos: set both. 1 m back towards the sun: the drone is inside the
            # shadow map's depth.
            m.light_dir[sun] = m.light_dir0[sun] = self.sun_direction
            m.light_pos[sun] = m.light_pos0[sun] = towards_sun
            m.light_diffuse[sun] = r["sun_intensity"]
            m.light_castshadow[sun] = r["shadows"]
        m.vis.headlight.active = int(r["ambient_light"] > 0.0)
        m.vis.headlight.ambient[:] = r["ambient_light"]
        m.vis.quality.shadowsize = self.cfg["camera"]["shadow_map_size"] if r["shadows"] else 0
        m.vis.map.shadowclip = self.cfg["camera"]["shadow_clip_m"] / max(1e-6, float(m.stat.extent))

    # ----- set-up ------------------------------------------------------------------------------
    def _place_at_start(self):
        mj, m, d = self._mj, self.model, self.data
        mj.mj_resetData(m, d)
        vx, vy, vyaw = self.cfg["vehicle_start"]["x"], self.cfg["vehicle_start"]["y"], self.cfg["vehicle_start"]["yaw_deg"]
        d.qpos[self.vehicle_qpos:self.vehicle_qpos + 3] = (vx, vy, math.radians(vyaw))
        mj.mj_forward(m, d)
        start = self.cfg["drone"]
        if start["start_on_pad"]:
            self._put_drone_on_pad()
            self.autopilot.reset()
        else:
            x, y, z = start["start_position"]
            self._set_drone_pose((x, y, z), yaw=math.radians(start["start_yaw_deg"]))
            if z > FOOT_CLEARANCE + 0.3:
                self.autopilot.set_mode(FlightMode.FLYING, "started in the air")
        mj.mj_forward(m, d)

    def _put_drone_on_pad(self):
        pad = self.data.site_xpos[self.pad_site]
        yaw = float(self.data.qpos[self.vehicle_qpos + 2])
        self._set_drone_pose((pad[0], pad[1], pad[2] + FOOT_CLEARANCE + 0.001), yaw)
        self.data.qvel[self.drone_qvel:self.drone_qvel + 2] = self.data.qvel[self.vehicle_qvel:self.vehicle_qvel + 2]

    def _set_drone_pose(self, position, yaw):
        q = self.drone_qpos
        self.data.qpos[q:q + 3] = position
        self.data.qpos[q + 3:q + 7] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
        self.data.qvel[self.drone_qvel:self.drone_qvel + 6] = 0.0

    # ----- commands ----------------------------------------------------------------------------
    @property
    def time(self):
        return float(self.data.time)

    @property
    def dt(self):
        """Physics step [s]."""
        return float(self.model.opt.timestep)

    def set_velocity_command(self, vx, vy, vz, yaw_rate):
        """Returns None when accepted, else why the command was ignored (the drone then holds). An accepted
        command reaches the drone after the command link's latency, or is lost (realism)."""
        if self.ardrone or self.px4:
            raise RuntimeError("set_velocity_command needs drone_model velocity_quad (this world flies %s: use %s)" % (
                self.drone_model, "set_ardrone_command" if self.ardrone else "px4_world's set-points and commands"))
        problem = VelocityCommand.problem((vx, vy, vz, yaw_rate))
        if problem:
            self._send(self._hold)
            return problem
        if self.time < self.link_lost_until:
            return None
        if self.command_link.loss > 0.0 and self.command_link.lost_next():
            return None
        self._send(lambda: self._apply_velocity_command(VelocityCommand(vx, vy, vz, yaw_rate)))
        return None

    def set_ardrone_command(self, lx, ly, lz, ax, ay, az):
        """drone_model ardrone2: a cmd_vel reached the driver (linear x, y, z, angular x, y, z; see
        ardrone_firmware). Returns None when the driver took it (components outside [-1, 1] clipped: counted in
        ardrone_driver.clipped), else why it refused it (a non-finite component; the previous command stays).
        The driver's SDK sends the kept command to the drone every 1/driver_resend_hz s, over the command link
        (latency, losses); with driver_resend_hz 0 it is sent once, now."""
        if not self.ardrone:
            raise RuntimeError("set_ardrone_command needs drone_model ardrone2 (this world flies %s: "
                               "use set_velocity_command)" % self.drone_model)
        problem = self.ardrone_driver.receive((lx, ly, lz, ax, ay, az))
        if problem is None and self.cfg["ardrone2"]["driver_resend_hz"] <= 0.0:
            self._send_ardrone_command()
        return problem

    def _send_ardrone_command(self):
        """One AT command with the driver's kept command, over the command link (it may be lost)."""
        if self.time < self.link_lost_until:
            return
        if self.command_link.loss > 0.0 and self.command_link.lost_next():
            return
        command = self.ardrone_driver.command
        self._send(lambda: self.autopilot.receive_command(command, self.time))

    def _hold(self):
        self.command = HOLD

    def _apply_velocity_command(self, command):
        self.command = command
        self.command_time = self.time

    def _send(self, action):
        """Over the command link: now, or once its latency has passed (in step)."""
        if self.command_link.latency <= 0.0 and self.command_link.jitter <= 0.0:
            return action()
        self.command_link.push(self.time, action)
        return True

    def set_vehicle_command(self, speed, yaw_rate):
        problem = VelocityCommand.problem((speed, yaw_rate))
        if problem:
            self.vehicle_target = (0.0, 0.0)
            return problem
        self.vehicle_target = (speed, yaw_rate)
        self.vehicle_command_time = self.time
        return None

    def takeoff(self):
        """Take-off command; True when the drone took it (or, with a command latency, when it was sent)."""
        return self._send(self._takeoff)

    def _takeoff(self):
        if self.px4:
            LOG.warning("ardrone/takeoff ignored: drone_model px4_quad takes off through MAVROS (px4_world)")
            return False
        if self.battery.empty:
            LOG.warning("take-off refused: the battery is empty")
            return False
        z = float(self.data.qpos[self.drone_qpos + 2])
        # The climb is measured as the autopilot sees the height: its own estimate, if it flies on it.
        flown_z = self.firmware.height if self.firmware is not None and self.firmware.ready else z
        if self.ardrone:
            self.autopilot.heard(self.time)
        if self.autopilot.takeoff(flown_z):
            self._takeoff_z = z
            self.touchdown = None
            return True
        return False

    def land(self):
        return self._send(self._land)

    def _land(self):
        if self.px4:
            LOG.warning("ardrone/land ignored: drone_model px4_quad lands through MAVROS (px4_world)")
            return False
        if self.ardrone:
            self.autopilot.heard(self.time)
        return self.autopilot.land()

    def reset(self):
        """Back to the start, motors off, as after /ardrone/reset."""
        return self._send(self._reset)

    def _reset(self):
        self.autopilot.reset()
        if self.px4:
            self.px4_world.reset()
        self.touchdown = None
        if self.cfg["drone"]["start_on_pad"]:
            self._put_drone_on_pad()
        else:
            x, y, z = self.cfg["drone"]["start_position"]
            self._set_drone_pose((x, y, z), math.radians(self.cfg["drone"]["start_yaw_deg"]))
        self._mj.mj_forward(self.model, self.data)

    def set_conditions(self, wind_speed=None, wind_direction_deg=None, gust_mps=None, temp=None, battery=None):
        if wind_speed is not None:
            self.wind.speed = wind_speed
        if wind_direction_deg is not None:
            self.wind.direction_deg = wind_direction_deg
        if gust_mps is not None:
            self.wind.gust_mps = gust_mps
        if temp is not None:
            self.temperature = temp
        if battery is not None:
            self.battery.level = battery

    # ----- stepping ----------------------------------------------------------------------------
    def step(self):
        m, d = self.model, self.data
        dt = m.opt.timestep
        qp, qv = self.drone_qpos, self.drone_qvel
        position = d.qpos[qp:qp + 3]
        quat = d.qpos[qp + 3:qp + 7]
        velocity = d.qvel[qv:qv + 3].copy()
        omega = d.qvel[qv + 3:qv + 6]  # free joint angular velocity is in the body frame

        now = float(d.time)
        if self.command_link.pending:
            for action in self.command_link.due(now):
                action()
        if now - self.command_time > self.cfg["drone"]["command_timeout"]:
            self.command = HOLD
        if self.ardrone:
            self._driver_and_watchdog_step(now)
        self.wind.step(dt)
        airborne = self.autopilot.airborne_control
        if airborne or position[2] > 0.3:
            wind = self.wind.velocity()
            force = aerodynamic_force(wind, velocity, self.drag_area)
            if (self.ardrone or self.px4) and airborne:
                # Rotor drag, proportional to the air speed, while the rotors turn (horizontal, in the world frame: at
                # the firmware's tilts the rotor plane is within 30 deg of level).
                force[:2] -= self.rotor_drag * (velocity[:2] - wind[:2])
            d.xfrc_applied[self.drone_body, :3] = force
        else:
            d.xfrc_applied[self.drone_body, :3] = 0.0
        if self.px4:
            mode_before = self.autopilot.mode
            flown_position, flown_velocity = self.px4_world.step(now, dt, quat)
        elif self.firmware is not None:
            flown_position, flown_velocity = self._firmware_step(now, dt, quat)
        else:
            flown_position, flown_velocity = position, velocity
        if self.ardrone:
            thrusts = self.autopilot.update(dt, flown_position, flown_velocity, quat, omega,
                                            power_available=not self.battery.empty,
                                            altitude=self._firmware_altitude(now, position, quat))
        else:
            thrusts = self.autopilot.update(dt, flown_position, flown_velocity, quat, omega, self.command,
                                            power_available=not self.battery.empty)
        d.ctrl[self.rotor_ctrl] = thrusts
        if self.px4 and self.autopilot.mode == FlightMode.TAKING_OFF and mode_before != FlightMode.TAKING_OFF:
            self._takeoff_z = float(position[2])  # (a take-off of PX4's own: the contact check's reference)
            self.touchdown = None
        self._drive_vehicle(dt, now)
        if self.false_target_mocap >= 0:
            self._place_false_target(now)
        # mj_step computes positions (xpos, sites, contacts, the rendered scene) before it integrates, so after it
        # they lag qpos and the clock by a step: the pad's ground truth lagged the drone's by 4 ms, 6 cm at 15 m/s.
        # The second half of this step, then the first half of the next one, gives the same motion with every
        # derived quantity at the new time (mj_forward after any pose is set puts the first half in place).
        self._mj.mj_step2(m, d)
        self._mj.mj_step1(m, d)
        thrust_fraction = float(thrusts.sum()) / self.max_total_thrust
        self.battery.step(dt, thrust_fraction, self.temperature, motors_on=airborne)
        if d.ncon:
            self._check_contacts(velocity)

    def _driver_and_watchdog_step(self, now):
        """drone_model ardrone2: the driver's SDK sends its kept command again; the firmware's watchdog."""
        rate = self.cfg["ardrone2"]["driver_resend_hz"]
        if rate > 0.0 and now + 1e-9 >= self.next_at_command:
            self.next_at_command = max(self.next_at_command + 1.0 / rate, now)
            self._send_ardrone_command()
        self.autopilot.watchdog(now)
        bias_x, bias_y, _ = self.accel_bias.value.tolist()
        # The firmware levels on its attitude estimate, which the accelerometer's bias tilts (see imu()).
        self.autopilot.attitude_error = (bias_y / 9.81, -bias_x / 9.81)

    def _firmware_altitude(self, now, position, quat):
        """The AR.Drone firmware's altitude (navdata altd) [m]: its feet above the surface below. On its own
        estimate (realism: firmware_on_estimate), else the true height above the surface a ray finds at the
        sonar's rate."""
        if self.firmware is not None:
            return None if self.firmware.height is None else self.firmware.height - FOOT_CLEARANCE
        z = float(position[2])
        if now + 1e-9 >= self.surface_due:
            self.surface_due = now + 1.0 / self.cfg["rates"]["sonar_hz"]
            rotation = quat_to_matrix(quat)
            distance = self.sonar_distance_true(position, rotation)
            if math.isfinite(distance):
                self.surface_z = z - distance * float(rotation[2, 2])
        return z - self.surface_z - FOOT_CLEARANCE

    def ardrone_altitude(self):
        """drone_model ardrone2: the firmware's altitude above the surface below [m] (navdata altd in metres)."""
        if self.firmware is not None:
            height = self.firmware.height
            return 0.0 if height is None else height - FOOT_CLEARANCE
        return float(self.data.qpos[self.drone_qpos + 2]) - self.surface_z - FOOT_CLEARANCE

    def ardrone_navdata(self):
        """drone_model ardrone2: the fields of ardrone_autonomy/Navdata as the driver fills them, in its units
        (a dict by field name; see ardrone_navdata.navdata_fields)."""
        return navdata_fields(self)

    def _firmware_step(self, now, dt, quat):
        """The on-board estimate the autopilot flies on: (position with the estimated height above the
        surface below as z, estimated velocity)."""
        fw, r = self.firmware, self.realism
        rotation = quat_to_matrix(quat)
        self._step_biases(now)
        specific_force = self.data.sensordata[self.accel_adr:self.accel_adr + 3] + self.accel_bias.value + \
            self._noise("imu", (self.noise or {}).get("imu_accel_std", 0), 3)
        fw.predict(dt, rotation @ specific_force - np.array([0.0, 0.0, 9.81]))
        schedule = self.firmware_schedule
        if now >= schedule["sonar"]:
            period = 1.0 / self.cfg["rates"]["sonar_hz"]
            schedule["sonar"] = now + period
            distance = self.sonar()
            height = (distance + FOOT_CLEARANCE) * max(0.5, rotation[2, 2]) if math.isfinite(distance) else None
            step = fw.sonar(now, period, height, self.altimeter()[0])
            if step:
                self.autopilot.shift_altitude_reference(step)
        if now >= schedule["flow"]:
            period = 1.0 / self.cfg["firmware"]["flow_rate_hz"]
            schedule["flow"] = now + period
            fw.flow(period, self._flow_measurement(rotation))
        position = self.data.qpos[self.drone_qpos:self.drone_qpos + 3].copy()
        position[2] = fw.height if fw.height is not None else position[2]
        return position, np.array([fw.velocity[0], fw.velocity[1], fw.climb])

    def _flow_measurement(self, rotation):
        """World-frame horizontal velocity the optical flow measures: relative to what the camera sees
        (flow_surface_coupling), scaled by the run's scale error, noisy."""
        velocity, _ = self.drone_velocity()
        measured = velocity[:2].copy()
        if self.realism["flow_surface_coupling"]:
            self.surface_weight = self._surface_weight(rotation)
            if self.surface_weight > 0.0:
                measured -= self.surface_weight * np.array(self.vehicle_velocity()[:2])
        std = (self.noise or {}).get("flow_velocity_std", 0)
        return measured * self.flow_scale + self._noise("flow", std, 2)

    def _surface_weight(self, rotation):
        """How much the optical flow follows the vehicle: by the share of the camera's view its top covers."""
        camera_position, _ = self.camera_pose_in_body()
        position, _ = self.drone_pose()
        width, height, fx, _, _, _ = self.camera_intrinsics()
        rays = camera_footprint.corner_rays(math.degrees(2.0 * math.atan(width / 2.0 / fx)), width / height)
        corners = camera_footprint.footprint(position + rotation @ camera_position, rotation @ CAMERA_OPTICAL_IN_BODY,
                                             rays, float(self.data.site_xpos[self.pad_site][2]))
        x, y, yaw = self.vehicle_pose()
        if corners is None:  # at or below the vehicle's top: on it, or beside it
            share = float(self._over_vehicle(position))
        else:
            share = camera_footprint.coverage(corners, (x, y), yaw, self.vehicle_rectangle)
        f = self.cfg["firmware"]
        return camera_footprint.surface_weight(share, f["coverage_low"], f["coverage_high"])

    def _step_biases(self, now, period=0.02):
        """Move the IMU biases and the yaw drift on to ``now``, at most every ``period`` [s]: they wander over
        seconds, and drawing them at every physics step cost 10 us of its 100."""
        dt = now - self.biases_time
        if dt >= period:
            self.gyro_bias.step(dt)
            self.accel_bias.step(dt)
            self.yaw_drift_walk.step(dt)
            self.biases_time = now

    def _drive_vehicle(self, dt, now):
        vc = self.vehicle_cfg
        if now - self.vehicle_command_time > vc["command_timeout"]:
            self.vehicle_target = (0.0, 0.0)
        target_v = max(-vc["max_speed"], min(vc["max_speed"], self.vehicle_target[0]))
        target_w = max(-vc["max_yaw_rate"], min(vc["max_yaw_rate"], self.vehicle_target[1]))
        v, w = self.vehicle_command
        v += max(-vc["max_accel"] * dt, min(vc["max_accel"] * dt, target_v - v))
        w += max(-vc["max_yaw_accel"] * dt, min(vc["max_yaw_accel"] * dt, target_w - w))
        self.vehicle_command = [v, w]
        yaw = float(self.data.qpos[self.vehicle_qpos + 2])
        self.data.ctrl[self.vehicle_ctrl] = (v * math.cos(yaw), v * math.sin(yaw), w)
        half_track = vc["track_width"] / 2
        left, right = (v - w * half_track) / vc["wheel_radius"], (v + w * half_track) / vc["wheel_radius"]
        angles = self.wheel_angles
        angles[0] += dt * left
        angles[1] += dt * right
        angles[2] += dt * left
        angles[3] += dt * right

    def _check_contacts(self, velocity_before):
        mode = self.autopilot.mode
        if mode not in (FlightMode.TAKING_OFF, FlightMode.FLYING, FlightMode.LANDING):
            return
        d, m = self.data, self.model
        z = float(d.qpos[self.drone_qpos + 2])
        if mode == FlightMode.TAKING_OFF and z < self._takeoff_z + 0.15:
            return  # still leaving the surface it took off from
        surface = None
        for i in range(d.ncon):
            g1, g2 = d.contact.geom1[i], d.contact.geom2[i]
            b1, b2 = m.geom_bodyid[g1], m.geom_bodyid[g2]
            if self.drone_body not in (b1, b2):
                continue
            other = g2 if b1 == self.drone_body else g1
            if other == self.pad_geom:
                surface = SURFACE_PAD
            elif other == self.ground_geom:
                surface = surface or SURFACE_GROUND
            elif surface is None:
                surface = SURFACE_VEHICLE
        if surface is None:
            return
        relative = velocity_before.copy()
        if surface != SURFACE_GROUND:
            relative[:2] -= d.qvel[self.vehicle_qvel:self.vehicle_qvel + 2]
        impact = float(np.linalg.norm(relative))
        rotation = quat_to_matrix(d.qpos[self.drone_qpos + 3:self.drone_qpos + 7])
        tilt = math.degrees(math.acos(max(-1.0, min(1.0, rotation[2, 2]))))
        limits = self.cfg["touchdown"]
        surface, crashed = classify_touchdown(surface, impact, tilt, limits["crash_speed"], limits["crash_tilt_deg"])
        if self.ardrone:
            if not crashed and mode != FlightMode.LANDING:
                return  # the AR.Drone touches down only after the land command: else it flies on (altitude_min)
        elif self.px4:
            if not crashed and mode != FlightMode.LANDING and self.autopilot.climbing:
                return  # a graze while climbing is not a landing (PX4's land detector needs a descent or a hover)
        elif not crashed and mode != FlightMode.LANDING and self.command.vz > 0:
            return  # a graze while climbing is not a landing
        pad = d.site_xpos[self.pad_site]
        position = d.qpos[self.drone_qpos:self.drone_qpos + 3].copy()
        pad_error = math.hypot(position[0] - pad[0], position[1] - pad[1])
        self.touchdown = Touchdown(self.time, surface, crashed, impact, tilt, position, pad_error)
        self.touchdowns.append(self.touchdown)
        self.autopilot.touched_down(crashed)
        LOG.info(self.touchdown.describe())

    # ----- faults (robustness scenarios) --------------------------------------------------------
    FAULTS = ("camera_blackout", "detection_false_target", "link_loss", "pilot_takeover")

    def inject_fault(self, fault, duration_s):
        """Start a fault for ``duration_s`` sim seconds; returns False for an unknown fault."""
        until = self.time + duration_s
        if fault == "camera_blackout":
            self.camera_blackout_until = until
        elif fault == "detection_false_target" and self.false_target_mocap >= 0:
            self.false_target_until = until
        elif fault == "link_loss":
            # No command reaches the drone (drone_model ardrone2: the firmware's watchdog hovers, then lands;
            # velocity_quad: the velocity commands are lost). The node may drop what the drone sends meanwhile
            # too (link_lost).
            self.link_lost_until = until
        elif fault == "pilot_takeover" and self.px4:
            # drone_model px4_quad: the pilot flips the RC mode switch to px4_quad/pilot_takeover_mode and keeps the
            # drone (duration_s does not matter: the pilot hands back by a mode request, e.g. OFFBOARD).
            self.px4_world.pilot_mode(self.cfg["px4_quad"]["pilot_takeover_mode"])
        else:
            return False
        LOG.info("fault %s for %.1f s", fault, duration_s)
        return True

    def link_lost(self):
        return self.time < self.link_lost_until

    def camera_blacked_out(self):
        return self.time < self.camera_blackout_until

    def _place_false_target(self, now):
        """Beside the vehicle (1.6 m to its left, on the ground) while the fault lasts; the AprilTag pad's world
        also puts its foreign pad FOREIGN_PAD_OFFSET to the vehicle's right."""
        if now < self.false_target_until:
            x, y, yaw = self.data.qpos[self.vehicle_qpos:self.vehicle_qpos + 3]
            self.data.mocap_pos[self.false_target_mocap] = (x - 1.6 * math.sin(yaw), y + 1.6 * math.cos(yaw), 0.003)
            self.data.mocap_quat[self.false_target_mocap] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
            if self.foreign_pad_mocap >= 0:
                self.data.mocap_pos[self.foreign_pad_mocap] = (x + FOREIGN_PAD_OFFSET * math.sin(yaw),
                                                               y - FOREIGN_PAD_OFFSET * math.cos(yaw), 0.003)
                self.data.mocap_quat[self.foreign_pad_mocap] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
        elif self.data.mocap_pos[self.false_target_mocap][2] > -1.0:
            self.data.mocap_pos[self.false_target_mocap] = (0.0, 0.0, -50.0)
            if self.foreign_pad_mocap >= 0:
                self.data.mocap_pos[self.foreign_pad_mocap] = (0.0, 0.0, -50.0)

    # ----- ground truth (scoring and tf only) ----------------------------------------------------
    def drone_pose(self):
        q = self.drone_qpos
        return self.data.qpos[q:q + 3].copy(), self.data.qpos[q + 3:q + 7].copy()

    def drone_velocity(self):
        """World-frame linear velocity and body-frame angular velocity."""
        v = self.drone_qvel
        return self.data.qvel[v:v + 3].copy(), self.data.qvel[v + 3:v + 6].copy()

    def vehicle_pose(self):
        x, y, yaw = self.data.qpos[self.vehicle_qpos:self.vehicle_qpos + 3]
        return float(x), float(y), float(yaw)

    def vehicle_velocity(self):
        vx, vy, wz = self.data.qvel[self.vehicle_qvel:self.vehicle_qvel + 3]
        return float(vx), float(vy), float(wz)

    def pad_position(self):
        return self.data.site_xpos[self.pad_site].copy()

    def pad_offset_in_vehicle(self):
        """Pad centre in the vehicle frame (for the static tf)."""
        return self.model.site_pos[self.pad_site].copy()

    # ----- sensors (what the drone itself measures) ------------------------------------------------
    def _noise(self, stream, std, size=None):
        if self.noise is None or std <= 0.0:
            return np.zeros(size) if size else 0.0
        return self.rng[stream].normal(0.0, std, size)

    def imu(self):
        """(orientation quaternion w,x,y,z; angular velocity body [rad/s]; specific force body [m/s^2]) as the
        drone reports them: biased (realism), noisy, and the attitude estimate tilted by the accelerometer's
        bias (it is levelled on it) and turned by the yaw drift."""
        n = self.noise or {}
        self._step_biases(self.time, period=0.0)
        gyro = self.data.sensordata[self.gyro_adr:self.gyro_adr + 3] + self.gyro_bias.value + \
            self._noise("imu", n.get("imu_gyro_std", 0), 3)
        accel = self.data.sensordata[self.accel_adr:self.accel_adr + 3] + self.accel_bias.value + \
            self._noise("imu", n.get("imu_accel_std", 0), 3)
        _, quat = self.drone_pose()
        error = self._noise("imu", math.radians(n.get("imu_orientation_std_deg", 0)), 3)
        error = error + np.array([self.accel_bias.value[1] / 9.81, -self.accel_bias.value[0] / 9.81, 0.0])
        yaw_drift = self.yaw_drift()
        if yaw_drift:
            quat = _quat_multiply(np.array([math.cos(yaw_drift / 2), 0.0, 0.0, math.sin(yaw_drift / 2)]), quat)
        if np.any(error):
            half = 0.5 * error
            dq = np.array([1.0, half[0], half[1], half[2]])
            quat = _quat_multiply(quat, dq / np.linalg.norm(dq))
        return quat, gyro, accel

    def yaw_drift(self):
        """How far the reported yaw has drifted from the true one [rad] (realism)."""
        return self.yaw_drift_rate * self.time + float(self.yaw_drift_walk.value[0])

    def sonar(self):
        """Distance from the feet to the first surface along the body's -z axis [m] (pad, vehicle body or
        ground: whatever is below), +inf beyond the range, and now and then a spurious echo or none at all
        (realism: sonar_outlier_rate)."""
        position, quat = self.drone_pose()
        distance = self.sonar_distance_true(position, quat_to_matrix(quat))
        limit = self.cfg["sensors"]["sonar_max_range"]
        minimum = self.cfg["sensors"]["sonar_min_range"]
        outliers = self.realism["sonar_outlier_rate"]
        if outliers > 0.0 and self.rng["sonar_outlier"].random() < outliers:
            if self.rng["sonar_outlier"].random() < 0.5:
                return math.inf  # no echo
            true_range = min(distance, limit) - FOOT_CLEARANCE
            return float(self.rng["sonar_outlier"].uniform(minimum, max(minimum, true_range)))  # an early echo
        if distance > limit:
            return math.inf
        return max(minimum, distance - FOOT_CLEARANCE + self._noise("sonar", (self.noise or {}).get("sonar_std", 0)))

    def altimeter(self):
        """Barometric altitude above the world origin [m] and pressure [hPa]."""
        altitude = float(self.data.qpos[self.drone_qpos + 2]) + self._noise(
            "altimeter", (self.noise or {}).get("altimeter_std", 0))
        pressure = 1013.25 * (1.0 - 2.25577e-5 * altitude) ** 5.25588
        return altitude, pressure

    def gps(self):
        """GPS-like position and velocity of the drone, world frame: white noise plus the slowly drifting
        error (realism); None during a dropout."""
        if self.gps_outage.active(self.time):
            return None
        position, _ = self.drone_pose()
        velocity, _ = self.drone_velocity()
        n = self.noise or {}
        drift = self.gps_error.step(self.time - self.gps_error_time)
        self.gps_error_time = self.time
        return (position + drift + self._noise("gps", n.get("gps_position_std", 0), 3),
                velocity + self._noise("gps", n.get("gps_velocity_std", 0), 3))

    def vehicle_gps(self):
        """GPS-like pose (x, y, yaw), velocity (vx, vy) and yaw rate of the vehicle (its odometry), noisy, the
        position with its own drifting error; during a GPS dropout the position is None (the odometry goes on)."""
        x, y, yaw = self.vehicle_pose()
        vx, vy, yaw_rate = self.vehicle_velocity()
        n = self.noise or {}
        drift = self.vehicle_gps_error.step(self.time - self.vehicle_gps_error_time)
        self.vehicle_gps_error_time = self.time
        p = self._noise("vehicle_gps", n.get("gps_position_std", 0), 2) + drift
        v = self._noise("vehicle_gps", n.get("gps_velocity_std", 0), 2)
        heading = self._noise("vehicle_gps", math.radians(n.get("vehicle_heading_std_deg", 0)))
        turn = self._noise("vehicle_gps", n.get("vehicle_yaw_rate_std", 0))
        position = None if self.vehicle_gps_outage.active(self.time) else (x + p[0], y + p[1])
        return position, yaw + heading, (vx + v[0], vy + v[1]), yaw_rate + turn

    def flow_velocity(self):
        """Heading-frame velocity (forward, left, up) as the AR.Drone reports it in navdata: its firmware's
        estimate (realism: firmware_on_estimate), else the velocity (relative to the surface the camera
        sees, with flow_surface_coupling) with white noise."""
        _, quat = self.drone_pose()
        rotation = quat_to_matrix(quat)
        yaw = yaw_from_quaternion(*quat)
        c, s = math.cos(yaw), math.sin(yaw)
        if self.firmware is not None:
            vx, vy = self.firmware.velocity
            return c * vx + s * vy, -s * vx + c * vy, self.firmware.climb
        velocity, _ = self.drone_velocity()
        std = (self.noise or {}).get("flow_velocity_std", 0)
        horizontal = self._flow_measurement(rotation)
        return (c * horizontal[0] + s * horizontal[1], -s * horizontal[0] + c * horizontal[1],
                velocity[2] + self._noise("flow", std))

    # ----- camera ------------------------------------------------------------------------------
    def camera_intrinsics(self):
        """(width, height, fx, fy, cx, cy) of the bottom camera's published image in pixels."""
        width, height = self.cfg["camera"]["width"], self.cfg["camera"]["height"]
        fy = (height / 2.0) / math.tan(math.radians(self.camera_fovy) / 2.0)
        return width, height, fy, fy, (width - 1) / 2.0, (height - 1) / 2.0

    def camera_distortion(self):
        """plumb_bob coefficients (k1, k2, p1, p2, k3) of the lens (camera_info D)."""
        r = self.realism
        return [r["lens_k1"], r["lens_k2"], r["lens_p1"], r["lens_p2"], r["lens_k3"]]

    def camera_frame_lost(self):
        """Draw whether the frame due now is lost on the link (then it is not rendered at all)."""
        return self.camera_link.loss > 0.0 and self.camera_link.lost_next()

    def camera_pose_in_body(self):
        """Optical-frame origin and rotation matrix in the drone body frame."""
        return self.model.cam_pos[self.camera].copy(), CAMERA_OPTICAL_IN_BODY

    def open_camera(self):
        """Set up the camera (lens, exposure, its renderer thread) and warm its renderer up in the background;
        otherwise the first frame does it (0.3 s of imports and OpenGL set-up amid the flight)."""
        if self._renderer is None:
            self._open_camera()
            self._renderer.warm_up()

    def _open_camera(self):
        from .camera_model import Exposure, Lens
        r, cam = self.realism, self.cfg["camera"]
        self.lens = Lens(self.camera_intrinsics(), self.camera_distortion())
        self.model.cam_fovy[self.camera] = self.lens.render_fovy_deg  # wide enough for the distorted corners
        camera_view = self._mj.MjvOption()
        # The drone's geoms lie outside the camera's view; they are in the scene only to cast their shadow.
        camera_view.geomgroup[DRONE_GEOM_GROUP] = int(r["shadows"])
        camera_view.sitegroup[:] = 0  # site markers are not part of the world a camera sees
        self.exposure = Exposure(self.rng["exposure"], (cam["height"], cam["width"], 3), r["exposure_gain_std"],
                                 r["exposure_time_constant_s"], r["pixel_noise_std"])
        self._renderer = FrameRenderer(self._mj, self.model, self.camera, cam["height"], cam["width"], camera_view,
                                       self._develop)

    def capture_camera(self, noise_std=None):
        """Capture the bottom camera's frame of this instant: a Future of its RGB image (height, width, 3) uint8,
        as the real camera delivers it (realism): distorted by the lens, blurred by the motion during the
        exposure, its brightness wandering, noisy. It is rendered in the camera's thread while the physics
        steps on (frame_renderer)."""
        self.open_camera()
        blur = self._motion_blur_px() if self.realism["camera_exposure_s"] > 0.0 else None
        std = self.cfg["camera"]["noise"] if noise_std is None else noise_std
        return self._renderer.capture(self.data, (blur, self.time, std))

    def render_camera(self, noise_std=None):
        """The image of capture_camera(), waited for."""
        return self.capture_camera(noise_std).result(timeout=FRAME_TIMEOUT_S)

    def camera_thread_id(self):
        """The native id of the camera's rendering thread, or None before it has started."""
        return self._renderer.thread_id if self._renderer is not None else None

    def camera_thread_seconds(self):
        """CPU seconds the camera's thread has spent rendering and developing frames so far [s]."""
        return self._renderer.render_s if self._renderer is not None else 0.0

    def _develop(self, rendered, job):
        """The raw render of a frame as the camera delivers it (in the camera's thread, in capture order)."""
        from .camera_model import motion_blur
        blur, capture_time, noise_std = job
        image = self.lens.apply(rendered)
        if blur is not None:
            image = motion_blur(image, *blur)
        image = self.exposure.apply(image, capture_time)
        if noise_std > 0.0:
            noisy = image + self.rng["camera"].normal(0.0, 255.0 * noise_std, image.shape)
            image = np.clip(noisy, 0, 255).astype(np.uint8)
        return image

    def _motion_blur_px(self):
        """(du, dv) [px]: how far the image moves during the exposure, from the motion of this instant."""
        from .camera_model import image_motion
        velocity, omega = self.drone_velocity()
        position, quat = self.drone_pose()
        rotation = quat_to_matrix(quat)
        below = self._surface_velocity_below(position)
        optical_from_world = CAMERA_OPTICAL_IN_BODY @ rotation.T
        distance = self.sonar_distance_true(position, rotation)
        return image_motion(self.camera_intrinsics()[2], self.realism["camera_exposure_s"],
                            optical_from_world @ (velocity - below), CAMERA_OPTICAL_IN_BODY @ omega, distance)

    def _over_vehicle(self, position):
        """Whether the point (x, y) of ``position`` lies above the vehicle's top rectangle."""
        x, y, yaw = self.vehicle_pose()
        c, s = math.cos(yaw), math.sin(yaw)
        dx, dy = position[0] - x, position[1] - y
        px, py = c * dx + s * dy, -s * dx + c * dy
        rect = self.vehicle_rectangle
        return rect[0] <= px <= rect[1] and rect[2] <= py <= rect[3]

    def _surface_velocity_below(self, position):
        """Velocity of the surface straight below the drone: the vehicle's if it is under it, else zero."""
        if self._over_vehicle(position):
            vx, vy, _ = self.vehicle_velocity()
            return np.array([vx, vy, 0.0])
        return np.zeros(3)

    def sonar_distance_true(self, position, rotation):
        """Distance along the camera axis (body -z) to the first surface, without noise [m] (inf if none)."""
        geom = np.zeros(1, dtype=np.int32)
        distance = self._mj.mj_ray(self.model, self.data, position, -rotation[:, 2], None, 1, self.drone_body, geom)
        return distance if distance >= 0 else math.inf

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def _textured_top_rectangle(model, pad_geom):
    """(x_min, x_max, y_min, y_max) [m] in the vehicle frame of what the drone's optical flow can follow on the
    vehicle: the pad, whose edges, strip and marker are features (a car's roof is smooth paint, and the
    Summit XL's body lies under the pad)."""
    (x, y, _), (hx, hy, _) = model.geom_pos[pad_geom], model.geom_size[pad_geom]
    return (x - hx, x + hx, y - hy, y + hy)


def _as_slice(indices):
    """A slice when the indices are consecutive (the usual case), else the list itself."""
    if list(indices) == list(range(indices[0], indices[0] + len(indices))):
        return slice(indices[0], indices[0] + len(indices))
    return indices


def _quat_multiply(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])
