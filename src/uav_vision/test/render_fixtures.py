#!/usr/bin/env python3
"""Renders the bottom-camera fixtures of the detector gtests with mujoco_sim's ROS-free core.

Two sets, each a directory of PNGs (RGB images saved as ordinary PNGs) and a truth.csv (columns:
uav_vision.rendered_frames.TRUTH_COLUMNS) with, per image, the ground truth and what the drone's own
sensors would read there:
- ``ideal`` (test/data/rendered): the first fixtures, pinned to the ``ideal`` realism profile (perfect
  lens, even light, no blur or noise), poses drawn by band;
- ``realistic`` (test/data/rendered_realistic): the ``realistic`` profile (lens distortion, the sun's
  shadows of the drone and the vehicle, motion blur, exposure wander) and a few ``harsh`` frames, each
  frame chosen for what it shows (see REALISTIC). The profile's sensor noise is left out of the PNGs
  (it would make each ten times larger) and recorded in pixel_noise_std_omitted for the test to add.
Poses come from fixed seeds, so re-running gives the same files. After `source env.sh`:

    MUJOCO_GL=osmesa python src/uav_vision/test/render_fixtures.py [--set ideal|realistic|all]
"""
import argparse
import math
import os

import numpy as np

from uav_vision.rendered_frames import FrameRenderer, View, save_png, write_truth

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = {"ideal": os.path.join(HERE, "data", "rendered"), "realistic": os.path.join(HERE, "data", "rendered_realistic")}

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


def render_realistic(out):
    raise NotImplementedError


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", choices=("ideal", "realistic", "all"), default="all")
    parser.add_argument("--out", help="directory to write to instead of test/data/<set> (one set only)")
    args = parser.parse_args()
    sets = ("ideal", "realistic") if args.set == "all" else (args.set,)
    if args.out and len(sets) > 1:
        parser.error("--out needs --set ideal or --set realistic")
    for name in sets:
        out = args.out or OUT[name]
        os.makedirs(out, exist_ok=True)
        rows = {"ideal": render_ideal, "realistic": render_realistic}[name](out)
        write_truth(os.path.join(out, "truth.csv"), rows)
        print("wrote %d images and truth.csv to %s" % (len(rows), out))


if __name__ == "__main__":
    main()
