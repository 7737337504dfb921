"""analyze: report of one flight from its ROS 1 bag, without ROS (rosbags, numpy, matplotlib).

Users run it through landing_eval's entry point, which adds the scenario beside the bag (its wind):

    rosrun landing_eval analyze BAG --out DIR
    .venv/bin/python -m landing_eval.analyze BAG --out DIR     # plain shell: no ROS sourced, no master
    .venv/bin/python src/landing_eval/scripts/analyze BAG --out DIR
    .venv/bin/python -m flight_analysis.analyze BAG --out DIR  # this module alone: no scenario is read

(``python -m ...`` finds the packages through the .pth file `make build` writes into the venv, so it works
from any directory of a shell where nothing is sourced.) This package imports nothing of the workspace's
other packages: the scenario is read by a ``load_scenario`` function its caller hands in.

Writes to DIR: ``metrics.json`` (outcome, touchdown error, time to land, tracking / vision / prediction
errors, state timeline, supervisor decisions, battery, wind; a metric the bag cannot give is null and
``notes`` says which topic was missing), ``timeseries.csv`` (20 Hz, time-aligned), ``top_view.png``,
``altitude.png``, ``errors.png``, ``report.md``, and ``camera.gif`` when the bag holds camera frames.

A damaged or truncated bag is read as far as it goes; what was lost is said on stderr, in metrics.json
(``data.problems``) and at the top of report.md. Exit status: 0 when a report was written (even from a
partial bag), 2 when nothing usable could be read (missing file, not a bag, no messages), 1 on a bad
command line."""
import argparse
import csv
import json
import math
import os
import sys
import time

import numpy as np

if __package__ in (None, ""):  # run as a file: make the package importable
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    __package__ = "flight_analysis"  # noqa: A001

from . import analysis_metrics as M  # noqa: E402
from .analysis_bag import BagError, Flat, read_bag  # noqa: E402

T_DRONE = "/groundtruth/ardrone"
T_DRONE_ODOM = "/ardrone/ground_truth/state"
T_PAD = "/groundtruth/landing_pad"
T_NAVDATA = "/drone/navdata"
T_NAVDATA_BEFORE = "/ardrone/navdata"  # the same (landing_msgs/Navdata) in bags of before the drivers' interfaces
T_TOUCHDOWN = "/ardrone/touchdown"
T_TAKEOFF = "/ardrone/takeoff"
T_LAND = "/ardrone/land"
T_VISION = "/platform/current_platform_position_in_world"
T_VISION_REL = "/platform/current_platform_position_in_ardrone"
T_PREDICTION = "/kalman_prediction_path"
T_KALMAN = "/kalman_platform_odom"
T_ESTIMATE = "/ardrone/odom_estimate"
T_STATE = "/platform_tracking/state"
T_TRACKER_CMD = "/platform_tracking/command"
T_DECISIONS = "/supervisor/decisions"
T_MODE = "/supervisor/mode"
T_OPERATOR = "/operator/command"
T_EMERGENCY = "/emergency/position"
T_ROSOUT = "/rosout_agg"
IMAGE_TOPICS = ("/platform_detection/debug_image", "/ardrone/bottom/image_raw")
TOPICS = (T_DRONE, T_DRONE_ODOM, T_PAD, T_NAVDATA, T_NAVDATA_BEFORE, T_TOUCHDOWN, T_TAKEOFF, T_LAND, T_VISION, T_VISION_REL,
          T_PREDICTION, T_KALMAN, T_ESTIMATE, T_STATE, T_TRACKER_CMD, T_DECISIONS, T_MODE, T_OPERATOR,
          T_EMERGENCY, T_ROSOUT) + IMAGE_TOPICS
GIF_RATE_HZ = 2.0


# ----------------------------------------------------------------------------------------------------
# From messages to arrays

def _stamp(message, bag_t):
    header = getattr(message, "header", None)
    if header is None:
        return bag_t
    t = header.stamp.sec + header.stamp.nanosec * 1e-9
    return t if t > 0 else bag_t


