"""run_scenario: one scenario, headless, under its own ROS master; writes result.json and the bag.

The flight is scored with the simulator's ground truth (touchdown classification and the resting
distance from the pad); nothing here feeds ground truth back into the flying system."""
import argparse
import collections
import json
import os
import signal
import subprocess
import sys
import threading
import time

from .isolated_ros import IsolatedLaunch, IsolatedProcess, graph_unconnected, reconnect_subscribers

from . import scenario as scenario_mod
from . import scoring

SETTLE_AFTER_TOUCHDOWN_S = 1.0  # sim seconds the drone must rest before the outcome is read
EMERGENCY_REPORT_WAIT_S = 4.0   # sim seconds to wait for emergency/position after an emergency touchdown


def launch_arguments(s):
    """roslaunch arguments of interface/scenario.launch for a validated scenario ``s``."""
    start = s["drone"]["start"]
    c = s["conditions"]
    args = {
        "vehicle": s["platform"]["vehicle"], "path": s["platform"]["path"], "speed": s["platform"]["speed_mps"],
        "radius": s["platform"]["radius_m"], "seed": s["seed"], "camera_rate": s["sensors"]["camera_fps"],
        "camera_noise": s["sensors"]["camera_noise"], "start_on_pad": str(start == "on_pad").lower(),
        "wind_speed": c["wind_speed"], "wind_direction_deg": c["wind_direction_deg"], "wind_gust": c["wind_gust"],
        "drone_battery": c["drone_battery"], "control_battery": c["control_battery"], "temp": c["temp"],
    }
    if start != "on_pad":
        args.update(start_x=start["x"], start_y=start["y"], start_z=start["z"])
    realism = s["realism"]
    args.update(realism=realism["profile"], realism_overrides=json.dumps(realism["overrides"], separators=(",", ":")),
                # The stack is told how its drone's firmware reports velocity (a calibration fact, not truth).
                flow_coupling=str(realism["values"]["flow_surface_coupling"]).lower())
    if "drone_speed" in c:
        args["drone_speed"] = c["drone_speed"]
    return ["%s:=%s" % (k, v) for k, v in args.items()]


def recorder_command(bag):
    """rosbag record of the topics interface/record.launch records (its record_regex), started directly:
    through a second roslaunch it took 0.4 s longer to start and to stop."""
    import xml.etree.ElementTree as ElementTree
    import rospkg
    launch = os.path.join(rospkg.RosPack().get_path("interface"), "launch", "record.launch")
    regex = next(arg.get("default") for arg in ElementTree.parse(launch).getroot().iter("arg")
                 if arg.get("name") == "record_regex")
    return ["rosrun", "rosbag", "record", "--output-name=" + bag, "--lz4", "-e", regex, "__name:=flight_recorder"]


class EventSchedule:
    """Scenario events in sim-time order; ``due(t)`` pops those whose time has come."""

    def __init__(self, events):
        self.pending = list(events)

    def due(self, t):
        fired = []
        while self.pending and self.pending[0]["at_s"] <= t:
            fired.append(self.pending.pop(0))
        return fired


