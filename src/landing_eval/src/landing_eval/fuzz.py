"""Seeded garbage on every input topic of a flying graph (a scenario's `fuzz:` block), and what became of it.

The fuzzer (``python -m landing_eval.fuzz``, started by run_scenario against the run's master) finds every
topic a node of the graph subscribes to and, from ``start_s`` for ``duration_s`` of sim time, publishes on each
about once every ``period_s`` a copy of the latest real message with one thing wrong:

- a number NaN, +-inf or huge (1e30) in any float field (positions, velocities, quaternions, covariances, ...);
- the header's frame_id of another tree, its stamp minutes in the past or in the future;
- per type: an image of zero size, with a wrong encoding, cut short or claiming huge dimensions; an empty
  path or one whose poses go back in time; a text that is empty, 10 kB long or no known word; a navdata
  state code that does not exist; a lock-step acknowledgement in another node's name or with a negative
  period;

and every ``burst_every_s`` one topic after the other (in a seeded order) gets a burst: its latest message
repeated at ten times its rate for a second.

Not fuzzed: /clock (the time base every node runs on: garbage there is another simulation, not garbage
input), /rosout (logging), /mujoco_sim/fault (the tests' fault-injection hook: its valid messages are faults)
and std_msgs/Empty topics (take-off, land, reset, start: every Empty is a valid command, there is nothing to
garble).

``summary()`` (ROS-free) then says per topic what was sent and which of its subscribers logged a rejection
naming it, and checks that no node logged the same kind of problem more often than once per throttle period."""
import argparse
import copy
import json
import math
import os
import random
import re
import subprocess
import sys
import time

EXCLUDED = {
    "/clock": "the simulation's time base",
    "/rosout": "logging",
    "/mujoco_sim/fault": "the tests' fault-injection hook (its valid messages are faults)",
}
NOT_NODES = ("/scenario_runner", "/flight_recorder", "/input_fuzzer", "/rosout")
# Subscriptions that look only at a message's arrival (the supervisor's and the station's sensor watchdogs): garbage counts as
# a sign of life there, nothing to reject.
ARRIVAL_ONLY = {(node, topic) for node in ("/supervisor", "/station")
                for topic in ("/ardrone/bottom/camera_info", "/ardrone/imu", "/ardrone/gps/odom")} | \
    {("/supervisor", "/ardrone/sonar_height")}
BURST_FACTOR, BURST_S = 10.0, 1.0
REJECTION_PERIOD_S = 5.0  # the nodes' throttle of a rejection line (input_check.RejectionLog, warn_period)
READY_FILE, COUNTS_FILE = "fuzz_ready", "fuzz.json"


def command(cfg, out_dir):
    """The fuzzer's command line for a scenario's validated `fuzz:` block."""
    return [sys.executable, "-m", "landing_eval.fuzz", "--out", out_dir, "--seed", str(cfg["seed"]),
            "--start", str(cfg["start_s"]), "--duration", str(cfg["duration_s"]), "--period", str(cfg["period_s"]),
            "--burst-every", str(cfg["burst_every_s"]), "__name:=input_fuzzer"]


def wait_until_ready(out_dir, process, deadline):
    """Until the fuzzer's publishers are connected to every subscriber (it writes READY_FILE)."""
    path = os.path.join(out_dir, READY_FILE)
    while not os.path.isfile(path):
        if not process.alive():
            raise RuntimeError("the input fuzzer exited with code %s; see %s" % (process.process.returncode,
                                                                                process.log_path))
        if time.monotonic() > deadline:
            raise TimeoutError("the input fuzzer did not connect to the graph in time; see %s" % process.log_path)
        time.sleep(0.05)


def wait_until_ended(process, timeout):
    """Until the interrupted fuzzer has written what it sent and exited, for at most ``timeout`` wall seconds (then
    the summary reads its last periodic save, and says no more than that file)."""
    try:
        process.process.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        pass


# ----- garbage, ROS-free but for the message classes ------------------------------------------------------
FLOAT_TYPES = ("float64", "float32")


