"""run_scenario: one scenario, headless, under its own ROS master; writes result.json and the bag.

The flight is scored with the simulator's ground truth (touchdown classification and the resting
distance from the pad); nothing here feeds ground truth back into the flying system.

A run always ends, within wall_limits(time limit)["total"], and always leaves a result.json (written
atomically): the outcome of every mission, or `aborted` with the reason when the graph fell apart (the
launch ended, the simulation clock stopped) or never came up. A bag whose recorder was killed is reindexed.

This module orchestrates a run: its plan, the graph's start and stop, the wall-time budget and the command line.
The rest is one module each: flight_monitor (watching and scoring the flight from inside the graph), recorders
(the flight recorder and its bags), events (what fires when) and result_file (result.json)."""
import argparse
import collections
import contextlib
import faulthandler
import json
import os
import signal
import sys
import time

from .events import EventSchedule, scenario_events
from .flight_monitor import FlightMonitor, GraphFailure
from .isolated_ros import IsolatedCore, IsolatedLaunch, IsolatedProcess
from .recorders import LONG_RUN_S, RECORDER_SPLIT_S, Recorders
from .result_file import finish

from . import processes
from . import scenario as scenario_mod
from . import warm_graph

START_UP_WALL_S = 240.0         # master, graph, recorder, connections and the first clock tick, at most [s]
SHUT_DOWN_WALL_S = 60.0         # stopping the recorder and the launch (20 s each before SIGKILL), reindexing [s]
FUZZER_STOP_S = 10.0            # how long the interrupted input fuzzer may take to write what it sent and exit [wall s]
INTERRUPTED = "interrupted"  # how the error of a run stopped from outside (Ctrl-C, SIGTERM) begins


def wall_limits(time_limit_s, flight_wall_s=None):
    """Wall-clock budget of a run [s]: its flight (``flight_wall_s``, default 4 x the sim time limit, at least
    300 s), start-up and shut-down; ``total`` bounds the whole run_scenario process."""
    flight = flight_wall_s or max(300.0, 4.0 * time_limit_s)
    return {"start_up": START_UP_WALL_S, "flight": flight, "shut_down": SHUT_DOWN_WALL_S,
            "total": START_UP_WALL_S + flight + SHUT_DOWN_WALL_S}


def launch_arguments(s):
    """roslaunch arguments of interface/scenario.launch for a validated scenario ``s``."""
    start = s["drone"]["start"]
    c = s["conditions"]
    args = {
        "vehicle": s["platform"]["vehicle"], "pad": s["pad"], "drone_model": s["drone"]["model"], "path": s["platform"]["path"], "speed": s["platform"]["speed_mps"],
        "radius": s["platform"]["radius_m"], "seed": s["seed"], "camera_rate": s["sensors"]["camera_fps"],
        "camera_noise": s["sensors"]["camera_noise"], "start_on_pad": str(start == "on_pad").lower(),
        "wind_speed": c["wind_speed"], "wind_direction_deg": c["wind_direction_deg"], "wind_gust": c["wind_gust"],
        "drone_battery": c["drone_battery"], "control_battery": c["control_battery"], "temp": c["temp"],
    }
    if start != "on_pad":
        args.update(start_x=start["x"], start_y=start["y"], start_z=start["z"])
    realism = s["realism"]
    args.update(realism=realism["profile"], realism_overrides=json.dumps(realism["overrides"], separators=(",", ":")),
                # The stack is told how its drone's firmware reports velocity (a calibration fact, not truth); a PX4
                # reports its EKF's velocity, which fuses GPS and follows no vehicle under it.
                flow_coupling=str(bool(realism["values"]["flow_surface_coupling"])
                                  and s["drone"]["model"] != "px4_quad").lower())
    if "drone_speed" in c:
        args["drone_speed"] = c["drone_speed"]
    return ["%s:=%s" % (k, v) for k, v in args.items()]


