"""Start and stop of this workspace's rospy nodes, with three of rospy's defaults mended.

    from landing_runtime.rospy_node import init_node, spin
    init_node("name")   # instead of rospy.init_node("name")
    ...
    spin()              # instead of rospy.spin()

A node that works on a timer (supervisor, emergency, cmd_vel_mux) is a class whose constructor reads its
parameters and whose ``tick()`` runs at its rate:

    def main():
        return run_node("name", NodeClass, startup_errors=(SettingsError,))   # NodeClass.spin: spin_at(rate, tick)

A class that makes its subscribers, latched publishers and services through ``NodeHandles`` can be reset:
``run_node(..., resettable=True)`` offers ``~reset`` (ResettableNode). A node driven by its callbacks alone has
no ``tick()``; run_node then only waits for the shutdown.

- Signals: rospy's handler can deadlock mid-publish (see landing_runtime.shutdown); here a signal starts a
  thread that shuts rospy down.
- Accept backlog: rospy's TCPROS server listens with a backlog of 5 and accepts in one thread. When a
  node subscribes to 20 of a publisher's topics at once (rosbag record does), the kernel drops the
  surplus connection requests and the client retries them after 1 s: the bag then missed the first
  seconds of ground truth and navdata (6 sim-seconds at 6x real time).
- Prompt exit: rospy.spin() looks for the shutdown every 0.5 s and a sleep on sim time every 0.3 s
  once the clock has stopped; here both wake up as soon as rospy shuts down. A node's script ends with
  ``exit_promptly(main())`` instead of ``sys.exit(main())``.
"""
import contextlib
import logging
import os
import socket
import sys
import threading
import warnings

import rospy

from landing_runtime.shutdown import shutdown_on_signals

ACCEPT_BACKLOG = 128  # pending inbound connections the kernel keeps for the TCPROS server [-]


def init_node(name, **kwargs):
    """rospy.init_node(name, **kwargs) and the three mends above (call from the main thread)."""
    rospy.init_node(name, disable_signals=True, **kwargs)
    shutdown_on_signals()
    _after_shutdown_flag(_wake_sleepers)
    widen_accept_backlog()


def widen_accept_backlog(backlog=ACCEPT_BACKLOG):
    """Listen again on rospy's TCPROS server socket with a longer backlog (Linux updates it in place)."""
    from rospy.impl import tcpros_base
    server = tcpros_base.init_tcpros_server()  # the node's server; created by init_node
    server.start_server()  # a no-op once started
    server.tcp_ros_server.server_sock.listen(backlog)


