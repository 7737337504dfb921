#!/usr/bin/env python3
"""Renders the bottom-camera fixtures of uav_vision's detector gtests with mujoco_sim's ROS-free core.

The fixtures are committed in uav_vision (src/uav_vision/test/data), whose gtests (rendered_fixtures_test.cpp,
realistic_fixtures_test.cpp) only read them, through include/uav_vision/rendered_frames.h: the generator lives
here, in landing_bench, because rendering needs the simulator and uav_vision does not depend on it.

Two sets, each a directory of PNGs (RGB images saved as ordinary PNGs) and a truth.csv (columns:
landing_bench.rendered_frames.TRUTH_COLUMNS, read by name by uav_vision's loadRenderedFrames) with, per image, the ground truth and what the drone's own
sensors would read there:
- ``ideal`` (src/uav_vision/test/data/rendered): the first fixtures, pinned to the ``ideal`` realism profile (perfect
  lens, even light, no blur or noise), poses drawn by band;
- ``realistic`` (src/uav_vision/test/data/rendered_realistic): the ``realistic`` profile (lens distortion, the sun's
  shadows of the drone and the vehicle, motion blur, exposure wander) and a few ``harsh`` frames, each
  frame chosen for what it shows (see REALISTIC). The profile's sensor noise is left out of the PNGs
  (it would make each ten times larger) and recorded in pixel_noise_std_omitted for the test to add;
- ``apriltag`` (src/uav_vision/test/data/rendered_apriltag): the AprilTag pad (mujoco_sim.pads) in the ``realistic``
  profile from 6 m down to 0.3 m, in the drone's shadow, blurred, with the foreign pad (other tag ids) and the red
  false target in view, and frames without it (see APRILTAG); read by apriltag_fixtures_test.cpp.
Poses come from fixed seeds, so re-running gives the same files. After `source env.sh`, from the workspace:

    MUJOCO_GL=osmesa python src/landing_bench/test/render_fixtures.py [--set ideal|realistic|apriltag|all]

then `catkin_make run_tests_uav_vision_gtest_uav_vision_detector_test` reads them.
"""
import argparse
import math
import os

import numpy as np

from landing_bench.rendered_frames import FrameRenderer, View, save_png, write_truth

HERE = os.path.dirname(os.path.abspath(__file__))
FIXTURES = os.path.realpath(os.path.join(HERE, "..", "..", "uav_vision", "test", "data"))  # uav_vision's
OUT = {"ideal": os.path.join(FIXTURES, "rendered"), "realistic": os.path.join(FIXTURES, "rendered_realistic"),
       "apriltag": os.path.join(FIXTURES, "rendered_apriltag")}

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


def render_ideal(out):
    """The first fixture set, drawn exactly as it always was (same seed, same order of draws)."""
    rng = np.random.default_rng(2026)
    renderers, rows, index = {}, [], 0
    for band, count, (h_min, h_max), (r_min, r_max), max_tilt, vehicle in BANDS:
        if vehicle not in renderers:
            renderers[vehicle] = FrameRenderer(vehicle, "ideal", seed=11, sonar_neighbours=False)
        renderer = renderers[vehicle]
        made = 0
        while made < count:
            vehicle_yaw = rng.uniform(-math.pi, math.pi)
            vehicle_position = (rng.uniform(-3, 3), rng.uniform(-3, 3))
            height = rng.uniform(h_min, h_max)
            radius, bearing = rng.uniform(r_min, r_max), rng.uniform(-math.pi, math.pi)
            tilt, tilt_dir = math.radians(rng.uniform(0.0, max_tilt)), rng.uniform(-math.pi, math.pi)
            view = View(camera_offset=(radius * math.cos(bearing), radius * math.sin(bearing)), camera_height=height,
                        roll=tilt * math.cos(tilt_dir), pitch=tilt * math.sin(tilt_dir),
                        yaw=rng.uniform(-math.pi, math.pi),
                        vehicle_yaw=vehicle_yaw, vehicle_position=vehicle_position, band=band)
            if renderer.set_view(view) < 0.15:
                continue  # the pad hardly in view: not a detection fixture
            name = "%02d_%s_%s_h%03d.png" % (index, band, vehicle, int(round(height * 100)))
            image, row = renderer.render(name)
            save_png(os.path.join(out, name), image)
            rows.append(row)
            index += 1
            made += 1
    for renderer in renderers.values():
        renderer.close()
    return rows


