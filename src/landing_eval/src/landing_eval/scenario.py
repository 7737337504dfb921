"""Scenario files (SPEC section 7): loading and validation, ROS-free.

A bad file gives an error that names the file, the field and what is expected, never a silent default
for a typo: unknown fields are errors too."""
import math
import os

import yaml

VEHICLES = ("summit_xl", "car")
PATHS = ("straight", "circle", "figure8", "back_and_forth", "square", "stop_and_go", "random")
# The landing pad (SPEC section 7): the thesis' red square, or the AprilTag pad (a fiducial pad). The simulator puts it
# on the vehicle (mujoco_sim.pads) and the detector looks for it (uav_vision's detector parameter).
PADS = ("red_square", "apriltag")
# The drone models the simulator flies (mujoco_sim's drone_model): ardrone2 is the AR.Drone 2.0 behind its real
# driver's interface (ardrone_autonomy), px4_quad a PX4 quadrotor behind MAVROS (the stack's mavros_adapter),
# velocity_quad the simulator's own velocity-commanded quadrotor.
DRONE_MODELS = ("ardrone2", "px4_quad", "velocity_quad")
# A scenario that names no model flies its vehicle's default.
DEFAULT_DRONE_MODEL = {"summit_xl": "velocity_quad", "car": "velocity_quad"}
OPERATOR_ACTIONS = ("landing", "emergency", "manual", "continue", "quit", "takeoff")
# pilot_takeover: the pilot flips the RC mode switch away from OFFBOARD (drone_model px4_quad only).
FAULTS = ("camera_blackout", "kill_node", "detection_false_target", "link_loss", "pilot_takeover")
CONDITION_PARAMS = ("wind_speed", "wind_direction_deg", "wind_gust", "drone_battery", "control_battery", "temp",
                    "drone_speed")
OUTCOMES = ("landed_on_pad", "landed_off_pad", "emergency_landed", "crashed", "timeout", "aborted")
# kill_node: the signal sent to the node's process. KILL is a crash (a bug, the OOM killer): no clean-up at all.
KILL_SIGNALS = ("KILL", "TERM", "INT")
# Not ROS nodes of the launch but killable as such: the ROS master and the runner's flight recorder.
MASTER = "master"
MISSION_CONDITIONS = ("wind_speed", "wind_direction_deg", "gust_mps", "temp", "control_battery")


class ScenarioError(ValueError):
    """The scenario file is missing, unreadable or has a bad field."""


def _number(value, where, low=-math.inf, high=math.inf, integer=False):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or (integer and not isinstance(value, int)):
        raise ScenarioError("%s: expected %s, got %r" % (where, "an integer" if integer else "a number", value))
    if not math.isfinite(value) or value < low or value > high:
        raise ScenarioError("%s: expected a value in [%g, %g], got %r" % (where, low, high, value))
    return value if integer else float(value)


def _choice(value, where, choices):
    if value not in choices:
        raise ScenarioError("%s: expected one of %s, got %r" % (where, ", ".join(choices), value))
    return value


def _mapping(value, where, known):
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise ScenarioError("%s: expected a mapping, got %r" % (where, value))
    unknown = sorted(set(value) - set(known))
    if unknown:
        raise ScenarioError("%s: unknown field(s) %s (known: %s)" % (where, ", ".join(map(str, unknown)),
                                                                       ", ".join(known)))
    return value