def float_fields(msg, prefix=()):
    """Every float field of a message, recursively (the first element of an array of messages): tuples
    (path to the owner as ((attribute, index or None), ...), field name, index in an array field or None, type)."""
    found = []
    for name, kind in zip(msg.__slots__, msg._slot_types):
        value, base = getattr(msg, name), kind.split("[")[0]
        if base in FLOAT_TYPES:
            found += [(prefix, name, i, base) for i in range(len(value))] if "[" in kind else [(prefix, name, None, base)]
        elif hasattr(value, "_slot_types"):
            found += float_fields(value, prefix + ((name, None),))
        elif "[" in kind and value and hasattr(value[0], "_slot_types"):
            found += float_fields(value[0], prefix + ((name, 0),))
    return found


def field_label(field):
    prefix, name, index, _ = field
    parts = ["%s[%d]" % (a, i) if i is not None else a for a, i in prefix] + [name]
    return ".".join(parts) + ("[%d]" % index if index is not None else "")


def set_float(msg, field, value):
    """Set one of float_fields(msg) to ``value`` (an array field, possibly a tuple, is rebuilt as a list)."""
    prefix, name, index, _ = field
    owner = msg
    for attribute, i in prefix:
        owner = getattr(owner, attribute)
        owner = owner[i] if i is not None else owner
    if index is None:
        setattr(owner, name, value)
    else:
        values = list(getattr(owner, name))
        values[index] = value
        setattr(owner, name, values)


def garble_string(rng):
    return rng.choice(["", "fuzz-%08x" % rng.getrandbits(32), "x" * 10000, '{"fault": ', "\t \n",
                       "landing; rm -rf /", "%s%s%s", "NaN"])


def garble(msg_type, template, rng, now):
    """(kind, message): a copy of ``template`` (or a fresh message of class ``msg_type``) with one thing wrong,
    stamped ``now`` unless the stamp is what is wrong; None when this type offers nothing to garble (Bool)."""
    import rospy
    msg = copy.deepcopy(template) if template is not None else msg_type()
    header = getattr(msg, "header", None)
    if header is not None:
        header.stamp = rospy.Time.from_sec(max(now, 1e-3))
    kinds = []
    floats = float_fields(msg)
    if floats:
        kinds += ["nan", "inf", "huge"]
    if header is not None:
        kinds += ["wrong frame", "stamp from the past", "stamp from the future"]
    type_name = msg._type
    if type_name == "sensor_msgs/Image":
        kinds = ["zero size", "wrong encoding", "cut short", "huge dimensions", "stamp from the past",
                 "stamp from the future", "wrong frame"]
    elif type_name == "nav_msgs/Path":
        kinds += ["empty", "poses going back"]
    elif type_name == "std_msgs/String":
        kinds = ["text"]
    elif type_name == "landing_msgs/Navdata":
        kinds += ["unknown state"]
    elif type_name == "landing_msgs/LockstepAck":
        kinds = ["another node's name", "negative period", "stamp from the future"]
    if not kinds:
        return None
    kind = rng.choice(kinds)
    if kind in ("nan", "inf", "huge"):
        field = rng.choice(floats)
        value = {"nan": math.nan, "inf": rng.choice([math.inf, -math.inf]),
                 "huge": rng.choice([1e30, -1e30]) if field[3] == "float32" else rng.choice([1e30, -1e300, 1e300])}[kind]
        set_float(msg, field, value)
        kind = "%s in %s" % (kind, field_label(field))
    elif kind == "wrong frame":
        header.frame_id = "fuzz_frame_%d" % rng.randrange(1000)
    elif kind == "stamp from the past":
        header.stamp = rospy.Time.from_sec(max(1e-3, now - rng.uniform(5.0, 1000.0)))
    elif kind == "stamp from the future" and type_name == "landing_msgs/LockstepAck":
        msg.stamp = rospy.Time.from_sec(now + rng.uniform(5.0, 1000.0))
    elif kind == "stamp from the future":
        header.stamp = rospy.Time.from_sec(now + rng.uniform(5.0, 1000.0))
    elif kind == "zero size":
        msg.width = msg.height = msg.step = 0
        msg.data = b""
    elif kind == "wrong encoding":
        msg.width, msg.height, msg.step = 320, 240, 960
        msg.encoding = rng.choice(["jpeg", "mono16", "bgra8", "fuzz8", ""])
        msg.data = bytes(960 * 240)
    elif kind == "cut short":
        msg.width, msg.height, msg.step, msg.encoding = 320, 240, 960, "rgb8"
        msg.data = bytes(rng.randrange(0, 960 * 240))
    elif kind == "huge dimensions":
        msg.width, msg.height, msg.step, msg.encoding = 4000000, 3000000, 12000000, "rgb8"
        msg.data = bytes(960)
    elif kind == "empty":
        msg.poses = []
    elif kind == "poses going back":
        msg.poses = list(reversed(msg.poses)) if len(msg.poses) > 1 else msg.poses * 2
    elif kind == "text":
        msg.data = garble_string(rng)
    elif kind == "unknown state":
        msg.state = rng.choice([11, 99, 200, 255])
    elif kind == "another node's name":
        msg.node = rng.choice(["/fuzz_ghost", "/supervisor", "/platform_detection", ""])
        msg.stamp = rospy.Time.from_sec(max(1e-3, now - 1.0))
    elif kind == "negative period":
        msg.period = rospy.Duration.from_sec(-rng.uniform(0.01, 100.0))
    if type_name == "sensor_msgs/Image" and kind.startswith("stamp"):
        msg.width, msg.height, msg.step, msg.encoding = 320, 240, 960, "rgb8"
        msg.data = bytes(960 * 240)
    return kind, msg