def offset_for_pixel(u, v, height, yaw=0.0, intrinsics=(256.0, 159.5, 119.5)):
    """Camera offset from the pad (world, horizontal) that puts the pad centre near pixel (u, v) of the
    ideal image of a level camera with heading ``yaw``: image right is the drone's right, image up its
    forward (docs/conventions.md)."""
    f, cx, cy = intrinsics
    forward, right = -(v - cy) / f * height, (u - cx) / f * height  # pad from the camera, body axes
    c, s = math.cos(yaw), math.sin(yaw)
    pad_x, pad_y = c * forward + s * right, s * forward - c * right  # body (forward, left=-right) -> world
    return (-pad_x, -pad_y)


def shadow_view(renderer, arguments):
    """View arguments with ``jitter`` replaced: the camera where the drone's shadow falls on the pad, ``jitter``
    [m] from its centre, the drone tilted (as when flying towards it) to bring the pad into view."""
    arguments = dict(arguments)
    sun = renderer.towards_sun
    offset = np.asarray(arguments.pop("jitter")) + sun[:2] / sun[2] * (arguments["camera_height"] + 0.035)
    towards_pad = -offset / np.linalg.norm(offset)
    yaw, tilt = arguments.get("yaw", 0.0), math.radians(arguments.pop("tilt_towards_pad", 12.0))
    c, s = math.cos(yaw), math.sin(yaw)
    forward, left = c * towards_pad[0] + s * towards_pad[1], -s * towards_pad[0] + c * towards_pad[1]
    # Pitching forward (negative pitch) and rolling left (positive roll) turn the camera that way.
    arguments.update(camera_offset=tuple(offset), pitch=-tilt * forward, roll=tilt * left)
    return arguments


