"""The simulated world, ROS-free: physics, autopilot, vehicle drive, wind, battery, sensors, camera.

Everything random draws from generators derived from one seed, so a run is reproducible.
"""
import logging
import math
import os

import numpy as np

from landing_msgs.geometry import yaw_from_quaternion

from .autopilot import HOLD, Autopilot, FlightMode, VelocityCommand, quat_to_matrix
from .config import ConfigError
from .environment import Battery, Wind, aerodynamic_force

LOG = logging.getLogger("mujoco_sim.simulator")

SURFACE_PAD, SURFACE_GROUND, SURFACE_VEHICLE = 1, 2, 3
SURFACE_NAMES = {SURFACE_PAD: "pad", SURFACE_GROUND: "ground", SURFACE_VEHICLE: "vehicle"}
# Optical frame (x right, y down, z forward) of the MuJoCo bottom camera, in the drone body frame.
CAMERA_OPTICAL_IN_BODY = np.array([[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
FOOT_CLEARANCE = 0.065  # base_link height above the surface the drone stands on [m]
DRONE_GEOM_GROUP = 3    # the drone's own geoms, hidden from its bottom camera


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


def load_model(model_file):
    """Load an MJCF file; a missing or malformed file raises ConfigError naming it."""
    import mujoco
    if not os.path.isfile(model_file):
        raise ConfigError("%s: model file not found" % model_file)
    try:
        model = mujoco.MjModel.from_xml_path(model_file)
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
        self.model = load_model(model_file)
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
        self.camera_blackout_until = -1.0

        streams = np.random.SeedSequence(seed).spawn(8)
        self.rng = {name: np.random.default_rng(s) for name, s in zip(
            ("imu", "sonar", "altimeter", "gps", "camera", "wind", "vehicle_gps", "flow"), streams)}
        self.noise = config["noise"] if config["noise"]["enabled"] else None

        drone = config["drone"]
        rotors = []
        for act in self.rotor_actuators:
            site = m.actuator_trnid[act][0]
            x, y = m.site_pos[site][:2]
            rotors.append((float(x), float(y), float(m.actuator_gear[act][5])))
        mass = float(m.body_mass[self.drone_body])
        self.autopilot = Autopilot(drone, mass, m.body_inertia[self.drone_body].copy(), rotors,
                                   max_rotor_thrust=float(m.actuator_ctrlrange[self.rotor_actuators[0]][1]))
        self.max_total_thrust = 4 * self.autopilot.max_rotor_thrust
        self.command = HOLD
        self.command_time = -1e9
        self.wind = Wind(self.rng["wind"], gust_time_constant=config["wind"]["gust_time_constant"])
        bat = config["battery"]
        self.battery = Battery(bat["initial_percent"], bat["idle_drain"], bat["thrust_drain"],
                               bat["cold_reference_temp"], bat["cold_factor_per_deg"])
        self.temperature = config["conditions"]["temp"]
        self.drag_area = np.array([drone["drag_area_horizontal"]] * 2 + [drone["drag_area_vertical"]])

        self.vehicle_target = (0.0, 0.0)      # commanded (v, omega)
        self.vehicle_command = [0.0, 0.0]     # after acceleration limits
        self.vehicle_command_time = -1e9
        self.wheel_angles = [0.0, 0.0, 0.0, 0.0]
        self.touchdown = None                 # last Touchdown
        self.touchdowns = []
        self._takeoff_z = None
        self._renderer = None
        self.camera_frame = None
        self._place_at_start()

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
        """Returns None when accepted, else why the command was ignored (the drone then holds)."""
        problem = VelocityCommand.problem((vx, vy, vz, yaw_rate))
        if problem:
            self.command = HOLD
            return problem
        self.command = VelocityCommand(vx, vy, vz, yaw_rate)
        self.command_time = self.time
        return None

    def set_vehicle_command(self, speed, yaw_rate):
        problem = VelocityCommand.problem((speed, yaw_rate))
        if problem:
            self.vehicle_target = (0.0, 0.0)
            return problem
        self.vehicle_target = (speed, yaw_rate)
        self.vehicle_command_time = self.time
        return None

    def takeoff(self):
        if self.battery.empty:
            LOG.warning("take-off refused: the battery is empty")
            return False
        z = float(self.data.qpos[self.drone_qpos + 2])
        if self.autopilot.takeoff(z):
            self._takeoff_z = z
            self.touchdown = None
            return True
        return False

    def land(self):
        return self.autopilot.land()

    def reset(self):
        """Back to the start, motors off, as after /ardrone/reset."""
        self.autopilot.reset()
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
        if now - self.command_time > self.cfg["drone"]["command_timeout"]:
            self.command = HOLD
        self.wind.step(dt)
        airborne = self.autopilot.airborne_control
        if airborne or position[2] > 0.3:
            d.xfrc_applied[self.drone_body, :3] = aerodynamic_force(self.wind.velocity(), velocity, self.drag_area)
        else:
            d.xfrc_applied[self.drone_body, :3] = 0.0
        thrusts = self.autopilot.update(dt, position, velocity, quat, omega, self.command,
                                        power_available=not self.battery.empty)
        d.ctrl[self.rotor_ctrl] = thrusts
        self._drive_vehicle(dt, now)
        if self.false_target_mocap >= 0:
            self._place_false_target(now)
        self._mj.mj_step(m, d)
        thrust_fraction = float(thrusts.sum()) / self.max_total_thrust
        self.battery.step(dt, thrust_fraction, self.temperature, motors_on=airborne)
        if d.ncon:
            self._check_contacts(velocity)

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
        if not crashed and mode != FlightMode.LANDING and self.command.vz > 0:
            return  # a graze while climbing is not a landing
        pad = d.site_xpos[self.pad_site]
        position = d.qpos[self.drone_qpos:self.drone_qpos + 3].copy()
        pad_error = math.hypot(position[0] - pad[0], position[1] - pad[1])
        self.touchdown = Touchdown(self.time, surface, crashed, impact, tilt, position, pad_error)
        self.touchdowns.append(self.touchdown)
        self.autopilot.touched_down(crashed)
        LOG.info(self.touchdown.describe())

    # ----- faults (robustness scenarios) --------------------------------------------------------
    FAULTS = ("camera_blackout", "detection_false_target")

    def inject_fault(self, fault, duration_s):
        """Start a fault for ``duration_s`` sim seconds; returns False for an unknown fault."""
        until = self.time + duration_s
        if fault == "camera_blackout":
            self.camera_blackout_until = until
        elif fault == "detection_false_target" and self.false_target_mocap >= 0:
            self.false_target_until = until
        else:
            return False
        LOG.info("fault %s for %.1f s", fault, duration_s)
        return True

    def camera_blacked_out(self):
        return self.time < self.camera_blackout_until

    def _place_false_target(self, now):
        """Beside the vehicle (1.6 m to its left, on the ground) while the fault lasts."""
        if now < self.false_target_until:
            x, y, yaw = self.data.qpos[self.vehicle_qpos:self.vehicle_qpos + 3]
            self.data.mocap_pos[self.false_target_mocap] = (x - 1.6 * math.sin(yaw), y + 1.6 * math.cos(yaw), 0.003)
            self.data.mocap_quat[self.false_target_mocap] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
        elif self.data.mocap_pos[self.false_target_mocap][2] > -1.0:
            self.data.mocap_pos[self.false_target_mocap] = (0.0, 0.0, -50.0)

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
        """(orientation quaternion w,x,y,z; angular velocity body [rad/s]; specific force body [m/s^2])."""
        n = self.noise or {}
        gyro = self.data.sensordata[self.gyro_adr:self.gyro_adr + 3] + self._noise("imu", n.get("imu_gyro_std", 0), 3)
        accel = self.data.sensordata[self.accel_adr:self.accel_adr + 3] + self._noise("imu", n.get("imu_accel_std", 0), 3)
        _, quat = self.drone_pose()
        tilt_noise = self._noise("imu", math.radians(n.get("imu_orientation_std_deg", 0)), 3)
        if self.noise is not None:
            half = 0.5 * tilt_noise
            dq = np.array([1.0, half[0], half[1], half[2]])
            quat = _quat_multiply(quat, dq / np.linalg.norm(dq))
        return quat, gyro, accel

    def sonar(self):
        """Distance along the body -z axis to the first surface [m], +inf beyond the range."""
        position, quat = self.drone_pose()
        direction = -quat_to_matrix(quat)[:, 2]
        geom = np.zeros(1, dtype=np.int32)
        distance = self._mj.mj_ray(self.model, self.data, position, direction, None, 1, self.drone_body, geom)
        limit = self.cfg["sensors"]["sonar_max_range"]
        if distance < 0 or distance > limit:
            return math.inf
        return max(self.cfg["sensors"]["sonar_min_range"],
                   distance - FOOT_CLEARANCE + self._noise("sonar", (self.noise or {}).get("sonar_std", 0)))

    def altimeter(self):
        """Barometric altitude above the world origin [m] and pressure [hPa]."""
        altitude = float(self.data.qpos[self.drone_qpos + 2]) + self._noise(
            "altimeter", (self.noise or {}).get("altimeter_std", 0))
        pressure = 1013.25 * (1.0 - 2.25577e-5 * altitude) ** 5.25588
        return altitude, pressure

    def gps(self):
        """GPS-like position and velocity of the drone, world frame, noisy."""
        position, _ = self.drone_pose()
        velocity, _ = self.drone_velocity()
        n = self.noise or {}
        return (position + self._noise("gps", n.get("gps_position_std", 0), 3),
                velocity + self._noise("gps", n.get("gps_velocity_std", 0), 3))

    def vehicle_gps(self):
        """GPS-like pose (x, y, yaw), velocity (vx, vy) and yaw rate of the vehicle (its odometry), noisy."""
        x, y, yaw = self.vehicle_pose()
        vx, vy, yaw_rate = self.vehicle_velocity()
        n = self.noise or {}
        p = self._noise("vehicle_gps", n.get("gps_position_std", 0), 2)
        v = self._noise("vehicle_gps", n.get("gps_velocity_std", 0), 2)
        heading = self._noise("vehicle_gps", math.radians(n.get("vehicle_heading_std_deg", 0)))
        turn = self._noise("vehicle_gps", n.get("vehicle_yaw_rate_std", 0))
        return (x + p[0], y + p[1], yaw + heading), (vx + v[0], vy + v[1]), yaw_rate + turn

    def flow_velocity(self):
        """Heading-frame velocity as the AR.Drone's optical flow reports it, noisy."""
        velocity, _ = self.drone_velocity()
        _, quat = self.drone_pose()
        yaw = yaw_from_quaternion(*quat)
        c, s = math.cos(yaw), math.sin(yaw)
        std = (self.noise or {}).get("flow_velocity_std", 0)
        return (c * velocity[0] + s * velocity[1] + self._noise("flow", std),
                -s * velocity[0] + c * velocity[1] + self._noise("flow", std),
                velocity[2] + self._noise("flow", std))

    # ----- camera ------------------------------------------------------------------------------
    def camera_intrinsics(self):
        """(width, height, fx, fy, cx, cy) of the bottom camera in pixels."""
        width, height = self.cfg["camera"]["width"], self.cfg["camera"]["height"]
        fy = (height / 2.0) / math.tan(math.radians(float(self.model.cam_fovy[self.camera])) / 2.0)
        return width, height, fy, fy, (width - 1) / 2.0, (height - 1) / 2.0

    def camera_pose_in_body(self):
        """Optical-frame origin and rotation matrix in the drone body frame."""
        return self.model.cam_pos[self.camera].copy(), CAMERA_OPTICAL_IN_BODY

    def render_camera(self, noise_std=None):
        """RGB image (height, width, 3) uint8 from the bottom camera."""
        if self._renderer is None:
            self._renderer = self._mj.Renderer(self.model, self.cfg["camera"]["height"], self.cfg["camera"]["width"])
            self._camera_view = self._mj.MjvOption()
            self._camera_view.geomgroup[DRONE_GEOM_GROUP] = 0
            self._camera_view.sitegroup[:] = 0  # site markers are not part of the world a camera sees
        self._renderer.update_scene(self.data, camera=self.camera, scene_option=self._camera_view)
        image = self._renderer.render()
        std = self.cfg["camera"]["noise"] if noise_std is None else noise_std
        if std > 0.0:
            noisy = image + self.rng["camera"].normal(0.0, 255.0 * std, image.shape)
            image = np.clip(noisy, 0, 255).astype(np.uint8)
        return image

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


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
