"""preflight node: the pre-flight check (interface.preflight) on the live inputs, at 2 Hz of ROS time.

In: the topics of ~topics (any type: their arrival is what counts), the NavSatFix topics of ~fix_topics,
~camera_info_topic (CameraInfo), ~camera_status_topic (the drone adapter's ~status; '' for none), drone/navdata
(battery, and the link's latency as arrival minus stamp). Out: preflight/status (landing_msgs/PreflightStatus,
latched, on change). A missing or bad parameter stops the node with its name."""
import sys

import rospy
from landing_msgs.msg import Navdata, PreflightStatus
from landing_runtime.rospy_node import NodeHandles, run_node, spin_at
from rospy.msg import AnyMsg
from sensor_msgs.msg import CameraInfo, NavSatFix
from std_msgs.msg import String

from .preflight import PreflightCheck

RATE_HZ = 2.0
NUMBERS = {"window_s": (0.5, 60.0), "min_battery_percent": (0.0, 100.0), "max_link_latency_s": (0.001, 10.0)}


class SettingsError(ValueError):
    pass


def read_settings():
    values = rospy.get_param("~")
    settings = {}
    for key, (low, high) in NUMBERS.items():
        value = values.get(key)
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not low <= value <= high:
            raise SettingsError("preflight: parameter ~%s must be a number in [%g, %g], got %r (config/preflight.yaml)"
                                % (key, low, high, value))
        settings[key] = float(value)
    topics = values.get("topics")
    if not isinstance(topics, list) or not all(
            isinstance(t, dict) and isinstance(t.get("name"), str) and not isinstance(t.get("min_rate_hz"), bool)
            and isinstance(t.get("min_rate_hz"), (int, float)) and t["min_rate_hz"] > 0 for t in topics):
        raise SettingsError("preflight: parameter ~topics must be a list of {name: topic, min_rate_hz: > 0}, got %r"
                            % (topics,))
    settings["topics"] = {t["name"]: float(t["min_rate_hz"]) for t in topics}
    for key in ("fix_topics",):
        value = values.get(key)
        if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
            raise SettingsError("preflight: parameter ~%s must be a list of topic names, got %r" % (key, value))
        settings[key] = value
    for key in ("camera_info_topic", "camera_status_topic"):
        value = values.get(key)
        if not isinstance(value, str):
            raise SettingsError("preflight: parameter ~%s must be a topic name ('' for none), got %r" % (key, value))
        settings[key] = value
    return settings


class PreflightNode:
    def __init__(self):
        self.check = PreflightCheck(read_settings())
        s = self.check.s
        self.handles = NodeHandles()
        self.pub = self.handles.latched(rospy.Publisher("preflight/status", PreflightStatus, queue_size=1, latch=True))
        # A node has one subscription per topic: the topics read for their content count their arrivals there.
        typed = {s["camera_info_topic"]: (CameraInfo, lambda m: self.check.calibration(m.K[0], m.D)),
                 "drone/navdata": (Navdata, self._on_navdata)}
        for topic, (kind, use) in typed.items():
            self.handles.subscriber(topic, kind, self._counted(topic, use), queue_size=5)
        for topic in s["topics"]:
            if topic not in typed:
                self.handles.subscriber(topic, AnyMsg, self._counted(topic, None), queue_size=50)
        for topic in s["fix_topics"]:
            self.handles.subscriber(topic, NavSatFix, lambda m, topic=topic: self.check.fix(topic, m.status.status),
                                    queue_size=5)
        if s["camera_status_topic"]:
            self.handles.subscriber(s["camera_status_topic"], String, lambda m: self.check.camera_selection(m.data),
                                    queue_size=1)
        self.last = None

    def _counted(self, topic, use):
        def callback(msg):
            if topic in self.check.meters:
                self.check.arrived(topic, rospy.get_time())
            if use is not None:
                use(msg)
        return callback

    def _on_navdata(self, msg):
        self.check.navdata(msg.battery_percent, rospy.get_time() - msg.header.stamp.to_sec())

    def tick(self):
        items = self.check.items(rospy.get_time())
        status = ([item.line() for item in items], [item.name for item in items if not item.ok])
        if status != self.last:
            self.last = status
            if status[1]:
                rospy.loginfo("preflight: not ready: %s", "; ".join(line for line in status[0] if ": ok" not in line))
            else:
                rospy.loginfo("preflight: ready (%d items)", len(items))
        # Each tick, not only on a change: a reader checks the stamp against its clock (a stale verdict is no verdict).
        msg = PreflightStatus(ready=not status[1], items=status[0], failed=status[1])
        msg.header.stamp = rospy.Time.now()
        self.pub.publish(msg)

    def spin(self):
        spin_at(RATE_HZ, self.tick)


def main():
    return run_node("preflight", PreflightNode, startup_errors=(SettingsError,))


if __name__ == "__main__":
    sys.exit(main())