# ----- the fuzzer node ------------------------------------------------------------------------------------
class Fuzzer:
    def __init__(self, args):
        import rosgraph
        import rospy
        from roslib.message import get_message_class
        self.rospy, self.args = rospy, args
        self.rng = random.Random(args.seed)
        master = rosgraph.Master(rospy.get_name())
        _, subscriptions, _ = master.getSystemState()
        types = dict(master.getTopicTypes())
        self.topics, self.skipped = {}, {}
        for topic, nodes in sorted(subscriptions):
            nodes = sorted(n for n in nodes if n not in NOT_NODES)
            if not nodes:
                continue
            if topic in EXCLUDED:
                self.skipped[topic] = EXCLUDED[topic]
            elif types.get(topic) == "std_msgs/Empty":
                self.skipped[topic] = "std_msgs/Empty: every message is a valid command"
            elif types.get(topic) in (None, "*"):
                self.skipped[topic] = "no type known"
            else:
                self.topics[topic] = {"type": types[topic], "class": get_message_class(types[topic]),
                                      "subscribers": nodes}
        self.latest, self.arrivals = {}, {}
        self.publishers = {}
        for topic, info in self.topics.items():
            self.publishers[topic] = rospy.Publisher(topic, info["class"], queue_size=200)
            if info["type"] != "sensor_msgs/Image":  # images are built from scratch: 230 kB a frame saved
                rospy.Subscriber(topic, info["class"], lambda m, topic=topic: self._remember(topic, m), queue_size=1)
        self.counts = {topic: {} for topic in self.topics}
        self.bursts = []
        self.first_t = self.last_t = None

    def _remember(self, topic, msg):
        if (getattr(msg, "_connection_header", None) or {}).get("callerid") == self.rospy.get_name():
            return  # our own garbage
        self.latest[topic] = msg
        times = self.arrivals.setdefault(topic, [])
        times.append(self.rospy.get_time())
        del times[:-20]

    def rate(self, topic):
        """Messages per sim second on ``topic`` lately (None if unknown)."""
        times = self.arrivals.get(topic, [])
        if len(times) < 3 or times[-1] <= times[0]:
            return None
        return (len(times) - 1) / (times[-1] - times[0])

    def wait_connected(self, timeout=60.0):
        import rosgraph
        master = rosgraph.Master(self.rospy.get_name())
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            subscribers = dict(master.getSystemState()[1])
            pending = [t for t, p in self.publishers.items()
                       if p.get_num_connections() < len([n for n in subscribers.get(t, []) if n != self.rospy.get_name()])]
            if not pending:
                return
            time.sleep(0.1)
        self.rospy.logwarn("input fuzzer: still not connected on %s", pending[:5])

    def count(self, topic, kind):
        kind = kind.split(" in ")[0]
        self.counts[topic][kind] = self.counts[topic].get(kind, 0) + 1

    def save(self):
        data = {"topics": {t: {"type": i["type"], "subscribers": i["subscribers"], "sent": self.counts[t]}
                           for t, i in self.topics.items()},
                "skipped": self.skipped, "bursts": self.bursts, "first_t": self.first_t, "last_t": self.last_t,
                "period_s": self.args.period, "seed": self.args.seed}
        path = os.path.join(self.args.out, COUNTS_FILE)
        with open(path + ".tmp", "w") as stream:
            json.dump(data, stream, indent=1)
        os.replace(path + ".tmp", path)

    def run(self):
        rospy, rng, args = self.rospy, self.rng, self.args
        end = args.start + args.duration
        order = sorted(self.topics)
        rng.shuffle(order)
        burst_topics = list(order)
        next_garbage = {t: args.start + rng.expovariate(1.0 / args.period) for t in order}
        next_burst, burst = args.start + args.burst_every / 2.0, None
        saved_wall = time.monotonic()
        while not rospy.is_shutdown():
            t = rospy.get_time()
            if t >= end:
                break
            if t >= args.start:
                self.first_t = self.first_t if self.first_t is not None else round(t, 3)
                self.last_t = round(t, 3)
                for topic in order:
                    if t >= next_garbage[topic]:
                        next_garbage[topic] = t + rng.expovariate(1.0 / args.period)
                        self._send_garbage(topic, t)
                if burst is None and t >= next_burst and burst_topics:
                    topic = burst_topics[len(self.bursts) % len(burst_topics)]
                    burst = self._start_burst(topic, t)
                    next_burst = t + args.burst_every
                if burst is not None:
                    burst = self._continue_burst(burst, t)
            if time.monotonic() - saved_wall > 5.0:
                self.save()
                saved_wall = time.monotonic()
            time.sleep(0.002)
        self.save()

    def _send_garbage(self, topic, t):
        info = self.topics[topic]
        made = garble(info["class"], self.latest.get(topic), self.rng, t)
        if made is None:
            return
        kind, msg = made
        try:
            self.publishers[topic].publish(msg)
        except Exception as err:  # a value the message type cannot even carry: that is not input anyone gets
            self.count(topic, "unserialisable (%s)" % type(err).__name__)
            return
        self.count(topic, kind)

    def _start_burst(self, topic, t):
        info = self.topics[topic]
        template = self.latest.get(topic)
        if info["type"] == "sensor_msgs/Image":
            template = info["class"](width=320, height=240, step=960, encoding="rgb8", data=bytes(960 * 240))
            template.header.frame_id = "ardrone/bottom_camera"
        if template is None:
            self.bursts.append({"topic": topic, "at_s": round(t, 3), "sent": 0, "note": "no message seen yet"})
            return None
        rate = (self.rate(topic) or 20.0) * BURST_FACTOR
        record = {"topic": topic, "at_s": round(t, 3), "rate_hz": round(rate, 1), "sent": 0}
        self.bursts.append(record)
        return {"topic": topic, "template": template, "interval": 1.0 / rate, "next": t, "until": t + BURST_S,
                "record": record}

    def _continue_burst(self, burst, t):
        while t >= burst["next"] and burst["next"] < burst["until"]:
            msg = copy.deepcopy(burst["template"])
            if hasattr(msg, "header") and self.topics[burst["topic"]]["type"] == "sensor_msgs/Image":
                msg.header.stamp = self.rospy.Time.from_sec(t)
            self.publishers[burst["topic"]].publish(msg)
            burst["record"]["sent"] += 1
            self.count(burst["topic"], "burst")
            burst["next"] += burst["interval"]
        return None if burst["next"] >= burst["until"] else burst


