"""Detection benchmark on thousands of bottom-camera frames rendered on the fly (nothing is kept).

    rosrun landing_bench rendered_benchmark [--frames 3000] [--profiles realistic harsh] [--seed 1] [--keep DIR]
                                            [--views approach|close] [--pad red_square|apriltag]

For each realism profile the same seeded views are rendered with mujoco_sim (landing_bench.rendered_frames)
into a temporary directory, and ``detector_benchmark`` scores them: recall with the whole pad in view,
false detections (a pad reported where none is, or more than 0.25 m from the truth) as a share of all
frames, recall at close range (camera below 0.5 m, the centre marker at least partly in view), centre error
statistics, frames per second on one core.

The views are those of a landing approach: the camera 0.3-5 m above the pad, the pad anywhere from the
image centre to out of view, the drone tilted up to 15 deg, moving relative to the vehicle up to 1.5 m/s
and turning (motion blur), the vehicle driving; in a third of the frames the drone's shadow is put on
the pad, in a third the red false target (fault detection_false_target) is beside the vehicle and in a
tenth of the frames the camera looks at it. Each group of 25 frames has its own sun (the profile's
random elevation and azimuth) and the exposure wanders from frame to frame as the profile says.

``--pad apriltag`` renders the AprilTag pad (mujoco_sim.pads) instead, and detector_benchmark scores its detector: the
camera 0.3-6 m above the pad (issue 44's range), and in a third of the frames the foreign pad (the same tag families,
other ids) on the ground beside the vehicle, looked at in a tenth of all frames, besides the red false target.
"""
import argparse
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

from mujoco_sim.pads import FOREIGN_PAD_OFFSET, PADS

from .rendered_frames import FrameRenderer, View, save_png, write_truth

FRAMES_PER_SUN = 25         # frames rendered with one simulator (one sun), then a new seed
CAR_SHARE = 0.25            # of the frames over the car (pad 1.72 m high), the rest over the Summit XL
MAX_SPEED = {"summit_xl": 3.0, "car": 15.0}  # vehicle speeds drawn up to these [m/s]
MAX_HEIGHT = {"red_square": 5.0, "apriltag": 6.0}  # camera heights above the pad drawn up to these [m]
FALSE_TARGET_OFFSET = 1.6   # the false target beside the vehicle, to its left (mujoco_sim simulator) [m]


def sample_view(rng, renderer):
    """A view of a landing approach (see the module's docstring)."""
    vehicle_yaw = rng.uniform(-math.pi, math.pi)
    height = rng.uniform(0.3, MAX_HEIGHT[getattr(renderer, "pad", "red_square")])
    # Half of the views near the pad (mostly all of it in view), half further out (parts of it, or none).
    reach = 0.35 * height if rng.random() < 0.5 else 0.75 * height + 0.6
    radius, bearing = rng.uniform(0.0, reach), rng.uniform(-math.pi, math.pi)
    offset = np.array([radius * math.cos(bearing), radius * math.sin(bearing)])
    false_target = rng.random() < 1.0 / 3.0
    look = rng.random()
    if look < 1.0 / 3.0:
        # The drone's shadow on the pad: the camera up-sun of the pad by the shadow's reach.
        sun = renderer.towards_sun
        offset = rng.uniform(-0.5, 0.5, 2) + sun[:2] / max(sun[2], 0.2) * (height + 0.035)
    elif false_target and look > 0.9:
        # Looking at the false target, 1.6 m to the vehicle's left, with or without the pad in view.
        left = np.array([-math.sin(vehicle_yaw), math.cos(vehicle_yaw)])
        offset = FALSE_TARGET_OFFSET * left + rng.uniform(-0.6, 0.6, 2) * (0.5 + 0.3 * height)
    tilt, tilt_dir = math.radians(rng.uniform(0.0, 15.0)), rng.uniform(-math.pi, math.pi)
    speed, heading = rng.uniform(0.0, 1.5), rng.uniform(-math.pi, math.pi)
    foreign_pad = False
    if getattr(renderer, "pad", "red_square") == "apriltag":
        # The foreign pad beside the vehicle (to its right) in a third of the frames, looked at in a tenth of all.
        # (Drawn last: the red square's views stay the ones they were.)
        foreign_pad = rng.random() < 1.0 / 3.0
        if foreign_pad and rng.random() < 0.3:
            right = np.array([math.sin(vehicle_yaw), -math.cos(vehicle_yaw)])
            offset = FOREIGN_PAD_OFFSET * right + rng.uniform(-0.6, 0.6, 2) * (0.5 + 0.3 * height)
    return View(camera_offset=tuple(offset), camera_height=height, roll=tilt * math.cos(tilt_dir),
                pitch=tilt * math.sin(tilt_dir), yaw=rng.uniform(-math.pi, math.pi), vehicle_yaw=vehicle_yaw,
                vehicle_position=tuple(rng.uniform(-3.0, 3.0, 2)),
                vehicle_speed=rng.uniform(0.0, MAX_SPEED[renderer.vehicle]),
                relative_velocity=(speed * math.cos(heading), speed * math.sin(heading), rng.uniform(-0.5, 0.3)),
                body_rates=tuple(np.clip(rng.normal(0.0, 0.3, 3), -1.0, 1.0)), false_target=false_target,
                foreign_pad=foreign_pad, band="bench")


