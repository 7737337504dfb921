"""Bottom-camera frames rendered by mujoco_sim's ROS-free Simulator, with their ground truth.

A ``View`` says where the drone and the vehicle are and how they move; ``FrameRenderer`` puts the world
in that state and renders the frame as the camera of the chosen realism profile delivers it (lens,
shadows, blur, exposure, noise), with a row of truth: the pad centre relative to the drone, what of the
pad, its strip, its marker and the red false target is in view (through the distorted lens), the share
of the pad in shadow, and what the drone's own sensors read there (IMU attitude, sonar, barometer).

Used by test/render_fixtures.py (the committed fixtures of uav_vision's gtests, src/uav_vision/test/data, which
uav_vision's C++ reads through include/uav_vision/rendered_frames.h) and by rendered_benchmark (thousands of
frames rendered on the fly for uav_vision's detector_benchmark). Here, in landing_bench, because rendering needs
the simulator: uav_vision itself does not depend on mujoco_sim. Columns of the truth rows: ``TRUTH_COLUMNS``.
"""
import dataclasses
import math
import os

import cv2
import mujoco
import numpy as np

from mujoco_sim.autopilot import quat_to_matrix
from mujoco_sim.camera_model import image_motion
from mujoco_sim.pads import FOREIGN_PAD_BODY, FOREIGN_PAD_HALF, FOREIGN_PAD_OFFSET, check_pad
from mujoco_sim.schema import load_sim_config
from mujoco_sim.simulator import CAMERA_OPTICAL_IN_BODY, SONAR_FIELD_OF_VIEW_RAD, Simulator

SIM_PACKAGE = os.path.realpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..", "mujoco_sim"))
CAMERA_BELOW_BASE = 0.035    # bottom camera origin below base_link [m] (docs/conventions.md)
PAD_HALF = 0.5               # half side of the pad [m]
MARKER_HALF = 0.07           # half side of the white centre marker [m]
STRIP_HALF = (0.06, 0.35)    # half extents of the green strip along the pad's forward and left axes [m]
FALSE_TARGET_HALF = (0.5, 0.3)  # half extents of the red false target (mujoco_sim models/common.xml) [m]
INNER_TAG_HALF = 0.1         # AprilTag pad: half the inner tag's square with its white ring (its "marker") [m]
HEADING_OFFSET = 0.36        # AprilTag pad: its heading point (in place of the strip's centre) ahead of the centre [m]
TIME_STEP = 5.0              # sim time between two frames of one renderer: the exposure's wander moves on [s]

TRUTH_COLUMNS = [
    "image", "band", "vehicle", "profile", "height_landing_platform", "camera_height",
    "width", "height", "fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3",
    "pad_base_x", "pad_base_y", "pad_base_z", "pad_world_x", "pad_world_y", "pad_world_z",
    "pad_camera_x", "pad_camera_y", "pad_camera_z", "strip_base_x", "strip_base_y", "strip_base_z",
    "qw", "qx", "qy", "qz", "imu_qw", "imu_qx", "imu_qy", "imu_qz", "tilt_deg",
    "sonar_range", "sonar_range_before", "sonar_range_after", "sonar_field_of_view",
    "baro_altitude", "baro_altitude_m2", "baro_altitude_m1", "baro_altitude_p1", "baro_altitude_p2",
    "visible_pad_share", "visible_pad_corners", "strip_corners_in_view", "marker_corners_in_view",
    "pad_shadow_share", "false_target_share", "blur_px", "exposure_gain", "sun_elevation_deg",
    "pixel_noise_std_omitted", "pad", "foreign_pad_share",
]