def _pose_track(items, odometry=False):
    rows = []
    for bag_t, m in items:
        if isinstance(m, Flat):
            rows.append((m.stamp if m.stamp > 0 else bag_t,) + m.values[:7])
            continue
        pose = m.pose.pose if odometry else m.pose
        p, q = pose.position, pose.orientation
        rows.append((_stamp(m, bag_t), p.x, p.y, p.z, q.x, q.y, q.z, q.w))
    if not rows:
        return None
    a = np.array(rows, dtype=float)
    return M.make_track(a[:, 0], x=a[:, 1], y=a[:, 2], z=a[:, 3], qx=a[:, 4], qy=a[:, 5], qz=a[:, 6], qw=a[:, 7])


def _point_track(items):
    rows = [((m.stamp if m.stamp > 0 else bag_t,) + m.values[:3]) if isinstance(m, Flat) else
            (_stamp(m, bag_t), m.point.x, m.point.y, m.point.z) for bag_t, m in items]
    if not rows:
        return None
    a = np.array(rows, dtype=float)
    return M.make_track(a[:, 0], x=a[:, 1], y=a[:, 2], z=a[:, 3])


def _predictions(items):
    rows = []
    for bag_t, m in items:
        if isinstance(m, Flat):  # poses: (sec, nsec, frame, x, y, z, ...)
            if not m.values:
                continue
            made = m.stamp if m.stamp > 0 else bag_t
            first, last = m.values[0], m.values[-1]
            t0, t_h = first[0] + first[1] * 1e-9 or made, last[0] + last[1] * 1e-9 or made
            rows.append((made, t_h, last[3], last[4], t0, first[3], first[4]))
            continue
        poses = list(m.poses)
        if not poses:
            continue
        made = _stamp(m, bag_t)
        first, last = poses[0], poses[-1]
        t0, t_h = _stamp(first, made), _stamp(last, made)
        rows.append((made, t_h, last.pose.position.x, last.pose.position.y, t0, first.pose.position.x,
                     first.pose.position.y))
    if not rows:
        return None
    a = np.array(sorted(rows), dtype=float)
    return {"t": a[:, 0], "t_h": a[:, 1], "x_h": a[:, 2], "y_h": a[:, 3], "t0": a[:, 4], "x0": a[:, 5],
            "y0": a[:, 6]}


def _text(message):
    return message.data if hasattr(message, "data") else str(message)


def _expected_absent(metrics):
    """Topics whose absence from the bag is no news: the fallback and legacy topics, and the emergency
    coordinates of a flight that made no emergency landing."""
    absent = {T_DRONE_ODOM, T_NAVDATA_BEFORE}
    if metrics.get("outcome") != "emergency_landed":
        absent.add(T_EMERGENCY)
    return absent


