"""Drives the vehicle along a scripted path by publishing robotnik_base_control/cmd_vel in sim time.

Restarted after a crash (respawn in summit_moves.launch), it carries on along the same path from where the
vehicle was on it: the path's start time is kept in the private parameter ~started_at with ~launch_id (unique
to each roslaunch, kept across respawns).

``~reset`` (std_srvs/Trigger, between the scenarios of a warm graph) starts afresh from the parameters as they are
then: the path starts again (after the next ardrone/takeoff with ~start_on_takeoff), and ~started_at is forgotten,
so that a crash before the new path starts does not resume the previous scenario's path. A bad parameter refuses
the reset and the path goes on."""
import math
import sys

import rospy
from geometry_msgs.msg import Twist
from landing_runtime.lockstep import LockstepAcker
from landing_runtime.rospy_node import NodeHandles, direct_publisher, run_node
from std_msgs.msg import Empty

from .paths import PATHS, Path, PathError


class StartupError(RuntimeError):
    """A missing or bad parameter; the message names it."""


def _required(name):
    if not rospy.has_param(name):
        raise StartupError("summit_moves: required parameter '%s' is not set (see summit_moves/config/path.yaml)"
                           % name)
    return rospy.get_param(name)


def _number(name, convert=float, lowest=-math.inf):
    value = _required(name)
    try:
        number = convert(value)
    except (ValueError, TypeError):
        raise StartupError("summit_moves: parameter '%s' must be a number, got %r" % (name, value))
    if not (math.isfinite(number) and number >= lowest):
        raise StartupError("summit_moves: parameter '%s' must be a finite number >= %g, got %r" % (name, lowest, value))
    return number


def _path():
    kind = _required("~path")
    if kind not in PATHS:
        raise StartupError("summit_moves: parameter '~path' must be one of %s, got %r" % (", ".join(PATHS), kind))
    speed, radius, seed = _number("~speed"), _number("~radius"), _number("~seed", int)
    try:
        return Path(kind, speed, radius, seed)
    except PathError as err:  # names speed or radius
        raise StartupError("summit_moves: bad path parameter (~speed %r, ~radius %r): %s" % (speed, radius, err))


class SummitMovesNode:
    """One path from the parameters as they are at construction; ``tick()`` publishes its command at ``rate_hz``.
    ``carry_on``: the first object of a process resumes the path a crashed predecessor of the same launch started;
    an object made by a reset starts afresh and forgets that start."""

    def __init__(self, carry_on=False):
        self.path = _path()
        self.rate_hz = _number("~rate_hz")
        if self.rate_hz <= 0.0:
            raise StartupError("summit_moves: parameter '~rate_hz' must be positive, got %r" % self.rate_hz)
        self.start_delay = _number("~start_delay", lowest=0.0)
        self.takeoff_seen = not bool(_required("~start_on_takeoff"))  # the path may start
        self.launch_id = rospy.get_param("~launch_id", None)
        # Every parameter is valid from here on: nothing below may refuse the reset.
        self.start_time = self._saved_start() if carry_on else None
        if not carry_on:
            self._forget_saved_start()
        self.last_now = None  # to notice ROS time moving back (the simulator restarted): the path starts again
        self.handles = NodeHandles()
        self.publisher = direct_publisher("robotnik_base_control/cmd_vel", Twist)
        self.handles.subscriber("ardrone/takeoff", Empty, self._on_takeoff, queue_size=1)
        self.lockstep = LockstepAcker(period=1.0 / self.rate_hz)
        if self.start_time is not None:
            self.takeoff_seen = True
            rospy.logwarn("summit_moves: restarted; carrying on along the path started at t=%.2f s", self.start_time)
        rospy.loginfo("summit_moves: %s path at %.2f m/s (radius %.1f m)%s", self.path.kind, self.path.speed,
                      self.path.radius, "" if self.takeoff_seen else ", from the drone's take-off on")

    def _saved_start(self):
        """The path's start time a crashed predecessor of this launch kept, or None."""
        saved = rospy.get_param("~started_at", None)
        if isinstance(saved, dict) and self.launch_id is not None and saved.get("launch_id") == self.launch_id and \
                isinstance(saved.get("time"), (int, float)):
            return saved["time"]
        return None

    @staticmethod
    def _forget_saved_start():
        try:
            rospy.delete_param("~started_at")
        except KeyError:  # nothing kept yet
            pass
        except Exception as err:  # the master is gone: there will be no respawn to mislead either
            rospy.logwarn("summit_moves: cannot forget the previous path's start time: %s", err)

    def _on_takeoff(self, _msg):
        self.takeoff_seen = True

    def tick(self):
        stamp = rospy.Time.now()
        now = stamp.to_sec()
        if self.last_now is not None and now < self.last_now:
            self.start_time = None
        self.last_now = now
        if self.takeoff_seen and self.start_time is None:
            self.start_time = now + self.start_delay
            try:
                rospy.set_param("~started_at", {"time": self.start_time, "launch_id": self.launch_id})
            except Exception as err:  # the master is gone: a restart would start the path afresh
                rospy.logwarn("summit_moves: cannot keep the path's start time for a restart: %s", err)
        speed, yaw_rate = self.path.command(now - self.start_time) if self.start_time is not None else (0.0, 0.0)
        msg = Twist()
        msg.linear.x, msg.angular.z = speed, yaw_rate
        self.publisher.publish(msg)
        self.lockstep.ack(stamp)


def main():
    return run_node("summit_moves", SummitMovesNode, startup_errors=(StartupError,), resettable=True, carries_on=True)


if __name__ == "__main__":
    sys.exit(main())
