"""Flight metrics from time series, ROS-free and message-free (plain numpy arrays and dicts).

Times are sim seconds. A *track* is a dict with a sorted time array ``t`` and same-length arrays
(``x``, ``y``, ``z``, ...). Errors are horizontal (x, y) distances in metres unless stated.
Averages "over time" are taken on a uniform grid (``GRID_HZ``) so that a topic's publishing rate does
not weight them."""
import json
import math
import re

import numpy as np

GRID_HZ = 20.0             # rate of the time-aligned series (timeseries.csv, tracking error)
MAX_GAP_S = 0.5            # a track is not interpolated across a gap longer than this
PAD_TOLERANCE_M = 0.25     # "landed on the pad" (SPEC section 7)
TRACKING_STATES = ("TRACKING", "LANDING")   # tracker states in which the tracking error is scored

NAV_STATES = {0: "UNKNOWN", 1: "INITED", 2: "LANDED", 3: "FLYING", 4: "HOVERING", 5: "TEST", 6: "TAKING_OFF",
              7: "GOTO_HOVER", 8: "LANDING", 9: "LOOPING", 10: "CRASHED"}
NAV_LANDED, NAV_CRASHED = 2, 10
NAV_AIRBORNE = (3, 4, 6, 7, 8, 9)
SURFACES = {1: "pad", 2: "ground", 3: "vehicle"}


# ----------------------------------------------------------------------------------------------------
# Tracks and interpolation

def make_track(t, **columns):
    """Track with time-sorted, de-duplicated samples (the last sample of equal stamps wins)."""
    t = np.asarray(t, dtype=float)
    order = np.argsort(t, kind="stable")
    t = t[order]
    keep = np.ones(len(t), dtype=bool)
    if len(t) > 1:
        keep[:-1] = t[1:] != t[:-1]
    track = {"t": t[keep]}
    for name, values in columns.items():
        track[name] = np.asarray(values, dtype=float)[order][keep]
    return track


def empty(track):
    return track is None or len(track["t"]) == 0


def interp(track, name, t_query, max_gap=MAX_GAP_S):
    """``track[name]`` linearly interpolated at ``t_query``; NaN outside the track's time span and
    inside gaps between samples longer than ``max_gap``."""
    t_query = np.atleast_1d(np.asarray(t_query, dtype=float))
    out = np.full(t_query.shape, np.nan)
    if empty(track):
        return out
    t, values = track["t"], track[name]
    if len(t) == 1:
        out[np.abs(t_query - t[0]) <= 1e-9] = values[0]
        return out
    inside = (t_query >= t[0]) & (t_query <= t[-1])
    out[inside] = np.interp(t_query[inside], t, values)
    right = np.clip(np.searchsorted(t, t_query, side="left"), 1, len(t) - 1)
    gap = t[right] - t[right - 1]
    exact = np.isin(t_query, t)
    out[(gap > max_gap) & ~exact] = np.nan
    return out


def horizontal_distance(ax, ay, bx, by):
    return np.hypot(np.asarray(ax, dtype=float) - bx, np.asarray(ay, dtype=float) - by)


def grid(t0, t1, rate=GRID_HZ):
    """Uniform time grid from t0 to t1 inclusive (as far as a whole step reaches)."""
    if t0 is None or t1 is None or not t1 >= t0:
        return np.zeros(0)
    n = int(math.floor((t1 - t0) * rate + 1e-9)) + 1
    return t0 + np.arange(n) / rate


# ----------------------------------------------------------------------------------------------------
# Statistics

def error_stats(errors, t=None):
    """MAE, RMSE, max, median and count of the finite values in ``errors`` (None if there are none);
    with ``t``, also the time span they cover."""
    errors = np.asarray(errors, dtype=float)
    ok = np.isfinite(errors)
    if not ok.any():
        return None
    e = errors[ok]
    out = {"mae_m": _r(np.mean(np.abs(e))), "rmse_m": _r(np.sqrt(np.mean(e ** 2))), "max_m": _r(np.max(np.abs(e))),
           "median_m": _r(np.median(np.abs(e))), "samples": int(e.size)}
    if t is not None:
        tt = np.asarray(t, dtype=float)[ok]
        out["from_s"], out["to_s"] = _r(tt[0], 3), _r(tt[-1], 3)
    return out


