"""Closed-loop landing in the real physics WITHOUT vision: mujoco_sim's ROS-free Simulator, this
package's estimator fed from the simulator's sensor functions, and the state machine flying the drone.

The one thing that is not real is the pad prediction: ``PipelineStandIn`` replaces the camera,
uav_vision and ped_traj_pred. It reads the simulator's ground-truth pad (a test fixture, never an
input of the estimator or the controller directly), adds noise and latency and builds a
constant-velocity predicted path, as the Kalman predictor publishes it.

Run as a script to write the figures and the table of touchdown errors:
    python closed_loop_landing.py --out DIR
"""
import argparse
import collections
import json
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SRC = os.path.join(HERE, "..", "..")
for _path in (os.path.join(HERE, "..", "src"), os.path.join(SRC, "drone_estimator", "src"), os.path.join(SRC, "mujoco_sim", "src"),
              os.path.join(SRC, "summit_moves", "src")):
    if _path not in sys.path:
        sys.path.append(_path)

from drone_estimator.estimator import DroneEstimator  # noqa: E402
from drone_estimator.params import EstimatorParams  # noqa: E402
from platform_tracking.controller import DroneState, PadPrediction  # noqa: E402
from platform_tracking.params import TrackingParams  # noqa: E402
from platform_tracking.state_machine import Inputs, Nav, State, TrackingStateMachine  # noqa: E402

SIM_PKG = os.path.join(SRC, "mujoco_sim")
PAD_HEIGHT = {"summit_xl": 0.497, "car": 1.72}


def _sim_modules():
    from mujoco_sim.autopilot import FlightMode
    from mujoco_sim.schema import load_sim_config
    from mujoco_sim.simulator import Simulator
    return FlightMode, load_sim_config, Simulator


class Schedule:
    """Fires every ``1 / rate_hz`` seconds of sim time (as the simulator node's publishers)."""

    def __init__(self, rate_hz, start=0.0):
        self.period, self.next = 1.0 / rate_hz, start

    def due(self, t):
        if t + 1e-9 >= self.next:
            self.next = max(self.next + self.period, t)
            return True
        return False


class PipelineStandIn:
    """STAND-IN for the vision + Kalman pipeline (uav_vision -> ped_traj_pred); it is not vision.

    At ``rate_hz`` it samples the pad centre, adds ``noise`` [m] per axis (and ``velocity_noise``
    [m/s] to the velocity), and delivers a prediction ``latency`` seconds later, stamped with the
    sampling time, with a constant-velocity path every ``time_step`` up to ``path_time`` ahead.

    ``anchor`` says where the pad's world position comes from: "truth" = the true pad position plus
    noise; "estimate" = the drone's own estimated position plus the true drone->pad vector, which is
    how uav_vision builds platform/current_platform_position_in_world (docs/conventions.md), so the
    estimator's absolute error cancels as it does in the real pipeline. ``blackouts`` are (start,
    end) sim-time windows with no detection, to exercise the lost-target path.
    """

    def __init__(self, seed, anchor="estimate", noise=0.03, velocity_noise=0.05, latency=0.05, rate_hz=30.0,
                 path_time=2.0, time_step=0.1, blackouts=()):
        if anchor not in ("truth", "estimate"):
            raise ValueError("anchor must be 'truth' or 'estimate'")
        self.rng = np.random.default_rng(seed + 1000)
        self.anchor, self.noise, self.velocity_noise, self.latency = anchor, noise, velocity_noise, latency
        self.path_time, self.time_step, self.blackouts = path_time, time_step, list(blackouts)
        self.schedule = Schedule(rate_hz)
        self.in_flight = collections.deque()
        self.latest = None

    def step(self, t, true_pad, true_pad_velocity, true_drone, estimated_drone):
        if self.schedule.due(t) and not any(a <= t < b for a, b in self.blackouts):
            if self.anchor == "truth" or estimated_drone is None:
                seen = np.array(true_pad, dtype=float)
            else:
                seen = np.asarray(estimated_drone, dtype=float) + (np.asarray(true_pad) - np.asarray(true_drone))
            seen = seen + self.rng.normal(0.0, self.noise, 3)
            velocity = np.array(true_pad_velocity, dtype=float) + self.rng.normal(0.0, self.velocity_noise, 3)
            velocity[2] = 0.0
            times = [t + k * self.time_step for k in range(int(round(self.path_time / self.time_step)) + 1)]
            path = [seen + velocity * (tk - t) for tk in times]
            self.in_flight.append((t + self.latency, PadPrediction(t, seen, velocity, times, path)))
        while self.in_flight and self.in_flight[0][0] <= t + 1e-9:
            self.latest = self.in_flight.popleft()[1]
        return self.latest


