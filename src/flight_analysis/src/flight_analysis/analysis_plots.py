"""Plots of one flight (matplotlib, Agg backend: no display needed): top view, altitude with state bands,
errors over time; and an animated GIF of camera frames when the bag holds them."""
import os

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Patch, Polygon  # noqa: E402

from . import analysis_metrics as M  # noqa: E402

DPI = 110
STATE_COLOURS = {
    # platform_tracking states
    "LANDED": "#bdbdbd", "TAKING_OFF": "#9ecae1", "TRACKING": "#a1d99b", "LANDING": "#fdae6b",
    "RELOCATING": "#fc9272", "FORCE_LANDING": "#bcbddc",
    # navdata states (used when the tracker's state is not in the bag)
    "FLYING": "#a1d99b", "HOVERING": "#c7e9c0", "GOTO_HOVER": "#c7e9c0", "CRASHED": "#de2d26", "INITED": "#f0f0f0",
    "UNKNOWN": "#f0f0f0",
}
EXTRA_COLOURS = ["#e7cb94", "#9edae5", "#dbdb8d", "#f7b6d2", "#c49c94", "#c5b0d5"]
C_DRONE, C_PAD, C_VISION, C_PRED, C_EST, C_KALMAN = "#1f77b4", "#d62728", "#ff7f0e", "#9467bd", "#2ca02c", "#8c564b"


def _colour(state, extra):
    if state not in STATE_COLOURS:
        extra.setdefault(state, EXTRA_COLOURS[len(extra) % len(EXTRA_COLOURS)])
        return extra[state]
    return STATE_COLOURS[state]


def _bands(ax, segments, extra):
    """Shade the axes by state; returns legend handles of the states shown."""
    seen = {}
    for segment in segments or []:
        if segment["end_s"] is None or segment["end_s"] <= segment["start_s"]:
            continue
        colour = _colour(segment["state"], extra)
        ax.axvspan(segment["start_s"], segment["end_s"], color=colour, alpha=0.45, lw=0, zorder=0)
        seen.setdefault(segment["state"], colour)
    return [Patch(facecolor=c, alpha=0.6, label=s.replace("_", " ").lower()) for s, c in seen.items()]


def _partial(metrics):
    data = metrics.get("data") or {}
    if data.get("status", "ok") != "ok":
        return "  [PARTIAL: damaged bag, data up to t = %.1f s]" % (data.get("end_s") or 0.0)
    return ""


def _state_segments(metrics):
    if metrics.get("state_timeline"):
        return metrics["state_timeline"], "tracker state"
    if metrics.get("navdata_timeline"):
        return metrics["navdata_timeline"], "navdata state"
    return [], None


def _touchdown_line(ax, metrics):
    td = metrics.get("touchdown")
    if td:
        ax.axvline(td["t"], color="k", ls="--", lw=1.0, label="touchdown (%s)" % td["surface"])


def _no_data(ax, text):
    import textwrap
    ax.text(0.5, 0.5, textwrap.fill(text, 80), ha="center", va="center", transform=ax.transAxes, color="0.3",
            fontsize=10.5, bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "0.8"})


