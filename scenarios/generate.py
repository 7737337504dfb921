#!/usr/bin/env python3
"""Writes the shipped scenario suite (SPEC section 7) into this directory, one YAML file a scenario, and
the stress sets behind the README's seeded figures into stress/<set>/ and the soak and fuzz runs into
reliability/ (neither part of the suite: `make bench` reads the files of scenarios/ itself, not its
subdirectories).

    python3 scenarios/generate.py          # rewrite the suite, the stress sets and target_scope.txt
    python3 scenarios/generate.py --check  # exit 1 if the committed files differ from the generator

Every scenario has a seed and an `expect:` block that the benchmark checks."""
import argparse
import os
import sys

import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
SUMMIT_PATHS = ("straight", "circle", "figure8", "back_and_forth", "square", "stop_and_go", "random")
ON_PAD = {"outcome": "landed_on_pad", "max_touchdown_error_m": 0.25}
# (scenario, node killed at t = 12 s while tracking, what happens) of the crash scenarios expected on the pad
CRASHES = (
    ("fault_detector_killed", "platform_detection",
     "the detector dies and respawns; the tracker never flies blind (prediction, then relocating)"),
    ("fault_kalman_killed", "prediction_kalman_node",
     "the pad filter dies and respawns; its track starts again from the next fixes, the tracker relocates meanwhile"),
    ("fault_estimator_killed", "drone_estimator",
     "the drone's estimator dies and respawns; the tracker holds (no estimate, no command) until it is back"),
    ("fault_tracker_killed", "platform_tracking",
     "the tracker dies and respawns; it reads the latched take-off command, climbs back to 4 m and lands"),
    ("fault_supervisor_killed", "supervisor",
     "the supervisor dies and respawns; it carries on in its mode from the state it left on the master"),
    ("fault_mux_killed", "cmd_vel_mux",
     "the command mux dies and respawns; the drone holds meanwhile, then the mux reads the latched mode"),
    ("fault_vehicle_path_killed", "summit_moves",
     "the vehicle's path node dies and respawns; the vehicle slows to a stop, then goes on along the same path"),
    ("fault_recorder_killed", "flight_recorder",
     "the flight recorder dies; the flight goes on, its bag is reindexed and a new one records the rest"),
    ("fault_master_killed", "master",
     "the ROS master dies; the nodes go on over their connections (nothing new can connect) and land"),
)


def scenario(name, seed, vehicle="summit_xl", path="straight", speed=1.0, radius=10.0, time_limit=120.0,
             conditions=None, sensors=None, events=None, start="on_pad", expect=None, description="", realism=None,
             comment=None, landing_at=0, drone_model=None):
    out = {"name": name, "description": description, "seed": seed, "time_limit_s": time_limit,
           "platform": {"vehicle": vehicle, "path": path, "speed_mps": speed, "radius_m": radius},
           "drone": dict({"start": start}, **({"model": drone_model} if drone_model else {})),
           "conditions": dict({"wind_speed": 0.0, "wind_direction_deg": 0.0, "gust_mps": 0.0, "drone_battery": 90,
                               "control_battery": 80, "temp": 15}, **(conditions or {})),
           "sensors": dict({"camera_noise": 0.0, "camera_fps": 30}, **(sensors or {})),
           "events": [{"at_s": landing_at, "operator": "landing"}] + list(events or []),
           "expect": expect or dict(ON_PAD)}
    if realism is not None:
        out["realism"] = realism
    if comment is not None:
        out["_comment"] = comment
    return out


