"""A warm graph: the master and nodes of one scenario, kept and reset for the next scenario with the same nodes
instead of stopped and started again (docs/warm_graph.md).

A reset sets the whole parameter tree to what a fresh roslaunch of the next scenario's arguments would set (so the
parameters the nodes wrote while flying, such as a respawn snapshot, are gone too), rebuilds the simulated world
(mujoco_sim/reset_world: ROS time goes on, the new world's time 0 is the ROS time of the reset) and then calls every
other node's ~reset (std_srvs/Trigger) side by side. A scenario whose launch would start other nodes (another
vehicle model is a parameter, but the operator station or the landing stack are nodes) gets a fresh graph."""
import concurrent.futures
import contextlib
import os
import re
import time

SIMULATOR = "/mujoco_sim"
RESET_SERVICE = "reset"        # each node's ~reset
KEPT_PARAMS = ("run_id", "roslaunch")  # what roslaunch itself wrote at the start, not the launch file
LEAVE_GRAPH_S = 10.0           # rospy's shutdown, at most (with the master gone it may wait for ever) [s]
RESET_CALL_S = 60.0            # a node's ~reset (the simulator's reset_world waits up to 60 s itself) at most [s]
_ORIGIN = re.compile(r"its time 0 is ROS time ([0-9.]+) s")


def _leave_graph():
    """rospy's shutdown (it unregisters this process's topics from the master) in a thread of its own; returns it."""
    import threading

    import rospy
    thread = threading.Thread(target=rospy.signal_shutdown, args=("the warm graph stops",), daemon=True)
    thread.start()
    return thread


class ResetError(RuntimeError):
    """A node refused or did not answer its reset: the graph cannot be reused."""


def launch_config(launch_args):
    """roslaunch's configuration (nodes, parameters) of ``launch_args`` (package, file, arg:=value ...), read as a
    fresh roslaunch reads it ($(find), $(eval), $(anon) resolved)."""
    import roslaunch.config
    import rospkg
    package, name, args = launch_args[0], launch_args[1], list(launch_args[2:])
    path = os.path.join(rospkg.RosPack().get_path(package), "launch", name)
    return roslaunch.config.load_config_default([(path, args)], None, verbose=False)


def node_signature(config):
    """What a reset cannot change: which nodes run, from which executables, with which arguments and remappings."""
    return tuple(sorted((n.namespace + n.name, n.package, n.type, n.args, tuple(map(tuple, n.remap_args)))
                        for n in config.nodes))


def node_names(config):
    return sorted((n.namespace.rstrip("/") + "/" + n.name) for n in config.nodes)


def parameter_tree(config, kept):
    """The whole parameter tree a fresh launch of ``config`` sets, with the ``kept`` top-level entries of the
    present tree (``{name: value}``)."""
    tree = dict(kept)
    for key, param in config.params.items():
        parts = [p for p in key.split("/") if p]
        branch = tree
        for part in parts[:-1]:
            if not isinstance(branch.get(part), dict):
                branch[part] = {}
            branch = branch[part]
        branch[parts[-1]] = param.value
    return tree


def time_origin(reply_message):
    """The new world's time 0 (ROS time [s]) named in reset_world's reply."""
    found = _ORIGIN.search(reply_message or "")
    if not found:
        raise ResetError("mujoco_sim/reset_world's reply names no time origin: %r" % reply_message)
    return float(found.group(1))


class GraphMismatch(RuntimeError):
    """The scenario needs another graph than the warm one (other nodes), or the warm one is gone: it must fly in
    another runner process (rospy joins one master per process, for good)."""