def main(argv=None):
    import rospy
    parser = argparse.ArgumentParser(description="Publish seeded garbage on every input topic of the running graph.")
    parser.add_argument("--out", required=True, help="directory for fuzz.json (what was sent) and fuzz_ready")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--start", type=float, default=5.0, help="sim time of the first garbage [s]")
    parser.add_argument("--duration", type=float, default=60.0, help="sim seconds of garbage")
    parser.add_argument("--period", type=float, default=1.0, help="mean sim seconds between two garbage messages "
                                                                    "on one topic")
    parser.add_argument("--burst-every", type=float, default=10.0, help="sim seconds between two bursts")
    args = parser.parse_args(rospy.myargv(argv if argv is not None else sys.argv)[1:])
    from landing_runtime.rospy_node import init_node
    init_node("input_fuzzer")
    fuzzer = Fuzzer(args)
    fuzzer.wait_connected()
    fuzzer.save()
    with open(os.path.join(args.out, READY_FILE), "w") as stream:
        stream.write("%d topics\n" % len(fuzzer.topics))
    rospy.loginfo("input fuzzer: %d topics from t=%.1f s for %.1f s, garbage every %.2f s a topic; skipped %s",
                  len(fuzzer.topics), args.start, args.duration, args.period, ", ".join(sorted(fuzzer.skipped)))
    fuzzer.run()
    return 0


