"""supervisor node: thin ROS wrapper of interface.supervisor.Supervisor.

In:  the condition parameters (/wind_speed, /drone_battery, ... via rospy.get_param_cached, pushed by the
     master), sensor watchdogs (ardrone/bottom/camera_info, ardrone/imu, ardrone/gps/odom,
     ardrone/sonar_height), platform speed (kalman_platform_odom, else summit_xl/gps/odom), the
     tracker's state (platform_tracking/state), the drone's state (drone/navdata), the pad seen by the
     camera (platform/current_platform_position_in_ardrone, to tell a touchdown on the pad), operator/command
     and the Trigger services supervisor/{landing,emergency,manual,continue}.
Out: supervisor/decisions (JSON per decision), supervisor/mode, supervisor/warning, landing_allowed,
     supervisor/flight_management (JSON {open, auto_takeoff_at}; all latched) and platform_tracking/command
     (the hand-over to the tracker).
Everything runs in sim time. Garbage on an input (implausible values, stamps from another time, frames of another
tree, unknown words or states) is dropped with a throttled warning saying what was wrong.

Restarted after a crash (respawn in supervisor.launch), it carries on in the mode it had: its state
(Supervisor.snapshot) is kept in the private parameter ~recovery on the master, which outlives the
node, tagged with ~launch_id (unique to each roslaunch, kept across respawns); another launch starts afresh.

``~reset`` (std_srvs/Trigger, between the scenarios of a warm graph) starts afresh from the parameters as they are
then (the condition parameters read anew from the master): mode idle, nothing latched but what a fresh start
publishes (no tracker command), the idle take-off timer from the reset on. It does not recover ~recovery, and
overwrites it with its fresh state at once, so that a crash later in the new scenario carries on in that scenario.
A bad parameter refuses the reset and the supervisor goes on as it was.
"""
import json
import sys
import threading
import time

from landing_runtime.message_constants import message_constants
from landing_runtime.input_check import (MAX_ALTITUDE_M, MAX_SPEED_MPS, RosRejectionLog, choice_problem, first_problem,
                                      frame_problem, numbers_problem, stamp_problem)

import rospy
from rospy.impl.paramserver import get_param_server_cache
from landing_runtime.lockstep import LockstepAcker
from landing_msgs.msg import Navdata, TrackerState
from geometry_msgs.msg import PointStamped
from landing_runtime.rospy_node import NodeHandles, run_node, unconnected_subscribers
from nav_msgs.msg import Odometry
from std_msgs.msg import Bool, String
from std_srvs.srv import Trigger, TriggerResponse

from .conditions import MISSING, ConditionTableError, load_table
from .supervisor import OPERATOR_COMMANDS, Flight, Settings, SettingsError, Supervisor
from .supervisor_measures import PlatformSpeed, SensorWatchdog, TargetLostTimer, TouchdownJudge, flight_from_navdata

# The camera's liveness is read from camera_info, which the driver publishes with every frame: the same
# arrivals without copying 230 kB images into this process.
SENSOR_TOPICS = {"camera_silence_s": "ardrone/bottom/camera_info", "imu_silence_s": "ardrone/imu",
                 "odometry_silence_s": "ardrone/gps/odom", "sonar_silence_s": "ardrone/sonar_height"}
SERVICES = ("landing", "emergency", "manual", "continue")
TRACKER_STATES = message_constants(TrackerState)
NAVDATA_STATES = message_constants(Navdata, "STATE_")
WORLD_FRAME, BODY_FRAME = "world", "ardrone/base_link"  # docs/conventions.md
DECISIONS_WAIT_S = 3.0  # wall seconds decisions wait at the start for supervisor/decisions' subscribers to connect
REPEAT_S = 2.0  # the same operator word again within this (sim) time is a repetition, not a new command [s]
NODE_PARAMS = {  # private parameter: (lowest, highest); besides Settings.SPEC and conditions_file
    "rate_hz": (5.0, 200.0),
    "platform_odom_timeout_s": (0.05, 60.0),
    "platform_speed_window_s": (0.1, 60.0),
    "navdata_timeout_s": (0.05, 60.0),
    "warning_repeat_s": (0.5, 3600.0),
    "touchdown_detection_age_s": (0.05, 60.0),
    "touchdown_max_offset_m": (0.01, 10.0),
}