def crash(node, what):
    """A node killed (SIGKILL) at t = 12 s while the drone tracks the Summit XL on a 10 m circle at 1.5 m/s, a landing
    on the pad expected (in the realistic world: 9 of 9 on the pad on 2026-11-25)."""
    return dict(path="circle", speed=1.5, description=what,
                events=[{"at_s": 12.0, "fault": "kill_node", "name": node}])


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
    for path, speed in (("straight", 1.0), ("circle", 2.0), ("figure8", 1.0), ("random", 2.0), ("square", 1.0),
                        ("back_and_forth", 2.0), ("stop_and_go", 2.0)):
        for repeat in range(1, 4 if path in ("straight", "circle", "figure8", "random") else 3):
            add("summit_%s_%gms_seed%d" % (path, speed, repeat), path=path, speed=speed,
                description="repeat with another seed")
    # Car on a straight road and on a 50 m circle.
    for speed in (5.0, 10.0, 15.0):
        for repeat in range(2):
            add("car_straight_%gms%s" % (speed, "_seed%d" % repeat if repeat else ""), vehicle="car", path="straight",
                speed=speed, time_limit=150.0, description="car on a straight road at %g m/s" % speed)
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
    # Adverse conditions and operator choices: every flag of the supervisor, with the expected outcome.
    # The reported coordinates are the drone's own estimate: as good as its GPS, whose error drifts by a
    # metre per axis in the realistic profile (two in harsh); 5 m is what a rescue needs.
    emergency = lambda condition: {"outcome": "emergency_landed", "no_pad_landing": True,  # noqa: E731
                                   "emergency_position_within_m": 5.0,
                                   "decisions_include": [{"condition": condition, "action": "emergency_landing"}]}
    stays = lambda condition, action: {"outcome": "timeout", "no_pad_landing": True,  # noqa: E731
                                       "decisions_include": [{"condition": condition, "action": action}]}
    lands_despite = lambda condition, action: dict(ON_PAD, decisions_include=[  # noqa: E731
        {"condition": condition, "action": action}])
    in_flight = lambda param, value, at_s=12.0: [{"at_s": at_s, "set_param": param, "value": value}]  # noqa: E731
    add("adverse_battery_10_in_flight", path="circle", events=in_flight("drone_battery", 10),
        expect=emergency("drone_battery_critical"), description="thesis test 4.2.2: battery 10 % => emergency")
    add("adverse_battery_35_at_start", conditions={"drone_battery": 35}, time_limit=40.0,
        expect=stays("drone_battery_landing", "no_go"), description="below 40 %: no take-off for a landing")
    add("adverse_battery_35_in_flight_no_answer", path="circle", events=in_flight("drone_battery", 35),
        expect=emergency("drone_battery_landing"), description="no-go warning unanswered => emergency landing")
    add("adverse_battery_35_in_flight_continue", path="circle", time_limit=60.0,
        events=in_flight("drone_battery", 35) + [{"at_s": 14.0, "operator": "continue"}],
        expect=stays("drone_battery_landing", "warn"), description="operator continues: no landing on the pad")
    add("adverse_wind_13_at_start", conditions={"wind_speed": 13.0}, time_limit=40.0,
        expect=stays("wind_critical", "no_go"), description="critical wind: no take-off")
    add("adverse_wind_13_in_flight", path="circle", events=in_flight("wind_speed", 13.0),
        expect=emergency("wind_critical"), description="critical wind in flight: Flag #1")
    add("adverse_wind_11_persists", path="circle", events=in_flight("wind_speed", 11.0),
        expect=emergency("wind_strong"), description="Flag #3: three re-checks, still windy => emergency")
    add("adverse_wind_11_clears", path="circle",
        events=in_flight("wind_speed", 11.0) + in_flight("wind_speed", 3.0, at_s=15.0),
        expect=lands_despite("wind_strong", "continue"), description="Flag #3: clears before the third check")
    add("adverse_cold_0", path="circle", conditions={"temp": 0.0},
        expect=lands_despite("temp_cold", "warn"), description="Flag #2: warn and go on")
    add("adverse_temp_minus_15_in_flight", path="circle", events=in_flight("temp", -15.0),
        expect=emergency("temp_out_of_range"), description="outside the operating range: Flag #1")
    add("adverse_control_battery_15", path="circle", conditions={"control_battery": 15},
        expect=lands_despite("control_battery_low", "warn"), description="controller battery low: Flag #2")
    add("adverse_control_battery_3_in_flight", path="circle", events=in_flight("control_battery", 3),
        expect=emergency("control_battery_critical"), description="controller battery critical: Flag #1")
    add("adverse_drone_speed_18", path="circle", conditions={"drone_speed": 18.0},
        expect=lands_despite("drone_speed_high", "warn"), description="drone near its maximum speed: Flag #2")
    add("adverse_car_20ms_too_fast", vehicle="car", path="straight", speed=20.0, time_limit=90.0,
        expect={"outcome": ["emergency_landed", "timeout"], "no_pad_landing": True,
                "decisions_include": [{"condition": "platform_too_fast", "action": "warn"}]},
        description="platform faster than the drone can safely land on: no-go")
    add("adverse_camera_lost_10s", path="circle",
        events=[{"at_s": 12.0, "fault": "camera_blackout", "duration_s": 10.0}],
        expect=emergency("camera_missing"), description="camera silent: Flag #3 re-checks, then emergency")
    add("adverse_battery_unreadable", path="circle", events=in_flight("drone_battery", "abc"),
        expect={"outcome": "emergency_landed", "no_pad_landing": True}, description="'abc' is treated as unsafe")
    add("adverse_wind_negative", path="circle", events=in_flight("wind_speed", -5.0),
        expect={"outcome": "emergency_landed", "no_pad_landing": True}, description="-5 m/s is treated as unsafe")
    add("operator_emergency", path="circle", events=[{"at_s": 12.0, "operator": "emergency"}],
        expect=emergency("operator"), description="thesis test 4.2.2: emergency from the menu")
    add("operator_manual", path="circle", time_limit=40.0, events=[{"at_s": 12.0, "operator": "manual"}],
        expect={"outcome": "timeout", "no_pad_landing": True}, description="the operator takes over (and hovers)")
    add(*CRASHES[0][:1], **crash(*CRASHES[0][1:]))  # (in its place of old: the seeds after it stay as they were)
    items.append(scenario("idle_auto_takeoff", seed=seed + 1, path="circle", time_limit=150.0,
                          expect=dict(ON_PAD, decisions_include=[{"condition": "idle", "action": "takeoff"}]),
                          description="no operator choice for 30 s: the drone takes off by itself"))
    items[-1]["events"] = []
    items[-1]["supervisor"] = {"no_operator": True}
    seed += 1
    # A crash (SIGKILL) of every node of the graph mid-flight, on the Summit XL's 10 m circle at 1.5 m/s: each
    # must end safely (docs/reliability.md, "Crashes").
    for name, node, what in CRASHES[1:]:
        add(name, **crash(node, what))
    add("fault_emergency_killed", path="circle", speed=1.5,
        events=in_flight("drone_battery", 10) + [{"at_s": 13.0, "fault": "kill_node", "name": "emergency"}],
        expect=emergency("drone_battery_critical"),
        description="the emergency module dies during an emergency landing; restarted, it reads the latched mode, "
                    "lands and reports the coordinates")
    add("fault_simulator_killed", path="circle", speed=1.5, time_limit=60.0,
        events=[{"at_s": 12.0, "fault": "kill_node", "name": "mujoco_sim"}],
        expect={"outcome": "aborted"},
        description="the simulator (the world itself) dies: not restarted; roslaunch ends the run (required), "
                    "run_scenario reports it aborted with the reason and the bag is readable to the kill")
    # The AR.Drone's Wi-Fi drops: no navdata, video, GPS or commands for a while. Its firmware hovers on its own
    # (after 2 s without a command) and lands by itself after 5 s more; the stack holds and takes over again.
    for duration, at_s in ((1.5, 8.0), (3.0, 18.0), (6.0, 18.0)):
        add("link_loss_%gs_at%g" % (duration, at_s), path="circle", speed=1.0, drone_model="ardrone2",
            events=[{"at_s": at_s, "fault": "link_loss", "duration_s": duration}],
            description="the AR.Drone's Wi-Fi link lost for %g s from t=%g s" % (duration, at_s))
    return items