def extract(contents):
    """Arrays and lists of everything the analysis uses, from the decoded messages."""
    get = contents.get
    d = {"drone": _pose_track(get(T_DRONE)), "drone_source": T_DRONE}
    if d["drone"] is None and get(T_DRONE_ODOM):
        d["drone"], d["drone_source"] = _pose_track(get(T_DRONE_ODOM), odometry=True), T_DRONE_ODOM
    d["pad"] = _pose_track(get(T_PAD))
    nav = get(T_NAVDATA) or [(t, m) for t, m in get(T_NAVDATA_BEFORE) or () if not hasattr(m, "batteryPercent")]
    if nav:
        a = np.array([((m.stamp if m.stamp > 0 else t,) + m.values[:3]) if isinstance(m, Flat) else
                      (_stamp(m, t), m.state, m.battery_percent, m.altitude) for t, m in nav], dtype=float)
        d["nav"] = M.make_track(a[:, 0], state=a[:, 1], battery=a[:, 2], sonar=a[:, 3])
    else:
        d["nav"] = None
    d["touchdowns"] = [{
        "t": round(_stamp(m, t), 3), "surface": M.SURFACES.get(int(m.surface), "unknown(%s)" % m.surface),
        "surface_code": int(m.surface), "crashed": bool(m.crashed), "impact_speed_mps": round(float(m.impact_speed), 3),
        "tilt_deg": round(float(m.tilt_deg), 2), "pad_error_m": round(float(m.pad_error), 4),
        "position": [round(m.position.x, 3), round(m.position.y, 3), round(m.position.z, 3)]}
        for t, m in get(T_TOUCHDOWN)]
    d["touchdowns"].sort(key=lambda item: item["t"])
    d["takeoff_cmds"] = [t for t, _ in get(T_TAKEOFF)]
    d["land_cmds"] = [t for t, _ in get(T_LAND)]
    d["vision"] = _point_track(get(T_VISION))
    d["vision_rel"] = _point_track(get(T_VISION_REL))
    d["predictions"] = _predictions(get(T_PREDICTION))
    d["kalman"] = _pose_track(get(T_KALMAN), odometry=True) if get(T_KALMAN) else None
    d["estimate"] = _pose_track(get(T_ESTIMATE), odometry=True) if get(T_ESTIMATE) else None
    d["states"] = [(t, M.normalize_state(_text(m))) for t, m in get(T_STATE)]
    d["modes"] = [(t, M.normalize_state(_text(m))) for t, m in get(T_MODE)]
    d["decisions"] = [x for x in (M.parse_decision(_text(m) if hasattr(m, "data") else m, t)
                                  for t, m in get(T_DECISIONS)) if x is not None]
    d["operator"] = [(t, _text(m)) for t, m in get(T_OPERATOR)]
    d["tracker_commands"] = [(t, _text(m)) for t, m in get(T_TRACKER_CMD)]
    d["emergency_position"] = None
    if get(T_EMERGENCY):
        m = get(T_EMERGENCY)[-1][1]
        d["emergency_position"] = [round(float(m.x), 3), round(float(m.y), 3)]
    d["log"] = [(t, getattr(m, "msg", "")) for t, m in get(T_ROSOUT)]
    d["images"] = next(((topic, get(topic)) for topic in IMAGE_TOPICS if get(topic)), None)
    return d


# ----------------------------------------------------------------------------------------------------
# Metrics

def _load_scenario(bag_path, load_scenario=None):
    """The scenario of a run_scenario output directory (result.json beside the bag) as ``load_scenario(path)``
    reads it (landing_eval.scenario.load, handed in by landing_eval.analyze), or None."""
    if load_scenario is None:
        return None
    result_path = os.path.join(os.path.dirname(os.path.abspath(bag_path)), "result.json")
    try:
        with open(result_path) as stream:
            result = json.load(stream)
        return load_scenario(result["scenario"])
    except Exception:  # no result.json, no scenario, or a bad one: the wind is then unknown
        return None


