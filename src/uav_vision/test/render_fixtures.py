#!/usr/bin/env python3
"""Renders the bottom-camera fixtures of the detector gtest with mujoco_sim's ROS-free core.

Writes test/data/rendered/*.png (RGB images saved as ordinary PNGs) and test/data/rendered/truth.csv
with, for every image, the ground truth (pad centre relative to the drone and the camera, attitude,
camera height above the pad) and what the drone's own sensors would read there (IMU attitude with its
noise, sonar range, barometric altitude). Poses are drawn from a fixed seed, so re-running it gives the
same files. Run from anywhere after `source env.sh`:

    MUJOCO_GL=osmesa python src/uav_vision/test/render_fixtures.py
"""
import argparse
import csv
import math
import os

import cv2
import mujoco
import numpy as np

from mujoco_sim.autopilot import quat_to_matrix
from mujoco_sim.schema import load_sim_config
from mujoco_sim.simulator import Simulator

HERE = os.path.dirname(os.path.abspath(__file__))
SIM_PKG = os.path.join(HERE, "..", "..", "mujoco_sim")
OUT = os.path.join(HERE, "data", "rendered")
CAMERA_BELOW_BASE = 0.035   # bottom camera origin below base_link [m] (docs/conventions.md)
PAD_HALF = 0.5              # half side of the pad [m]

# (band, number of images, camera height range above the pad [m], horizontal camera offset from the pad
# centre [m], maximum tilt [deg], vehicle). Low passes see the pad partly; high ones see all of it.
BANDS = [
    ("low", 12, (0.8, 0.98), (0.15, 0.55), 15.0, "summit_xl"),
    ("low", 4, (0.8, 0.98), (0.0, 0.15), 10.0, "summit_xl"),
    ("mid", 8, (1.0, 3.0), (0.0, 0.8), 15.0, "summit_xl"),
    ("high", 8, (3.0, 4.0), (0.0, 1.0), 15.0, "summit_xl"),
    ("high", 4, (4.0, 4.0), (0.0, 0.8), 15.0, "summit_xl"),
    ("mid", 2, (1.2, 3.0), (0.0, 0.6), 12.0, "car"),
    ("high", 2, (4.0, 4.0), (0.0, 0.6), 12.0, "car"),
    # The last half metre: the red fills the view and the centre marker is the only feature.
    ("close", 8, (0.3, 0.6), (0.0, 0.12), 10.0, "summit_xl"),
    ("close", 2, (0.3, 0.6), (0.0, 0.10), 8.0, "car"),
]
MARKER_HALF = 0.07          # half side of the white centre marker [m]