def direct_publisher(topic, data_class, latch=False):
    """A rospy.Publisher that writes each message to its subscribers' sockets in the publishing thread
    (queue_size=None, without rospy's warning about it). For the small messages of the control loop: with a
    queue_size rospy hands every message to a writer thread per connection and yields the CPU after each one
    (QueuedConnection: time.sleep(0)), which cost more than the write itself and, on a loaded machine, delays
    the message by a scheduler slice. A subscriber that stops reading blocks the publisher only once the
    socket's buffer (hundreds of such messages) is full. Sent without Nagle's algorithm (without_nagle)."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*queue_size.*")
        return without_nagle(rospy.Publisher(topic, data_class, queue_size=None, latch=latch))


def unconnected_subscribers(publisher):
    """How many of the subscribers the master lists for ``publisher``'s topic it is not connected to yet: one
    that has registered but not connected would miss a message published now. Raises what the master call
    raises (the master busy or gone)."""
    import rosgraph
    listed = dict(rosgraph.Master(rospy.get_name()).getSystemState()[1]).get(publisher.resolved_name, [])
    return max(0, len(listed) - publisher.get_num_connections())


class _NoDelayListener(rospy.SubscribeListener):
    def __init__(self, publisher):
        super().__init__()
        self.publisher = publisher

    def peer_subscribe(self, _topic, _publish, _publish_single):
        for connection in list(self.publisher.impl.connections):
            sock = getattr(connection, "socket", None)
            if sock is not None:
                try:
                    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                except OSError:  # closed meanwhile
                    pass


def without_nagle(publisher):
    """``publisher`` (a rospy.Publisher), with TCP_NODELAY on the socket of every subscriber that connects: each
    message goes out at once. rospy sets it only when the subscriber asks (tcp_nodelay=True), and rospy's and
    roscpp's own /clock subscriptions, and rosbag's, do not: small messages then waited for the ACK of the
    previous one, which the receiver delays by up to 40 ms, and arrived in bursts. Returns ``publisher``."""
    publisher.impl.add_subscriber_listener(_NoDelayListener(publisher))
    return publisher


def _after_shutdown_flag(callback):
    """Call ``callback()`` once rospy.is_shutdown() is true: rospy.on_shutdown hooks run before that, so
    a loop they wake would see no shutdown and go back to sleep."""
    rospy.core.add_shutdown_hook(lambda _reason: callback())


def _wake_sleepers():
    """rospy.sleep and Rate.sleep wait on the sim-time condition: wake them so they see the shutdown."""
    condition = rospy.rostime.get_rostime_cond()
    with condition:
        condition.notify_all()


def spin():
    """Block until rospy shuts down; returns at once when it does."""
    stopped = threading.Event()
    _after_shutdown_flag(stopped.set)
    while not rospy.is_shutdown():
        stopped.wait(1.0)


@contextlib.contextmanager
def ended_by_shutdown():
    """Around a node's publishing loop: a stop (SIGINT, as roslaunch sends) closes the publishers between the
    loop's is_shutdown() check and a publish, which then raises; that ends the loop quietly instead of with a
    traceback. (rospy closes them in its pre-shutdown hooks, before is_shutdown() turns true.) Any other
    ROSException still raises."""
    try:
        yield
    except rospy.ROSException:
        if not rospy.core.is_shutdown_requested():
            raise


def spin_at(rate_hz, tick, until=lambda: False):
    """Call ``tick()`` at ``rate_hz`` of ROS time (sim time under /use_sim_time) until rospy shuts down or
    ``until()`` is true; not before the clock runs (a scenario holds the physics at first). A jump back in time is
    logged, not fatal."""
    rate = rospy.Rate(rate_hz)
    with ended_by_shutdown():
        while not rospy.is_shutdown() and not until():
            if rospy.get_time() > 0.0:
                tick()
            try:
                rate.sleep()
            except rospy.ROSTimeMovedBackwardsException:
                rospy.logwarn("%s: ROS time moved backwards; carrying on", rospy.get_name())
            except rospy.ROSInterruptException:
                break


def run_node(name, make_node, startup_errors, resettable=False, carries_on=False):
    """main() of a node: init_node(name), ``node = make_node()``, ``node.spin()`` (with ``resettable``: behind
    ~reset, ResettableNode); returns the exit status. A startup error (one of ``startup_errors``: a missing or bad
    parameter) is logged as fatal and gives 2. ``carries_on``: the node keeps state for a respawn after a crash;
    the process's first object is made as ``make_node(carry_on=True)`` (it may take up a crashed predecessor's
    state), an object made by a reset as ``make_node(carry_on=False)`` (a new scenario starts afresh)."""
    init_node(name)
    first, later = make_node, make_node
    if carries_on:
        first, later = (lambda: make_node(carry_on=True)), (lambda: make_node(carry_on=False))
    try:
        node = first()
    except startup_errors as err:
        rospy.logfatal(str(err))
        return 2
    if resettable:
        ResettableNode(node, later, startup_errors).spin()
    else:
        node.spin()
    return 0


class NodeHandles:
    """What one node object holds in rospy that a reset (ResettableNode) must let go of or hand over:
    - its subscribers (``subscriber``), unregistered by ``close``;
    - its latched publishers (``latched``): a fresh node has nothing latched, so the reset drops their latched
      message (``drop_latches``) before the next object is built, and puts it back if that object fails;
    - its services (``service``): rospy refuses a service name twice in one process, so the first object's
      rospy.Service stays and the next object's handler takes it over once that object is in use (``activate``).
    Plain publishers need nothing: the next object's publishers on the same topics share their connections."""

    _services = {}  # resolved service name -> _HandedOverService, one per process

    def __init__(self):
        self._subscribers, self._latched, self._handlers = [], [], []

    def subscriber(self, topic, *args, commands=False, **kwargs):
        """rospy.Subscriber(topic, ...). ``commands``: the topic carries one-shot commands (latched so that a
        respawned node gets the last one), none of which is meant for a node object that a reset has just built.
        rospy hands a new subscriber the last latched message each existing connection received (ros_comm #1852),
        whether or not its publisher still holds it; for a command topic that message is forgotten first."""
        if commands:
            impl = rospy.topics.get_topic_manager().get_subscriber_impl(rospy.resolve_name(topic))
            for connection in list(impl.connections) if impl is not None else []:
                connection.latch = None
        self._subscribers.append(rospy.Subscriber(topic, *args, **kwargs))
        return self._subscribers[-1]

    def latched(self, publisher):
        """``publisher`` (a rospy.Publisher made with latch=True), remembered for drop_latches; returns it."""
        self._latched.append(publisher)
        return publisher

    def service(self, name, service_class, handler):
        """A rospy.Service ``name`` answered by ``handler``: made now for the first object of the process; for a
        later one, ``handler`` answers from ``activate`` on (until then the object in use answers)."""
        resolved = rospy.resolve_name(name)
        shared = NodeHandles._services.get(resolved)
        if shared is None:
            shared = NodeHandles._services[resolved] = _HandedOverService(resolved, service_class, handler)
        elif shared.service_class is not service_class:
            raise ValueError("service %s was offered as %s and now as %s" % (
                resolved, shared.service_class._type, service_class._type))
        self._handlers.append((shared, handler))
        return shared

    def drop_latches(self):
        """Forget every latched message (as a fresh node has none); returns what ``restore_latches`` puts back."""
        dropped = [(publisher.impl, publisher.impl.latch) for publisher in self._latched]
        for impl, _message in dropped:
            impl.latch = None
        return dropped

    @staticmethod
    def restore_latches(dropped):
        for impl, message in dropped:
            if impl.latch is None:  # (the failed object published nothing in its place)
                impl.latch = message

    def activate(self):
        """This object's service handlers answer from now on."""
        for shared, handler in self._handlers:
            shared.handler = handler

    def close(self):
        for subscriber in self._subscribers:
            subscriber.unregister()
        self._subscribers = []