@dataclasses.dataclass
class View:
    """One frame's world state. Positions are relative to the pad centre, in world axes."""
    camera_offset: tuple          # camera optical centre - pad centre, horizontal (east, north) [m]
    camera_height: float          # camera optical centre above the pad's top [m]
    roll: float = 0.0             # drone attitude [rad] (R = Rz(yaw) Ry(pitch) Rx(roll))
    pitch: float = 0.0
    yaw: float = 0.0
    vehicle_yaw: float = 0.0      # [rad]
    vehicle_position: tuple = (0.0, 0.0)  # [m]
    vehicle_speed: float = 0.0    # forward [m/s]
    relative_velocity: tuple = (0.0, 0.0, 0.0)  # drone velocity - vehicle velocity, world [m/s]
    body_rates: tuple = (0.0, 0.0, 0.0)  # drone angular velocity, body frame [rad/s]
    false_target: bool = False    # the red false target beside the vehicle (fault detection_false_target)
    foreign_pad: bool = False     # AprilTag pad: the foreign pad (other tag ids) on the ground beside the vehicle
    log_gain: float = None        # exposure: log of the brightness gain; None: the profile's wander
    band: str = ""                # label for the truth row


def rotation_quat(roll, pitch, yaw):
    """Quaternion (w, x, y, z) of R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy])


def sim_config(profile, overrides=None):
    """mujoco_sim's configuration with the realism ``profile`` and single keys ``overrides``."""
    return load_sim_config(os.path.join(SIM_PACKAGE, "config", "sim.yaml"),
                           {"realism": {"profile": profile, "overrides": dict(overrides or {})}})