def top_view(d, metrics, path):
    fig, ax = plt.subplots(figsize=(11.0, 7.5))
    fig.subplots_adjust(left=0.07, right=0.66, top=0.94, bottom=0.08)
    drone, pad = d["drone"], d["pad"]
    if not M.empty(pad):
        ax.plot(pad["x"], pad["y"], color=C_PAD, lw=4.0, alpha=0.35, solid_capstyle="round",
                label="landing pad centre (ground truth)")
        ax.plot(pad["x"][0], pad["y"][0], "o", color=C_PAD, ms=9, mfc="white", mew=2, label="pad at start")
    if not M.empty(drone):
        ax.plot(drone["x"], drone["y"], color=C_DRONE, lw=1.2, label="drone (ground truth)")
        ax.plot(drone["x"][0], drone["y"][0], "o", color=C_DRONE, ms=6, mfc="white", mew=1.5, label="drone at start")
        ax.plot(drone["x"][-1], drone["y"][-1], "s", color=C_DRONE, ms=6, mfc="white", mew=1.5, label="drone at end")
    if not M.empty(d["vision"]):
        ax.plot(d["vision"]["x"], d["vision"]["y"], ".", color=C_VISION, ms=2.5, alpha=0.5,
                label="pad seen by the vision (world)")
    if not M.empty(d["estimate"]):
        ax.plot(d["estimate"]["x"], d["estimate"]["y"], color=C_EST, lw=0.8, alpha=0.7, ls=":",
                label="drone's own estimate")
    td = metrics.get("touchdown")
    if td:
        good = metrics.get("landed_on_pad")
        if not M.empty(pad):
            _pad_outline(ax, pad, td["t"])
        colour = "#2ca02c" if good else "#d62728"
        ax.plot(td["position"][0], td["position"][1], "X", color=colour, ms=14, mec="k", mew=1.0, zorder=5,
                label="touchdown: %s" % _touchdown_text(metrics))
    emergency = metrics.get("emergency_position")
    if emergency:
        ax.plot(emergency[0], emergency[1], "*", color="#e377c2", ms=14, mec="k", label="reported emergency position")
    if M.empty(drone) and M.empty(pad):
        _no_data(ax, "no ground truth (/groundtruth/ardrone, /groundtruth/landing_pad) in the bag")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (east) [m]")
    ax.set_ylabel("y (north) [m]")
    ax.set_title("Top view: paths of the drone and the landing pad (world frame)" + _partial(metrics))
    ax.grid(True, alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        _outside_legend(ax)
    _save(fig, path)


def _outside_legend(ax, handles=None, labels=None):
    if handles is None:
        handles, labels = ax.get_legend_handles_labels()
    ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8.5, framealpha=0.9,
              borderaxespad=0.0)


def _save(fig, path):
    fig.savefig(path, dpi=DPI)
    plt.close(fig)


def _touchdown_text(metrics):
    td = metrics["touchdown"]
    text = "crashed on the %s" % td["surface"] if td["crashed"] else "on the %s" % td["surface"]
    if td["surface"] == "pad" or td.get("pad_error_m") is not None:
        text += ", %.2f m from the pad centre" % td["pad_error_m"]
    return text


def _pad_outline(ax, pad, t, size=1.0):
    """The 1 m pad square at time t (oriented by the pad's yaw when known)."""
    x, y = M.interp(pad, "x", t)[0], M.interp(pad, "y", t)[0]
    if not np.isfinite(x):
        x, y = pad["x"][-1], pad["y"][-1]
    yaw = 0.0
    if "qw" in pad:
        q = [M.interp(pad, k, t)[0] for k in ("qx", "qy", "qz", "qw")]
        if all(np.isfinite(q)):
            yaw = np.arctan2(2 * (q[3] * q[2] + q[0] * q[1]), 1 - 2 * (q[1] ** 2 + q[2] ** 2))
    h = size / 2
    corners = np.array([[-h, -h], [h, -h], [h, h], [-h, h]])
    rot = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
    ax.add_patch(Polygon(corners @ rot.T + [x, y], closed=True, fill=False, ec=C_PAD, lw=1.2, ls="--",
                         label="pad (1 m) at touchdown"))