def plan(scenario_path, realism=None, landing_stack=True, supervisor=True, real_time=False):
    """The scenario of ``scenario_path`` as run() flies it, and the roslaunch arguments of its graph: (s, launch).
    ``real_time``: sim time paced at wall time and never held for a lagging node, as on a real drone (the compute
    budget is measured so). Raises scenario.ScenarioError."""
    s = scenario_mod.load(scenario_path, realism)
    s["_needs_tracker"] = landing_stack
    s["_supervisor"] = supervisor and landing_stack
    launch = ["interface", "scenario.launch", "landing_stack:=%s" % str(landing_stack).lower(),
              "supervisor:=%s" % str(s["_supervisor"]).lower()] + launch_arguments(s) + \
        (["station:=true"] if s["fuzz"] else []) + \
        (["real_time_factor:=1", "lockstep:=false"] if real_time else [])
    return s, launch


def run(scenario_path, out_dir, wall_timeout=None, landing_stack=True, supervisor=True, realism=None, split_s=None,
        warm=None, on_flown=None, launch_config=None, real_time=False, companions=()):
    """Run one scenario (in the realism profile ``realism`` if given, else the scenario's); returns the
    result dict (also written to out_dir/result.json, whatever happens after the scenario file was read).
    ``split_s``: a new bag every split_s seconds of sim time (0: one bag; None: RECORDER_SPLIT_S for a run
    whose time limit is over LONG_RUN_S). ``warm``: a warm_graph.WarmGraph: the scenario flies on its graph after
    a reset (the first one starts it), and the graph is left running; raises warm_graph.GraphMismatch, before
    anything is written, when the scenario needs other nodes than that graph runs. ``on_flown()``: called on a warm
    graph once the flight is scored and the graph free for the next scenario, while the recorder still stops.
    ``launch_config``: roslaunch's configuration of the scenario's graph (warm_graph.launch_config), if read ahead.
    ``real_time``: see plan(). ``companions``: {name: command} of processes that watch the flight (a probe), started
    in the graph once it is connected, interrupted when the flight ends (each logs to out_dir/NAME.log)."""
    wall_start = time.monotonic()
    s, launch = plan(scenario_path, realism, landing_stack, supervisor, real_time)
    config = warm.check_fits(launch_config or warm_graph.launch_config(launch)) if warm is not None else None
    os.makedirs(out_dir, exist_ok=True)
    events = scenario_events(s)
    limits = wall_limits(s["time_limit_s"], wall_timeout)
    result = {"name": s["name"], "seed": s["seed"], "scenario": os.path.abspath(scenario_path), "pad": s["pad"],
              "realism": {"profile": s["realism"]["profile"], "overrides": s["realism"]["overrides"],
                          "values": s["realism"]["values"]},
              "wall_limits_s": limits}
    phases = {"start_up": None, "flight": 0.0}
    steps = collections.OrderedDict()  # wall seconds from the start at which each step of start-up and shut-down ended

    def step(name):
        steps[name] = round(time.monotonic() - wall_start, 3)
    monitor, recorders, core, ros = None, None, None, None
    # Waits for this process to have left the graph, once the launch and the recorder have ended and before
    # the master stops (the stack unwinds in reverse order). (Not on a warm graph: this process stays in it.)
    leaving = []

    def left_graph():
        for finish_leaving in leaving:
            finish_leaving()
            step("left_graph")
    start_deadline = wall_start + limits["start_up"]

    def start_graph(stack, log_dir):
        # The master in a process tree of its own: one roslaunch started would end the whole graph with it.
        core = stack.enter_context(IsolatedCore(os.path.join(log_dir, "core.log")))
        if warm is None:
            stack.callback(left_graph)
        os.environ["ROS_MASTER_URI"] = core.master_uri
        # The launch starts beside the master and waits for it (roslaunch --wait).
        ros = stack.enter_context(IsolatedLaunch(launch, os.path.join(log_dir, "launch.log"), port=core.port))
        core.wait_for_master(timeout=max(1.0, start_deadline - time.monotonic()))
        return core, ros
    try:
        with contextlib.ExitStack() as stack:
            reused = warm is not None and warm.started  # (a warm graph flown before: reset for this scenario)
            if warm is None:
                core, ros = start_graph(stack, out_dir)
            elif reused:
                core, ros = warm.core, warm.ros
            else:
                core, ros = warm.start(config, start_graph)
            if split_s is None:
                split_s = RECORDER_SPLIT_S if s["time_limit_s"] > LONG_RUN_S else 0
            recorders = Recorders(out_dir, ros.master_uri, stack, split_s)
            # On a reused graph the monitor subscribes before the nodes are reset, forgetting what the previous
            # scenario latched: it hears what the reset nodes publish afresh, and nothing older.
            monitor = FlightMonitor(s, ros, recorders, core, reused)
            if warm is not None:
                stack.callback(monitor.close)  # (after the recorder has stopped: the stack unwinds in reverse)
            if reused:
                monitor.origin = warm.reset(config)
                step("reset")
            if warm is not None:
                result["graph"] = warm.describe()
            step("master")
            monitor.wait_for_graph(start_deadline)
            step("graph")
            if reused:
                monitor.wait_for_recorder_gone(start_deadline)
                step("previous_recorder_gone")

            monitor.wait_for_recorder(recorders.start(), start_deadline)
            step("recorder")
            monitor.wait_for_connections(start_deadline)
            step("connections")
            fuzzer = None
            if s["fuzz"]:
                from . import fuzz
                fuzzer = stack.enter_context(IsolatedProcess(fuzz.command(s["fuzz"], out_dir),
                                                             os.path.join(out_dir, "fuzz.log"), ros.master_uri))
                fuzz.wait_until_ready(out_dir, fuzzer, start_deadline)
            watchers = [stack.enter_context(IsolatedProcess(command, os.path.join(out_dir, name + ".log"),
                                                            ros.master_uri)) for name, command in companions.items()] \
                if companions else []
            # Before the physics runs: reading /proc for a dozen processes took long enough for the simulator to fly
            # 0.1-0.4 s of sim time before the scenario's events at t = 0 were applied.
            start = monitor.sample_resources("start", wall_start)
            # Where each process of the graph listens (docs/reliability.md, "Security": loopback unless asked otherwise).
            result["listening"] = processes.listening_of({name: info["pid"] for name, info in start["nodes"].items()})
            step("sampled")
            monitor.release(start_deadline)
            step("clock_runs")
            sim_start = monitor.clock()
            wall_flight_start = time.monotonic()
            phases["start_up"] = wall_flight_start - wall_start
            error, aborted = None, False
            try:
                monitor.run(EventSchedule(events), s["time_limit_s"], wall_flight_start + limits["flight"], wall_start)
            except TimeoutError as err:
                error = str(err)
            except GraphFailure as err:
                error, aborted = str(err), True
                monitor.missions.abandon("aborted")
            sim_time = monitor.clock()
            phases["flight"] = time.monotonic() - wall_flight_start
            if time.monotonic() - wall_start - monitor.resources.samples[-1]["wall_s"] > 5.0:
                monitor.sample_resources("end", wall_start)  # (a mission that just ended has its own sample)
            if warm is not None:
                monitor.hold()
            # The result needs neither the bag nor the graph any more: they stop side by side while it is
            # scored and this process leaves the graph.
            # (The master stops last, when the stack unwinds: nodes unregister from it as they stop.)
            for process in ([fuzzer] if fuzzer else []) + watchers + ([recorders.current] if recorders.current else []) + \
                    ([ros] if warm is None else []):
                process.interrupt()
            step("flight")
            result.update(monitor.scored(error, aborted, sim_start, sim_time, phases["flight"]))
            step("scored")
            if fuzzer is not None:
                # What it sent is final once it has ended: it writes it every 5 wall seconds and once more as it ends.
                # Read before that last write, a fresh machine's run lacked 12.7 of its 42 fuzzed sim seconds.
                fuzz.wait_until_ended(fuzzer, FUZZER_STOP_S)
                result["fuzz"] = fuzz.summary(out_dir, monitor.warnings, s["fuzz"])
            if warm is None:
                leaving.append(monitor.start_leaving_graph())
            else:
                if aborted or monitor.master_lost_at is not None:
                    # (the graph fell apart, or its master is gone: the next scenario needs another runner process)
                    warm.close("the scenario %s" % ("aborted" if aborted else "killed the master"))
                monitor.close()
                # (time.monotonic() of this process: what a warm sweep spends between two flights)
                result["graph"]["released_at_s"] = round(wall_flight_start, 3)
                if on_flown is not None:
                    on_flown()
    except Exception as err:  # noqa: BLE001 (whatever went wrong, the run leaves its result and the reason)
        # The graph never came up (or the run could not even start): still a result, with the reason.
        if warm is not None:
            warm.close()  # (in whatever state it is, it serves no other scenario)
        result.update(outcome="aborted", error="%s: %s" % (type(err).__name__, err), touchdown_error_m=None,
                      time_to_land_s=None, decisions=monitor.decisions if monitor else [])
    except KeyboardInterrupt as err:
        if warm is not None:
            warm.close()
        result.update(outcome="aborted", error="%s (%s)" % (INTERRUPTED, err or "Ctrl-C"), touchdown_error_m=None,
                      time_to_land_s=None, decisions=monitor.decisions if monitor else [])
        if monitor is not None and monitor.missions.records:  # the missions flown so far, for a soak's report
            result["missions"] = monitor.missions.records
        finish(result, out_dir, wall_start, phases, monitor, recorders, steps)
        raise
    for name, process in (("recorder", recorders and recorders.current), ("launch", ros), ("master", core)):
        if process is not None and process.exited_at is not None:
            steps[name + "_exited"] = round(process.exited_at - wall_start, 3)
    return finish(result, out_dir, wall_start, phases, monitor, recorders, steps)



