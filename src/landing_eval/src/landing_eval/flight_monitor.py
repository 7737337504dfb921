"""FlightMonitor: the runner's process inside the graph during one flight. It waits for the graph, the recorder and
the connections, starts the physics, applies the scenario's events, watches the graph's health (launch, clock,
master, recorder), ends each mission once the drone rests, and scores the flight from the simulator's ground truth."""
import collections
import json
import threading
import time

from flight_analysis import scoring
from landing_runtime.rospy_node import NodeHandles

from .isolated_ros import graph_unconnected, reconnect_subscribers
from .recorders import RECORDER

from . import faults
from . import missions as missions_mod
from . import processes

SETTLE_AFTER_TOUCHDOWN_S = 1.0  # sim seconds the drone must rest before the outcome is read
EMERGENCY_REPORT_WAIT_S = 4.0   # sim seconds to wait for emergency/position after an emergency touchdown
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
CALLBACK_EXCEPTION = "bad callback"  # how rospy logs an exception it caught in a subscriber's callback


class GraphFailure(RuntimeError):
    """The graph fell apart during the flight (the launch ended, the clock stopped): the run is aborted."""


def only_from(node, callback):
    """A subscriber callback that hears only ``node`` (by the connection's caller id)."""
    def heard(msg):
        if (getattr(msg, "_connection_header", None) or {}).get("callerid") == node:
            callback(msg)
    return heard


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