def validate(data, source):
    """Validated scenario dict with every optional field filled in."""
    top = _mapping(data, source, ("name", "seed", "time_limit_s", "platform", "drone", "conditions", "sensors",
                                  "events", "expect", "description", "supervisor", "tracking", "realism", "missions",
                                  "fuzz", "pad"))
    if "name" not in top or not isinstance(top["name"], str) or not top["name"]:
        raise ScenarioError("%s: field 'name' is required (a non-empty string)" % source)
    out = {"name": top["name"], "description": str(top.get("description", "")),
           "seed": _number(top.get("seed", 0), "%s: field 'seed'" % source, 0, 2 ** 31 - 1, integer=True),
           "time_limit_s": _number(top.get("time_limit_s", 180.0), "%s: field 'time_limit_s'" % source, 1.0, 86400.0)}

    where = "%s: field 'platform" % source
    platform = _mapping(top.get("platform"), where + "'", ("vehicle", "path", "speed_mps", "radius_m"))
    vehicle = _choice(platform.get("vehicle", "summit_xl"), where + ".vehicle'", VEHICLES)
    out["platform"] = {
        "vehicle": vehicle,
        "path": _choice(platform.get("path", "straight"), where + ".path'", PATHS),
        "speed_mps": _number(platform.get("speed_mps", 1.0), where + ".speed_mps'", 0.0,
                             3.0 if vehicle == "summit_xl" else 25.0),
        "radius_m": _number(platform.get("radius_m", 10.0), where + ".radius_m'", 1.0, 1000.0),
    }

    where = "%s: field 'drone" % source
    drone = _mapping(top.get("drone"), where + "'", ("start", "model"))
    model = _choice(drone.get("model", DEFAULT_DRONE_MODEL[vehicle]), where + ".model'", DRONE_MODELS)
    start = drone.get("start", "on_pad")
    if start == "on_pad":
        out["drone"] = {"start": "on_pad"}
    else:
        start = _mapping(start, where + ".start' (on_pad or {x, y, z})", ("x", "y", "z"))
        if set(start) != {"x", "y", "z"}:
            raise ScenarioError("%s.start': expected on_pad or a mapping with x, y and z in m, got %r" % (where, start))
        out["drone"] = {"start": {k: _number(start[k], "%s.start.%s'" % (where, k), -1e4, 1e4) for k in "xyz"}}
        if out["drone"]["start"]["z"] < 0.3:
            raise ScenarioError("%s.start.z': a start away from the pad must be in the air (z >= 0.3 m)" % where)
    out["drone"]["model"] = model
    if model != "px4_quad" and any(isinstance(e, dict) and e.get("fault") == "pilot_takeover" for e in
                                   (top.get("events") or []) if isinstance(top.get("events"), list)):
        raise ScenarioError("%s: fault pilot_takeover needs drone: {model: px4_quad} (a mode switch of PX4's RC), "
                            "the drone is %s" % (source, model))
    out["pad"] = _choice(top.get("pad", "red_square"), "%s: field 'pad'" % source, PADS)

    where = "%s: field 'conditions" % source
    conditions = _mapping(top.get("conditions"), where + "'", ("wind_speed", "wind_direction_deg", "gust_mps",
                                                               "drone_battery", "control_battery", "temp", "drone_speed"))
    out["conditions"] = {
        "wind_speed": _number(conditions.get("wind_speed", 0.0), where + ".wind_speed'", 0.0, 60.0),
        "wind_direction_deg": _number(conditions.get("wind_direction_deg", 0.0), where + ".wind_direction_deg'", -360, 360),
        "wind_gust": _number(conditions.get("gust_mps", 0.0), where + ".gust_mps'", 0.0, 30.0),
        "drone_battery": _number(conditions.get("drone_battery", 100.0), where + ".drone_battery'", 0.0, 100.0),
        "control_battery": _number(conditions.get("control_battery", 100.0), where + ".control_battery'", 0.0, 100.0),
        "temp": _number(conditions.get("temp", 15.0), where + ".temp'", -60.0, 70.0),
    }
    if "drone_speed" in conditions:
        out["conditions"]["drone_speed"] = _number(conditions["drone_speed"], where + ".drone_speed'", 0.0, 40.0)

    where = "%s: field 'sensors" % source
    sensors = _mapping(top.get("sensors"), where + "'", ("camera_noise", "camera_fps"))
    out["sensors"] = {"camera_noise": _number(sensors.get("camera_noise", 0.0), where + ".camera_noise'", 0.0, 1.0),
                      "camera_fps": _number(sensors.get("camera_fps", 30.0), where + ".camera_fps'", 1.0, 120.0)}

    out["realism"] = realism_of(top.get("realism"), "%s: field 'realism'" % source)

    events = top.get("events", []) or []
    if not isinstance(events, list):
        raise ScenarioError("%s: field 'events': expected a list, got %r" % (source, events))
    out["events"] = [_event(e, "%s: field 'events[%d]" % (source, i)) for i, e in enumerate(events)]
    out["events"].sort(key=lambda e: e["at_s"])
    out["missions"] = _missions(top.get("missions"), "%s: field 'missions" % source)
    out["fuzz"] = _fuzz(top.get("fuzz"), "%s: field 'fuzz" % source)
    for key in ("expect", "supervisor", "tracking"):
        value = top.get(key, {}) or {}
        if not isinstance(value, dict):
            raise ScenarioError("%s: field '%s': expected a mapping, got %r" % (source, key, value))
        out[key] = value
    if "outcome" in out["expect"]:
        outcomes = out["expect"]["outcome"]
        for outcome in outcomes if isinstance(outcomes, list) else [outcomes]:
            _choice(outcome, "%s: field 'expect.outcome'" % source, OUTCOMES)
    return out


def realism_of(selection, where, profile=None):
    """The realism a scenario asks for (a profile name, or a mapping {profile: NAME, key: value, ...};
    default realistic), checked against the simulator's profiles: {"profile": name, "overrides": {...},
    "values": {every key: value in force}}. ``profile`` (e.g. from --realism) replaces the scenario's profile
    but not its single keys."""
    from mujoco_sim import realism
    from mujoco_sim.config import ConfigError
    if selection is None:
        selection = {}
    elif isinstance(selection, str):
        selection = {"profile": selection}
    if not isinstance(selection, dict):
        raise ScenarioError("%s: expected a profile name (%s) or a mapping {profile: NAME, key: value}, got %r" % (
            where, " | ".join(realism.PROFILES), selection))
    selection = dict(selection, **({"profile": profile} if profile else {}))
    try:
        name, values = realism.resolve(realism.shipped_profiles(), selection, where)
    except ConfigError as err:
        raise ScenarioError(str(err)) from err
    overrides = {k: values[k] for k in selection if k != "profile"}
    return {"profile": name, "overrides": overrides, "values": values}