# What the realistic set shows, frame by frame: (label, renderer key, view arguments). Renderer keys:
# (vehicle, profile, seed, overrides), one renderer per seed; a high sun (within the realistic profile's range) puts the drone's
# shadow in the camera's view of the pad. Labels: shadow, blur, dark, bright, corner (the pad near an
# image corner, where the lens bends it most), false (the red false target in view), none (no pad in
# view), low (pad cut by the border), close (the marker alone), car, harsh.
SUMMIT = ("summit_xl", "realistic", 101, {})
SUMMIT_2 = ("summit_xl", "realistic", 102, {})
HIGH_SUN = ("summit_xl", "realistic", 103, {"sun_elevation_deg": 63.0, "sun_elevation_spread_deg": 0.0})
HIGH_SUN_2 = ("summit_xl", "realistic", 104, {"sun_elevation_deg": 60.0, "sun_elevation_spread_deg": 0.0})
CAR = ("car", "realistic", 105, {})
HARSH = ("summit_xl", "harsh", 106, {"sun_elevation_deg": 45.0, "sun_elevation_spread_deg": 0.0})
DRIFT = dict(relative_velocity=(0.4, -0.2, -0.1), body_rates=(0.1, -0.15, 0.05))  # an ordinary approach
FAST = dict(relative_velocity=(2.0, 1.0, -0.3), body_rates=(0.8, -0.6, 0.3))     # a hard manoeuvre: blur
REALISTIC = [
    ("whole", SUMMIT, dict(camera_offset=(0.3, -0.2), camera_height=2.0, roll=0.05, pitch=-0.08, yaw=0.4, **DRIFT)),
    ("whole", SUMMIT, dict(camera_offset=(-0.5, 0.4), camera_height=3.0, roll=-0.1, pitch=0.05, yaw=2.1, **DRIFT)),
    ("whole", SUMMIT, dict(camera_offset=(0.2, 0.6), camera_height=4.0, roll=0.12, pitch=0.1, yaw=-1.2, **DRIFT)),
    ("whole", SUMMIT_2, dict(camera_offset=(0.0, 0.3), camera_height=1.5, roll=0.0, pitch=0.1, yaw=-2.6, **DRIFT)),
    ("corner", SUMMIT, dict(camera_offset=offset_for_pixel(262, 28, 3.0), camera_height=3.0, **DRIFT)),
    ("corner", SUMMIT_2, dict(camera_offset=offset_for_pixel(55, 200, 3.5, yaw=1.0), camera_height=3.5, yaw=1.0)),
    ("corner", SUMMIT_2, dict(camera_offset=offset_for_pixel(258, 195, 4.5, yaw=-0.5), camera_height=4.5,
                              yaw=-0.5, **DRIFT)),
    ("corner", SUMMIT, dict(camera_offset=offset_for_pixel(50, 35, 4.0, yaw=2.5), camera_height=4.0, yaw=2.5)),
    ("shadow", HIGH_SUN, dict(camera_height=1.2, jitter=(0.0, 0.0), yaw=0.3, **DRIFT)),
    ("shadow", HIGH_SUN, dict(camera_height=1.6, jitter=(0.35, 0.1), yaw=1.9)),
    ("shadow", HIGH_SUN, dict(camera_height=2.2, jitter=(-0.3, 0.45), yaw=-1.0, **DRIFT)),
    ("shadow", HIGH_SUN_2, dict(camera_height=1.0, jitter=(0.45, -0.45), yaw=2.8)),
    ("shadow", HIGH_SUN_2, dict(camera_height=1.8, jitter=(-0.5, 0.0), yaw=0.9, **DRIFT)),
    ("shadow", HIGH_SUN_2, dict(camera_height=2.6, jitter=(0.1, -0.5), yaw=-2.2)),
    ("blur", SUMMIT, dict(camera_offset=(0.2, 0.1), camera_height=1.2, yaw=0.7, **FAST)),
    ("blur", SUMMIT_2, dict(camera_offset=(-0.3, 0.2), camera_height=2.0, yaw=-1.4, roll=0.15, **FAST)),
    ("blur", CAR, dict(camera_offset=(0.2, -0.3), camera_height=1.5, yaw=2.0, vehicle_speed=12.0, **FAST)),
    ("dark", SUMMIT, dict(camera_offset=(0.4, 0.1), camera_height=2.5, yaw=1.1, log_gain=-0.3, **DRIFT)),
    ("dark", HIGH_SUN, dict(camera_height=1.4, jitter=(0.2, 0.2), yaw=-0.4, log_gain=-0.3)),
    ("bright", SUMMIT_2, dict(camera_offset=(-0.2, -0.5), camera_height=3.2, yaw=0.2, log_gain=0.3, **DRIFT)),
    ("bright", HIGH_SUN_2, dict(camera_height=1.3, jitter=(-0.2, 0.3), yaw=2.4, log_gain=0.3)),
    ("false", SUMMIT, dict(camera_offset=(-0.6, 0.9), camera_height=3.5, yaw=0.0, false_target=True, **DRIFT)),
    ("false", SUMMIT_2, dict(camera_offset=(-0.2, 1.0), camera_height=4.5, yaw=1.3, false_target=True)),
    ("false", CAR, dict(camera_offset=(0.3, 1.2), camera_height=4.0, yaw=-0.7, false_target=True, **DRIFT)),
    ("false", SUMMIT, dict(camera_offset=(0.1, 1.6), camera_height=2.0, yaw=0.5, false_target=True)),
    ("false", SUMMIT_2, dict(camera_offset=(0.5, 2.0), camera_height=1.2, yaw=-2.0, false_target=True, **DRIFT)),
    ("false", SUMMIT, dict(camera_offset=(-0.7, 1.9), camera_height=4.8, yaw=2.9, false_target=True)),
    ("none", SUMMIT, dict(camera_offset=(3.0, -2.0), camera_height=2.5, yaw=0.8, **DRIFT)),
    ("none", SUMMIT_2, dict(camera_offset=(-1.6, -1.2), camera_height=1.5, yaw=-1.1)),
    ("none", CAR, dict(camera_offset=(1.8, 0.0), camera_height=1.0, yaw=0.0, **DRIFT)),
    ("low", SUMMIT, dict(camera_offset=(0.35, 0.3), camera_height=0.85, roll=0.1, yaw=0.6, **DRIFT)),
    ("low", SUMMIT_2, dict(camera_offset=(-0.4, 0.1), camera_height=0.95, pitch=-0.1, yaw=-2.3)),
    ("low", HIGH_SUN, dict(camera_height=0.9, jitter=(0.3, -0.25), yaw=1.5, **DRIFT)),
    ("low", SUMMIT, dict(camera_offset=(0.1, -0.45), camera_height=0.8, roll=-0.12, yaw=3.0)),
    ("close", SUMMIT, dict(camera_offset=(0.03, -0.02), camera_height=0.45, yaw=0.9, **DRIFT)),
    ("close", SUMMIT_2, dict(camera_offset=(-0.05, 0.04), camera_height=0.55, roll=0.08, yaw=-0.3)),
    ("close", HIGH_SUN, dict(camera_height=0.5, jitter=(0.0, 0.05), tilt_towards_pad=22.0, yaw=2.2)),
    ("car", CAR, dict(camera_offset=(0.2, 0.3), camera_height=2.5, roll=0.08, yaw=1.4, vehicle_speed=10.0, **DRIFT)),
    ("car", CAR, dict(camera_offset=(-0.4, 0.2), camera_height=4.0, pitch=0.1, yaw=-0.6, vehicle_speed=15.0)),
    ("harsh", HARSH, dict(camera_offset=(0.3, 0.2), camera_height=2.5, yaw=0.5, log_gain=-0.5, **DRIFT)),
    ("harsh", HARSH, dict(camera_height=1.6, jitter=(0.2, -0.2), yaw=-1.7, **FAST)),
    ("harsh", HARSH, dict(camera_offset=(-0.3, 0.8), camera_height=3.5, yaw=2.0, log_gain=0.5, false_target=True)),
    ("harsh", HARSH, dict(camera_offset=(0.5, -0.4), camera_height=4.5, roll=0.1, yaw=-2.8, **DRIFT)),
]


