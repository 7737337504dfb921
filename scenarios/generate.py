#!/usr/bin/env python3
"""Writes the shipped scenario suite (SPEC section 7) into this directory: one YAML file a scenario.

    python3 scenarios/generate.py          # rewrite the suite
    python3 scenarios/generate.py --check  # exit 1 if the committed files differ from the generator

Every scenario has a seed and an `expect:` block that the benchmark checks."""
import argparse
import os
import sys

import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
SUMMIT_PATHS = ("straight", "circle", "figure8", "back_and_forth", "square", "stop_and_go", "random")
ON_PAD = {"outcome": "landed_on_pad", "max_touchdown_error_m": 0.25}


def scenario(name, seed, vehicle="summit_xl", path="straight", speed=1.0, radius=10.0, time_limit=120.0,
             conditions=None, sensors=None, events=None, start="on_pad", expect=None, description=""):
    out = {"name": name, "description": description, "seed": seed, "time_limit_s": time_limit,
           "platform": {"vehicle": vehicle, "path": path, "speed_mps": speed, "radius_m": radius},
           "drone": {"start": start},
           "conditions": dict({"wind_speed": 0.0, "wind_direction_deg": 0.0, "gust_mps": 0.0, "drone_battery": 90,
                               "control_battery": 80, "temp": 15}, **(conditions or {})),
           "sensors": dict({"camera_noise": 0.0, "camera_fps": 30}, **(sensors or {})),
           "events": [{"at_s": 0, "operator": "landing"}] + list(events or []),
           "expect": expect or dict(ON_PAD)}
    return out


def suite():
    items, seed = [], 100

    def add(*args, **kwargs):
        nonlocal seed
        seed += 1
        items.append(scenario(*args, seed=seed, **kwargs))

    # Summit XL: every path at every speed of the thesis' robot.
    for path in SUMMIT_PATHS:
        for speed in (0.5, 1.0, 2.0, 3.0):
            add("summit_%s_%gms" % (path, speed), path=path, speed=speed, radius=10.0 if path != "square" else 5.0,
                description="Summit XL on a %s path at %g m/s" % (path, speed))
    # Repeated seeds of the common cases (the landing success rate is measured over these).
    for path, speed in (("straight", 1.0), ("circle", 2.0), ("figure8", 1.0), ("random", 2.0)):
        for repeat in range(1, 4):
            add("summit_%s_%gms_seed%d" % (path, speed, repeat), path=path, speed=speed,
                description="repeat with another seed")
    # Car on a straight road and on a 50 m circle.
    for speed in (5.0, 10.0, 15.0):
        add("car_straight_%gms" % speed, vehicle="car", path="straight", speed=speed, time_limit=150.0,
            description="car on a straight road at %g m/s" % speed)
    for speed in (5.0, 10.0):
        add("car_circle_r50_%gms" % speed, vehicle="car", path="circle", speed=speed, radius=50.0, time_limit=150.0,
            description="car on a 50 m circle at %g m/s" % speed)
    # Wind with gusts, from several directions.
    for wind in (0.0, 4.0, 8.0):
        for direction in (0.0, 90.0, 225.0):
            add("wind_%gms_dir%d" % (wind, direction), path="circle", speed=1.0,
                conditions={"wind_speed": wind, "wind_direction_deg": direction, "gust_mps": wind / 4.0},
                description="%g m/s wind towards %d deg with gusts" % (wind, direction))
    for wind in (4.0, 8.0):
        add("wind_%gms_straight_2ms" % wind, path="straight", speed=2.0,
            conditions={"wind_speed": wind, "wind_direction_deg": 180.0, "gust_mps": wind / 4.0},
            description="head wind on a straight path")
    # Camera noise and blackouts.
    for noise in (0.02, 0.05):
        for path in ("straight", "circle"):
            add("camera_noise_%g_%s" % (noise, path), path=path, speed=1.0, sensors={"camera_noise": noise},
                description="pixel noise %g of full scale" % noise)
    for duration in (1.0, 2.0, 3.0):
        for at_s in (8.0, 18.0):
            add("camera_blackout_%gs_at%g" % (duration, at_s), path="circle", speed=1.0,
                events=[{"at_s": at_s, "fault": "camera_blackout", "duration_s": duration}],
                description="no camera frames for %g s from t=%g s" % (duration, at_s))
    # A second red object beside the vehicle.
    for path, speed in (("straight", 1.0), ("circle", 2.0), ("figure8", 1.0)):
        add("false_target_%s_%gms" % (path, speed), path=path, speed=speed,
            events=[{"at_s": 2.0, "fault": "detection_false_target", "duration_s": 60.0}],
            description="a red 1.0 x 0.6 m object drives 1.6 m beside the pad")
    # Rendezvous from afar using the vehicle's reported position.
    for vehicle, path, speed, start in (("summit_xl", "straight", 1.0, {"x": -30.0, "y": 5.0, "z": 6.0}),
                                        ("summit_xl", "circle", 1.0, {"x": 20.0, "y": -20.0, "z": 6.0}),
                                        ("car", "straight", 10.0, {"x": -30.0, "y": 5.0, "z": 8.0})):
        add("rendezvous_%s_%s_%gms" % (vehicle, path, speed), vehicle=vehicle, path=path, speed=speed, start=start,
            time_limit=180.0, description="drone starts 30 m away and must find the vehicle")
    return items


def write(directory, check=False):
    expected = {}
    for item in suite():
        text = "# Generated by scenarios/generate.py: edit the generator, not this file.\n" + \
               yaml.safe_dump(item, sort_keys=False, default_flow_style=None, width=110)
        expected[item["name"] + ".yaml"] = text
    if check:
        present = {f for f in os.listdir(directory) if f.endswith(".yaml")}
        stale = sorted(name for name, text in expected.items()
                       if name not in present or open(os.path.join(directory, name)).read() != text)
        extra = sorted(present - set(expected))
        if stale or extra:
            print("scenario suite differs from the generator: stale %s, extra %s" % (stale[:5], extra[:5]))
            return 1
        return 0
    for name in os.listdir(directory):
        if name.endswith(".yaml"):
            os.remove(os.path.join(directory, name))
    for name, text in expected.items():
        with open(os.path.join(directory, name), "w") as stream:
            stream.write(text)
    print("wrote %d scenarios to %s" % (len(expected), directory))
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--check", action="store_true", help="compare instead of writing")
    args = parser.parse_args()
    sys.exit(write(HERE, check=args.check))