def _r(value, digits=4):
    if value is None:
        return None
    value = float(value)
    return round(value, digits) if math.isfinite(value) else None


# ----------------------------------------------------------------------------------------------------
# State timelines and windows

def normalize_state(text):
    """Tracker state as an upper-case token: 'Taking off', 'taking_off', '{"state": "TAKING_OFF"}' ->
    'TAKING_OFF'."""
    if not isinstance(text, str):
        return str(text)
    value = text.strip()
    if value.startswith("{"):
        try:
            data = json.loads(value)
            if isinstance(data, dict):
                value = str(data.get("state", data.get("name", value)))
        except ValueError:
            pass
    return re.sub(r"[^A-Za-z0-9]+", "_", value).strip("_").upper() or "UNKNOWN"


def timeline(times, states, end_s):
    """Segments ``[{state, start_s, end_s, duration_s}]`` from samples of a state (repeats merged); the
    last segment lasts until ``end_s``."""
    segments = []
    for t, state in sorted(zip(times, states), key=lambda item: item[0]):
        if segments and segments[-1]["state"] == state:
            continue
        if segments:
            segments[-1]["end_s"] = t
        segments.append({"state": state, "start_s": t, "end_s": None})
    if segments:
        last = segments[-1]
        last["end_s"] = max(last["start_s"], end_s if end_s is not None else last["start_s"])
    for segment in segments:
        segment["start_s"], segment["end_s"] = _r(segment["start_s"], 3), _r(segment["end_s"], 3)
        segment["duration_s"] = _r(segment["end_s"] - segment["start_s"], 3)
    return segments


def state_in(state, states):
    """``state`` is one of ``states`` or a refinement of one ('TRACKING_FAST' counts as 'TRACKING')."""
    return state in states or any(state.startswith(s + "_") for s in states)


def windows_of(segments, states):
    """[(start, end)] of the segments whose state is in ``states`` (see state_in), adjacent ones merged."""
    out = []
    for segment in segments:
        if state_in(segment["state"], states):
            if out and abs(out[-1][1] - segment["start_s"]) < 1e-6:
                out[-1] = (out[-1][0], segment["end_s"])
            else:
                out.append((segment["start_s"], segment["end_s"]))
    return out


def in_windows(t, windows):
    """Mask of the times inside the half-open windows [start, end)."""
    t = np.asarray(t, dtype=float)
    mask = np.zeros(t.shape, dtype=bool)
    for start, end in windows:
        mask |= (t >= start - 1e-9) & (t < end - 1e-9)
    return mask


# ----------------------------------------------------------------------------------------------------
# Metrics

def tracking_error(drone, pad, windows=None, rate=GRID_HZ):
    """Horizontal drone <-> pad distance on a uniform grid over the time both tracks cover (restricted to
    ``windows`` when given): (grid times, errors, stats or None)."""
    if empty(drone) or empty(pad):
        return np.zeros(0), np.zeros(0), None
    t = grid(max(drone["t"][0], pad["t"][0]), min(drone["t"][-1], pad["t"][-1]), rate)
    if windows is not None:
        t = t[in_windows(t, windows)]
    errors = horizontal_distance(interp(drone, "x", t), interp(drone, "y", t), interp(pad, "x", t),
                                 interp(pad, "y", t))
    return t, errors, error_stats(errors, t)


def sample_errors(samples, truth):
    """Horizontal error of each sample (a track with x, y) against ``truth`` interpolated at the same
    stamps; NaN where the truth is not known."""
    if empty(samples) or empty(truth):
        return np.zeros(0)
    t = samples["t"]
    return horizontal_distance(samples["x"], samples["y"], interp(truth, "x", t), interp(truth, "y", t))