def altitude(d, metrics, cols, path):
    fig, (ax, axb) = plt.subplots(2, 1, figsize=(13.0, 6.5), sharex=True, gridspec_kw={"height_ratios": [3, 1]})
    fig.subplots_adjust(left=0.06, right=0.79, top=0.94, bottom=0.09, hspace=0.12)
    extra = {}
    segments, what = _state_segments(metrics)
    handles = _bands(ax, segments, extra)
    _bands(axb, segments, extra)
    drone, pad = d["drone"], d["pad"]
    if not M.empty(drone):
        ax.plot(drone["t"], drone["z"], color=C_DRONE, lw=1.4, label="drone height (ground truth)")
    if not M.empty(pad):
        ax.plot(pad["t"], pad["z"], color=C_PAD, lw=1.2, label="pad surface (ground truth)")
    if np.isfinite(cols["sonar_m"]).any():
        ax.plot(cols["t_s"], cols["sonar_m"], color="0.35", lw=0.7, alpha=0.7, label="sonar range (to surface below)")
    _touchdown_line(ax, metrics)
    if M.empty(drone) and M.empty(pad):
        _no_data(ax, "no ground truth in the bag")
    ax.set_ylabel("height above ground [m]")
    ax.set_title("Altitude over time" + (" (bands: %s)" % what if what else "") + _partial(metrics))
    ax.grid(True, alpha=0.3)
    lines, labels = ax.get_legend_handles_labels()
    _outside_legend(ax, lines + handles, labels + [h.get_label() for h in handles])
    battery = cols["battery_pct"]
    if np.isfinite(battery).any():
        axb.plot(cols["t_s"], battery, color="#636363", lw=1.4)
        low, high = np.nanmin(battery), np.nanmax(battery)
        axb.set_ylim(max(0, low - 2), min(100, high + 2) if high > low else high + 2)
    else:
        _no_data(axb, "no battery level (%s)" % "/drone/navdata")
    _touchdown_line(axb, metrics)
    axb.set_ylabel("battery [%]")
    axb.set_xlabel("sim time [s]")
    axb.grid(True, alpha=0.3)
    _save(fig, path)


def errors(d, metrics, cols, path):
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(13.0, 7.5), sharex=True)
    fig.subplots_adjust(left=0.06, right=0.70, top=0.94, bottom=0.08, hspace=0.12)
    extra = {}
    segments, what = _state_segments(metrics)
    handles = _bands(ax, segments, extra)
    _bands(ax2, segments, extra)
    t, tracking = cols["t_s"], cols["tracking_error_m"]
    tops = []
    if np.isfinite(tracking).any():
        ax.plot(t, tracking, color=C_DRONE, lw=1.0, label="drone-pad horizontal distance (ground truth)")
        tops.append(np.nanpercentile(tracking, 99))
        windows = d.get("tracking_windows")
        stats = metrics.get("tracking_error")
        if not stats:
            _no_data(ax, metrics["notes"].get("tracking_error", "not scored"))
        elif windows:
            scored = np.where(M.in_windows(t, windows), tracking, np.nan)
            ax.plot(t, scored, color="#08306b", lw=2.0,
                    label="scored: MAE %.2f m, RMSE %.2f m" % (stats["mae_m"], stats["rmse_m"]))
    else:
        _no_data(ax, "no tracking error: %s" % metrics["notes"].get("tracking_error", "no ground truth while airborne"))
    ax.axhline(M.PAD_TOLERANCE_M, color="k", ls=":", lw=1.0, label="landing tolerance %.2f m" % M.PAD_TOLERANCE_M)
    _touchdown_line(ax, metrics)
    ax.set_ylabel("tracking error [m]")
    ax.set_title("Errors over time" + (" (bands: %s)" % what if what else "") + _partial(metrics))
    if tops:
        ax.set_ylim(0, max(max(tops) * 1.15 + 0.05, M.PAD_TOLERANCE_M * 1.5))
    ax.grid(True, alpha=0.3)
    lines, labels = ax.get_legend_handles_labels()
    _outside_legend(ax, lines + handles, labels + [h.get_label() for h in handles])

    tops, plotted = [], False
    if len(d["vision_errors"]) and np.isfinite(d["vision_errors"]).any():
        stats = metrics["vision_error"]
        ax2.plot(d["vision"]["t"], d["vision_errors"], ".", color=C_VISION, ms=3,
                 label="vision (pad in world) vs truth: MAE %.2f m" % stats["mae_m"])
        tops.append(np.nanpercentile(d["vision_errors"], 99))
        plotted = True
    if len(d["prediction_errors"]) and np.isfinite(d["prediction_errors"]).any():
        stats = metrics["prediction_error"]
        ax2.plot(d["predictions"]["t"], d["prediction_errors"], ".", color=C_PRED, ms=3,
                 label="Kalman prediction at +%.1f s vs truth: MAE %.2f m" % (stats["horizon_s"], stats["mae_m"]))
        tops.append(np.nanpercentile(d["prediction_errors"], 99))
        plotted = True
    if len(d["kalman_errors"]) and np.isfinite(d["kalman_errors"]).any():
        ax2.plot(d["kalman"]["t"], d["kalman_errors"], color=C_KALMAN, lw=1.0,
                 label="Kalman pad estimate now: MAE %.2f m" % metrics["kalman_odom_error"]["mae_m"])
        tops.append(np.nanpercentile(d["kalman_errors"], 99))
        plotted = True
    if len(d["estimate_errors"]) and np.isfinite(d["estimate_errors"]).any():
        ax2.plot(d["estimate"]["t"], d["estimate_errors"], color=C_EST, lw=1.0,
                 label="drone's own position estimate: MAE %.2f m" % metrics["estimate_error"]["mae_m"])
        tops.append(np.nanpercentile(d["estimate_errors"], 99))
        plotted = True
    if not plotted:
        _no_data(ax2, "no vision, prediction or estimate in the bag (the landing stack did not run)")
    if tops:
        ax2.set_ylim(0, max(tops) * 1.15 + 0.05)
    _touchdown_line(ax2, metrics)
    ax2.set_ylabel("horizontal error [m]")
    ax2.set_xlabel("sim time [s]  (prediction errors are plotted at the time the prediction was made)")
    ax2.grid(True, alpha=0.3)
    if plotted:
        _outside_legend(ax2)
    _save(fig, path)