class FrameRenderer:
    """A simulator of one vehicle, realism profile and seed (the seed draws the sun); ``render`` a View.
    ``omit_pixel_noise``: render without the profile's sensor noise (small PNGs for the repository) and
    record its std-dev in the truth for the consumer to add. ``sonar_neighbours``: draw three sonar readings
    (the frame's and one each side of it) and five barometric altitudes, else one each (as the first fixtures
    did). ``pad``: the pad's face (mujoco_sim.pads.PADS); on the AprilTag pad the truth's strip is its heading point
    (the strip's place) and its marker the inner tag's square, and a View may put the foreign pad in view."""

    def __init__(self, vehicle, profile, seed, overrides=None, omit_pixel_noise=False, sonar_neighbours=True,
                 pad="red_square"):
        overrides = dict(overrides or {})
        config = sim_config(profile, overrides)
        self.noise_omitted = 0.0
        if omit_pixel_noise:
            self.noise_omitted = config["realism"]["values"]["pixel_noise_std"]
            config = sim_config(profile, dict(overrides, pixel_noise_std=0.0))
        config["pad"] = check_pad(pad)
        self.pad = pad
        self.profile, self.vehicle, self.sonar_neighbours = profile, vehicle, sonar_neighbours
        self.state = None
        self.sim = Simulator(config, os.path.join(SIM_PACKAGE, "models", "world_%s.xml" % vehicle), vehicle, seed=seed)
        m = self.sim.model
        self.strip_geom = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "landing_pad_heading")
        self.marker_geom = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "landing_pad_marker")
        self.false_target_geom = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "false_target")
        self.foreign_pad_geom = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, FOREIGN_PAD_BODY)
        self.towards_sun = -np.asarray(self.sim.sun_direction, dtype=float)
        self._aim_the_sun()
        self.sun_elevation_deg = math.degrees(math.asin(max(-1.0, min(1.0, self.towards_sun[2]))))

    def _aim_the_sun(self):
        """Points the rendered sun where the simulator drew it. mujoco_sim sets the sun's light_dir and
        light_pos, but MuJoCo places a light of mode 'track' from light_dir0 and light_pos0, so every profile
        rendered the model file's sun (77 deg up): the profile's sun is what these frames are to show. A no-op
        once the simulator sets them itself."""
        m = self.sim.model
        sun = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_LIGHT, "sun")
        if sun >= 0 and float(np.dot(m.light_dir0[sun], -self.towards_sun)) < math.cos(1e-3):  # (ideal: the same)
            m.light_dir0[sun] = -self.towards_sun
            m.light_pos0[sun] = self.towards_sun

    def close(self):
        self.sim.close()

    def place_vehicle(self, view):
        """Moves the vehicle (and the false target) to the view's pose; returns the pad centre [m]."""
        sim = self.sim
        m, d = sim.model, sim.data
        d.qpos[sim.vehicle_qpos:sim.vehicle_qpos + 3] = (view.vehicle_position[0], view.vehicle_position[1],
                                                         view.vehicle_yaw)
        if view.false_target:
            sim.inject_fault("detection_false_target", 1e9)
        else:
            sim.false_target_until = -1.0
        sim._place_false_target(sim.time)
        if sim.foreign_pad_mocap >= 0:
            # The foreign pad as the view says (the fault puts it beside the vehicle with the false target).
            x, y, yaw = d.qpos[sim.vehicle_qpos:sim.vehicle_qpos + 3]
            d.mocap_pos[sim.foreign_pad_mocap] = ((x + FOREIGN_PAD_OFFSET * math.sin(yaw),
                                                   y - FOREIGN_PAD_OFFSET * math.cos(yaw), 0.003)
                                                  if view.foreign_pad else (0.0, 0.0, -50.0))
            d.mocap_quat[sim.foreign_pad_mocap] = (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))
        mujoco.mj_forward(m, d)
        return sim.pad_position()

    def set_view(self, view):
        """Puts the world in the state of ``view``; returns the share of the pad in view (nothing drawn
        from the simulator's random streams: a view may be rejected without changing later frames)."""
        sim = self.sim
        m, d = sim.model, sim.data
        pad = self.place_vehicle(view)
        quat = rotation_quat(view.roll, view.pitch, view.yaw)
        rot = quat_to_matrix(quat)
        camera = pad + np.array([view.camera_offset[0], view.camera_offset[1], view.camera_height])
        base = camera - rot @ np.array([0.0, 0.0, -CAMERA_BELOW_BASE])
        sim._set_drone_pose(tuple(base), view.yaw)
        d.qpos[sim.drone_qpos + 3:sim.drone_qpos + 7] = quat
        c, s = math.cos(view.vehicle_yaw), math.sin(view.vehicle_yaw)
        vehicle_velocity = np.array([view.vehicle_speed * c, view.vehicle_speed * s, 0.0])
        d.qvel[sim.vehicle_qvel:sim.vehicle_qvel + 3] = (vehicle_velocity[0], vehicle_velocity[1], 0.0)
        d.qvel[sim.drone_qvel:sim.drone_qvel + 3] = vehicle_velocity + np.asarray(view.relative_velocity)
        d.qvel[sim.drone_qvel + 3:sim.drone_qvel + 6] = view.body_rates
        mujoco.mj_forward(m, d)
        self.state = (view, pad, camera, base, quat, rot, rot @ sim.camera_pose_in_body()[1])
        return float(np.mean(self._inside(self._project(self._pad_grid(), camera, self.state[6]))))

    def render(self, image_name=""):
        """(RGB image, truth row) of the view last set."""
        sim = self.sim
        sim.data.time += TIME_STEP
        if sim._renderer is None:
            sim.render_camera(noise_std=0.0)  # opens the renderer and the exposure model
        view = self.state[0]
        if view.log_gain is not None:
            sim.exposure.log_gain, sim.exposure.time = float(view.log_gain), sim.time
        image = sim.render_camera(noise_std=0.0)  # the profile's own noise only (camera/noise is a scenario's)
        return image, self._truth(image_name, sim.exposure.gain(sim.time))

    def _project(self, points_world, camera, cam_rot_world):
        """Pixels of world points through the distorted lens (NaN behind the camera)."""
        width, height, fx, fy, cx, cy = self.sim.camera_intrinsics()
        p = (np.asarray(points_world, dtype=float) - camera) @ cam_rot_world
        ahead = p[:, 2] > 1e-6
        out = np.full((len(p), 2), np.nan)
        if np.any(ahead):
            camera_matrix = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
            pixels, _ = cv2.projectPoints(p[ahead].reshape(-1, 1, 3), np.zeros(3), np.zeros(3), camera_matrix,
                                          np.array(self.sim.camera_distortion(), dtype=float))
            out[ahead] = pixels.reshape(-1, 2)
        return out

    def _inside(self, pixels):
        width, height = self.sim.camera_intrinsics()[:2]
        with np.errstate(invalid="ignore"):
            return ((pixels[:, 0] >= 0) & (pixels[:, 0] <= width - 1) &
                    (pixels[:, 1] >= 0) & (pixels[:, 1] <= height - 1))

    def _corners(self, geom, half_x, half_y, lift=0.0):
        d = self.sim.data
        axes = d.geom_xmat[geom].reshape(3, 3)
        top = d.geom_xpos[geom] + axes @ np.array([0.0, 0.0, lift])
        return [top + axes @ np.array([sx * half_x, sy * half_y, 0.0])
                for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))]

    def _grid(self, geom, half_x, half_y, lift, n=21):
        d = self.sim.data
        axes = d.geom_xmat[geom].reshape(3, 3)
        top = d.geom_xpos[geom] + axes @ np.array([0.0, 0.0, lift])
        return np.array([top + axes @ np.array([u, v, 0.0]) for u in np.linspace(-half_x, half_x, n)
                         for v in np.linspace(-half_y, half_y, n)])

    def _shadowed(self, points):
        """Whether each point's ray towards the sun is blocked: by the drone, or anything but the vehicle that
        carries the pad (whose strip and marker stand on the pad's top)."""
        sim = self.sim
        geom = np.zeros(1, dtype=np.int32)
        return np.array([mujoco.mj_ray(sim.model, sim.data, p + 1e-3 * self.towards_sun, self.towards_sun, None, 1,
                                       sim.vehicle_body, geom) >= 0 for p in points])

    def _pad_lift(self):
        """Height of the pad's top (its centre site) above its geom's centre [m]."""
        return float(self.sim.pad_position()[2] - self.sim.data.geom_xpos[self.sim.pad_geom][2])

    def _pad_grid(self):
        return self._grid(self.sim.pad_geom, PAD_HALF, PAD_HALF, self._pad_lift())

    def _truth(self, image_name, gain):
        sim = self.sim
        view, pad, camera, base, quat, rot, cam_rot_world = self.state
        width, height_px, fx, fy, cx, cy = sim.camera_intrinsics()
        pad_top = float(pad[2])
        pad_lift = self._pad_lift()
        pad_corners = self._corners(sim.pad_geom, PAD_HALF, PAD_HALF, pad_lift)
        if self.pad == "apriltag":
            # The heading point where the strip's centre was, and the inner tag's square as the marker.
            axes = sim.data.geom_xmat[sim.pad_geom].reshape(3, 3)
            strip_top = pad + axes @ np.array([HEADING_OFFSET, 0.0, 0.0])
            strip_corners = [strip_top + axes @ np.array([sx * STRIP_HALF[0], sy * STRIP_HALF[1], 0.0])
                             for sx, sy in ((1, 1), (-1, 1), (-1, -1), (1, -1))]
            marker_corners = self._corners(sim.pad_geom, INNER_TAG_HALF, INNER_TAG_HALF, pad_lift)
        else:
            strip_corners = self._corners(self.strip_geom, STRIP_HALF[0], STRIP_HALF[1], 0.0015)
            marker_corners = self._corners(self.marker_geom, MARKER_HALF, MARKER_HALF, 0.0015)
            strip_top = sim.data.geom_xpos[self.strip_geom] + sim.data.geom_xmat[self.strip_geom].reshape(3, 3) @ \
                np.array([0.0, 0.0, 0.0015])
        pad_grid = self._pad_grid()
        pad_grid_visible = self._inside(self._project(pad_grid, camera, cam_rot_world))
        shadowed = self._shadowed(pad_grid) if sim.realism["shadows"] else np.zeros(len(pad_grid), bool)
        false_share = 0.0
        if view.false_target:
            target_grid = self._grid(self.false_target_geom, FALSE_TARGET_HALF[0], FALSE_TARGET_HALF[1], 0.003, n=11)
            false_share = float(np.mean(self._inside(self._project(target_grid, camera, cam_rot_world))))
        foreign_share = 0.0
        if view.foreign_pad and self.foreign_pad_geom >= 0:
            foreign_grid = self._grid(self.foreign_pad_geom, FOREIGN_PAD_HALF, FOREIGN_PAD_HALF, 0.003, n=11)
            foreign_share = float(np.mean(self._inside(self._project(foreign_grid, camera, cam_rot_world))))
        # The blur the simulator applied: the image motion during the exposure (mujoco_sim simulator._motion_blur).
        velocity, omega = sim.drone_velocity()
        distance = sim.sonar_distance_true(base, rot)
        du, dv = image_motion(fx, sim.realism["camera_exposure_s"],
                              CAMERA_OPTICAL_IN_BODY @ rot.T @ (velocity - sim._surface_velocity_below(base)),
                              CAMERA_OPTICAL_IN_BODY @ omega, distance)
        # Sonar readings around the frame (25 Hz: one before, one after), as the node keeps them; each draws
        # its own noise and outliers.
        sonars = [sim.sonar() for _ in range(3)] if self.sonar_neighbours else [sim.sonar()] * 3
        imu_quat, _, _ = sim.imu()
        altitude, _ = sim.altimeter()
        # The barometer at 20 Hz: two readings each side of the frame's, each with its own noise.
        around = [sim.altimeter()[0] for _ in range(4)] if self.sonar_neighbours else [altitude] * 4
        pad_rel_world = pad - base
        k1, k2, p1, p2, k3 = sim.camera_distortion()
        return {
            "image": image_name, "band": view.band, "vehicle": self.vehicle, "profile": self.profile,
            "height_landing_platform": round(pad_top, 4), "camera_height": view.camera_height,
            "width": width, "height": height_px, "fx": fx, "fy": fy, "cx": cx, "cy": cy,
            "k1": k1, "k2": k2, "p1": p1, "p2": p2, "k3": k3,
            "pad_base_x": (rot.T @ pad_rel_world)[0], "pad_base_y": (rot.T @ pad_rel_world)[1],
            "pad_base_z": (rot.T @ pad_rel_world)[2],
            "pad_world_x": pad_rel_world[0], "pad_world_y": pad_rel_world[1], "pad_world_z": pad_rel_world[2],
            "pad_camera_x": ((pad - camera) @ cam_rot_world)[0], "pad_camera_y": ((pad - camera) @ cam_rot_world)[1],
            "pad_camera_z": ((pad - camera) @ cam_rot_world)[2],
            "strip_base_x": (rot.T @ (strip_top - base))[0], "strip_base_y": (rot.T @ (strip_top - base))[1],
            "strip_base_z": (rot.T @ (strip_top - base))[2],
            "qw": quat[0], "qx": quat[1], "qy": quat[2], "qz": quat[3],
            "imu_qw": imu_quat[0], "imu_qx": imu_quat[1], "imu_qy": imu_quat[2], "imu_qz": imu_quat[3],
            "tilt_deg": math.degrees(math.hypot(view.roll, view.pitch)),  # as drawn: direction and amount
            "sonar_range": sonars[1], "sonar_range_before": sonars[0], "sonar_range_after": sonars[2],
            # The beam the sonar's echoes come from, as sensor_msgs/Range field_of_view.
            "sonar_field_of_view": SONAR_FIELD_OF_VIEW_RAD,
            "baro_altitude": altitude, "baro_altitude_m2": around[0], "baro_altitude_m1": around[1],
            "baro_altitude_p1": around[2], "baro_altitude_p2": around[3],
            "visible_pad_share": float(np.mean(pad_grid_visible)),
            "visible_pad_corners": int(np.sum(self._inside(self._project(pad_corners, camera, cam_rot_world)))),
            "strip_corners_in_view": int(np.sum(self._inside(self._project(strip_corners, camera, cam_rot_world)))),
            "marker_corners_in_view": int(np.sum(self._inside(self._project(marker_corners, camera, cam_rot_world)))),
            "pad_shadow_share": float(np.mean(shadowed & pad_grid_visible)),
            "false_target_share": false_share,
            "blur_px": math.hypot(du, dv) if sim.realism["camera_exposure_s"] > 0.0 else 0.0,
            "exposure_gain": gain,
            "sun_elevation_deg": self.sun_elevation_deg,
            "pixel_noise_std_omitted": self.noise_omitted,
            "pad": self.pad, "foreign_pad_share": foreign_share,
        }


def write_truth(path, rows):
    """truth.csv: one row per image, floats with 6 decimals."""
    import csv
    with open(path, "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=TRUTH_COLUMNS, lineterminator="\n")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: ("%.6f" % v if isinstance(v, float) else v) for k, v in row.items()})


def save_png(path, image_rgb, compression=9):
    cv2.imwrite(path, cv2.cvtColor(image_rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_PNG_COMPRESSION, compression])