class FlightMonitor:
    """Watches a run from inside the graph and decides when it is over (ROS-bound part of the runner)."""

    def __init__(self, s, wall_timeout):
        import rosgraph
        import rospy
        from landing_msgs.msg import PositionXYCommand, Touchdown
        from std_msgs.msg import String
        self.rospy, self.s = rospy, s
        # rospy picks its clock at init_node: set /use_sim_time here rather than race roslaunch setting it,
        # or the runner may count wall time and end the flight at once.
        rosgraph.Master("/scenario_runner").setParam("/use_sim_time", True)
        rospy.init_node("scenario_runner", disable_signals=True)
        self.touchdown, self.touchdown_wall = None, None
        # Ground-truth poses by stamp: drone and pad are published in the same simulator step, and only
        # samples of one instant may be compared (the pad moves up to 25 m/s).
        self.drone_poses, self.pad_poses = collections.OrderedDict(), collections.OrderedDict()
        self.poses_lock = threading.Lock()  # the two subscriber threads write, resting_pad_error reads
        self.tracker_state, self.emergency_position = None, None
        self.decisions, self.emergency_ordered, self.landing_start = [], False, None
        rospy.Subscriber("ardrone/touchdown", Touchdown, self._on_touchdown)
        rospy.Subscriber("platform_tracking/state", String, lambda m: setattr(self, "tracker_state", m.data))
        rospy.Subscriber("emergency/position", PositionXYCommand,
                         lambda m: setattr(self, "emergency_position", [round(m.x, 3), round(m.y, 3)]))
        rospy.Subscriber("supervisor/decisions", String, self._on_decision)
        self.operator = rospy.Publisher("operator/command", String, queue_size=10, latch=True)
        self.tracker_command = rospy.Publisher("platform_tracking/command", String, queue_size=10, latch=True)
        self.fault = rospy.Publisher("mujoco_sim/fault", String, queue_size=10)
        self.wall_deadline = time.monotonic() + wall_timeout

    def _remember(self, poses, msg, keep=100):
        with self.poses_lock:
            poses[msg.header.stamp] = msg.pose.position
            while len(poses) > keep:
                poses.popitem(last=False)

    def _on_touchdown(self, msg):
        if self.touchdown is None:
            # Ground truth is only read once the drone is down: two 50 Hz streams fewer during the flight.
            from geometry_msgs.msg import PoseStamped
            self.rospy.Subscriber("groundtruth/ardrone", PoseStamped, lambda m: self._remember(self.drone_poses, m))
            self.rospy.Subscriber("groundtruth/landing_pad", PoseStamped, lambda m: self._remember(self.pad_poses, m))
        if self.touchdown is None or msg.header.stamp.to_sec() > self.touchdown.header.stamp.to_sec():
            self.touchdown = msg

    def _on_decision(self, msg):
        try:
            decision = json.loads(msg.data)
        except ValueError:
            return
        self.decisions.append(decision)
        if decision.get("action") == "emergency_landing":
            self.emergency_ordered = True

    def _needed_topics(self):
        """Topics the analysis of the bag cannot do without."""
        needed = ["/ardrone/navdata", "/ardrone/touchdown", "/groundtruth/ardrone", "/groundtruth/landing_pad",
                  "/summit_xl/gps/odom", "/tf"]
        return needed + (["/platform_tracking/state"] if self.s.get("_needs_tracker") else [])

    def _outputs_of_every_node(self):
        """One topic each node of the landing stack advertises when it starts: once all are advertised,
        every node is up and has subscribed to its inputs (the nodes subscribe as they advertise)."""
        stack = ["/ardrone/odom_estimate", "/kalman_prediction_path", "/platform/current_platform_position_in_world"]
        supervision = ["/supervisor/mode", "/emergency/state", "/cmd_vel_mux/selected"]
        return (stack if self.s.get("_needs_tracker") else []) + (supervision if self.s.get("_supervisor") else [])

    def _wait(self, condition, what, deadline):
        while not condition():
            if time.monotonic() > deadline:
                raise TimeoutError("%s within the time allowed (tracker state %r)" % (what, self.tracker_state))
            time.sleep(0.02)

    def wait_for_graph(self, timeout=120.0):
        """Until every needed topic is advertised and the landing stack (if any) reports its state."""
        import rosgraph
        master = rosgraph.Master("/scenario_runner")

        def ready():
            advertised = {topic for topic, _ in master.getSystemState()[0]}
            return all(t in advertised for t in self._needed_topics() + self._outputs_of_every_node()) and \
                (not self.s.get("_needs_tracker") or self.tracker_state is not None)
        self._wait(ready, "the graph did not come up", time.monotonic() + timeout)

    def wait_for_recorder(self, recorder, timeout=60.0):
        """Until rosbag record (the IsolatedProcess ``recorder``) subscribes to every needed topic. It
        discovers topics on start-up and then on a sim-time timer, which does not run while the physics is
        held: hence it is started after the graph is up (wait_for_graph)."""
        import rosgraph
        master = rosgraph.Master("/scenario_runner")

        def ready():
            if not recorder.alive():
                raise RuntimeError("rosbag record exited with code %s; see %s" % (
                    recorder.process.returncode, recorder.log_path))
            subscribers = {topic: nodes for topic, nodes in master.getSystemState()[1]}
            return all("/flight_recorder" in subscribers.get(t, []) for t in self._needed_topics())
        self._wait(ready, "the flight recorder did not subscribe", time.monotonic() + timeout)

    def wait_for_connections(self, timeout=120.0, retry_after=3.0):
        """Until every subscription in the graph is connected to its publishers. The simulator's
        lock-step only waits for nodes that have acknowledged once: a node whose inputs were still
        connecting at the start fell seconds behind (the supervisor then saw 'odometry missing' for 5 s
        and refused the take-off, 1 run in 100). A subscription still unconnected after ``retry_after``
        seconds gets its publishers again (reconnect_subscribers), every ``retry_after`` seconds."""
        import rosgraph
        master = rosgraph.Master("/scenario_runner")
        missing, since = [], {}

        def connected():
            missing[:] = graph_unconnected(master)
            now = time.monotonic()
            stuck = [m for m in missing if now - since.setdefault(m, now) > retry_after]
            if stuck:
                for topic, subscriber in reconnect_subscribers(master, stuck):
                    self.rospy.logwarn("%s had not connected to %s within %.0f s: sent its publishers again",
                                       subscriber, topic, retry_after)
                since.update((m, now) for m in stuck)
            return not missing
        try:
            self._wait(connected, "the graph did not connect", time.monotonic() + timeout)
        except TimeoutError as err:
            raise TimeoutError("%s; %d subscriptions never connected, e.g. %s" % (
                err, len(missing), ", ".join("%s from %s to %s" % m for m in missing[:3])))

    def release(self, timeout=120.0):
        """Start the simulator's physics and wait for the clock to run."""
        from std_msgs.msg import Empty
        deadline = time.monotonic() + timeout
        start = self.rospy.Publisher("mujoco_sim/start", Empty, queue_size=1, latch=True)
        start.publish(Empty())
        while self.rospy.get_time() <= 0.0:
            if time.monotonic() > deadline:
                raise TimeoutError("the simulator did not start within %.0f s" % timeout)
            time.sleep(0.02)

    def apply(self, event):
        from std_msgs.msg import String
        rospy = self.rospy
        rospy.loginfo("scenario event at t=%.2f: %s", rospy.get_time(), event)
        if "operator" in event:
            action = event["operator"]
            self.operator.publish(String(data=action))
            if action in ("landing", "takeoff"):
                self.landing_start = self.landing_start or rospy.get_time()
                if not self.s.get("_supervisor"):
                    # Without the supervisor in the graph, the landing mode is the tracker's own take-off.
                    self.tracker_command.publish(String(data="takeoff"))
            if action == "emergency":
                self.emergency_ordered = True
        elif "set_param" in event:
            rospy.set_param("/" + event["set_param"], event["value"])
        elif event["fault"] == "kill_node":
            name = event["name"] if event["name"].startswith("/") else "/" + event["name"]
            result = subprocess.run(["rosnode", "kill", name], capture_output=True, text=True, timeout=30)
            rospy.loginfo("killed %s: %s", name, (result.stdout + result.stderr).strip())
        else:
            self.fault.publish(String(data=json.dumps({"fault": event["fault"], "duration_s": event["duration_s"]})))

    def run(self, schedule, time_limit):
        rospy = self.rospy
        while True:
            t = rospy.get_time()
            for event in schedule.due(t):
                self.apply(event)
            if self.touchdown is not None:
                touchdown_time = self.touchdown.header.stamp.to_sec()
                # After an emergency landing, wait for the coordinates the emergency module reports.
                settle = EMERGENCY_REPORT_WAIT_S if self.emergency_ordered and self.emergency_position is None \
                    else SETTLE_AFTER_TOUCHDOWN_S
                if self.touchdown.crashed or self._latest_common_pose_time() >= touchdown_time + settle:
                    return
            if t >= time_limit:
                return
            if time.monotonic() > self.wall_deadline:
                raise TimeoutError("wall-clock limit reached at sim time %.1f s" % t)
            time.sleep(0.02)

    def _latest_common_stamp(self):
        with self.poses_lock:
            common = [stamp for stamp in self.drone_poses if stamp in self.pad_poses]
        return common[-1] if common else None

    def _latest_common_pose_time(self):
        stamp = self._latest_common_stamp()
        return float("-inf") if stamp is None else stamp.to_sec()

    def scored(self, error, sim_start, sim_time, flight_wall):
        """The result.json fields of the flight (SPEC section 7) from what was seen; ``error``: why the run
        was cut short, or None."""
        touchdown, resting_error = self.touchdown, self.resting_pad_error()
        outcome, touchdown_error = scoring.outcome(touchdown, resting_error, self.emergency_ordered)
        touchdown_time = touchdown.header.stamp.to_sec() if touchdown else None
        return {
            "outcome": outcome if error is None else "timeout",
            "touchdown_error_m": touchdown_error,
            "time_to_land_s": round(touchdown_time - (self.landing_start or sim_start), 3)
            if touchdown_time is not None and not touchdown.crashed else None,
            "decisions": self.decisions,
            "emergency_position": self.emergency_position,
            "sim_time_s": round(sim_time, 3),
            "real_time_factor": round((sim_time - sim_start) / flight_wall, 3) if flight_wall > 0 else None,
            "touchdown": None if touchdown is None else {
                "surface": {1: "pad", 2: "ground", 3: "vehicle"}.get(touchdown.surface, "unknown"),
                "crashed": touchdown.crashed, "impact_speed_mps": round(touchdown.impact_speed, 3),
                "pad_error_m": round(touchdown.pad_error, 4),
                "resting_pad_error_m": None if resting_error is None else round(resting_error, 4),
                "position": [round(touchdown.position.x, 3), round(touchdown.position.y, 3),
                             round(touchdown.position.z, 3)]},
            "tracker_final_state": self.tracker_state,
            "error": error,
        }

    def resting_pad_error(self):
        """Horizontal drone-to-pad distance at the latest instant both poses are known for."""
        stamp = self._latest_common_stamp()
        if stamp is None:
            return None
        with self.poses_lock:
            drone, pad = self.drone_poses[stamp], self.pad_poses[stamp]
        return ((drone.x - pad.x) ** 2 + (drone.y - pad.y) ** 2) ** 0.5