class StartupError(RuntimeError):
    pass


def _node_params():
    """Private parameters (config/supervisor.yaml); StartupError names a missing or bad one."""
    private = rospy.get_param("~", {})
    where = "supervisor (%s, config/supervisor.yaml)" % rospy.get_name()
    if "conditions_file" not in private:
        raise StartupError("%s: required parameter '~conditions_file' (path of config/conditions.yaml) is missing"
                           % where)
    if not isinstance(private.get("target_lost_state"), str):
        raise StartupError("%s: required parameter '~target_lost_state' (the tracker's state meaning the pad is "
                           "lost, e.g. RELOCATING) is missing or not a text" % where)
    initial = private.get("initial_conditions", None)
    if not isinstance(initial, dict) or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in initial.values()):
        raise StartupError("%s: required parameter '~initial_conditions' must map condition parameters to "
                           "numbers, got %r" % (where, initial))
    values = {"initial_conditions": initial}
    for name, (low, high) in NODE_PARAMS.items():
        if name not in private:
            raise StartupError("%s: required parameter '~%s' is missing" % (where, name))
        value = private[name]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not low <= value <= high:
            raise StartupError("%s: parameter '~%s' must be a number in %g..%g, got %r"
                               % (where, name, low, high, value))
        values[name] = float(value)
    try:
        settings = Settings.from_mapping(private, where)
    except SettingsError as err:
        raise StartupError(str(err))
    drone_model_file = private.get("drone_model_file")
    if not isinstance(drone_model_file, str) or not drone_model_file:
        raise StartupError("%s: required parameter '~drone_model_file' (the drone model's limits, "
                           "interface/config/drone_models/MODEL.yaml) is missing" % where)
    return private["conditions_file"], drone_model_file, private["target_lost_state"], settings, values


