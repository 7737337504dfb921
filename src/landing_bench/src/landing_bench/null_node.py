"""A null node of the graph floor (landing_bench.graph_floor), rospy: the transport of one rospy node of the landing
graph without its work.

It reads ``~null_spec`` (graph_floor.NodeShape.null_spec: {"subscribes": [{topic, type}], "publishes": [{topic,
type, rate_hz, md5sum, definition, data: the serialised default message}], "acks": [{input, period, rate_hz}],
"driver": {timer_hz, input, hz}}), subscribes to every topic with its real message class (a Python node deserialises
what it receives), and publishes the default message of each publication at its rate on the events of its driver (a
timer, or an input: NodeShape.driver). It acknowledges what the real node acknowledges.
"""
import rospy

from landing_runtime.lockstep import LockstepAcker
from landing_runtime.rospy_node import direct_publisher, exit_promptly, init_node, spin, spin_at


class Publication:
    """A default message published ``rate_hz`` times per sim second, on events of a driver at ``driver_hz``."""

    def __init__(self, spec, driver_hz):
        import roslib.message
        message_class = roslib.message.get_message_class(spec["type"])
        if message_class is None or message_class._md5sum != spec["md5sum"]:
            raise ValueError("message type %s of %s is not the one built here" % (spec["type"], spec["topic"]))
        self.message = message_class().deserialize(spec["data"].data)  # an XML-RPC binary
        self.publisher = direct_publisher(spec["topic"], message_class)
        self.share = spec["rate_hz"] / driver_hz if driver_hz > 0 else 1.0
        self.credit = 0.0

    def on_driver_event(self):
        self.credit += self.share
        while self.credit >= 1.0 - 1e-9:  # (the shares' rounding must not drop a message)
            self.credit -= 1.0
            self.publisher.publish(self.message)


class NullNode:
    def __init__(self, spec):
        import roslib.message
        acks, driver = spec.get("acks", []), spec["driver"]
        self.rate_hz, self.driver = driver["timer_hz"], driver["input"]
        timer = next((a for a in acks if a["period"] > 0), None)
        self.timer_ack = LockstepAcker(period=timer["period"]) if timer is not None else None
        self.publications = [Publication(p, driver["hz"]) for p in spec.get("publishes", [])]
        input_acks = {a["input"]: LockstepAcker(a["input"]) for a in acks if a["period"] <= 0}
        self.subscribers = []
        for sub in spec.get("subscribes", []):
            message_class = roslib.message.get_message_class(sub["type"])
            if message_class is None:
                raise ValueError("message type %s of %s is not built here" % (sub["type"], sub["topic"]))
            self.subscribers.append(rospy.Subscriber(
                sub["topic"], message_class, self._received, callback_args=(sub["topic"], input_acks.get(sub["topic"])),
                tcp_nodelay=True))

    def _received(self, message, args):
        topic, acker = args
        if acker is not None:
            acker.ack(message.header.stamp)
        if topic == self.driver:  # ("" for a timer: no topic)
            self._publish_due()

    def _publish_due(self):
        for publication in self.publications:
            publication.on_driver_event()

    def tick(self):
        self._publish_due()
        if self.timer_ack is not None:
            self.timer_ack.ack(rospy.Time.now())

    def spin(self):
        if self.rate_hz:
            spin_at(self.rate_hz, self.tick)
        else:
            spin()


def main():
    init_node("null_node")
    spec = rospy.get_param("~null_spec", None)
    if not isinstance(spec, dict):
        rospy.logfatal("%s: required parameter ~null_spec (set by landing_bench.graph_floor) is missing",
                       rospy.get_name())
        return 2
    try:
        node = NullNode(spec)
    except (ValueError, KeyError, TypeError) as err:
        rospy.logfatal("%s: bad ~null_spec: %s", rospy.get_name(), err)
        return 2
    node.spin()
    return 0


if __name__ == "__main__":
    exit_promptly(main())
