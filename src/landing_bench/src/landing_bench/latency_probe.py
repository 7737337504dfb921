"""A probe in the flight's graph that notes when each message of the frame -> command chain arrives (wall clock), and
writes the chain's latencies (landing_bench.frame_latency) to ~out as JSON every few seconds and at its end.

    rosrun landing_bench latency_probe _out:=DIR/latency.json image:=... detection:=... estimate:=... \
        stack_command:=... drone_command:=...

Messages are taken unparsed (rospy.AnyMsg): of an image only its header's stamp is read, so the probe costs the
graph little. compute_budget starts it beside a real-time flight.
"""
import json
import os
import struct
import threading
import time

import rospy

from landing_runtime.rospy_node import init_node, spin

from .frame_latency import ArrivalLog, summary

SAVE_PERIOD_S = 5.0  # wall seconds between two writes of the figures (a probe killed loses no more) [s]
# A std_msgs/Header serialised: uint32 seq, then the stamp as uint32 secs, uint32 nsecs.
HEADER_STAMP = struct.Struct("<III")


def header_stamp_ns(raw):
    """The header stamp [ns] of a serialised message that starts with a std_msgs/Header, or None if it is short."""
    if len(raw) < HEADER_STAMP.size:
        return None
    _, secs, nsecs = HEADER_STAMP.unpack_from(raw)
    return secs * 1000000000 + nsecs


class Probe:
    def __init__(self, out_path):
        self.out_path, self.log, self.lock = out_path, ArrivalLog(), threading.Lock()
        stamped = {"image": self.log.frame, "detection": self.log.detection}
        timed = {"estimate": self.log.estimate, "stack_command": self.log.stack_command,
                 "drone_command": self.log.drone_command}
        # {role: subscriber}: each role's topic is relative, remapped by whoever starts the probe
        self.subscribers = {role: rospy.Subscriber(role, rospy.AnyMsg, self._stamped(note), queue_size=50,
                                                   tcp_nodelay=True) for role, note in stamped.items()}
        self.subscribers.update({role: rospy.Subscriber(role, rospy.AnyMsg, self._timed(note), queue_size=50,
                                                        tcp_nodelay=True) for role, note in timed.items()})

    def _stamped(self, note):
        def heard(msg):
            wall = time.monotonic()
            stamp = header_stamp_ns(msg._buff)
            if stamp is not None:
                with self.lock:
                    note(stamp, wall)
        return heard

    def _timed(self, note):
        def heard(_msg):
            wall = time.monotonic()
            with self.lock:
                note(wall)
        return heard

    def save(self):
        with self.lock:
            figures = summary(self.log)
        figures["topics"] = {role: sub.resolved_name for role, sub in self.subscribers.items()}
        temporary = self.out_path + ".part"
        with open(temporary, "w") as stream:
            json.dump(figures, stream, indent=1)
        os.replace(temporary, self.out_path)


def main():
    init_node("latency_probe")
    out = rospy.get_param("~out", "")
    if not out:
        rospy.logfatal("latency_probe: required parameter '~out' (the JSON file to write) is missing")
        return 2
    probe = Probe(out)
    saver = threading.Thread(target=lambda: _save_every(probe), daemon=True)
    saver.start()
    spin()
    probe.save()
    return 0


def _save_every(probe):
    while not rospy.is_shutdown():
        time.sleep(SAVE_PERIOD_S)
        probe.save()