def sample_close_view(rng, renderer):
    """A view of the last half metre of a landing: the camera 0.3-0.7 m above the pad and up to 0.3 m off its
    centre (the centre marker wholly in view, cut by the image border, or out of view), tilted up to 10 deg,
    moving relative to the vehicle up to 1 m/s, no false target."""
    height, radius, bearing = rng.uniform(0.3, 0.7), rng.uniform(0.0, 0.3), rng.uniform(-math.pi, math.pi)
    tilt, tilt_dir = math.radians(rng.uniform(0.0, 10.0)), rng.uniform(-math.pi, math.pi)
    speed, heading = rng.uniform(0.0, 1.0), rng.uniform(-math.pi, math.pi)
    return View(camera_offset=(radius * math.cos(bearing), radius * math.sin(bearing)), camera_height=height,
                roll=tilt * math.cos(tilt_dir), pitch=tilt * math.sin(tilt_dir), yaw=rng.uniform(-math.pi, math.pi),
                vehicle_yaw=rng.uniform(-math.pi, math.pi), vehicle_position=tuple(rng.uniform(-3.0, 3.0, 2)),
                vehicle_speed=rng.uniform(0.0, MAX_SPEED["summit_xl"]),
                relative_velocity=(speed * math.cos(heading), speed * math.sin(heading), rng.uniform(-0.5, 0.1)),
                body_rates=tuple(np.clip(rng.normal(0.0, 0.3, 3), -1.0, 1.0)), false_target=False, band="close")


VIEWS = {"approach": sample_view, "close": sample_close_view}


def render_set(profile, frames, seed, out, views="approach", pad="red_square"):
    """Renders ``frames`` views of ``profile`` into ``out`` (PNGs and truth.csv); the views depend on the seed
    (and the pad) only, so every profile sees the same ones. ``views``: ``approach`` (sample_view) or ``close``
    (sample_close_view, over the Summit XL only). ``pad``: the pad's face (mujoco_sim.pads.PADS)."""
    rng = np.random.default_rng(seed)
    rows = []
    renderer = None
    start = time.monotonic()
    for index in range(frames):
        if index % FRAMES_PER_SUN == 0:
            if renderer is not None:
                renderer.close()
            vehicle = "car" if views == "approach" and rng.random() < CAR_SHARE else "summit_xl"
            renderer = FrameRenderer(vehicle, profile, seed=seed * 100003 + index // FRAMES_PER_SUN, pad=pad)
        renderer.set_view(VIEWS[views](rng, renderer))
        name = "%05d_%s.png" % (index, renderer.vehicle)
        image, row = renderer.render(name)
        save_png(os.path.join(out, name), image, compression=1)
        rows.append(row)
        if (index + 1) % 500 == 0:
            print("  %s: %d of %d frames rendered (%.0f s)" % (profile, index + 1, frames, time.monotonic() - start),
                  flush=True)
    renderer.close()
    write_truth(os.path.join(out, "truth.csv"), rows)
    return rows


def find_detector_benchmark():
    """The detector_benchmark binary of this workspace (catkin's devel space, or the install space)."""
    from catkin.find_in_workspaces import find_in_workspaces
    found = find_in_workspaces(["libexec"], project="uav_vision", path="detector_benchmark", first_match_only=True)
    if not found:
        raise FileNotFoundError("detector_benchmark not found: build the workspace (make build) and source env.sh")
    return found[0]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    parser.add_argument("--frames", type=int, default=3000, help="frames per profile (default 3000)")
    parser.add_argument("--profiles", nargs="+", default=["realistic", "harsh"],
                        choices=("ideal", "realistic", "harsh"), help="realism profiles (default: realistic harsh)")
    parser.add_argument("--seed", type=int, default=1, help="seed of the views and the simulators (default 1)")
    parser.add_argument("--keep", help="keep the rendered frames in DIR/<profile> instead of a temporary directory")
    parser.add_argument("--worst", type=int, default=5, help="list this many of the worst frames (default 5)")
    parser.add_argument("--views", choices=sorted(VIEWS), default="approach",
                        help="approach: 0.3-5 m up, the pad anywhere (default); close: the last half metre, 0.3-0.7 m up "
                             "and up to 0.3 m off the centre")
    parser.add_argument("--pad", choices=PADS, default="red_square",
                        help="the pad rendered and scored: red_square (default) or apriltag (the AprilTag pad, 0.3-6 m up, "
                             "with a foreign pad beside the vehicle in a third of the frames)")
    args = parser.parse_args(argv)
    if args.frames < 1:
        parser.error("--frames must be at least 1")
    try:
        benchmark = find_detector_benchmark()
    except FileNotFoundError as err:
        print("rendered_benchmark: %s" % err, file=sys.stderr)
        return 2
    status = 0
    for profile in args.profiles:
        out = os.path.join(args.keep, profile) if args.keep else tempfile.mkdtemp(prefix="uav_vision_%s_" % profile)
        os.makedirs(out, exist_ok=True)
        try:
            print("== %s: rendering %d %s views of the %s pad (seed %d)" % (profile, args.frames, args.views, args.pad,
                                                                           args.seed), flush=True)
            render_set(profile, args.frames, args.seed, out, args.views, args.pad)
            status |= subprocess.call([benchmark, "--dir", out, "--worst", str(args.worst)])
        finally:
            if not args.keep:
                shutil.rmtree(out, ignore_errors=True)
    return status