def stress_sets():
    """{set name: scenarios} of the README's seeded figures."""
    sets = {}
    # Summit XL at 3 m/s on the square (5 m side, as in the suite) and stop-and-go paths, seeds 1001-1012.
    sets["square_stop_and_go_3ms"] = [
        scenario("summit_%s_3ms_seed%d" % (path, seed), seed=seed, path=path, speed=3.0,
                 radius=5.0 if path == "square" else 10.0,
                 description="Summit XL on a %s path at 3 m/s, seed %d" % (path, seed))
        for path in ("square", "stop_and_go") for seed in range(1001, 1013)]
    # 30 runs in 5 m/s wind with gusts (1.25 m/s), Summit XL at 2 and 3 m/s on six paths, from five directions.
    wind, seed = [], 2000
    for path in ("back_and_forth", "circle", "figure8", "random", "square", "stop_and_go"):
        for k, direction in enumerate((0.0, 72.0, 144.0, 216.0, 288.0)):
            seed += 1
            speed = 2.0 if k % 2 == 0 else 3.0
            wind.append(scenario("wind5_%s_%gms_dir%d" % (path, speed, direction), seed=seed, path=path, speed=speed,
                                 radius=5.0 if path == "square" else 10.0,
                                 conditions={"wind_speed": 5.0, "wind_direction_deg": direction, "gust_mps": 1.25},
                                 description="5 m/s wind towards %d deg, gusts 1.25 m/s" % direction))
    sets["wind_5ms"] = wind
    # Eight short runs (15-60 s of sim time) for timing sweeps (benchmark --jobs 2 against --ray) and the Ray
    # tests: outcomes that do not hang on the last centimetre (an emergency landing, a no-go, a slow landing).
    short = []
    for k, seed in enumerate((3001, 3002)):
        suffix = "ab"[k]
        short.append(scenario("short_battery_10_%s" % suffix, seed=seed, path="circle", time_limit=40.0,
                              events=[{"at_s": 6.0, "set_param": "drone_battery", "value": 10}],
                              expect={"outcome": "emergency_landed", "no_pad_landing": True,
                                      "decisions_include": [{"condition": "drone_battery_critical",
                                                             "action": "emergency_landing"}]},
                              description="battery 10 % six seconds after the take-off: emergency landing"))
        short.append(scenario("short_wind_13_%s" % suffix, seed=seed + 10, conditions={"wind_speed": 13.0},
                              time_limit=15.0, expect={"outcome": "timeout", "no_pad_landing": True,
                                                       "decisions_include": [{"condition": "wind_critical",
                                                                              "action": "no_go"}]},
                              description="critical wind: no take-off"))
        for speed in (0.5, 1.0):
            short.append(scenario("short_straight_%gms_%s" % (speed, suffix), seed=seed + 20 + int(speed * 2),
                                  speed=speed, time_limit=60.0, description="a landing on a slow straight path"))
    sets["short_sweep"] = short
    # The same scenarios and seeds in every realism profile (benchmark --realism): the Summit XL on each path at
    # 1 and 3 m/s, every other one in 5 m/s wind with gusts, and the car on a straight road at 5, 10 and 15 m/s.
    compare, seed = [], 4000
    for path in ("straight",) + tuple(p for p in SUMMIT_PATHS if p != "straight"):
        for speed in (1.0, 3.0):
            seed += 1
            windy = seed % 2 == 0
            compare.append(scenario("compare_summit_%s_%gms%s" % (path, speed, "_wind5" if windy else ""), seed=seed,
                                    path=path, speed=speed, radius=5.0 if path == "square" else 10.0,
                                    conditions={"wind_speed": 5.0, "wind_direction_deg": 45.0 * (seed % 8),
                                                "gust_mps": 1.25} if windy else None,
                                    description="Summit XL on a %s path at %g m/s%s" % (
                                        path, speed, ", 5 m/s wind with gusts" if windy else "")))
    for speed in (5.0, 10.0, 15.0):
        for k in range(2):
            seed += 1
            compare.append(scenario("compare_car_straight_%gms_%d" % (speed, k + 1), seed=seed, vehicle="car",
                                    speed=speed, time_limit=150.0,
                                    description="car on a straight road at %g m/s" % speed))
    sets["realism_compare"] = compare
    # The AR.Drone 2.0 through its driver's interface (drone_model ardrone2): the suite's Summit XL paths at 1-3 m/s,
    # its 4 m/s winds, one 8 m/s wind, its camera noise and a blackout, same names and seeds as in the suite.
    picked = [item for item in suite() if item["name"].startswith(("summit_", "wind_4ms", "camera_noise"))
              and item["name"].endswith(("_1ms", "_2ms", "_3ms", "dir0", "dir90", "dir225", "straight", "circle"))
              or item["name"] in ("wind_8ms_dir0", "camera_blackout_2s_at8")]
    for item in picked:
        item["drone"] = dict(item["drone"], model="ardrone2")
        if item["conditions"]["wind_speed"] >= 6.0:  # beyond the AR.Drone's wind (interface drone_models/ardrone2)
            item["description"] += ": too strong for the AR.Drone 2.0, no landing on the pad"
            item["expect"] = {"outcome": ["timeout", "emergency_landed"], "no_pad_landing": True,
                              "decisions_include": [{"condition": "wind_strong"}]}
    sets["ardrone2"] = picked
    # The car at 15 m/s, 12 seeds (run in realistic and harsh): half the take-offs from the car standing, half
    # from the car at speed (the landing ordered 6 s in): the drone's estimate must keep the car's speed through it.
    sets["car_15ms"] = [
        scenario("car_15ms_%s_seed%d" % ("at_speed" if at_speed else "from_start", seed), seed=seed, vehicle="car",
                 speed=15.0, time_limit=150.0, landing_at=6.0 if at_speed else 0,
                 description="car on a straight road at 15 m/s, the landing ordered %s" % (
                     "6 s in, the car at speed" if at_speed else "at the start"))
        for at_speed in (False, True) for seed in range(5001, 5007)]
    return sets