class _HandedOverService:
    """One rospy.Service whose answers come from the handler of the node object in use."""

    def __init__(self, name, service_class, handler):
        self.service_class, self.handler = service_class, handler
        self.service = rospy.Service(name, service_class, lambda request: self.handler(request))


class ResettableNode:
    """A node object (its subscribers, latched publishers and services made through ``handles``, a NodeHandles)
    behind ``~reset`` (std_srvs/Trigger). A timer-driven object has ``tick()`` and ``rate_hz``; an object driven by
    its callbacks alone has neither. A reset builds a new object from the parameters as they are then
    (``make_node``), as a fresh start does, and lets the old one go; a startup error refuses it, and the old
    object goes on. The old object's latched messages are dropped first (a fresh node has none; the new object
    publishes its own). The new object is built before the old one lets go of its subscriptions: rospy gives the new
    subscribers the connections that exist, and hands each the last latched message of each connection at once,
    as a fresh node would get it on connecting. Ticks and resets take turns (a lock): a tick runs whole on one
    object. (The old object's callbacks may still run while the new one is built; they touch only the old
    object.)"""

    def __init__(self, node, make_node, startup_errors):
        from std_srvs.srv import Trigger
        self.node, self.make_node, self.startup_errors = node, make_node, startup_errors
        self.lock = threading.Lock()
        self.generation = 0
        self.service = rospy.Service("~reset", Trigger, self._on_reset)

    def _on_reset(self, _request):
        from std_srvs.srv import TriggerResponse
        with self.lock:
            dropped = self.node.handles.drop_latches()
            try:
                node = self.make_node()
            except self.startup_errors as err:
                NodeHandles.restore_latches(dropped)
                message = "%s not reset (it goes on as it was): %s" % (rospy.get_name(), err)
                rospy.logerr(message)
                return TriggerResponse(success=False, message=message)
            old, self.node = self.node, node
            node.handles.activate()
            self.generation += 1
        old.handles.close()
        rospy.loginfo("%s reset", rospy.get_name())
        return TriggerResponse(success=True, message="%s reset" % rospy.get_name())

    def _tick(self):
        with self.lock:
            self.node.tick()

    def spin(self):
        """spin_at the present object's rate (after a reset, at the new object's from its next tick on); for an
        object without tick(), until rospy shuts down."""
        while not rospy.is_shutdown():
            generation = self.generation
            if not hasattr(self.node, "tick"):
                spin()
                return
            spin_at(self.node.rate_hz, self._tick, until=lambda: self.generation != generation)


def exit_promptly(status=0):
    """End the process with ``status`` (None: 0) once rospy has shut down and every log is flushed, without
    Python's finalization: it tears down every loaded module and took 0.15 s of CPU per node, 0.3 s of wall time
    for a graph of 7 Python nodes stopping together on 2 cores. The nodes keep no file open for writing;
    whatever else must be tidied happens before main() returns."""
    if not rospy.core.is_shutdown():
        rospy.signal_shutdown("main() returned")  # (what rospy's own atexit hook would do)
    logging.shutdown()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # closed, or its reader gone
            pass
    os._exit(status if isinstance(status, int) else 0 if status is None else 1)