def compute_metrics(d, contents, scenario=None):
    notes = {}
    present = {topic for topic, count in contents.counts.items() if count}

    def missing(key, *topics, why=None):
        gone = [t for t in topics if t not in present]
        notes[key] = why or ("missing topic%s %s in the bag" % ("s" if len(gone) > 1 else "", ", ".join(gone or topics)))

    end_s = contents.end_s
    m = {}
    # Outcome and touchdown.
    emergency_ordered = any(x.get("action") == "emergency_landing" for x in d["decisions"]) or \
        any(text.strip() == "emergency" for _, text in d["operator"])
    if d["touchdowns"]:
        last = d["touchdowns"][-1]
        resting = None
        if not M.empty(d["drone"]) and not M.empty(d["pad"]) and d["drone"]["t"][-1] > last["t"]:
            t_end = min(d["drone"]["t"][-1], d["pad"]["t"][-1])
            if t_end > last["t"]:
                resting = float(M.horizontal_distance(M.interp(d["drone"], "x", t_end), M.interp(d["drone"], "y", t_end),
                                                      M.interp(d["pad"], "x", t_end), M.interp(d["pad"], "y", t_end))[0])
                resting = None if not math.isfinite(resting) else round(resting, 4)
        touchdown = _Touchdown(last)
        outcome, error = M.outcome(touchdown, resting, emergency_ordered)
        m["outcome"] = outcome
        m["touchdown"] = dict(last, resting_pad_error_m=resting, events=len(d["touchdowns"]))
        m["landed_on_pad"] = outcome == "landed_on_pad"
        m["touchdown_error_m"] = error
        if error is None:
            notes["touchdown_error_m"] = "not on the pad within %.2f m (%s)" % (M.PAD_TOLERANCE_M, outcome)
    else:
        m["outcome"], m["touchdown"], m["landed_on_pad"], m["touchdown_error_m"] = None, None, None, None
        if contents.integrity.get("status") != "ok":
            why = "no touchdown in the part of the bag that could be read (up to t = %.2f s; see data.problems)" \
                % (contents.end_s or 0.0)
        else:
            why = "no touchdown recorded (no %s messages): the flight did not end on a surface, or the bag " \
                  "stops before it" % T_TOUCHDOWN
        for key in ("outcome", "touchdown", "landed_on_pad", "touchdown_error_m"):
            notes[key] = why
        if contents.integrity.get("status") == "ok" and d["nav"] is not None:
            m["outcome"] = "timeout"
            notes["outcome"] = "no touchdown before the end of the bag: timeout"
    m["emergency_ordered"] = emergency_ordered
    m["emergency_position"] = d["emergency_position"]

    # Time to land.
    nav = d["nav"]
    fallbacks = [(next((t for t, x in d["operator"] if x.strip() in ("landing", "takeoff")), None),
                  "first operator landing/takeoff command"),
                 (next((t for t, x in d["tracker_commands"] if x.strip() == "takeoff"), None),
                  "first platform_tracking takeoff command")]
    start, start_what = M.takeoff_time(d["takeoff_cmds"], None if nav is None else nav["t"],
                                       None if nav is None else nav["state"], fallbacks)
    m["time_to_land_s"], m["time_to_land"] = None, None
    if start is None:
        missing("time_to_land_s", T_TAKEOFF, T_NAVDATA)
    elif not d["touchdowns"]:
        notes["time_to_land_s"] = "no touchdown recorded"
    else:
        td = d["touchdowns"][-1]
        m["time_to_land"] = {"from_s": round(start, 3), "from": start_what, "to_s": td["t"],
                             "duration_s": round(td["t"] - start, 3)}
        if td["crashed"]:
            notes["time_to_land_s"] = "the drone crashed at t=%.2f s" % td["t"]
        else:
            m["time_to_land_s"] = round(td["t"] - start, 3)

    # State timelines.
    if d["states"]:
        m["state_timeline"] = M.timeline([t for t, _ in d["states"]], [s for _, s in d["states"]], end_s)
    else:
        m["state_timeline"] = None
        missing("state_timeline", T_STATE)
    m["navdata_timeline"] = None if nav is None else M.timeline(
        nav["t"], [M.NAV_STATES.get(int(s), str(int(s))) for s in nav["state"]], end_s)
    if nav is None:
        missing("navdata_timeline", T_NAVDATA)

    # Tracking error (ground truth).
    windows, window_what = None, None
    if m["state_timeline"]:
        windows = M.windows_of(m["state_timeline"], M.TRACKING_STATES)
        window_what = "in tracker states %s (%s)" % (" and ".join(M.TRACKING_STATES), T_STATE)
    elif nav is not None:
        windows = M.windows_of(m["navdata_timeline"], [M.NAV_STATES[s] for s in M.NAV_AIRBORNE])
        window_what = "while airborne (navdata state; no %s in the bag)" % T_STATE
    else:
        window_what = "over the whole bag (no %s nor %s)" % (T_STATE, T_NAVDATA)
    d["tracking_windows"] = windows
    t_grid, errors, stats = M.tracking_error(d["drone"], d["pad"], windows)
    if M.empty(d["drone"]) or M.empty(d["pad"]):
        m["tracking_error"] = None
        missing("tracking_error", T_DRONE, T_PAD)
    elif stats is None:
        m["tracking_error"] = None
        notes["tracking_error"] = "nothing to score: no ground truth %s" % window_what
    else:
        stats["window"] = window_what
        stats["duration_s"] = round(len(errors[np.isfinite(errors)]) / M.GRID_HZ, 2)
        if m["state_timeline"]:
            stats["by_state"] = {}
            for state in M.TRACKING_STATES:
                mask = M.in_windows(t_grid, M.windows_of(m["state_timeline"], (state,)))
                by = M.error_stats(errors[mask])
                if by:
                    stats["by_state"][state] = by
        m["tracking_error"] = stats

    # Vision against ground truth.
    vision_err = M.sample_errors(d["vision"], d["pad"])
    d["vision_errors"] = vision_err
    m["vision_error"] = M.error_stats(vision_err, None if d["vision"] is None else d["vision"]["t"])
    if m["vision_error"] is None:
        missing("vision_error", T_VISION, T_PAD) if (M.empty(d["vision"]) or M.empty(d["pad"])) else \
            notes.__setitem__("vision_error", "no detection overlaps the ground truth in time")
    else:
        m["vision_error"]["detections"] = int(len(d["vision"]["t"]))
        if windows:
            seconds = sum(b - a for a, b in windows)
            inside = int(M.in_windows(d["vision"]["t"], windows).sum())
            m["vision_error"]["detection_rate_hz_while_tracking"] = round(inside / seconds, 2) if seconds > 0 else None
    rel_err = M.relative_vision_errors(d["vision_rel"], d["drone"], d["pad"])
    d["vision_rel_errors"] = rel_err
    m["vision_relative_error"] = M.error_stats(rel_err)
    if m["vision_relative_error"] is None:
        missing("vision_relative_error", T_VISION_REL, T_DRONE, T_PAD)

    # Kalman prediction at its horizon, and now.
    at_h, horizons, now = M.prediction_errors(d["predictions"], d["pad"])
    d["prediction_errors"], d["prediction_now_errors"] = at_h, now
    m["prediction_error"] = M.error_stats(at_h, None if d["predictions"] is None else d["predictions"]["t"])
    if m["prediction_error"] is None:
        if d["predictions"] is None or M.empty(d["pad"]):
            missing("prediction_error", T_PREDICTION, T_PAD)
        else:
            notes["prediction_error"] = "no prediction horizon falls inside the ground truth's time span"
    else:
        m["prediction_error"]["horizon_s"] = round(float(np.median(horizons)), 3)
        m["prediction_error"]["predictions"] = int(len(horizons))
        m["prediction_error"]["first_pose"] = M.error_stats(now)
    kalman_err = M.sample_errors(d["kalman"], d["pad"])
    d["kalman_errors"] = kalman_err
    m["kalman_odom_error"] = M.error_stats(kalman_err)
    if m["kalman_odom_error"] is None:
        missing("kalman_odom_error", T_KALMAN, T_PAD)
    estimate_err = M.sample_errors(d["estimate"], d["drone"])
    d["estimate_errors"] = estimate_err
    m["estimate_error"] = M.error_stats(estimate_err)
    if m["estimate_error"] is None:
        missing("estimate_error", T_ESTIMATE, T_DRONE)

    # Supervisor, battery, wind.
    if T_DECISIONS in present:
        m["decisions"] = d["decisions"]
    else:
        m["decisions"] = None
        missing("decisions", T_DECISIONS)
    m["supervisor_modes"] = M.timeline([t for t, _ in d["modes"]], [s for _, s in d["modes"]], end_s) \
        if d["modes"] else None
    m["battery"] = None if nav is None else M.battery(nav["t"], nav["battery"])
    m["battery_used_pct"] = None if m["battery"] is None else m["battery"]["used_pct"]
    if m["battery"] is None:
        missing("battery", T_NAVDATA)
        notes["battery_used_pct"] = notes["battery"]
    winds = M.wind_speeds(d["decisions"], d["log"], scenario)
    m["max_wind_mps"] = round(max(w for _, w, _ in winds), 3) if winds else None
    m["wind"] = {"sources": sorted({s for _, _, s in winds}),
                 "values": [{"t": None if t is None else round(float(t), 3), "mps": w, "source": s}
                            for t, w, s in winds]} if winds else None
    if not winds:
        notes["max_wind_mps"] = ("the wind is not recorded: no wind value in %s, no 'condition /wind_speed' line in %s, "
                                 "no scenario beside the bag" % (T_DECISIONS, T_ROSOUT))
    m["notes"] = notes
    return m