def prediction_errors(predictions, pad):
    """Error of each prediction at its horizon. ``predictions``: dict of arrays ``t`` (time made),
    ``t_h`` (stamp of its last pose), ``x_h``, ``y_h`` (last pose), optionally ``t0``, ``x0``, ``y0``
    (first pose). Returns (errors at the horizon, horizons [s], errors of the first pose)."""
    if predictions is None or len(predictions["t"]) == 0 or empty(pad):
        return np.zeros(0), np.zeros(0), np.zeros(0)
    p = predictions
    at_h = horizontal_distance(p["x_h"], p["y_h"], interp(pad, "x", p["t_h"]), interp(pad, "y", p["t_h"]))
    now = horizontal_distance(p["x0"], p["y0"], interp(pad, "x", p["t0"]), interp(pad, "y", p["t0"])) \
        if "x0" in p else np.full(len(p["t"]), np.nan)
    return at_h, np.asarray(p["t_h"]) - np.asarray(p["t"]), now


def relative_vision_errors(samples, drone, pad):
    """Error of the pad position measured relative to the drone (``samples``: x, y, z in the drone's
    body frame) against the truth rotated into the body frame by the drone's true attitude (drone track
    with qx, qy, qz, qw); horizontal (body x, y) norm."""
    if empty(samples) or empty(drone) or empty(pad) or "qw" not in drone:
        return np.zeros(0)
    t = samples["t"]
    d = np.stack([interp(pad, k, t) - interp(drone, k, t) for k in "xyz"], axis=1)
    q = np.stack([interp(drone, k, t) for k in ("qx", "qy", "qz", "qw")], axis=1)
    norm = np.linalg.norm(q, axis=1, keepdims=True)
    q = q / np.where(norm > 0, norm, np.nan)
    body = rotate_inverse(q, d)
    return np.hypot(samples["x"] - body[:, 0], samples["y"] - body[:, 1])


def rotate_inverse(q, v):
    """v rotated by the inverse of unit quaternions q (x, y, z, w), row-wise: R(q)^T v."""
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    r = np.empty(q.shape[:1] + (3, 3))
    r[:, 0, 0] = 1 - 2 * (y * y + z * z)
    r[:, 0, 1] = 2 * (x * y - z * w)
    r[:, 0, 2] = 2 * (x * z + y * w)
    r[:, 1, 0] = 2 * (x * y + z * w)
    r[:, 1, 1] = 1 - 2 * (x * x + z * z)
    r[:, 1, 2] = 2 * (y * z - x * w)
    r[:, 2, 0] = 2 * (x * z - y * w)
    r[:, 2, 1] = 2 * (y * z + x * w)
    r[:, 2, 2] = 1 - 2 * (x * x + y * y)
    return np.einsum("nji,nj->ni", r, v)


def takeoff_time(takeoff_commands, nav_t, nav_state, fallbacks=()):
    """(time, what) the flight started: the earlier of the first ardrone/takeoff command and the first
    navdata sample that leaves LANDED after a LANDED one; else the first of ``fallbacks`` [(time, what)]."""
    candidates = []
    if len(takeoff_commands):
        candidates.append((float(min(takeoff_commands)), "first /ardrone/takeoff command"))
    if nav_t is not None and len(nav_t):
        landed = np.asarray(nav_state) == NAV_LANDED
        leaving = np.nonzero(landed[:-1] & ~landed[1:])[0]
        if len(leaving):
            candidates.append((float(nav_t[leaving[0] + 1]), "navdata left LANDED"))
    if candidates:
        return min(candidates)
    for candidate in fallbacks:
        if candidate[0] is not None:
            return float(candidate[0]), candidate[1]
    return None, None