def rotation_quat(roll, pitch, yaw):
    """Quaternion (w, x, y, z) of R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy])


def make_sim(vehicle):
    config = load_sim_config(os.path.join(SIM_PKG, "config", "sim.yaml"))
    return Simulator(config, os.path.join(SIM_PKG, "models", "world_%s.xml" % vehicle), vehicle, seed=11)


def project(points_world, cam_pos, cam_rot_world, intrinsics):
    """Pixel coordinates of world points; cam_rot_world = optical axes in the world."""
    _, _, fx, fy, cx, cy = intrinsics
    p = (np.asarray(points_world) - cam_pos) @ cam_rot_world
    return np.stack([fx * p[:, 0] / p[:, 2] + cx, fy * p[:, 1] / p[:, 2] + cy], axis=1)


def inside(pixels, width, height):
    return (pixels[:, 0] >= 0) & (pixels[:, 0] <= width - 1) & (pixels[:, 1] >= 0) & (pixels[:, 1] <= height - 1)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=OUT)
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    rng = np.random.default_rng(2026)
    sims = {}
    rows = []
    index = 0
    for band, count, (h_min, h_max), (r_min, r_max), max_tilt, vehicle in BANDS:
        if vehicle not in sims:
            sims[vehicle] = make_sim(vehicle)
        sim = sims[vehicle]
        m, d = sim.model, sim.data
        strip_geom = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "landing_pad_heading")
        marker_geom = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "landing_pad_marker")
        made = 0
        while made < count:
            vehicle_yaw = rng.uniform(-math.pi, math.pi)
            d.qpos[sim.vehicle_qpos:sim.vehicle_qpos + 3] = (rng.uniform(-3, 3), rng.uniform(-3, 3), vehicle_yaw)
            mujoco.mj_forward(m, d)
            pad = sim.pad_position()
            height = rng.uniform(h_min, h_max)
            radius, bearing = rng.uniform(r_min, r_max), rng.uniform(-math.pi, math.pi)
            tilt, tilt_dir = math.radians(rng.uniform(0.0, max_tilt)), rng.uniform(-math.pi, math.pi)
            roll, pitch = tilt * math.cos(tilt_dir), tilt * math.sin(tilt_dir)
            yaw = rng.uniform(-math.pi, math.pi)
            quat = rotation_quat(roll, pitch, yaw)
            rot = quat_to_matrix(quat)
            camera_offset_world = rot @ np.array([0.0, 0.0, -CAMERA_BELOW_BASE])
            camera = pad + np.array([radius * math.cos(bearing), radius * math.sin(bearing), height])
            base = camera - camera_offset_world
            sim._set_drone_pose(tuple(base), yaw)
            d.qpos[sim.drone_qpos + 3:sim.drone_qpos + 7] = quat
            mujoco.mj_forward(m, d)

            intrinsics = sim.camera_intrinsics()
            width, height_px = intrinsics[0], intrinsics[1]
            cam_rot_world = rot @ sim.camera_pose_in_body()[1]
            strip_top = d.geom_xpos[strip_geom] + d.geom_xmat[strip_geom].reshape(3, 3) @ np.array([0, 0, 0.0015])
            strip_axes = d.geom_xmat[strip_geom].reshape(3, 3)
            pad_axes = d.geom_xmat[sim.pad_geom].reshape(3, 3)
            corners = [pad + pad_axes @ np.array([sx * PAD_HALF, sy * PAD_HALF, 0]) for sx, sy in
                       ((1, 1), (-1, 1), (-1, -1), (1, -1))]
            strip_corners = [strip_top + strip_axes @ np.array([sx * 0.06, sy * 0.35, 0]) for sx, sy in
                             ((1, 1), (-1, 1), (-1, -1), (1, -1))]
            corners_px = project(corners, camera, cam_rot_world, intrinsics)
            marker_top = d.geom_xpos[marker_geom] + pad_axes @ np.array([0, 0, 0.0015])
            marker_corners = [marker_top + pad_axes @ np.array([sx * MARKER_HALF, sy * MARKER_HALF, 0]) for sx, sy in
                              ((1, 1), (-1, 1), (-1, -1), (1, -1))]
            marker_px = project(marker_corners, camera, cam_rot_world, intrinsics)
            strip_px = project(strip_corners, camera, cam_rot_world, intrinsics)
            # Visible share of the pad, from a grid of points on it.
            grid = np.array([pad + pad_axes @ np.array([u, v, 0]) for u in np.linspace(-0.5, 0.5, 21)
                             for v in np.linspace(-0.5, 0.5, 21)])
            visible_share = float(np.mean(inside(project(grid, camera, cam_rot_world, intrinsics), width, height_px)))
            if visible_share < 0.15:
                continue  # the pad hardly in view: not a detection fixture

            image = sim.render_camera(noise_std=0.0)
            imu_quat, _, _ = sim.imu()
            sonar = sim.sonar()
            altitude, _ = sim.altimeter()
            name = "%02d_%s_%s_h%03d.png" % (index, band, vehicle, int(round(height * 100)))
            cv2.imwrite(os.path.join(args.out, name), cv2.cvtColor(image, cv2.COLOR_RGB2BGR),
                        [cv2.IMWRITE_PNG_COMPRESSION, 9])
            pad_rel_world = pad - base
            rows.append({
                "image": name, "band": band, "vehicle": vehicle,
                "height_landing_platform": round(float(pad[2]), 4),
                "camera_height": height,
                "fx": intrinsics[2], "fy": intrinsics[3], "cx": intrinsics[4], "cy": intrinsics[5],
                "pad_base_x": (rot.T @ pad_rel_world)[0], "pad_base_y": (rot.T @ pad_rel_world)[1],
                "pad_base_z": (rot.T @ pad_rel_world)[2],
                "pad_world_x": pad_rel_world[0], "pad_world_y": pad_rel_world[1], "pad_world_z": pad_rel_world[2],
                "pad_camera_x": ((pad - camera) @ cam_rot_world)[0], "pad_camera_y": ((pad - camera) @ cam_rot_world)[1],
                "pad_camera_z": ((pad - camera) @ cam_rot_world)[2],
                "strip_base_x": (rot.T @ (strip_top - base))[0], "strip_base_y": (rot.T @ (strip_top - base))[1],
                "strip_base_z": (rot.T @ (strip_top - base))[2],
                "qw": quat[0], "qx": quat[1], "qy": quat[2], "qz": quat[3],
                "imu_qw": imu_quat[0], "imu_qx": imu_quat[1], "imu_qy": imu_quat[2], "imu_qz": imu_quat[3],
                "tilt_deg": math.degrees(tilt),
                "sonar_range": sonar, "baro_altitude": altitude,
                "visible_pad_share": visible_share,
                "visible_pad_corners": int(np.sum(inside(corners_px, width, height_px))),
                "strip_corners_in_view": int(np.sum(inside(strip_px, width, height_px))),
                "marker_corners_in_view": int(np.sum(inside(marker_px, width, height_px))),
            })
            index += 1
            made += 1
    for sim in sims.values():
        sim.close()
    with open(os.path.join(args.out, "truth.csv"), "w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(rows[0]), lineterminator="\n")
        writer.writeheader()
        for row in rows:
            writer.writerow({k: ("%.6f" % v if isinstance(v, float) else v) for k, v in row.items()})
    print("wrote %d images and truth.csv to %s" % (len(rows), args.out))


if __name__ == "__main__":
    main()