def reliability_set():
    """The soak and fuzz runs behind the README's reliability figures (rosrun landing_eval soak / fuzz), and their
    short versions in make test."""
    # Conditions the operator meets over a field day, one set per mission in turn (none a supervisor flag).
    day = [{"wind_speed": 0.0, "wind_direction_deg": 0.0, "gust_mps": 0.0, "temp": 15.0, "control_battery": 90.0},
           {"wind_speed": 3.0, "wind_direction_deg": 90.0, "gust_mps": 0.75, "temp": 21.0},
           {"wind_speed": 5.0, "wind_direction_deg": 200.0, "gust_mps": 1.25, "temp": 9.0, "control_battery": 70.0},
           {"wind_speed": 2.0, "wind_direction_deg": 300.0, "gust_mps": 0.5, "temp": 27.0},
           {"wind_speed": 6.0, "wind_direction_deg": 45.0, "gust_mps": 1.5, "temp": 12.0, "control_battery": 50.0},
           {"wind_speed": 1.0, "wind_direction_deg": 135.0, "gust_mps": 0.25, "temp": 18.0}]
    ideal = "realism: ideal - every mission is expected on the pad, which the realistic world does not give " \
            "reliably yet"
    items = []

    def missions(name, seed, count, pause, time_limit, description, expect, realism="ideal", fuzz=None,
                 comment=ideal):
        item = scenario(name, seed=seed, path="circle", speed=1.5, time_limit=time_limit, realism=realism,
                        expect=expect, description=description, comment=comment)
        item["missions"] = {"count": count, "pause_s": pause, "conditions": day, "battery_swap_below": 50.0}
        if fuzz:
            item["fuzz"] = fuzz
        items.append(item)

    every_mission_on_pad = lambda count: dict(ON_PAD, min_missions_on_pad=count, no_node_deaths=True)  # noqa: E731
    missions("soak_30_missions", 4001, 30, 220.0, 9000.0, "30 missions in one session, 220 s on the moving pad "
             "between two (a battery swap when below 50 %), the wind and temperature changing: over 2 h of sim time",
             every_mission_on_pad(30))
    missions("soak_3_missions", 4002, 3, 3.0, 240.0, "the soak made short for make test: 3 missions in a row",
             every_mission_on_pad(3))
    # Garbage on every input while missions go on (the realistic world: a safety property, not a landing).
    safe = {"outcome": ["landed_on_pad", "emergency_landed", "timeout"], "no_node_deaths": True}
    realistic = "the realistic world: the outcome must be safe (on the pad, an emergency landing, or still " \
                "flying at the time limit), not necessarily a landing"
    missions("fuzz_10_minutes", 4003, 1000, 5.0, 640.0, "seeded garbage on every input topic for 10 min of sim "
             "time while missions go on", safe, realism="realistic",
             fuzz={"start_s": 3.0, "duration_s": 637.0, "period_s": 1.0, "burst_every_s": 10.0, "seed": 4003},
             comment=realistic)
    missions("fuzz_short", 4004, 1000, 3.0, 45.0, "the fuzz made short for make test: 42 s of garbage on every "
             "input during a landing", safe, realism="realistic",
             fuzz={"start_s": 3.0, "duration_s": 42.0, "period_s": 0.5, "burst_every_s": 3.0, "seed": 4004},
             comment=realistic)
    return items