# ----- what became of it (ROS-free) -----------------------------------------------------------------------
_NUMBERS = re.compile(r"-?\d+(\.\d+)?(e[-+]?\d+)?")
_KIND = re.compile(r"rejected input on (\S+) \[([^\]]+)\]")


def summary(out_dir, warnings, cfg, period_s=REJECTION_PERIOD_S):
    """What the fuzz sent and what the nodes said about it: ``warnings`` are (sim s, node, text) of the run's
    WARN and worse log lines (stamped with the clock the nodes throttle on). Per topic: garbage sent by kind, the subscribers that logged a rejection naming
    it and those that never did; and every (node, kind of line) logged more often than once per ``period_s``
    (a rejection not throttled)."""
    try:
        with open(os.path.join(out_dir, COUNTS_FILE)) as stream:
            sent = json.load(stream)
    except (OSError, ValueError) as err:
        return {"error": "no fuzz record: %s" % err}
    topics = {}
    for topic, info in sent["topics"].items():
        content = {k: n for k, n in info["sent"].items() if k != "burst"}
        complained = sorted({node for _, node, text in warnings if topic in text and node in info["subscribers"]})
        expected = [n for n in info["subscribers"] if (n, topic) not in ARRIVAL_ONLY]
        topics[topic] = {"type": info["type"], "sent": info["sent"], "rejected_by": complained,
                         "never_rejected_by": sorted(set(expected) - set(complained)) if content else []}
    lines = {}
    for t, node, text in warnings:
        match = _KIND.search(text)
        key = (node, "%s [%s]" % match.groups() if match else _NUMBERS.sub("#", text)[:120])
        lines.setdefault(key, []).append(t)
    unthrottled = []
    for (node, what), times in sorted(lines.items()):
        span = max(times) - min(times)
        allowed = int(span / period_s) + 2  # the first line, one per period, and one for timing slack
        if len(times) > allowed:
            unthrottled.append({"node": node, "line": what, "count": len(times), "over_s": round(span, 1)})
    total = sum(n for info in sent["topics"].values() for n in info["sent"].values())
    return {"topics": topics, "skipped": sent["skipped"], "bursts": sent["bursts"], "messages_sent": total,
            "sim_time_fuzzed_s": round((sent["last_t"] or 0.0) - (sent["first_t"] or 0.0), 2)
            if sent.get("first_t") is not None else 0.0,
            "warning_lines": len(warnings), "unthrottled": unthrottled}


if __name__ == "__main__":
    sys.exit(main())