def battery(t, level, jump_pct=1.0):
    """Battery use from navdata ``level`` [%]: drain (sum of the small drops) apart from jumps larger than
    ``jump_pct`` between two samples (a level set by a scenario or the operator)."""
    level = np.asarray(level, dtype=float)
    ok = np.isfinite(level)
    t, level = np.asarray(t, dtype=float)[ok], level[ok]
    if level.size == 0:
        return None
    steps = np.diff(level)
    jumps = np.abs(steps) > jump_pct
    return {"start_pct": _r(level[0], 2), "end_pct": _r(level[-1], 2), "min_pct": _r(level.min(), 2),
            "used_pct": _r(-np.sum(steps[~jumps]), 3),
            "level_set": [{"t": _r(t[i + 1], 3), "from_pct": _r(level[i], 2), "to_pct": _r(level[i + 1], 2)}
                          for i in np.nonzero(jumps)[0]]}


def parse_decision(data, bag_t):
    """A supervisor decision as a dict {t, condition, flag, action, reason, value}: from std_msgs/String
    JSON text, from a dict, or from a message object with those fields. None when not a decision."""
    if isinstance(data, str):
        try:
            data = json.loads(data)
        except ValueError:
            return {"t": _r(bag_t, 3), "condition": None, "flag": None, "action": None, "reason": data,
                    "value": None}
    if not isinstance(data, dict):
        data = {k: getattr(data, k) for k in ("t", "condition", "flag", "action", "reason", "value")
                if hasattr(data, k)}
        if "t" in data and hasattr(data["t"], "sec"):
            data["t"] = data["t"].sec + data["t"].nanosec * 1e-9
    if not data:
        return None
    out = {k: data.get(k) for k in ("t", "condition", "flag", "action", "reason", "value")}
    out.update({k: v for k, v in data.items() if k not in out})
    if out["t"] is None:
        out["t"] = _r(bag_t, 3)
    elif isinstance(out["t"], (int, float)) and not isinstance(out["t"], bool):
        out["t"] = _r(out["t"], 3)
    if isinstance(out["flag"], (int, float)) and out["flag"] in (0,):  # uint8 "no flag"
        out["flag"] = None
    for key, value in list(out.items()):
        if isinstance(value, float) and not math.isfinite(value):
            out[key] = None
    return out


def outcome(touchdown, resting_error, emergency_ordered):
    """(outcome, touchdown_error_m) as in flight_analysis.scoring (SPEC section 7)."""
    from . import scoring
    return scoring.outcome(touchdown, resting_error, emergency_ordered)


def wind_speeds(decisions, log_lines, scenario=None):
    """[(t, wind speed m/s, source)] seen in supervisor decisions (wind rows with a numeric value), the
    simulator's 'condition /wind_speed: a -> b' log lines [(t, text)] and the scenario (its initial
    conditions and set_param events)."""
    out = []
    for decision in decisions:
        condition = str(decision.get("condition") or "")
        value = decision.get("value")
        if condition.startswith("wind") and not any(k in condition for k in ("dir", "gust")) \
                and isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
            out.append((decision.get("t"), float(value), "/supervisor/decisions (%s)" % condition))
    pattern = re.compile(r"condition /wind_speed: *([-+0-9.eE]+|\S+) *-> *([-+0-9.eE]+)")
    for t, text in log_lines:
        match = pattern.search(text)
        if match:
            for group in match.groups():
                try:
                    value = float(group)
                except ValueError:
                    continue
                if math.isfinite(value):
                    out.append((t, value, "/rosout_agg (simulator)"))
    if scenario:
        conditions = scenario.get("conditions") or {}
        if isinstance(conditions.get("wind_speed"), (int, float)):
            out.append((0.0, float(conditions["wind_speed"]), "scenario conditions"))
        for event in scenario.get("events") or []:
            if isinstance(event, dict) and event.get("set_param") == "wind_speed":
                try:
                    out.append((event.get("at_s"), float(event.get("value")), "scenario event"))
                except (TypeError, ValueError):
                    pass
    return out