def render(item):
    item = dict(item)
    comment = item.pop("_comment", None)
    return "# Generated by scenarios/generate.py: edit the generator, not this file.\n" + \
        ("# %s\n" % comment if comment else "") + \
        yaml.safe_dump(item, sort_keys=False, default_flow_style=None, width=110)


def write_set(directory, items, check):
    """Writes ``items`` into ``directory`` (its other *.yaml files removed), or with ``check`` returns 1 and
    says what differs. Subdirectories are left alone."""
    expected = {item["name"] + ".yaml": render(item) for item in items}
    present = {f for f in os.listdir(directory) if f.endswith(".yaml")} if os.path.isdir(directory) else set()
    if check:
        stale = sorted(name for name, text in expected.items()
                       if name not in present or open(os.path.join(directory, name)).read() != text)
        extra = sorted(present - set(expected))
        if stale or extra:
            print("%s differs from the generator: stale %s, extra %s" % (directory, stale[:5], extra[:5]))
            return 1
        return 0
    os.makedirs(directory, exist_ok=True)
    for name in present:
        os.remove(os.path.join(directory, name))
    for name, text in expected.items():
        with open(os.path.join(directory, name), "w") as stream:
            stream.write(text)
    print("wrote %d scenarios to %s" % (len(expected), directory))
    return 0