class SupervisorNode:
    """The supervisor from the parameters as they are at construction; ``tick()`` evaluates the conditions at
    ``rate_hz``. ``carry_on``: the first object of a process carries on from the state a crashed predecessor of the
    same launch left in ~recovery; an object made by a reset starts afresh."""

    # The object whose state ~recovery keeps: the newest one. One retired by a reset may still answer a command
    # while its successor takes over, and must not write the previous scenario's state over its successor's.
    _recovery_owner = None
    _recovery_lock = threading.Lock()

    def __init__(self, carry_on=False):
        conditions_file, drone_model_file, lost_state, settings, self.params = _node_params()
        try:
            self.table = load_table(conditions_file, drone_model_file)
            self.params["initial_conditions"] = dict(self.params["initial_conditions"], **self.table.initial_conditions)
        except ConditionTableError as err:
            raise StartupError("supervisor: %s" % err)
        # Every parameter is valid from here on: nothing below may refuse the reset.
        self.rate_hz = self.params["rate_hz"]
        self.lock = threading.Lock()
        self.touchdown = TouchdownJudge(self.params["touchdown_detection_age_s"], self.params["touchdown_max_offset_m"])
        self.core = Supervisor(self.table, settings, log=self._log, touchdown_judge=self.touchdown)
        self.saved_snapshot = None
        self.launch_id = rospy.get_param("~launch_id", None)  # one roslaunch's, kept across respawns
        self.unsent = []  # decisions waiting for the subscribers of supervisor/decisions (_listened_to)
        self.decisions_wait_until = time.monotonic() + DECISIONS_WAIT_S
        if carry_on:
            self._recover()
        self.watchdog = SensorWatchdog(SENSOR_TOPICS)
        self.platform = PlatformSpeed(self.params["platform_odom_timeout_s"], self.params["platform_speed_window_s"])
        self.target = TargetLostTimer(lost_state)
        self.navdata = None  # (receipt time, state)
        self.published = {"mode": None, "warning": None, "landing_allowed": None, "flight_management": None}
        self.last_warning_sent = -1e9
        self.lockstep = LockstepAcker(period=1.0 / self.params["rate_hz"])
        self.rejections = RosRejectionLog()
        self.last_command = (None, 0.0)  # (word, sim time) of the latest operator command taken

        self.handles = NodeHandles()
        latched = self.handles.latched
        self.pub_decisions = rospy.Publisher("supervisor/decisions", String, queue_size=100)
        self.pub_mode = latched(rospy.Publisher("supervisor/mode", String, queue_size=1, latch=True))
        self.pub_warning = latched(rospy.Publisher("supervisor/warning", String, queue_size=1, latch=True))
        self.pub_allowed = latched(rospy.Publisher("landing_allowed", Bool, queue_size=1, latch=True))
        self.pub_tracker = latched(rospy.Publisher("platform_tracking/command", String, queue_size=10, latch=True))
        self.pub_flight_management = latched(
            rospy.Publisher("supervisor/flight_management", String, queue_size=1, latch=True))

        subscriber = self.handles.subscriber
        # AnyMsg: only the arrival matters, nothing is deserialised.
        self.sensor_subscribers = {name: subscriber(topic, rospy.AnyMsg, self._seen(name), queue_size=1)
                                   for name, topic in SENSOR_TOPICS.items()}
        subscriber("kalman_platform_odom", Odometry, self._on_platform_odom, queue_size=1)
        subscriber("summit_xl/gps/odom", Odometry, self._on_vehicle_gps, queue_size=5)
        subscriber("platform_tracking/state", String, self._on_tracker_state, queue_size=5)
        subscriber("drone/navdata", Navdata, self._on_navdata, queue_size=1)
        subscriber("platform/current_platform_position_in_ardrone", PointStamped, self._on_detection, queue_size=5)
        subscriber("operator/command", String, self._on_operator, queue_size=10, commands=True)
        for name in SERVICES:
            self.handles.service("supervisor/" + name, Trigger, self._service(name))
        for name, value in self.params["initial_conditions"].items():
            if not rospy.has_param("/" + name):
                rospy.set_param("/" + name, value)
                rospy.loginfo("supervisor: /%s was not set: starting from %g (thesis Flight Management default)",
                              name, value)
        # Read every condition parameter from the master now (a reset's runner has just set the new scenario's;
        # the master's push of them may still be on its way) and subscribe to it, so the master pushes changes
        # from here on.
        for name in self.table.params():
            self._read_param_anew(name)
        self._publish(0.0)  # mode idle, no warning, landing not allowed: known before the clock runs
        with SupervisorNode._recovery_lock:
            SupervisorNode._recovery_owner = self
        if not carry_on:
            self._save()  # a reset's fresh state replaces the previous scenario's at once
        rospy.loginfo("supervisor: %d conditions from %s; answer timeout %g s, auto take-off after %g s, "
                      "Flag #3 re-checks every %g s x %d", len(self.table), self.table.path,
                      settings.answer_timeout_s, settings.idle_takeoff_s, settings.recheck_interval_s,
                      settings.recheck_count)

    def _recover(self):
        """Carry on from the state a crashed predecessor of this launch left in ~recovery, if any."""
        try:
            saved, launch_id = rospy.get_param("~recovery", None), self.launch_id
            saved = json.loads(saved) if saved else None
        except (KeyError, ValueError, TypeError) as err:
            rospy.logwarn("supervisor: unreadable ~recovery (%s): starting afresh", err)
            return
        if not saved or launch_id is None or saved.get("launch_id") != launch_id or \
                not isinstance(saved.get("snapshot"), dict):
            return
        try:
            with self.lock:
                self.core.restore(rospy.get_time(), saved["snapshot"])
        except (KeyError, ValueError, TypeError) as err:
            rospy.logwarn("supervisor: cannot carry on from ~recovery (%s): starting afresh", err)
            return
        self.saved_snapshot = saved["snapshot"]
        rospy.logwarn("supervisor: restarted after a crash; carrying on in mode %s", self.core.mode.value)

    def _save(self):
        """Keep the core's state where a restarted supervisor finds it (only when it changed, and only while this
        object is the newest)."""
        snapshot = self.core.snapshot()
        if snapshot == self.saved_snapshot:
            return
        with SupervisorNode._recovery_lock:
            if SupervisorNode._recovery_owner is not self:
                return
            try:
                rospy.set_param("~recovery", json.dumps({"launch_id": self.launch_id, "snapshot": snapshot}))
                self.saved_snapshot = snapshot
            except Exception as err:  # the master is gone: the flight goes on, a restart would start afresh
                rospy.logwarn_throttle(30.0, "supervisor: cannot save its state for a restart: %s" % err)

    def _listened_to(self):
        """Whether supervisor/decisions (not latched) reaches its subscribers. Right after a restart they are still
        connecting, and the decision that says the supervisor carried on would be lost: decisions wait until every
        subscriber the master lists is connected, for at most DECISIONS_WAIT_S of wall time after the start."""
        if self.decisions_wait_until is None:
            return True
        if time.monotonic() < self.decisions_wait_until:
            try:
                if unconnected_subscribers(self.pub_decisions):
                    return False
            except Exception:  # the master is gone: nothing more will connect
                pass
        self.decisions_wait_until = None
        return True

    def _dropped(self, topic, problem):
        return self.rejections.reject(topic, problem)

    @staticmethod
    def _header_problem(msg, frame):
        return first_problem(stamp_problem(msg.header.stamp.to_sec(), rospy.get_time()),
                             frame_problem(msg.header.frame_id, frame))

    @staticmethod
    def _log(level, text):
        {"info": rospy.loginfo, "warn": rospy.logwarn, "error": rospy.logerr}[level](text)

    # ----- inputs ------------------------------------------------------------------------------------
    def _seen(self, name):
        def callback(_):
            self.watchdog.seen(name, rospy.get_time())
        return callback

    def _on_platform_odom(self, msg):
        v = msg.twist.twist.linear
        problem = numbers_problem(MAX_SPEED_MPS, velocity=(v.x, v.y)) or self._header_problem(msg, WORLD_FRAME)
        if problem:
            return self._dropped("kalman_platform_odom", problem)
        with self.lock:
            self.platform.on_filtered(rospy.get_time(), v.x, v.y)

    def _on_vehicle_gps(self, msg):
        v = msg.twist.twist.linear
        problem = numbers_problem(MAX_SPEED_MPS, velocity=(v.x, v.y)) or self._header_problem(msg, WORLD_FRAME)
        if problem:
            return self._dropped("summit_xl/gps/odom", problem)
        with self.lock:
            self.platform.on_gps(rospy.get_time(), v.x, v.y)

    def _on_tracker_state(self, msg):
        problem = choice_problem(msg.data, TRACKER_STATES, "tracker state")
        if problem:
            return self._dropped("platform_tracking/state", problem)
        with self.lock:
            self.target.on_state(rospy.get_time(), msg.data)
            self.touchdown.on_tracker_state(msg.data)

    def _on_detection(self, msg):
        p = msg.point
        problem = numbers_problem(MAX_ALTITUDE_M, point=(p.x, p.y, p.z)) or self._header_problem(msg, BODY_FRAME)
        if problem:
            return self._dropped("platform/current_platform_position_in_ardrone", problem)
        with self.lock:
            self.touchdown.on_detection(msg.header.stamp.to_sec(), msg.point.x, msg.point.y)

    def _on_navdata(self, msg):
        problem = choice_problem(msg.state, NAVDATA_STATES, "state") or \
            stamp_problem(msg.header.stamp.to_sec(), rospy.get_time())
        if problem:
            return self._dropped("drone/navdata", problem)
        self.navdata = (rospy.get_time(), msg.state)

    def _on_operator(self, msg):
        # An unknown word is garbage on the topic (a decision is for commands an operator gave), and so is a word
        # repeated within REPEAT_S of the same word carried out or ignored as moot (a publisher stuck in a loop):
        # one decision for it is enough. A command refused by a condition may be given again at once (the
        # operator retries once the cause is gone).
        word, now = msg.data.strip().lower(), rospy.get_time()
        problem = choice_problem(word, OPERATOR_COMMANDS, "command")
        if not problem and self.last_command[0] == word and 0.0 <= now - self.last_command[1] < REPEAT_S:
            problem = ("repeated", "%r again %.2f s after the last one" % (word, now - self.last_command[1]))
        if problem:
            return self._dropped("operator/command", problem)
        accepted, message = self._command(msg.data)
        moot = message.startswith("ignored")  # SupervisorCore._ignored: the mode it asks for is already in force
        self.last_command = (word, now) if accepted or moot else (None, 0.0)

    def _service(self, name):
        def handle(_request):
            accepted, message = self._command(name)
            return TriggerResponse(success=accepted, message=message)
        return handle

    def _command(self, word):
        with self.lock:
            accepted, message = self.core.command(rospy.get_time(), word)
            self._publish()
            self._save()
        return accepted, message

    @staticmethod
    def _read_param_anew(name):
        """The condition parameter /``name`` as the master holds it now, subscribed to: out of rospy's cache
        first, so that rospy subscribes to it (again), which returns the master's value."""
        try:
            get_param_server_cache().delete(rospy.resolve_name("/" + name))
        except KeyError:  # not cached yet
            pass
        return SupervisorNode._read_param(name)

    @staticmethod
    def _read_param(name):
        try:
            # Cached: pushed by the master, no XML-RPC round trip per tick. The simulator's battery mirror
            # never overwrites an operator's value on the master (it checks there first), so the pushes
            # end with the value the master holds.
            return rospy.get_param_cached("/" + name)
        except KeyError:
            return MISSING

    def _readings(self, t):
        readings = {name: self._read_param(name) for name in self.table.params()}
        readings["platform_speed"] = self.platform.value(t)
        readings["target_lost_s"] = self.target.value(t)
        for name, subscriber in self.sensor_subscribers.items():
            if subscriber.get_num_connections() > 0:
                self.watchdog.connected(name, t)
            readings[name] = self.watchdog.silence(name, t)
        return readings

    def _flight(self, t):
        if self.navdata is None or t - self.navdata[0] > self.params["navdata_timeout_s"]:
            return Flight.UNKNOWN
        return flight_from_navdata(self.navdata[1])

    # ----- outputs -----------------------------------------------------------------------------------
    def _publish(self, t=None):
        decisions, tracker_commands = self.core.take_outputs()
        self.unsent += decisions
        if self.unsent and self._listened_to():
            for decision in self.unsent:
                self.pub_decisions.publish(String(data=json.dumps(decision.as_dict())))
            self.unsent = []
        for command in tracker_commands:
            self.pub_tracker.publish(String(data=command))
        mode = self.core.mode.value
        if mode != self.published["mode"]:
            self.pub_mode.publish(String(data=mode))
            self.published["mode"] = mode
        warning = json.dumps(self.core.warning, sort_keys=True)
        now = rospy.get_time() if t is None else t
        repeat = self.core.warning and now - self.last_warning_sent >= self.params["warning_repeat_s"]
        if warning != self.published["warning"] or repeat:
            # A pending warning is sent again every warning_repeat_s (thesis: keep sending the message).
            self.pub_warning.publish(String(data=warning))
            self.published["warning"], self.last_warning_sent = warning, now
        flight_management = json.dumps(self.core.flight_management(), sort_keys=True)
        if flight_management != self.published["flight_management"]:
            self.pub_flight_management.publish(String(data=flight_management))
            self.published["flight_management"] = flight_management
        if self.core.landing_allowed != self.published["landing_allowed"]:
            self.pub_allowed.publish(Bool(data=self.core.landing_allowed))
            self.published["landing_allowed"] = self.core.landing_allowed

    def tick(self):
        now = rospy.Time.now()
        t = now.to_sec()
        with self.lock:
            self.core.tick(t, self._readings(t), self._flight(t))
            self._publish(t)
            self._save()
        self.lockstep.ack(now)


def main():
    return run_node("supervisor", SupervisorNode, startup_errors=(StartupError,), resettable=True, carries_on=True)


if __name__ == "__main__":
    sys.exit(main())