def render_set(frames, out, pad="red_square"):
    """Each frame of ``frames`` ((label, renderer key, view arguments)) as a PNG in ``out``, the profile's sensor noise
    left to the test; the rows of their truth."""
    renderers, rows = {}, []
    for index, (label, key, arguments) in enumerate(frames):
        vehicle, profile, seed, overrides = key
        if seed not in renderers:
            renderers[seed] = FrameRenderer(vehicle, profile, seed, overrides, omit_pixel_noise=True, pad=pad)
        renderer = renderers[seed]
        if "jitter" in arguments:
            arguments = shadow_view(renderer, arguments)
        # The vehicle heads along world x (the false target 1.6 m to its left, +y); the drone's yaw turns the view.
        view = View(band=label, vehicle_position=(0.5, -0.5), **arguments)
        renderer.set_view(view)
        name = "%02d_%s_%s_h%03d.png" % (index, label, key[0], int(round(view.camera_height * 100)))
        image, row = renderer.render(name)
        save_png(os.path.join(out, name), image)
        rows.append(row)
    for renderer in renderers.values():
        renderer.close()
    return rows


def render_realistic(out):
    """The realistic set: each frame of REALISTIC."""
    return render_set(REALISTIC, out)


# The AprilTag pad's set: (label, renderer key, view arguments), renderer keys as REALISTIC's. Labels: whole (the pad
# whole in view, 1.2-6 m), inner (the inner tag alone, 0.3-0.9 m), shadow, blur, foreign (the foreign pad beside the
# vehicle in view, with the pad), foreign_alone (the foreign pad without the pad), red (the red false target), none, car.
TAGS = ("summit_xl", "realistic", 201, {})
TAGS_2 = ("summit_xl", "realistic", 202, {})
TAGS_HIGH_SUN = ("summit_xl", "realistic", 203, {"sun_elevation_deg": 63.0, "sun_elevation_spread_deg": 0.0})
TAGS_CAR = ("car", "realistic", 204, {})
APRILTAG = [
    ("whole", TAGS, dict(camera_offset=(0.4, -0.3), camera_height=6.0, roll=0.05, pitch=-0.08, yaw=0.4, **DRIFT)),
    ("whole", TAGS, dict(camera_offset=(-0.8, 0.6), camera_height=5.0, roll=-0.1, pitch=0.05, yaw=2.1, **DRIFT)),
    ("whole", TAGS_2, dict(camera_offset=(0.2, 0.5), camera_height=4.0, roll=0.12, pitch=0.1, yaw=-1.2)),
    ("whole", TAGS_2, dict(camera_offset=(0.0, 0.3), camera_height=2.5, pitch=0.1, yaw=-2.6, **DRIFT)),
    ("whole", TAGS, dict(camera_offset=(0.1, -0.05), camera_height=1.4, yaw=0.9, **DRIFT)),
    ("corner", TAGS_2, dict(camera_offset=offset_for_pixel(60, 45, 4.0, yaw=2.5), camera_height=4.0, yaw=2.5)),
    ("inner", TAGS, dict(camera_offset=(0.03, -0.02), camera_height=0.9, yaw=0.9, **DRIFT)),
    ("inner", TAGS_2, dict(camera_offset=(-0.05, 0.04), camera_height=0.6, roll=0.08, yaw=-0.3)),
    ("inner", TAGS, dict(camera_offset=(0.02, 0.01), camera_height=0.4, yaw=2.0, **DRIFT)),
    ("inner", TAGS_2, dict(camera_offset=(0.01, -0.02), camera_height=0.3, yaw=-1.4)),
    ("shadow", TAGS_HIGH_SUN, dict(camera_height=1.6, jitter=(0.0, 0.0), yaw=0.3, **DRIFT)),
    ("shadow", TAGS_HIGH_SUN, dict(camera_height=2.4, jitter=(0.3, 0.2), yaw=1.9)),
    ("shadow", TAGS_HIGH_SUN, dict(camera_height=0.6, jitter=(0.0, 0.05), tilt_towards_pad=15.0, yaw=-1.0)),
    ("blur", TAGS, dict(camera_offset=(0.2, 0.1), camera_height=2.0, yaw=0.7,
                        relative_velocity=(1.0, 0.5, -0.2), body_rates=(0.4, -0.3, 0.2))),
    ("foreign", TAGS, dict(camera_offset=(0.0, -0.9), camera_height=3.5, yaw=0.0, false_target=True,
                           foreign_pad=True, **DRIFT)),
    ("foreign_alone", TAGS_2, dict(camera_offset=(0.0, -1.8), camera_height=1.6, yaw=0.5, false_target=True,
                                   foreign_pad=True)),
    ("foreign_alone", TAGS, dict(camera_offset=(0.3, -1.8), camera_height=3.0, yaw=-2.0, false_target=True,
                                 foreign_pad=True, **DRIFT)),
    ("red", TAGS_2, dict(camera_offset=(-0.2, 1.6), camera_height=2.0, yaw=1.3, false_target=True)),
    ("none", TAGS, dict(camera_offset=(3.0, -2.0), camera_height=2.5, yaw=0.8, **DRIFT)),
    ("car", TAGS_CAR, dict(camera_offset=(0.2, 0.3), camera_height=2.5, roll=0.08, yaw=1.4, vehicle_speed=10.0,
                           **DRIFT)),
    ("car", TAGS_CAR, dict(camera_offset=(-0.02, 0.03), camera_height=0.5, yaw=-0.6, vehicle_speed=10.0)),
]


def render_apriltag(out):
    """The AprilTag pad's set: each frame of APRILTAG."""
    return render_set(APRILTAG, out, pad="apriltag")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", choices=("ideal", "realistic", "apriltag", "all"), default="all")
    parser.add_argument("--out", help="directory to write to instead of src/uav_vision/test/data/<set> (one set only)")
    args = parser.parse_args()
    sets = ("ideal", "realistic", "apriltag") if args.set == "all" else (args.set,)
    if args.out and len(sets) > 1:
        parser.error("--out needs --set ideal, realistic or apriltag")
    for name in sets:
        out = args.out or OUT[name]
        os.makedirs(out, exist_ok=True)
        rows = {"ideal": render_ideal, "realistic": render_realistic, "apriltag": render_apriltag}[name](out)
        write_truth(os.path.join(out, "truth.csv"), rows)
        print("wrote %d images and truth.csv to %s" % (len(rows), out))


if __name__ == "__main__":
    main()