def _event(event, where):
    event = _mapping(event, where + "'", ("at_s", "operator", "set_param", "value", "fault", "duration_s", "name",
                                          "signal"))
    if "at_s" not in event:
        raise ScenarioError("%s.at_s': required (sim seconds)" % where)
    out = {"at_s": _number(event["at_s"], where + ".at_s'", 0.0, 86400.0)}
    kinds = [k for k in ("operator", "set_param", "fault") if k in event]
    if len(kinds) != 1:
        raise ScenarioError("%s': needs exactly one of operator, set_param, fault; got %s" % (where, kinds or "none"))
    kind = kinds[0]
    if kind == "operator":
        out["operator"] = _choice(event["operator"], where + ".operator'", OPERATOR_ACTIONS)
    elif kind == "set_param":
        out["set_param"] = _choice(event["set_param"], where + ".set_param'", CONDITION_PARAMS)
        if "value" not in event:
            raise ScenarioError("%s.value': required with set_param" % where)
        out["value"] = event["value"]  # deliberately unchecked: scenarios test how bad values are handled
    else:
        out["fault"] = _choice(event["fault"], where + ".fault'", FAULTS)
        out["duration_s"] = _number(event.get("duration_s", 2.0), where + ".duration_s'", 0.0, 600.0)
        if out["fault"] == "kill_node":
            if not isinstance(event.get("name"), str) or not event["name"].strip("/"):
                raise ScenarioError("%s.name': kill_node needs the node's name (or %r for the ROS master)"
                                    % (where, MASTER))
            out["name"] = event["name"]
            out["signal"] = _choice(event.get("signal", "KILL"), where + ".signal'", KILL_SIGNALS)
    if "signal" in event and out.get("fault") != "kill_node":
        raise ScenarioError("%s.signal': only kill_node takes a signal" % where)
    return out


def _missions(value, where):
    """Repeated missions in one session: after each landing the drone waits ``pause_s`` on the pad, the next
    entry of ``conditions`` (cycled) is set, the battery is swapped when below ``battery_swap_below``, and the
    operator starts the landing mission again, ``count`` missions in all. None: one mission."""
    if value is None:
        return None
    value = _mapping(value, where + "'", ("count", "pause_s", "conditions", "battery_swap_below"))
    if "count" not in value:
        raise ScenarioError("%s.count': required (missions in a row)" % where)
    out = {"count": _number(value["count"], where + ".count'", 1, 10000, integer=True),
           "pause_s": _number(value.get("pause_s", 10.0), where + ".pause_s'", 0.0, 3600.0),
           "battery_swap_below": _number(value.get("battery_swap_below", 50.0), where + ".battery_swap_below'",
                                         0.0, 100.0),
           "conditions": []}
    conditions = value.get("conditions", []) or []
    if not isinstance(conditions, list):
        raise ScenarioError("%s.conditions': expected a list of mappings, got %r" % (where, conditions))
    for i, entry in enumerate(conditions):
        here = "%s.conditions[%d]" % (where, i)
        entry = _mapping(entry, here + "'", MISSION_CONDITIONS)
        out["conditions"].append({k: _number(v, "%s.%s'" % (here, k), -360.0, 360.0) for k, v in entry.items()})
    return out


def _fuzz(value, where):
    """Seeded garbage on every input topic of the graph from ``start_s`` for ``duration_s`` (sim s): one
    garbage message per topic every ``period_s`` on average, and a burst at ten times a topic's rate every
    ``burst_every_s``. None: no fuzzing."""
    if value is None:
        return None
    value = _mapping(value, where + "'", ("start_s", "duration_s", "period_s", "burst_every_s", "seed"))
    return {"start_s": _number(value.get("start_s", 5.0), where + ".start_s'", 0.0, 86400.0),
            "duration_s": _number(value.get("duration_s", 60.0), where + ".duration_s'", 0.1, 86400.0),
            "period_s": _number(value.get("period_s", 1.0), where + ".period_s'", 0.01, 600.0),
            "burst_every_s": _number(value.get("burst_every_s", 10.0), where + ".burst_every_s'", 0.1, 86400.0),
            "seed": _number(value.get("seed", 0), where + ".seed'", 0, 2 ** 31 - 1, integer=True)}


def load(path, realism_profile=None):
    """Read and validate one scenario file; ``realism_profile`` replaces the profile it asks for."""
    if not os.path.isfile(path):
        raise ScenarioError("%s: scenario file not found" % path)
    try:
        with open(path) as stream:
            data = yaml.safe_load(stream)
    except yaml.YAMLError as err:
        raise ScenarioError("%s: not valid YAML: %s" % (path, err)) from err
    scenario = validate(data, path)
    if realism_profile:
        scenario["realism"] = realism_of(dict(scenario["realism"]["overrides"]), "%s: field 'realism'" % path,
                                         realism_profile)
    return scenario