def navdata_state(sim, FlightMode):
    mode = sim.autopilot.mode
    return {FlightMode.LANDED: Nav.LANDED, FlightMode.TAKING_OFF: Nav.TAKING_OFF, FlightMode.FLYING: Nav.FLYING,
            FlightMode.LANDING: Nav.LANDING, FlightMode.CRASHED: Nav.CRASHED}[mode]


def run_landing(vehicle="summit_xl", path="straight", speed=1.0, radius=10.0, seed=0, anchor="estimate",
                params=None, estimator_params=None, time_limit=120.0, takeoff_at=1.0, record=True,
                blackouts=(), operator_land_at=None, sim_overrides=None):
    """Fly one take-off, tracking and landing; returns a dict with the touchdown and the records."""
    FlightMode, load_sim_config, Simulator = _sim_modules()
    from summit_moves.paths import Path
    # The ideal realism profile: the stand-in pipeline knows nothing of late frames, lens or the flow over the
    # vehicle; the realistic world is flown by the whole graph (scenario tests).
    overrides = dict(sim_overrides or {})
    overrides.setdefault("realism", {"profile": "ideal"})
    config = load_sim_config(os.path.join(SIM_PKG, "config", "sim.yaml"), overrides)
    model = os.path.join(SIM_PKG, "models", "world_%s.xml" % vehicle)
    sim = Simulator(config, model, vehicle, seed)
    vehicle_path = Path(path, speed, radius, seed)
    estimator = DroneEstimator(estimator_params or EstimatorParams())
    log = []
    machine = TrackingStateMachine(params or TrackingParams(), logger=lambda line: log.append((sim.time, line)))
    pipeline = PipelineStandIn(seed, anchor=anchor, blackouts=blackouts)
    schedules = {name: Schedule(rate) for name, rate in (("imu", 100), ("navdata", 50), ("gps", 5),
                                                         ("altimeter", 20), ("sonar", 25), ("tracker", 30),
                                                         ("vehicle", 20), ("record", 20))}
    sonar = math.inf
    requested_takeoff = False
    land_requested = False
    records = collections.defaultdict(list)
    previous_pad = sim.pad_position()
    dt = sim.model.opt.timestep
    while sim.time < time_limit:
        t = sim.time
        if schedules["vehicle"].due(t):
            sim.set_vehicle_command(*vehicle_path.command(t))
        # Sensors, at their rates, into the estimator (no ground truth here).
        if schedules["navdata"].due(t):
            estimator.flow(t, *sim.flow_velocity())
        if schedules["gps"].due(t):
            position, velocity = sim.gps()
            estimator.gps(t, position, velocity)
        if schedules["altimeter"].due(t):
            estimator.altimeter(t, sim.altimeter()[0])
        if schedules["sonar"].due(t):
            sonar = sim.sonar()
            estimator.sonar(t, sonar)
        if schedules["imu"].due(t):
            estimator.imu(t, sim.imu()[0])
        estimate = estimator.estimate(t)
        # The stand-in pipeline (ground truth in, noisy delayed prediction out).
        true_pad = sim.pad_position()
        true_pad_velocity = (true_pad - previous_pad) / dt
        previous_pad = true_pad
        true_drone = sim.drone_pose()[0]
        prediction = pipeline.step(t, true_pad, true_pad_velocity, true_drone,
                                   None if estimate is None else estimate.position)
        if schedules["tracker"].due(t):
            drone = None if estimate is None else DroneState(estimate.position, estimate.velocity, estimate.yaw,
                                                             sonar if math.isfinite(sonar) else None)
            takeoff = not requested_takeoff and t >= takeoff_at
            requested_takeoff = requested_takeoff or takeoff
            land = operator_land_at is not None and not land_requested and t >= operator_land_at
            land_requested = land_requested or land
            vision_age = None if prediction is None else t - prediction.stamp  # the stand-in samples = detections
            out = machine.step(Inputs(t, drone, prediction, navdata_state(sim, FlightMode), takeoff=takeoff, land=land,
                                      vision_age=vision_age))
            if out.send_takeoff:
                sim.takeoff()
            if out.send_land:
                sim.land()
            if out.command is not None:
                c = out.command
                sim.set_velocity_command(c.vx, c.vy, c.vz, c.yaw_rate)
        if record and schedules["record"].due(t):
            records["t"].append(t)
            records["drone"].append(true_drone.copy())
            records["pad"].append(true_pad.copy())
            records["estimate"].append(np.full(3, np.nan) if estimate is None else estimate.position.copy())
            records["state"].append(machine.state.value)
        sim.step()
        if sim.touchdown is not None and machine.state == State.LANDED:
            break
    touchdown = sim.touchdown
    result = {
        "vehicle": vehicle, "path": path, "speed": speed, "radius": radius, "seed": seed, "anchor": anchor,
        "landed": touchdown is not None, "surface": None if touchdown is None else touchdown.surface,
        "crashed": None if touchdown is None else touchdown.crashed,
        "pad_error": None if touchdown is None else touchdown.pad_error,
        "impact_speed": None if touchdown is None else touchdown.impact_speed,
        "touchdown_time": None if touchdown is None else touchdown.time,
        "final_state": machine.state.value, "retries": machine.retries, "log": log,
        "records": {k: np.array(v) for k, v in records.items()},
    }
    return result


