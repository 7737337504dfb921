"""report.md of one flight: the metrics in words and tables, with the plots."""
import os

OUTCOME_WORDS = {"landed_on_pad": "landed on the pad", "landed_off_pad": "landed off the pad",
                 "emergency_landed": "emergency landing on the ground", "crashed": "crashed",
                 "timeout": "no touchdown before the end of the recording (timeout)"}


def _m(value, unit="m", digits=3):
    if value is None:
        return "n/a"
    return ("%." + str(digits) + "f %s") % (value, unit)


def _stats_row(name, stats, extra=""):
    if not stats:
        return "| %s | n/a | n/a | n/a | 0 | %s |" % (name, extra)
    return "| %s | %.3f | %.3f | %.3f | %d | %s |" % (name, stats["mae_m"], stats["rmse_m"], stats["max_m"],
                                                     stats["samples"], extra)


def write(metrics, files, out_dir):
    m, notes = metrics, metrics.get("notes", {})
    data = m["data"]
    lines = ["# Flight analysis: %s" % os.path.basename(m["bag"]), "",
             "Bag: `%s` (%s s of sim time, %d topics)." % (m["bag"], data.get("duration_s"), len(data.get("topics", {}))),
             ""]
    if data.get("problems"):
        lines += ["> **The bag is damaged; this report covers only what could be read.**", ">"]
        lines += ["> - %s" % p for p in data["problems"]]
        lines.append("")
    outcome = m.get("outcome")
    headline = OUTCOME_WORDS.get(outcome, outcome) if outcome else "unknown (%s)" % notes.get("outcome", "no touchdown")
    lines += ["## Outcome: %s" % headline, ""]
    td = m.get("touchdown")
    rows = [("landed on the pad (error <= 0.25 m, not crashed)", {True: "yes", False: "no", None: "n/a"}[m.get("landed_on_pad")]),
            ("touchdown error (pad centre)", _m(m.get("touchdown_error_m")))]
    if td:
        rows += [("touchdown", "t = %.2f s on the %s%s, impact %.2f m/s, tilt %.1f deg" % (
            td["t"], td["surface"], " (CRASH)" if td["crashed"] else "", td["impact_speed_mps"], td["tilt_deg"])),
                 ("distance from pad centre at first contact / at rest", "%s / %s" % (
                     _m(td["pad_error_m"]), _m(td.get("resting_pad_error_m"))))]
    ttl = m.get("time_to_land")
    rows.append(("time to land", "%s%s" % (_m(m.get("time_to_land_s"), "s", 1),
                                           " (from %s at t = %.2f s)" % (ttl["from"], ttl["from_s"]) if ttl else "")))
    battery = m.get("battery")
    rows.append(("battery used", "n/a" if not battery else "%.2f %% (%.1f %% -> %.1f %%%s)" % (
        battery["used_pct"], battery["start_pct"], battery["end_pct"],
        ", level set %d time(s)" % len(battery["level_set"]) if battery["level_set"] else "")))
    rows.append(("max wind", "n/a" if m.get("max_wind_mps") is None else "%.1f m/s (from %s)" % (
        m["max_wind_mps"], ", ".join(m["wind"]["sources"]))))
    if m.get("emergency_position"):
        rows.append(("reported emergency position", "x = %.2f m, y = %.2f m" % tuple(m["emergency_position"])))
    lines += ["| | |", "|---|---|"] + ["| %s | %s |" % row for row in rows] + [""]

    lines += ["## Errors against ground truth", "",
              "Horizontal distances. MAE = mean absolute error, RMSE = root mean square error.", "",
              "| what | MAE [m] | RMSE [m] | max [m] | samples | note |", "|---|---|---|---|---|---|"]
    te = m.get("tracking_error")
    lines.append(_stats_row("tracking: drone to pad", te, te["window"] + ", on a 20 Hz grid" if te else
                            notes.get("tracking_error", "")))
    for state, stats in (te or {}).get("by_state", {}).items():
        lines.append(_stats_row("&nbsp;&nbsp;while %s" % state.lower(), stats, ""))
    ve = m.get("vision_error")
    lines.append(_stats_row("vision: pad in world", ve, "%d detections" % ve["detections"] if ve else
                            notes.get("vision_error", "")))
    lines.append(_stats_row("vision: pad relative to drone", m.get("vision_relative_error"),
                            "" if m.get("vision_relative_error") else notes.get("vision_relative_error", "")))
    pe = m.get("prediction_error")
    lines.append(_stats_row("Kalman prediction at its horizon", pe, "horizon %.2f s, %d predictions" % (
        pe["horizon_s"], pe["predictions"]) if pe else notes.get("prediction_error", "")))
    if pe and pe.get("first_pose"):
        lines.append(_stats_row("&nbsp;&nbsp;its first pose (now)", pe["first_pose"], ""))
    lines.append(_stats_row("Kalman pad estimate now", m.get("kalman_odom_error"),
                            "" if m.get("kalman_odom_error") else notes.get("kalman_odom_error", "")))
    lines.append(_stats_row("drone's own position estimate", m.get("estimate_error"),
                            "" if m.get("estimate_error") else notes.get("estimate_error", "")))
    lines.append("")

    plots = [("top_view.png", "Top view"), ("altitude.png", "Altitude and state"), ("errors.png", "Errors over time"),
             ("camera.gif", "Camera")]
    shown = [(f, title) for f, title in plots if f in files]
    if shown:
        lines += ["## Plots", ""]
        for f, title in shown:
            lines += ["### %s" % title, "", "![%s](%s)" % (title, f), ""]

    lines += ["## State timeline", ""]
    timeline = m.get("state_timeline") or m.get("navdata_timeline")
    if timeline:
        lines += ["From %s." % ("/platform_tracking/state" if m.get("state_timeline") else
                               "/drone/navdata (the tracker's state is not in the bag)"), "",
                  "| state | from [s] | to [s] | duration [s] |", "|---|---|---|---|"]
        lines += ["| %s | %.2f | %.2f | %.2f |" % (s["state"], s["start_s"], s["end_s"], s["duration_s"]) for s in timeline]
    else:
        lines.append("n/a: %s" % notes.get("state_timeline", ""))
    lines += ["", "## Supervisor decisions", ""]
    decisions = m.get("decisions")
    if decisions:
        lines += ["| t [s] | condition | value | flag | action | reason |", "|---|---|---|---|---|---|"]
        lines += ["| %s | %s | %s | %s | %s | %s |" % (
            _cell(x.get("t")), _cell(x.get("condition")), _cell(x.get("value")), _cell(x.get("flag")),
            _cell(x.get("action")), _cell(x.get("reason"))) for x in decisions]
    elif decisions == []:
        lines.append("None recorded (the supervisor ran but decided nothing).")
    else:
        lines.append("n/a: %s" % notes.get("decisions", ""))
    lines += ["", "## Missing data", ""]
    if notes:
        lines += ["- **%s**: %s" % (k, v) for k, v in notes.items()]
    else:
        lines.append("Nothing: every metric could be computed.")
    lines += ["", "Files: %s." % ", ".join("`%s`" % f for f in files + ["report.md"]), ""]
    with open(os.path.join(out_dir, "report.md"), "w") as stream:
        stream.write("\n".join(lines))
    return "report.md"


def _cell(value):
    if value is None:
        return ""
    if isinstance(value, float):
        return "%.2f" % value
    return str(value).replace("|", "\\|").replace("\n", " ")
