"""run_scenario: one scenario, headless, under its own ROS master; writes result.json and the bag.

The flight is scored with the simulator's ground truth (touchdown classification and the resting
distance from the pad); nothing here feeds ground truth back into the flying system.

A run always ends, within wall_limits(time limit)["total"], and always leaves a result.json (written
atomically): the outcome of every mission, or `aborted` with the reason when the graph fell apart (the
launch ended, the simulation clock stopped) or never came up. A bag whose recorder was killed is reindexed."""
import argparse
import collections
import contextlib
import faulthandler
import glob
import json
import os
import signal
import subprocess
import sys
import threading
import time

from flight_analysis import scoring
from landing_runtime.rospy_node import NodeHandles

from .isolated_ros import IsolatedCore, IsolatedLaunch, IsolatedProcess, graph_unconnected, reconnect_subscribers

from . import faults
from . import missions as missions_mod
from . import processes
from . import scenario as scenario_mod
from . import warm_graph

SETTLE_AFTER_TOUCHDOWN_S = 1.0  # sim seconds the drone must rest before the outcome is read
EMERGENCY_REPORT_WAIT_S = 4.0   # sim seconds to wait for emergency/position after an emergency touchdown
START_UP_WALL_S = 240.0         # master, graph, recorder, connections and the first clock tick, at most [s]
SHUT_DOWN_WALL_S = 60.0         # stopping the recorder and the launch (20 s each before SIGKILL), reindexing [s]
FUZZER_STOP_S = 10.0            # how long the interrupted input fuzzer may take to write what it sent and exit [wall s]
# How often start-up asks the master (and, for the connections, every node) whether the graph is ready [s]: each
# question costs the processes coming up CPU on a machine the start-up already fills. 4 interleaved runs each:
# start-up 2.93-3.27 s polling every 0.02 s, 2.42-2.73 s every 0.1 s (0.05 s and 0.2 s: 2.66-2.97 s).
GRAPH_POLL_S = 0.1
WARM_GRAPH_POLL_S = 0.02  # the same on a warm graph, whose nodes are up and idle: nothing to slow down [s]
CLOCK_STALL_WALL_S = 30.0       # the sim clock standing still this long after the start: the simulator is gone [s]
MODE_WAIT_S = 30.0              # sim seconds a next mission waits for the supervisor to be back on the ground
# Sim seconds between setting a mission's conditions (a fresh battery) and choosing the landing mode: the master
# pushes the new parameters to the nodes while the operator's command travels on a topic, and the supervisor
# refused a take-off on the battery just swapped out (36.5 % < 40 %) when the command came first.
CONDITIONS_SETTLE_S = 1.0
RECORDER = "flight_recorder"
CALLBACK_EXCEPTION = "bad callback"  # how rospy logs an exception it caught in a subscriber's callback
INTERRUPTED = "interrupted"  # how the error of a run stopped from outside (Ctrl-C, SIGTERM) begins
# A run whose time limit is over LONG_RUN_S records a bag per RECORDER_SPLIT_S of sim time: rosbag record holds
# its whole bag's index in memory (about 1 MB a minute of flight) and frees it only when it starts the next bag [s].
LONG_RUN_S = 600.0
RECORDER_SPLIT_S = 120


def wall_limits(time_limit_s, flight_wall_s=None):
    """Wall-clock budget of a run [s]: its flight (``flight_wall_s``, default 4 x the sim time limit, at least
    300 s), start-up and shut-down; ``total`` bounds the whole run_scenario process."""
    flight = flight_wall_s or max(300.0, 4.0 * time_limit_s)
    return {"start_up": START_UP_WALL_S, "flight": flight, "shut_down": SHUT_DOWN_WALL_S,
            "total": START_UP_WALL_S + flight + SHUT_DOWN_WALL_S}


class GraphFailure(RuntimeError):
    """The graph fell apart during the flight (the launch ended, the clock stopped): the run is aborted."""