class _Touchdown:
    """What flight_analysis.scoring expects of a landing_msgs/Touchdown."""

    def __init__(self, td):
        self.surface, self.crashed, self.pad_error = td["surface_code"], td["crashed"], td["pad_error_m"]


# ----------------------------------------------------------------------------------------------------
# Time-aligned series

def timeseries(d, m, contents, rate=M.GRID_HZ):
    """Columns (dict name -> array) on a uniform grid over the bag."""
    starts = [x["t"][0] for x in (d["drone"], d["pad"], d["nav"]) if not M.empty(x)]
    ends = [x["t"][-1] for x in (d["drone"], d["pad"], d["nav"]) if not M.empty(x)]
    t = M.grid(min(starts), max(ends), rate) if starts else np.zeros(0)
    cols = {"t_s": t}
    for name, track in (("drone", d["drone"]), ("pad", d["pad"])):
        for k in "xyz":
            cols["%s_%s_m" % (name, k)] = M.interp(track, k, t)
    cols["tracking_error_m"] = M.horizontal_distance(cols["drone_x_m"], cols["drone_y_m"], cols["pad_x_m"],
                                                     cols["pad_y_m"])
    cols["height_above_pad_m"] = cols["drone_z_m"] - cols["pad_z_m"]
    cols["vision_error_m"] = _nearest(d["vision"], d["vision_errors"], t, 0.5 / rate)
    if d["predictions"] is not None:
        cols["prediction_error_m"] = _nearest({"t": d["predictions"]["t"]}, d["prediction_errors"], t, 0.5 / rate)
    else:
        cols["prediction_error_m"] = np.full(t.shape, np.nan)
    cols["estimate_error_m"] = _nearest(d["estimate"], d["estimate_errors"], t, 0.5 / rate)
    nav = d["nav"]
    cols["sonar_m"] = M.interp(nav, "sonar", t) if nav is not None else np.full(t.shape, np.nan)
    cols["battery_pct"] = _hold(nav, "battery", t)
    cols["navdata_state"] = _hold_labels(m["navdata_timeline"], t)
    cols["tracker_state"] = _hold_labels(m["state_timeline"], t)
    return cols