def describe(result):
    if not result["landed"]:
        return "%s %s %.1f m/s: no touchdown (state %s)" % (result["vehicle"], result["path"], result["speed"],
                                                            result["final_state"])
    surface = {1: "pad", 2: "ground", 3: "vehicle"}[result["surface"]]
    return "%s %s %.1f m/s: %s on the %s, error %.3f m, impact %.2f m/s at t=%.1f s, %d re-tries" % (
        result["vehicle"], result["path"], result["speed"], "CRASH" if result["crashed"] else "touchdown", surface,
        result["pad_error"], result["impact_speed"], result["touchdown_time"], result["retries"])


CASES = [("summit_xl", "straight", s) for s in (0.5, 1.0, 2.0, 3.0)] + [("summit_xl", "circle", 2.0)] + \
        [("car", "straight", s) for s in (5.0, 10.0, 15.0)]


def plot(result, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    r = result["records"]
    t, drone, pad, est = r["t"], r["drone"], r["pad"], r["estimate"]
    fig, axes = plt.subplots(3, 1, figsize=(8, 9), sharex=True)
    error = np.hypot(*(drone[:, :2] - pad[:, :2]).T)
    axes[0].plot(t, error, label="true drone - pad (horizontal)")
    axes[0].plot(t, np.hypot(*(est[:, :2] - drone[:, :2]).T), label="estimator error (horizontal)", alpha=0.7)
    axes[0].set_ylabel("m")
    axes[0].set_yscale("log")
    axes[0].set_ylim(1e-3, 2.0)
    axes[0].legend(loc="upper right")
    axes[1].plot(t, drone[:, 2] - pad[:, 2], label="drone base_link above pad top (truth)")
    axes[1].plot(t, est[:, 2] - pad[:, 2], label="estimated", alpha=0.7)
    axes[1].set_ylabel("m")
    axes[1].legend(loc="upper right")
    states = [s.value for s in State]
    axes[2].plot(t, [states.index(s) for s in r["state"]], drawstyle="steps-post")
    axes[2].set_yticks(range(len(states)))
    axes[2].set_yticklabels(states)
    axes[2].set_xlabel("sim time [s]")
    fig.suptitle(describe(result), fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", required=True, help="directory for figures and results.json")
    parser.add_argument("--seeds", type=int, default=3, help="seeds per case")
    parser.add_argument("--anchor", default="estimate", choices=("estimate", "truth"))
    parser.add_argument("--no-figures", action="store_true")
    args = parser.parse_args(argv)
    os.makedirs(args.out, exist_ok=True)
    table = []
    for vehicle, path, speed in CASES:
        errors = []
        for seed in range(args.seeds):
            result = run_landing(vehicle, path, speed, seed=seed, anchor=args.anchor)
            print(describe(result), flush=True)
            errors.append(result["pad_error"] if result["landed"] and result["surface"] == 1 else None)
            if seed == 0 and not args.no_figures:
                plot(result, os.path.join(args.out, "%s_%s_%g.png" % (vehicle, path, speed)))
        table.append({"vehicle": vehicle, "path": path, "speed": speed, "pad_errors": errors})
    with open(os.path.join(args.out, "results_%s.json" % args.anchor), "w") as stream:
        json.dump(table, stream, indent=1)
    with open(os.path.join(args.out, "results_%s.md" % args.anchor), "w") as stream:
        stream.write("Touchdown error [m] per seed (0..%d), pad prediction anchored on the %s; '-' = not on the pad.\n\n"
                     % (args.seeds - 1, "drone's own estimate (as uav_vision does)" if args.anchor == "estimate"
                        else "true pad position"))
        stream.write("| vehicle | path | speed [m/s] | touchdown errors [m] | max [m] |\n|---|---|---|---|---|\n")
        for row in table:
            landed = [e for e in row["pad_errors"] if e is not None]
            stream.write("| %s | %s | %g | %s | %s |\n" % (
                row["vehicle"], row["path"], row["speed"],
                ", ".join("-" if e is None else "%.3f" % e for e in row["pad_errors"]),
                "%.3f" % max(landed) if len(landed) == len(row["pad_errors"]) else "-"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