def stop_on_sigterm():
    """SIGTERM (the benchmark's stop, or a dying Ray worker's death signal) unwinds like Ctrl-C, so the
    launch and the recorder, each in a session of its own, are stopped instead of left running."""
    def handler(signum, _frame):
        raise KeyboardInterrupt("signal %s" % signal.Signals(signum).name)
    signal.signal(signal.SIGTERM, handler)


def main(argv=None):
    parser = argparse.ArgumentParser(description="Run one landing scenario headless; write result.json and flight.bag.")
    parser.add_argument("scenario", help="scenario YAML file (SPEC section 7)")
    parser.add_argument("--out", required=True, help="output directory")
    parser.add_argument("--wall-timeout", type=float, default=None,
                        help="wall-clock limit of the flight [s] (default: 4 x its time limit, at least 300 s); "
                             "start-up and shut-down have %.0f s more" % (START_UP_WALL_S + SHUT_DOWN_WALL_S))
    parser.add_argument("--no-landing-stack", action="store_true", help="simulator and vehicle only")
    parser.add_argument("--no-supervisor", action="store_true", help="landing stack without the supervisor")
    parser.add_argument("--realism", choices=("ideal", "realistic", "harsh"), default=None,
                        help="realism profile of the simulated world (default: the scenario's, else realistic); "
                             "single keys the scenario overrides stay overridden")
    parser.add_argument("--real-time", action="store_true",
                        help="pace sim time at wall time and never hold it for a lagging node, as a real flight")
    args = parser.parse_args(argv)
    stop_on_sigterm()
    # `kill -USR1 PID` prints where every thread of a run that seems stuck is (to stderr, the run's log).
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    try:
        result = run(args.scenario, args.out, args.wall_timeout, landing_stack=not args.no_landing_stack,
                     supervisor=not args.no_supervisor, realism=args.realism, real_time=args.real_time)
    except scenario_mod.ScenarioError as err:
        print("run_scenario: %s" % err, file=sys.stderr)
        return 2
    summary = "%s (%s): %s" % (result["name"], result["realism"]["profile"], result["outcome"])
    if result.get("missions") is not None:
        summary += ", %d of %d missions on the pad" % (result["missions_on_pad"], len(result["missions"]))
    if result["touchdown_error_m"] is not None:
        summary += ", touchdown error %.3f m" % result["touchdown_error_m"]
    if result["time_to_land_s"] is not None and result.get("missions") is None:
        summary += ", landed after %.1f s" % result["time_to_land_s"]
    if result["sim_time_s"] is not None:
        summary += " (sim %.1f s in %.1f s wall, %.1fx)" % (result["sim_time_s"], result["wall_time_s"],
                                                           result["real_time_factor"] or 0.0)
    print(summary)
    if result.get("error"):
        print("run_scenario: %s (logs in %s)" % (result["error"], args.out), file=sys.stderr)
    print("result: %s" % os.path.join(args.out, "result.json"))
    return 3 if result["outcome"] == "aborted" else 0