class WarmGraph:
    """The one graph of a runner process, kept between its scenarios (one job slot of a sweep). ``log_dir``: where
    the master's and the launch's logs go (they outlive each scenario's directory)."""

    def __init__(self, log_dir):
        self.log_dir = log_dir
        self.stack, self.core, self.ros, self.signature, self.nodes = None, None, None, None, []
        self.started = False        # a graph was started in this process (there is never a second one)
        self.resets = 0             # resets so far: the scenarios flown on the graph after its first
        self.gone = None            # why the graph was closed, if it was

    def check_fits(self, config):
        """``config`` (launch_config's), if this process can fly it: no graph yet, or one that runs the same nodes
        and can be reset. Raises GraphMismatch otherwise."""
        if not self.started:
            return config
        if self.gone:
            raise GraphMismatch("this runner's graph is gone (%s)" % self.gone)
        if not (self.ros.alive() and self.core.alive()):
            raise GraphMismatch("this runner's graph has stopped")
        if node_signature(config) != self.signature:
            raise GraphMismatch("the scenario needs other nodes than this runner's graph runs")
        try:
            lacking = self.lacking_resets()
        except OSError as err:  # (a scenario killed the master: nothing can connect to this graph any more)
            self.close("its master does not answer: %s" % err)
            raise GraphMismatch("this runner's graph is gone (%s)" % self.gone)
        if lacking:
            raise GraphMismatch("this runner's graph cannot be reset: no ~reset on %s" % ", ".join(lacking))
        return config

    def start(self, config, start_graph):
        """Start the graph: ``start_graph(stack, log_dir)`` enters the master and the launch into ``stack`` and
        returns (core, ros)."""
        if self.started:
            raise GraphMismatch("a runner process starts one graph only")
        self.started = True
        os.makedirs(self.log_dir, exist_ok=True)
        stack = contextlib.ExitStack()
        # The master and the launch are started from a thread that lives as long as the graph: the kernel stops
        # them when the thread that started them ends (isolated_ros.signal_on_parent_death), and a run's thread
        # ends with its run.
        self._keeper = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="warm_graph")
        try:
            self.core, self.ros = self._keeper.submit(start_graph, stack, self.log_dir).result()
        except BaseException:
            stack.close()
            self._keeper.shutdown(wait=False)
            self.gone = "it did not start"
            raise
        self.stack, self.signature, self.nodes = stack, node_signature(config), node_names(config)
        return self.core, self.ros

    def describe(self):
        """result.json's ``graph``: whether the scenario flew on a reset graph, and where that graph's logs are."""
        launch_log = self.ros.log_path
        return {"warm": self.resets > 0, "scenarios_before": self.resets, "launch_log": launch_log,
                "launch_log_offset": os.path.getsize(launch_log) if os.path.exists(launch_log) else 0}

    def lacking_resets(self):
        """The graph's nodes that offer no reset service (a node that does not, or one restarting)."""
        import rosgraph
        services = {name for name, _ in rosgraph.Master("/scenario_runner").getSystemState()[2]}
        return [n for n in self.nodes if "%s/%s" % (n, "reset_world" if n == SIMULATOR else RESET_SERVICE)
                not in services]

    def reset(self, config):
        """Reset the graph for a scenario of ``config`` (from check_fits); returns the new world's time 0 (ROS time
        [s]). Raises ResetError when a node refuses or does not answer (the graph is then closed)."""
        import rosgraph
        import rospy
        from std_srvs.srv import Trigger
        master = rosgraph.Master("/scenario_runner")
        try:
            present = master.getParam("/")
            master.setParam("/", parameter_tree(config, {k: present[k] for k in KEPT_PARAMS if k in present}))
            replies = {}
            world = rospy.ServiceProxy(SIMULATOR + "/reset_world", Trigger)
            rospy.wait_for_service(SIMULATOR + "/reset_world", timeout=RESET_CALL_S)
            replies[SIMULATOR] = world()
            if not replies[SIMULATOR].success:
                raise ResetError("%s: %s" % (SIMULATOR, replies[SIMULATOR].message))
            origin = time_origin(replies[SIMULATOR].message)
            nodes = [n for n in self.nodes if n != SIMULATOR]
            pool = concurrent.futures.ThreadPoolExecutor(max_workers=max(1, len(nodes)))
            try:
                calls = {n: pool.submit(self._reset_node, n) for n in nodes}
                deadline = time.monotonic() + RESET_CALL_S
                for name, call in calls.items():
                    try:
                        replies[name] = call.result(timeout=max(0.0, deadline - time.monotonic()))
                    except concurrent.futures.TimeoutError:
                        raise ResetError("%s did not answer its reset within %.0f s" % (name, RESET_CALL_S))
            finally:
                pool.shutdown(wait=False)  # (a node that hangs must not hang the runner)
            refused = ["%s: %s" % (n, r.message) for n, r in replies.items() if not r.success]
            if refused:
                raise ResetError("; ".join(refused))
        except ResetError as err:
            self.close(str(err))
            raise
        except (rospy.ROSException, rospy.ServiceException, OSError) as err:
            self.close(str(err))
            raise ResetError("the graph could not be reset: %s" % err) from err
        self.resets += 1
        return origin

    @staticmethod
    def _reset_node(name):
        import rospy
        from std_srvs.srv import Trigger
        service = "%s/%s" % (name, RESET_SERVICE)
        rospy.wait_for_service(service, timeout=RESET_CALL_S)
        return rospy.ServiceProxy(service, Trigger)()

    def close(self, reason="closed"):
        """Stop the graph (the launch, then the master), if it runs; ``reason`` is kept for check_fits."""
        self.gone = self.gone or reason
        if self.stack is not None:
            stack, self.stack = self.stack, None
            if self.ros is not None:
                self.ros.interrupt()
            leaving = _leave_graph()  # (this process: side by side with the nodes, and before the master stops)
            self.ros.__exit__(None, None, None)
            leaving.join(LEAVE_GRAPH_S)
            stack.close()
            self._keeper.shutdown(wait=False)
