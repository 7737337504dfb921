"""kill_node faults of a run: a signal to a node's process (found in the run's own process tree, so it works
with the master dead and never reaches another run), and the time until the restarted node publishes again.

Each node is timed on the topic that says it is back at work: its functional output where that flows
whatever the flight is doing, else its lock-step acknowledgement (sent once per processed input). Only a
message from the node itself counts (the caller id of the connection)."""
import os
import signal
import threading
import time

from . import processes

# node -> topics whose first message from it after the kill marks its recovery (the first one it publishes on)
RECOVERY_TOPICS = {
    "platform_detection": ["/lockstep_ack"],              # every processed frame (detections need the pad in view)
    "prediction_kalman_node": ["/kalman_platform_odom"],  # the pad track again
    "drone_estimator": ["/ardrone/odom_estimate"],
    "platform_tracking": ["/platform_tracking/cmd_vel", "/ardrone/cmd_vel"],  # commanding the drone again
    "supervisor": ["/landing_allowed"],                   # latched, published once it has taken over
    "emergency": ["/emergency/state"],                    # latched, published at start
    "cmd_vel_mux": ["/ardrone/cmd_vel"],
    "summit_moves": ["/robotnik_base_control/cmd_vel"],
}


class Kill:
    """One kill_node event: whom, when, and when (if) the node published again."""

    def __init__(self, name, signal_name, pid, t_sim, t_wall):
        self.name, self.signal, self.pid = name, signal_name, pid
        self.t_sim, self.t_wall = t_sim, t_wall
        self.recovered_sim = self.recovered_wall = self.topic = None
        self.error = None

    def as_dict(self):
        return {"name": self.name, "signal": self.signal, "pid": self.pid, "at_s": round(self.t_sim, 3),
                "recovered_topic": self.topic,
                "recovered_after_s": None if self.recovered_sim is None else round(self.recovered_sim - self.t_sim, 3),
                "recovered_after_wall_s": None if self.recovered_wall is None else
                round(self.recovered_wall - self.t_wall, 3),
                "error": self.error}


class FaultInjector:
    """Kills nodes of the run whose process trees start at ``roots()`` (pids) and times their recovery."""

    def __init__(self, rospy, roots):
        self.rospy, self.roots = rospy, roots
        self.kills = []
        self._lock = threading.Lock()
        self._subscribers = {}  # topic -> rospy.Subscriber (AnyMsg)

    def prepare(self, names):
        """Subscribe now to what tells the nodes ``names`` are back: a subscription made at the kill would need the
        master, which may be dead by then (rospy then waits for it for ever)."""
        for name in names:
            for topic in RECOVERY_TOPICS.get(name.strip("/"), []):
                self._watch(topic)

    def kill(self, name, signal_name, t_sim):
        name = name.strip("/")
        nodes = processes.nodes_below(self.roots())
        pid = nodes.get(name)
        record = Kill(name, signal_name, pid, t_sim, time.monotonic())
        with self._lock:
            self.kills.append(record)
        if pid is None:
            record.error = "no process of node %r in this run (nodes: %s)" % (name, ", ".join(sorted(nodes)))
            self.rospy.logwarn("kill_node: %s", record.error)
            return record
        try:
            os.kill(pid, getattr(signal, "SIG" + signal_name))
        except ProcessLookupError:
            record.error = "node %r (pid %d) was already gone" % (name, pid)
        self.rospy.loginfo("kill_node: SIG%s to %s (pid %d) at t=%.2f s", signal_name, name, pid, t_sim)
        return record

    def _watch(self, topic):
        with self._lock:
            if topic in self._subscribers:
                return
            self._subscribers[topic] = self.rospy.Subscriber(topic, self.rospy.AnyMsg,
                                                             lambda m, topic=topic: self._on_message(topic, m),
                                                             queue_size=50)

    def _on_message(self, topic, msg):
        caller = (getattr(msg, "_connection_header", None) or {}).get("callerid", "").strip("/")
        now_wall = time.monotonic()
        with self._lock:
            for record in self.kills:
                if record.name == caller and record.recovered_wall is None and record.error is None \
                        and topic in RECOVERY_TOPICS.get(caller, []):
                    record.recovered_wall, record.topic = now_wall, topic
                    record.recovered_sim = self.rospy.get_time()

    def mark_recovered(self, name, t_sim, what):
        """For a node the runner restarts itself (the flight recorder): it is back at ``t_sim``."""
        with self._lock:
            for record in self.kills:
                if record.name == name and record.recovered_wall is None:
                    record.recovered_wall, record.recovered_sim, record.topic = time.monotonic(), t_sim, what

    def close(self):
        with self._lock:
            subscribers, self._subscribers = list(self._subscribers.values()), {}
        for subscriber in subscribers:
            subscriber.unregister()

    def results(self):
        with self._lock:
            return [record.as_dict() for record in self.kills]