def in_target_scope(item):
    """Whether a suite scenario lies in the scope of issue 13's landing targets: a landing on the pad expected, the
    Summit XL at up to 3 m/s or the car on a straight road at up to 15 m/s, in wind of up to 5 m/s at the start."""
    platform, wind = item["platform"], item["conditions"]["wind_speed"]
    if item["expect"].get("outcome") != "landed_on_pad" or wind > 5.0:
        return False
    if platform["vehicle"] == "summit_xl":
        return platform["speed_mps"] <= 3.0
    return platform["path"] == "straight" and platform["speed_mps"] <= 15.0


def write_list(path, items, check):
    """Writes the scope list (``benchmark`` reads a .txt as one scenario file a line, relative to the list), or with
    ``check`` returns 1 if it differs."""
    text = "# Generated by scenarios/generate.py: the suite's scenarios in the scope of the landing targets (a landing\n" \
        "# on the pad expected; the Summit XL up to 3 m/s, the car on a straight road up to 15 m/s; wind up to 5 m/s).\n" \
        "# rosrun landing_eval benchmark scenarios/target_scope.txt --realism harsh --out DIR --jobs 2\n" + \
        "".join(sorted(item["name"] + ".yaml\n" for item in items if in_target_scope(item)))
    if check:
        if not os.path.isfile(path) or open(path).read() != text:
            print("%s differs from the generator" % path)
            return 1
        return 0
    with open(path, "w") as stream:
        stream.write(text)
    print("wrote %d scenario names to %s" % (text.count(".yaml\n"), path))
    return 0


def write(directory, check=False):
    status = write_set(directory, suite(), check)
    status |= write_list(os.path.join(directory, "target_scope.txt"), suite(), check)
    status |= write_set(os.path.join(directory, "reliability"), reliability_set(), check)
    for name, items in stress_sets().items():
        status |= write_set(os.path.join(directory, "stress", name), items, check)
    return status


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--check", action="store_true", help="compare instead of writing")
    args = parser.parse_args()
    sys.exit(write(HERE, check=args.check))