def launch_arguments(s):
    """roslaunch arguments of interface/scenario.launch for a validated scenario ``s``."""
    start = s["drone"]["start"]
    c = s["conditions"]
    args = {
        "vehicle": s["platform"]["vehicle"], "drone_model": s["drone"]["model"], "path": s["platform"]["path"], "speed": s["platform"]["speed_mps"],
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


def recorder_command(bag, split_s=0):
    """(command, environment) of the flight recorder (flight_recorder's record: rosbag record's options, half its CPU
    per message) of the topics interface/record.launch records (its record_regex, in its chunk_kb chunks, with its
    allocator and settings), started directly: through a second roslaunch it took 0.4 s longer to start and to stop,
    through rosrun (a shell script that runs catkin_find) 0.2 s longer to start. With ``split_s`` > 0 a new bag every
    split_s seconds of sim time (NAME_0.bag, NAME_1.bag, ...; see split_bags)."""
    import xml.etree.ElementTree as ElementTree
    import roslib.packages
    import rospkg
    launch = os.path.join(rospkg.RosPack().get_path("interface"), "launch", "record.launch")
    defaults = {arg.get("name"): arg.get("default") for arg in ElementTree.parse(launch).getroot().iter("arg")}
    split = ["--split", "--duration=%d" % split_s] if split_s > 0 else []
    record = roslib.packages.find_node("flight_recorder", "record")
    if not record:
        raise FileNotFoundError("flight_recorder's record executable was not found (build the workspace: make build)")
    return [record[0], "--output-name=" + bag] + split + [
        "--lz4", "--chunksize=" + defaults["chunk_kb"], "-e", defaults["record_regex"], "__name:=" + RECORDER], {
        "LD_PRELOAD": defaults["allocator"], "MALLOC_CONF": defaults["allocator_conf"],
        "GLIBC_TUNABLES": defaults["malloc_tunables"]}


def split_bags(bag):
    """The bags rosbag record --split wrote for ``--output-name=bag``, in order (NAME_0.bag, NAME_1.bag, ...;
    the last one still NAME_N.bag.active if its recorder was killed), as the names they have once repaired."""
    stem = bag[:-len(".bag")]
    found = {}
    for path in glob.glob(glob.escape(stem) + "_*.bag") + glob.glob(glob.escape(stem) + "_*.bag.active"):
        number = path[len(stem) + 1:].split(".bag", 1)[0]
        if number.isdigit():
            found[int(number)] = "%s_%s.bag" % (stem, number)
    return [found[k] for k in sorted(found)]


def only_from(node, callback):
    """A subscriber callback that hears only ``node`` (by the connection's caller id)."""
    def heard(msg):
        if (getattr(msg, "_connection_header", None) or {}).get("callerid") == node:
            callback(msg)
    return heard


class EventSchedule:
    """Scenario events in sim-time order; ``due(t)`` pops those whose time has come."""

    def __init__(self, events):
        self.pending = list(events)

    def due(self, t):
        fired = []
        while self.pending and self.pending[0]["at_s"] <= t:
            fired.append(self.pending.pop(0))
        return fired


class Recorders:
    """The flight recorder (rosbag record) and, after it died, its successors (flight.2.bag, ...)."""

    def __init__(self, out_dir, master_uri, stack, split_s=0):
        self.out_dir, self.master_uri, self.stack, self.split_s = out_dir, master_uri, stack, split_s
        self.bags, self.current = [], None

    def start(self):
        index = len(self.bags) + 1
        bag = os.path.abspath(os.path.join(self.out_dir, "flight.bag" if index == 1 else "flight.%d.bag" % index))
        log = os.path.join(self.out_dir, "recorder.log" if index == 1 else "recorder.%d.log" % index)
        command, env = recorder_command(bag, self.split_s)
        self.current = self.stack.enter_context(IsolatedProcess(command, log, self.master_uri, env))
        self.bags.append(bag)
        return self.current

    def written(self):
        """Every bag written so far, in order (each recorder's splits in turn)."""
        return [part for bag in self.bags for part in (split_bags(bag) if self.split_s > 0 else [bag])]

    def pids(self):
        return [self.current.process.pid] if self.current is not None and self.current.process else []


class FlightMonitor:
    """Watches a run from inside the graph and decides when it is over (ROS-bound part of the runner)."""

    def __init__(self, s, ros, recorders, core, reused=False):
        import rosgraph
        import rospy
        from geometry_msgs.msg import PoseStamped
        from landing_msgs.msg import PositionXYCommand, Touchdown
        from std_msgs.msg import String
        self.rospy, self.s, self.ros, self.recorders, self.core = rospy, s, ros, recorders, core
        # ``reused``: the graph flew a scenario before and is about to be reset for this one.
        self.poll_s = WARM_GRAPH_POLL_S if reused else GRAPH_POLL_S
        if not rospy.core.is_initialized():  # (a warm graph's next scenario: this process is in the graph already)
            # rospy picks its clock at init_node: set /use_sim_time here rather than race roslaunch setting it,
            # or the runner may count wall time and end the flight at once.
            rosgraph.Master("/scenario_runner").setParam("/use_sim_time", True)
            rospy.init_node("scenario_runner", disable_signals=True)
        # The world's time 0 in ROS time [s]: 0 on a fresh graph; on a reused one the ROS time of its reset (set by
        # the runner once it is known; until then the present, before which nothing belongs to this scenario).
        # Every time this monitor reports or compares is world time (clock(), world_time()).
        self.origin = rospy.get_time() if reused else 0.0
        self.handles, self.closed = NodeHandles(), False
        self.touchdown, self.touchdown_wall = None, None
        # Ground-truth poses by stamp: drone and pad are published in the same simulator step, and only
        # samples of one instant may be compared (the pad moves up to 25 m/s).
        self.drone_poses, self.pad_poses = collections.OrderedDict(), collections.OrderedDict()
        self.poses_lock = threading.Lock()  # the two subscriber threads write, resting_pad_error reads
        self.tracker_state, self.emergency_position, self.supervisor_mode = None, None, None
        self.decisions, self.emergency_ordered, self.landing_start = [], False, None
        self.missions = missions_mod.MissionLog()
        self.resources = processes.ResourceLog()
        self.warnings = []  # (wall s, node, text) of WARN and worse on /rosout_agg, when the scenario fuzzes
        # {node: {"count", "first"}} of the exceptions rospy caught in a node's callbacks ("bad callback"): the node
        # lives on, but whatever the callback did after the exception was lost (an ideal-world tracker once raised on
        # every camera fix, 27 times a second, unnoticed).
        self.callback_errors = {}
        self.master_lost_at = None
        self.recorder_deaths = []
        self._recorder_restart = None  # (new recorder, sim time) until it has subscribed again
        self.faults = faults.FaultInjector(rospy, self.process_roots)
        # Each topic is read from the node that owns it only: a scenario may publish garbage on it (fuzz:).
        sim = "/mujoco_sim"

        def sub(*args, **kwargs):
            # (on a reused graph, what the previous scenario latched is forgotten: see NodeHandles.subscriber)
            self.handles.subscriber(*args, commands=reused, **kwargs)
        sub("ardrone/touchdown", Touchdown, only_from(sim, self._on_touchdown))
        # Ground truth from the start (not once the drone is down): a subscription made later would need the master,
        # which may be dead by then (kill_node master), and rospy then waits for it for ever.
        sub("groundtruth/ardrone", PoseStamped, only_from(sim, lambda m: self._remember(self.drone_poses, m)))
        sub("groundtruth/landing_pad", PoseStamped, only_from(sim, lambda m: self._remember(self.pad_poses, m)))
        sub("platform_tracking/state", String,
            only_from("/platform_tracking", lambda m: setattr(self, "tracker_state", m.data)))
        sub("supervisor/mode", String, only_from("/supervisor", lambda m: setattr(self, "supervisor_mode", m.data)))
        sub("emergency/position", PositionXYCommand, only_from(
            "/emergency", lambda m: setattr(self, "emergency_position", [round(m.x, 3), round(m.y, 3)])))
        sub("supervisor/decisions", String, only_from("/supervisor", self._on_decision))
        from rosgraph_msgs.msg import Log
        sub("rosout_agg", Log, self._on_log, queue_size=1000)
        self.operator = rospy.Publisher("operator/command", String, queue_size=10, latch=True)
        self.tracker_command = rospy.Publisher("platform_tracking/command", String, queue_size=10, latch=True)
        self.fault = rospy.Publisher("mujoco_sim/fault", String, queue_size=10)
        from std_msgs.msg import Empty
        self.holder = rospy.Publisher("mujoco_sim/hold", Empty, queue_size=1)

    def clock(self):
        """World time [s]: ROS time since the world's time 0."""
        return self.rospy.get_time() - self.origin

    def world_time(self, stamp):
        """World time [s] of a ROS stamp."""
        return stamp.to_sec() - self.origin

    def close(self):
        """Leave the scenario without leaving the graph (a warm graph's next scenario gets a monitor of its own):
        unsubscribe, and forget the latched operator and tracker commands, which the reset nodes must not get."""
        if self.closed:
            return
        self.closed = True
        if self.rospy.core.is_shutdown_requested():
            return  # (the graph was closed: this process has left it, and with its master gone an unsubscribe may hang)
        self.faults.close()
        self.handles.close()
        for publisher in (self.operator, self.tracker_command):
            publisher.impl.latch = None

    def process_roots(self):
        """Pids whose process trees hold this run's nodes: the master's, the launch and the flight recorder."""
        return [self.core.process.pid, self.ros.process.pid] + self.recorders.pids()

    def _remember(self, poses, msg, keep=100):
        with self.poses_lock:
            poses[msg.header.stamp] = msg.pose.position
            while len(poses) > keep:
                poses.popitem(last=False)

    def _on_touchdown(self, msg):
        if self.world_time(msg.header.stamp) < 0.0:
            return  # (a previous world's, latched)
        if self.touchdown is None or msg.header.stamp.to_sec() > self.touchdown.header.stamp.to_sec():
            self.touchdown = msg

    def _on_decision(self, msg):
        try:
            decision = json.loads(msg.data)
        except ValueError:
            return
        if isinstance(decision, dict) and isinstance(decision.get("t"), (int, float)):
            decision["t"] = round(decision["t"] - self.origin, 3)  # (the supervisor's t is ROS time)
        self.decisions.append(decision)
        if decision.get("action") == "emergency_landing":
            self.emergency_ordered = True
            self.missions.emergency()

    def _on_log(self, msg):
        if msg.level >= msg.WARN and self.s.get("fuzz"):  # (sim time: the nodes throttle their warnings on their clock)
            self.warnings.append((round(self.world_time(msg.header.stamp), 3), msg.name, msg.msg))
        if msg.level >= msg.ERROR and msg.msg.startswith(CALLBACK_EXCEPTION):
            seen = self.callback_errors.setdefault(msg.name, {"count": 0, "first": msg.msg[-600:]})
            seen["count"] += 1

    def _needed_topics(self):
        """Topics the analysis of the bag cannot do without."""
        needed = ["/drone/navdata", "/ardrone/touchdown", "/groundtruth/ardrone", "/groundtruth/landing_pad",
                  "/summit_xl/gps/odom", "/tf"]
        return needed + (["/platform_tracking/state"] if self.s.get("_needs_tracker") else [])

    def _outputs_of_every_node(self):
        """One topic each node of the landing stack advertises when it starts: once all are advertised,
        every node is up and has subscribed to its inputs (the nodes subscribe as they advertise)."""
        stack = ["/ardrone/odom_estimate", "/kalman_prediction_path", "/platform/current_platform_position_in_world"]
        supervision = ["/supervisor/mode", "/emergency/state", "/cmd_vel_mux/selected"]
        return (stack if self.s.get("_needs_tracker") else []) + (supervision if self.s.get("_supervisor") else [])

    def _wait(self, condition, what, deadline, poll_s=None):
        while not condition():
            if not self.ros.alive():
                raise RuntimeError("%s: roslaunch exited with code %s (%s)" % (
                    what, self.ros.process.returncode, launch_failure(self.ros.log_path)))
            if time.monotonic() > deadline:
                raise TimeoutError("%s within the time allowed (tracker state %r)" % (what, self.tracker_state))
            time.sleep(poll_s or self.poll_s)

    def wait_for_graph(self, deadline):
        """Until every needed topic is advertised and the landing stack (if any) reports its state."""
        import rosgraph
        master = rosgraph.Master("/scenario_runner")

        def ready():
            advertised = {topic for topic, _ in master.getSystemState()[0]}
            return all(t in advertised for t in self._needed_topics() + self._outputs_of_every_node()) and \
                (not self.s.get("_needs_tracker") or self.tracker_state is not None)
        self._wait(ready, "the graph did not come up", deadline)

    def wait_for_recorder_gone(self, deadline):
        """Until the previous run's recorder, stopping beside this run's reset (a warm graph), has unsubscribed:
        the next one has its name, and its subscriptions could not be told apart."""
        import rosgraph
        master = rosgraph.Master("/scenario_runner")

        def gone():
            return not any("/" + RECORDER in nodes for _topic, nodes in master.getSystemState()[1])
        self._wait(gone, "the previous run's flight recorder did not unsubscribe", deadline)

    def wait_for_recorder(self, recorder, deadline):
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
            return all("/" + RECORDER in subscribers.get(t, []) for t in self._needed_topics())
        self._wait(ready, "the flight recorder did not subscribe", deadline)

    def wait_for_connections(self, deadline, retry_after=3.0):
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
            self._wait(connected, "the graph did not connect", deadline)
        except TimeoutError as err:
            raise TimeoutError("%s; %d subscriptions never connected, e.g. %s" % (
                err, len(missing), ", ".join("%s from %s to %s" % m for m in missing[:3])))

    def release(self, deadline):
        """Start the simulator's physics and wait for the clock to run."""
        from std_msgs.msg import Empty
        start = self.rospy.Publisher("mujoco_sim/start", Empty, queue_size=1, latch=True)
        start.publish(Empty())
        # (polled closely: sim time runs from here, and the scenario's events at t = 0 must not wait for the poll)
        self._wait(lambda: self.clock() > 0.0, "the simulator did not start", deadline, poll_s=0.005)

    def hold(self):
        """Hold the world (mujoco_sim/hold) once the flight is over: on a warm graph, which flies on otherwise, the
        nodes then rest while the recorder stops."""
        from std_msgs.msg import Empty
        self.holder.publish(Empty())

    def sample_resources(self, label, wall_start):
        return self.resources.sample(label, time.monotonic() - wall_start, self.clock(),
                                     processes.nodes_below(self.process_roots()))

    # ----- events ----------------------------------------------------------------------------------
    def _operator(self, action):
        from std_msgs.msg import String
        self.operator.publish(String(data=action))
        if action in ("landing", "takeoff") and not self.s.get("_supervisor"):
            # Without the supervisor in the graph, the landing mode is the tracker's own take-off.
            self.tracker_command.publish(String(data="takeoff"))

    def _set_param(self, name, value):
        try:
            self.rospy.set_param("/" + name, value)
        except Exception as err:  # the master is gone: nothing can be set any more
            self.rospy.logwarn("could not set /%s = %r: %s", name, value, err)

    def apply(self, event):
        from std_msgs.msg import String
        rospy = self.rospy
        t = self.clock()
        rospy.loginfo("scenario event at t=%.2f: %s", t, event)
        if "operator" in event:
            action = event["operator"]
            self._operator(action)
            if action in ("landing", "takeoff"):
                self.landing_start = self.landing_start or t
                if self.missions.current is None and not self.missions.records:
                    self.missions.start(self.landing_start)
            if action == "emergency":
                self.emergency_ordered = True
                self.missions.emergency()
        elif "set_param" in event:
            self._set_param(event["set_param"], event["value"])
        elif event["fault"] == "kill_node":
            self.faults.kill(event["name"], event["signal"], t)
        else:
            self.fault.publish(String(data=json.dumps({"fault": event["fault"], "duration_s": event["duration_s"]})))

    # ----- the flight ------------------------------------------------------------------------------
    def _settled(self, since):
        """The latest touchdown after sim time ``since``, once the drone has rested on it (or crashed)."""
        touchdown = self.touchdown
        if touchdown is None or self.world_time(touchdown.header.stamp) <= since:
            return None
        touchdown_time = self.world_time(touchdown.header.stamp)
        # After an emergency landing, wait for the coordinates the emergency module reports.
        ordered = self.missions.current["emergency_ordered"] if self.missions.current else self.emergency_ordered
        settle = EMERGENCY_REPORT_WAIT_S if ordered and self.emergency_position is None else SETTLE_AFTER_TOUCHDOWN_S
        if touchdown.crashed or self._latest_common_pose_time() >= touchdown_time + settle:
            return touchdown
        return None

    def _check_graph(self, clock):
        """Raises GraphFailure when the launch ended or the clock stopped; notes a lost master."""
        if not self.ros.alive():
            raise GraphFailure("roslaunch ended with code %s at t=%.2f s: %s" % (
                self.ros.process.returncode, self.clock(), launch_failure(self.ros.log_path)))
        t, now = self.clock(), time.monotonic()
        if t > clock["t"]:
            clock.update(t=t, wall=now)
        elif now - clock["wall"] > CLOCK_STALL_WALL_S:
            raise GraphFailure("the simulation clock has stood at t=%.2f s for %.0f s (wall): the simulator "
                               "stopped" % (t, now - clock["wall"]))
        if self.master_lost_at is None and now - clock.get("master_checked", 0.0) > 2.0:
            clock["master_checked"] = now
            if "master" not in processes.nodes_below([self.core.process.pid]):
                self.master_lost_at = round(t, 3)
                self.rospy.logwarn("the ROS master is gone (t=%.2f s): the graph flies on over its existing "
                                   "connections; nothing new can connect", t)
        current = self.recorders.current
        if current is not None and not current.alive() and not current.interrupted:
            self._recorder_died(t)

    def _recorder_died(self, t):
        died = self.recorders.current
        self.recorder_deaths.append({"at_s": round(t, 3), "exit_code": died.process.returncode,
                                     "bag": self.recorders.bags[-1]})
        if self.master_lost_at is not None:
            self.rospy.logwarn("the flight recorder died at t=%.2f s; with the master gone it cannot be restarted", t)
            self.recorders.current = None
            return
        import rosgraph
        try:  # the dead recorder is still registered (a SIGKILL unregisters nothing): its URI tells it apart
            old_uri = rosgraph.Master("/scenario_runner").lookupNode("/" + RECORDER)
        except Exception:
            old_uri = None
        self.recorders.start()
        self.rospy.logwarn("the flight recorder died at t=%.2f s (code %s): recording on into %s", t,
                           died.process.returncode, self.recorders.bags[-1])
        self._recorder_restart = (old_uri, t)

    def _check_recorder_restart(self):
        pending = self._recorder_restart
        if pending is None:
            return
        import rosgraph
        old_uri, _ = pending
        master = rosgraph.Master("/scenario_runner")
        try:
            registered = master.lookupNode("/" + RECORDER) != old_uri
            subscribers = {topic: nodes for topic, nodes in master.getSystemState()[1]}
        except Exception:  # not registered yet, or the master is busy
            return
        if registered and all("/" + RECORDER in subscribers.get(t, []) for t in self._needed_topics()):
            self._recorder_restart = None
            self.faults.mark_recovered(RECORDER, self.clock(), "subscribed to every needed topic")

    def _next_mission(self, plan, t):
        """Before the next mission: the operator acknowledges an emergency report, then once the supervisor is
        back on the ground sets the new conditions (and a fresh battery) and, CONDITIONS_SETTLE_S later, chooses
        the landing mode again. Returns True once the mission started."""
        if self.s.get("_supervisor"):
            if self.supervisor_mode == "emergency":
                self._operator("ack")
                return False
            waited = t - self._pause_end
            if self.supervisor_mode not in ("landed", "idle") and waited < MODE_WAIT_S:
                return False
        if self._conditions_set is None:
            try:
                battery = self.rospy.get_param("/drone_battery")
            except Exception:  # unreadable or the master gone: swap
                battery = None
            index = len(self.missions.records) + 1
            params, swapped = missions_mod.next_mission_settings(plan, index, battery)
            for name, value in params.items():
                self._set_param(name, value)
            self._conditions_set = (t, params, swapped)
            return False
        set_at, params, swapped = self._conditions_set
        if t - set_at < CONDITIONS_SETTLE_S:
            return False
        self._conditions_set = None
        self.rospy.loginfo("mission %d at t=%.2f s: %s", len(self.missions.records) + 1, t, params or "same conditions")
        self.emergency_position = None
        self.missions.start(t, params, swapped)
        self._operator("landing")
        return True

    def run(self, schedule, time_limit, wall_deadline, wall_start):
        """The flight until its last mission ended, the time limit, or the wall deadline (TimeoutError); raises
        GraphFailure when the graph fell apart."""
        rospy = self.rospy
        sim_start = self.clock()
        plan = self.s.get("missions")
        clock = {"t": self.clock(), "wall": time.monotonic()}
        self.faults.prepare([e["name"] for e in schedule.pending if e.get("fault") == "kill_node"])
        self._pause_end = None  # sim time the next mission may start
        self._conditions_set = None  # (sim time, conditions, battery swapped) of the next mission, once set
        while True:
            t = self.clock()
            for event in schedule.due(t):
                self.apply(event)
            self._check_graph(clock)
            self._check_recorder_restart()
            if self._pause_end is None:
                since = self.missions.current["start_s"] if self.missions.current else float("-inf")
                touchdown = self._settled(since)
                if touchdown is not None:
                    if self.missions.current is None:  # nobody chose the landing mode: it started by itself
                        self.missions.start(self.landing_start or sim_start)
                    record = self.missions.finish(touchdown, self.resting_pad_error(), self._landed_decision(since))
                    rospy.loginfo("mission %d: %s", record["mission"], record["outcome"])
                    self.sample_resources("mission %d" % record["mission"], wall_start)
                    if not plan or len(self.missions.records) >= plan["count"] or touchdown.crashed:
                        return
                    self._pause_end = t + plan["pause_s"]
            elif t >= self._pause_end and self._next_mission(plan, t):
                self._pause_end = None
            if t >= time_limit:
                if self.missions.current is None and not self.missions.records:
                    self.missions.start(self.landing_start or sim_start)
                self.missions.abandon("timeout")
                return
            if time.monotonic() > wall_deadline:
                self.missions.abandon("timeout")
                raise TimeoutError("wall-clock limit reached at sim time %.1f s" % t)
            time.sleep(0.02)

    def _landed_decision(self, since):
        for decision in reversed(self.decisions):
            if decision.get("action") == "landed" and decision.get("t", 0.0) >= since:
                return {"on_pad": (decision.get("value") or {}).get("on_pad"), "reason": decision.get("reason")}
        return None

    def _latest_common_stamp(self):
        with self.poses_lock:
            common = [stamp for stamp in self.drone_poses if stamp in self.pad_poses]
        return common[-1] if common else None

    def _latest_common_pose_time(self):
        stamp = self._latest_common_stamp()
        return float("-inf") if stamp is None else self.world_time(stamp)

    def scored(self, error, aborted, sim_start, sim_time, flight_wall):
        """The result.json fields of the flight (SPEC section 7) from what was seen; ``error``: why the run
        was cut short, or None; ``aborted``: the graph fell apart."""
        touchdown, resting_error = self.touchdown, self.resting_pad_error()
        outcome, touchdown_error = scoring.outcome(touchdown, resting_error, self.emergency_ordered)
        touchdown_time = self.world_time(touchdown.header.stamp) if touchdown else None
        records = self.missions.records
        if self.s.get("missions"):
            outcome = missions_mod.worst(r["outcome"] for r in records) if records else "timeout"
            if len(records) < self.s["missions"]["count"] and outcome == "landed_on_pad":
                outcome = "timeout"
        result = {
            "outcome": "aborted" if aborted else outcome if error is None else "timeout",
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
        if self.s.get("missions"):
            result["missions"] = records
            result["missions_on_pad"] = sum(r["outcome"] == "landed_on_pad" for r in records)
            on_pad = [r["touchdown_error_m"] for r in records if r["touchdown_error_m"] is not None]
            result["touchdown_error_m"] = round(max(on_pad), 4) if on_pad else None
        result["faults"] = self.faults.results()
        result["master_lost_at_s"] = self.master_lost_at
        result["recorder_deaths"] = self.recorder_deaths
        result["callback_errors"] = self.callback_errors
        return result

    def start_leaving_graph(self, timeout=10.0):
        """rospy's shutdown (0.6 s: it unregisters every topic from the master) in a thread of its own, so that it
        overlaps the graph's and the recorder's; returns ``finish()``, which waits for it, bounded: with the master
        gone a registration still retrying holds rospy's topic lock, and the shutdown waits for it for ever."""
        def shut_down():
            self.faults.close()
            self.rospy.signal_shutdown("scenario finished")
        thread = threading.Thread(target=shut_down, name="leave_graph", daemon=True)
        thread.start()
        deadline = time.monotonic() + timeout

        def finish():
            thread.join(max(0.0, deadline - time.monotonic()))
            if thread.is_alive():
                self.rospy.logwarn("rospy did not shut down within %.0f s (the master is gone?): leaving it behind",
                                   timeout)
        return finish

    def resting_pad_error(self):
        """Horizontal drone-to-pad distance at the latest instant both poses are known for."""
        stamp = self._latest_common_stamp()
        if stamp is None:
            return None
        with self.poses_lock:
            drone, pad = self.drone_poses[stamp], self.pad_poses[stamp]
        return ((drone.x - pad.x) ** 2 + (drone.y - pad.y) ** 2) ** 0.5


def launch_failure(log_path):
    """What roslaunch said about the node whose death ended it (the last 'REQUIRED process' line), if anything."""
    try:
        with open(log_path, errors="replace") as stream:
            text = stream.read()
    except OSError:
        return "no launch log"
    deaths = [d for d in processes.deaths_in_launch_log(text) if d["required"]]
    if deaths:
        return "required node %s died (exit code %d); see %s" % (deaths[-1]["node"], deaths[-1]["exit_code"], log_path)
    return "see %s" % log_path


def write_result(out_dir, result):
    """result.json, atomically: a reader sees the old file or the whole new one, never a part."""
    path = os.path.join(out_dir, "result.json")
    temporary = path + ".tmp"
    with open(temporary, "w") as stream:
        json.dump(result, stream, indent=2)
        stream.flush()
        os.fsync(stream.fileno())
    os.replace(temporary, path)
    return path


def repair_bags(bags, timeout=30.0):
    """A bag whose recorder was killed is left as NAME.active without an index: reindex it (rosbag reindex)
    and give it its name. Returns the bags as they are now (an unrepaired one keeps its .active name: the
    analysis reads it record by record)."""
    repaired = []
    for bag in bags:
        active = bag + ".active"
        if os.path.isfile(bag) or not os.path.isfile(active):
            repaired.append(bag if os.path.isfile(bag) else None)
            continue
        try:
            done = subprocess.run(["rosbag", "reindex", "--quiet", active], capture_output=True, text=True,
                                  timeout=timeout).returncode == 0
        except (OSError, subprocess.TimeoutExpired):
            done = False
        backup = bag + ".orig.active"
        if done:
            os.replace(active, bag)
            if os.path.isfile(backup):
                os.remove(backup)
            repaired.append(bag)
        else:
            repaired.append(active)
    return repaired


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
    # Without an operator event the operator chooses the landing mode at once, unless the scenario tests
    # what happens when nobody chooses (supervisor: {no_operator: true}).
    no_operator = bool(s["supervisor"].get("no_operator"))
    events = s["events"] if no_operator or any("operator" in e for e in s["events"]) else \
        [{"at_s": 0.0, "operator": "landing"}] + s["events"]
    limits = wall_limits(s["time_limit_s"], wall_timeout)
    result = {"name": s["name"], "seed": s["seed"], "scenario": os.path.abspath(scenario_path),
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
        for finish in leaving:
            finish()
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


def finish(result, out_dir, wall_start, phases, monitor, recorders, steps=None):
    """Repair the bags, add the run's bookkeeping and write result.json."""
    bags = repair_bags(recorders.written() if recorders else [])
    result["bag"] = bags[0] if bags else None
    if len(bags) > 1:
        result["bags"] = bags
    if monitor is not None:
        result["resources"] = {"samples": monitor.resources.samples, "table": monitor.resources.table(
            baseline=1 if len(monitor.resources.samples) > 3 else 0)}
    graph = result.get("graph") or {}  # (a warm graph's launch log: this scenario's part of it)
    try:
        with open(graph.get("launch_log") or os.path.join(out_dir, "launch.log"), "rb") as stream:
            stream.seek(graph.get("launch_log_offset", 0))
            result["node_deaths"] = processes.deaths_in_launch_log(stream.read().decode(errors="replace"))
    except OSError:
        result["node_deaths"] = []
    result["wall_time_s"] = round(time.monotonic() - wall_start, 2)
    # Where the wall time went: starting the master, graph and recorder; the flight; stopping them.
    start_up = phases["start_up"] if phases["start_up"] is not None else result["wall_time_s"]
    result["wall_phases_s"] = {"start_up": round(start_up, 2), "flight": round(phases["flight"], 2),
                               "shut_down": round(result["wall_time_s"] - start_up - phases["flight"], 2)}
    # When each step of start-up and shut-down ended (wall s from the start): where the fixed overhead goes.
    result["wall_steps_s"] = dict(steps or {}, result=round(time.monotonic() - wall_start, 3))
    result.setdefault("sim_time_s", None)
    result.setdefault("real_time_factor", None)
    write_result(out_dir, result)
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