def _nearest(track, values, t, tolerance):
    out = np.full(t.shape, np.nan)
    if M.empty(track) or len(values) == 0 or len(t) == 0:
        return out
    ts = np.asarray(track["t"])
    i = np.clip(np.searchsorted(ts, t), 1, len(ts) - 1) if len(ts) > 1 else np.zeros(len(t), dtype=int)
    if len(ts) > 1:
        i = np.where(np.abs(ts[i - 1] - t) < np.abs(ts[i] - t), i - 1, i)
    close = np.abs(ts[i] - t) <= tolerance
    out[close] = np.asarray(values)[i[close]]
    return out


def _hold(track, name, t):
    out = np.full(t.shape, np.nan)
    if M.empty(track):
        return out
    i = np.searchsorted(track["t"], t, side="right") - 1
    ok = i >= 0
    out[ok] = track[name][i[ok]]
    return out


def _hold_labels(segments, t):
    out = np.full(t.shape, "", dtype=object)
    for segment in segments or []:
        out[(t >= segment["start_s"]) & (t <= segment["end_s"])] = segment["state"]
    return out


def write_csv(path, cols):
    names = list(cols)
    with open(path, "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(names)
        n = len(cols["t_s"])
        formatted = []
        for name in names:
            values = cols[name]
            if values.dtype == object:
                formatted.append(values)
            else:
                formatted.append(["" if not np.isfinite(v) else "%.4f" % v for v in values])
        for row in zip(*formatted) if n else ():
            writer.writerow(row)


# ----------------------------------------------------------------------------------------------------
# Entry point

def analyze(bag_path, out_dir, plots=True, gif=True, load_scenario=None):
    """Analyze one bag; writes the outputs to out_dir and returns the metrics dict. ``load_scenario``: reads a
    scenario file (see _load_scenario); None: the scenario is not read. Raises BagError when nothing usable
    can be read."""
    wall = time.monotonic()
    timing = {}
    contents = read_bag(bag_path, TOPICS, max_rate={topic: GIF_RATE_HZ for topic in IMAGE_TOPICS},
                        unless={T_DRONE_ODOM: T_DRONE})
    timing["read_s"] = round(time.monotonic() - wall, 3)
    os.makedirs(out_dir, exist_ok=True)
    d = extract(contents)
    scenario = _load_scenario(bag_path, load_scenario)
    metrics = {"bag": os.path.abspath(bag_path)}
    metrics.update(compute_metrics(d, contents, scenario))
    duration = None if contents.start_s is None else round(contents.end_s - contents.start_s, 3)
    metrics["data"] = dict(contents.integrity, problems=contents.problems, start_s=_round(contents.start_s),
                           end_s=_round(contents.end_s), duration_s=duration,
                           topics={k: v for k, v in sorted(contents.counts.items())},
                           missing_topics=[t for t in TOPICS if not contents.counts.get(t)
                                           and t not in IMAGE_TOPICS and t not in _expected_absent(metrics)])
    cols = timeseries(d, metrics, contents)
    write_csv(os.path.join(out_dir, "timeseries.csv"), cols)
    files = ["metrics.json", "timeseries.csv"]
    timing["metrics_s"] = round(time.monotonic() - wall - timing["read_s"], 3)
    if plots:
        from . import analysis_plots
        files += analysis_plots.all_plots(d, metrics, cols, out_dir)
        if gif and d["images"]:
            name = analysis_plots.camera_gif(d["images"][0], d["images"][1], out_dir)
            if name:
                files.append(name)
    from . import analysis_report
    files.append(analysis_report.write(metrics, files, out_dir))
    metrics["outputs"] = files
    metrics["analysis_wall_time_s"] = round(time.monotonic() - wall, 3)
    timing["plots_and_report_s"] = round(metrics["analysis_wall_time_s"] - timing["read_s"] - timing["metrics_s"], 3)
    metrics["analysis_timing"] = timing
    with open(os.path.join(out_dir, "metrics.json"), "w") as stream:
        json.dump(_jsonable(metrics), stream, indent=2, allow_nan=False)
    return metrics


def _round(value, digits=3):
    return None if value is None else round(value, digits)


def _jsonable(value):
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value


def summary_line(m):
    parts = [m.get("outcome") or "no touchdown recorded"]
    if m.get("touchdown_error_m") is not None:
        parts.append("touchdown error %.3f m" % m["touchdown_error_m"])
    if m.get("time_to_land_s") is not None:
        parts.append("time to land %.1f s" % m["time_to_land_s"])
    if m.get("tracking_error"):
        parts.append("tracking MAE %.3f m / RMSE %.3f m" % (m["tracking_error"]["mae_m"], m["tracking_error"]["rmse_m"]))
    return ", ".join(parts)


def main(argv=None, load_scenario=None):
    parser = argparse.ArgumentParser(prog="analyze", description="Report of one flight from its ROS 1 bag "
                                     "(metrics.json, timeseries.csv, plots, report.md); needs no ROS.")
    parser.add_argument("bag", help="the flight's bag (run_scenario writes DIR/flight.bag)")
    parser.add_argument("--out", required=True, help="output directory (created if missing)")
    parser.add_argument("--no-plots", action="store_true", help="metrics, CSV and report only (faster)")
    parser.add_argument("--no-gif", action="store_true", help="skip the camera GIF even when frames exist")
    args = parser.parse_args(argv)
    try:
        metrics = analyze(args.bag, args.out, plots=not args.no_plots, gif=not args.no_gif,
                          load_scenario=load_scenario)
    except BagError as err:
        print("analyze: %s" % err, file=sys.stderr)
        return 2
    except ImportError as err:
        print("analyze: %s: run it with the workspace's python (.venv/bin/python), which has the packages of "
              "requirements.txt (rosbags, numpy, matplotlib)" % err, file=sys.stderr)
        return 3
    except OSError as err:
        print("analyze: %s" % err, file=sys.stderr)
        return 2
    for problem in metrics["data"]["problems"]:
        print("analyze: warning: %s: %s" % (args.bag, problem), file=sys.stderr)
    missing = metrics["data"]["missing_topics"]
    if missing:
        print("analyze: note: topics not in the bag: %s" % ", ".join(missing), file=sys.stderr)
    print("%s: %s" % (os.path.basename(args.bag), summary_line(metrics)))
    print("report: %s (analysis took %.2f s)" % (os.path.join(args.out, "report.md"), metrics["analysis_wall_time_s"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