def run(scenario_path, out_dir, wall_timeout=None, landing_stack=True, supervisor=True, realism=None):
    """Run one scenario (in the realism profile ``realism`` if given, else the scenario's); returns the
    result dict (also written to out_dir/result.json)."""
    s = scenario_mod.load(scenario_path, realism)
    s["_needs_tracker"] = landing_stack
    s["_supervisor"] = supervisor and landing_stack
    os.makedirs(out_dir, exist_ok=True)
    bag = os.path.abspath(os.path.join(out_dir, "flight.bag"))
    # Without an operator event the operator chooses the landing mode at once, unless the scenario tests
    # what happens when nobody chooses (supervisor: {no_operator: true}).
    no_operator = bool(s["supervisor"].get("no_operator"))
    events = s["events"] if no_operator or any("operator" in e for e in s["events"]) else \
        [{"at_s": 0.0, "operator": "landing"}] + s["events"]
    launch = ["interface", "scenario.launch", "landing_stack:=%s" % str(landing_stack).lower(),
              "supervisor:=%s" % str(s["_supervisor"]).lower()] + launch_arguments(s)
    wall_start = time.monotonic()
    wall_timeout = wall_timeout or max(300.0, 4.0 * s["time_limit_s"])
    result = {"name": s["name"], "seed": s["seed"], "scenario": os.path.abspath(scenario_path),
              "realism": {"profile": s["realism"]["profile"], "overrides": s["realism"]["overrides"],
                          "values": s["realism"]["values"]}}
    with IsolatedLaunch(launch, os.path.join(out_dir, "launch.log")) as ros:
        os.environ["ROS_MASTER_URI"] = ros.master_uri
        ros.wait_for_master()
        monitor = FlightMonitor(s, wall_timeout)
        monitor.wait_for_graph()
        recorder = IsolatedProcess(recorder_command(bag), os.path.join(out_dir, "recorder.log"), ros.master_uri)
        with recorder:
            monitor.wait_for_recorder(recorder)
            monitor.wait_for_connections()
            monitor.release()
            sim_start = monitor.rospy.get_time()
            wall_flight_start = time.monotonic()
            startup_wall = wall_flight_start - wall_start
            try:
                monitor.run(EventSchedule(events), s["time_limit_s"])
                error = None
            except TimeoutError as err:
                error = str(err)
            sim_time = monitor.rospy.get_time()
            flight_wall = time.monotonic() - wall_flight_start
            # The result needs neither the bag nor the graph any more: they stop side by side while it is
            # scored and this process leaves the graph.
            recorder.interrupt()
            ros.interrupt()
            result.update(monitor.scored(error, sim_start, sim_time, flight_wall))
            monitor.rospy.signal_shutdown("scenario finished")
    result["wall_time_s"] = round(time.monotonic() - wall_start, 2)
    # Where the wall time went: starting the master, graph and recorder; the flight; stopping them.
    result["wall_phases_s"] = {"start_up": round(startup_wall, 2), "flight": round(flight_wall, 2),
                               "shut_down": round(result["wall_time_s"] - startup_wall - flight_wall, 2)}
    result["bag"] = bag if os.path.isfile(bag) else None
    with open(os.path.join(out_dir, "result.json"), "w") as stream:
        json.dump(result, stream, indent=2)
    return result


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
    parser.add_argument("--wall-timeout", type=float, default=None, help="wall-clock limit [s]")
    parser.add_argument("--no-landing-stack", action="store_true", help="simulator and vehicle only")
    parser.add_argument("--no-supervisor", action="store_true", help="landing stack without the supervisor")
    parser.add_argument("--realism", choices=("ideal", "realistic", "harsh"), default=None,
                        help="realism profile of the simulated world (default: the scenario's, else realistic); "
                             "single keys the scenario overrides stay overridden")
    args = parser.parse_args(argv)
    stop_on_sigterm()
    try:
        result = run(args.scenario, args.out, args.wall_timeout, landing_stack=not args.no_landing_stack,
                     supervisor=not args.no_supervisor, realism=args.realism)
    except scenario_mod.ScenarioError as err:
        print("run_scenario: %s" % err, file=sys.stderr)
        return 2
    except (RuntimeError, TimeoutError) as err:
        print("run_scenario: %s (logs in %s)" % (err, args.out), file=sys.stderr)
        return 3
    summary = "%s (%s): %s" % (result["name"], result["realism"]["profile"], result["outcome"])
    if result["touchdown_error_m"] is not None:
        summary += ", touchdown error %.3f m" % result["touchdown_error_m"]
    if result["time_to_land_s"] is not None:
        summary += ", landed after %.1f s" % result["time_to_land_s"]
    summary += " (sim %.1f s in %.1f s wall, %.1fx)" % (result["sim_time_s"], result["wall_time_s"],
                                                       result["real_time_factor"] or 0.0)
    print(summary)
    print("result: %s" % os.path.join(args.out, "result.json"))
    return 0