def all_plots(d, metrics, cols, out_dir):
    """Writes every plot; returns their file names."""
    names = []
    for name, draw in (("top_view.png", lambda p: top_view(d, metrics, p)),
                       ("altitude.png", lambda p: altitude(d, metrics, cols, p)),
                       ("errors.png", lambda p: errors(d, metrics, cols, p))):
        draw(os.path.join(out_dir, name))
        names.append(name)
    return names


def camera_gif(topic, items, out_dir, max_frames=120, width=240):
    """camera.gif from sensor_msgs/Image messages [(t, msg)] (already thinned); returns its name or None."""
    from PIL import Image
    frames = []
    step = max(1, int(np.ceil(len(items) / max_frames)))
    for _, m in items[::step]:
        array = _image_array(m)
        if array is None:
            continue
        image = Image.fromarray(array)
        if image.width > width:
            image = image.resize((width, int(image.height * width / image.width)))
        frames.append(image.convert("P", palette=Image.ADAPTIVE, colors=128))
    if not frames:
        return None
    name = "camera.gif"
    frames[0].save(os.path.join(out_dir, name), save_all=True, append_images=frames[1:],
                   duration=int(1000 * step / 2.0 / 2.0), loop=0)
    return name


def _image_array(m):
    data = np.frombuffer(bytes(m.data), dtype=np.uint8)
    h, w, enc = int(m.height), int(m.width), m.encoding.lower()
    try:
        if enc in ("rgb8", "bgr8"):
            a = data[:h * int(m.step)].reshape(h, int(m.step))[:, :w * 3].reshape(h, w, 3)
            return a[:, :, ::-1].copy() if enc == "bgr8" else a.copy()
        if enc in ("rgba8", "bgra8"):
            a = data[:h * int(m.step)].reshape(h, int(m.step))[:, :w * 4].reshape(h, w, 4)[:, :, :3]
            return a[:, :, ::-1].copy() if enc == "bgra8" else a.copy()
        if enc in ("mono8", "8uc1"):
            return data[:h * int(m.step)].reshape(h, int(m.step))[:, :w].copy()
    except ValueError:
        return None
    return None
