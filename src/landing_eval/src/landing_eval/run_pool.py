"""Where the benchmark's runs execute: local subprocesses (a thread pool of ``jobs``) or Ray tasks on a
cluster whose machines all have the workspace built at the same path.

Either way one run is ``execute_run(spec)``: ``python -m landing_eval.runner_cli`` in a subprocess under its
own ROS master, on the machine that runs it. Locally the runs can also fly on warm graphs (warm_local_runs): a
WarmWorker process per job slot keeps its graph and resets it between runs. The pools yield ``(spec, outcome)``
as runs finish; the caller turns each outcome into a results row (benchmark.row_of)."""
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time

from .isolated_ros import signal_on_parent_death
from .runner import INTERRUPTED, SHUT_DOWN_WALL_S, START_UP_WALL_S

# Environment a run needs from the machine that starts the sweep: the venv and the built workspace (the
# same paths on every node). ROS_MASTER_URI, ROS_IP and ROS_HOSTNAME are not among them: each run has
# its own master on its own node.
FORWARDED_ENV = ("PATH", "PYTHONPATH", "LD_LIBRARY_PATH", "CMAKE_PREFIX_PATH", "PKG_CONFIG_PATH", "ROS_PACKAGE_PATH",
                 "ROS_ROOT", "ROS_ETC_DIR", "ROS_DISTRO", "ROS_VERSION", "ROS_PYTHON_VERSION",
                 "ROSLISP_PACKAGE_DIRECTORIES", "MUJOCO_GL", "LP_NUM_THREADS")
STOP_GRACE_S = 30.0     # a run given SIGINT or SIGTERM has this long to stop its graph before SIGKILL [s]
# Wall time a run may take beyond its flight's wall limit: its own start-up and shut-down budgets (it ends by
# itself within them, runner.wall_limits) and STOP_GRACE_S more before it is stopped from here.
START_STOP_MARGIN_S = START_UP_WALL_S + SHUT_DOWN_WALL_S + STOP_GRACE_S
RAY_MAX_RETRIES = 3     # a task whose worker or node died is run again, elsewhere if need be, this often


def _prepare_child():
    """preexec_fn of a run: SIGTERM when the process that started it dies (a killed Ray worker, a killed
    benchmark), so no run goes on without anybody to read its result; the runner unwinds on SIGTERM and
    stops its graph (which also stops by itself if the runner is SIGKILLed: Ray kills a dead worker's
    children so)."""
    signal_on_parent_death(signal.SIGTERM)


def forwarded_environment():
    return {key: os.environ[key] for key in FORWARDED_ENV if key in os.environ}


def _clear(out_dir):
    """An earlier attempt's directory (a run whose worker died, or an interrupted sweep) is moved aside and
    removed, so nothing of it is mistaken for this run's output; a process of it that is still stopping
    keeps writing into the moved copy."""
    if os.path.lexists(out_dir):
        stale = "%s.stale-%d-%d" % (out_dir, os.getpid(), int(time.time() * 1000))
        os.rename(out_dir, stale)
        shutil.rmtree(stale, ignore_errors=True)
    os.makedirs(out_dir)


class _Running:
    """The run subprocesses of this process, so that an interrupted sweep can stop them."""
    lock, processes = threading.Lock(), set()

    @classmethod
    def stop_all(cls):
        with cls.lock:
            processes = list(cls.processes)
        for process in processes:
            if process.poll() is None:
                process.send_signal(signal.SIGINT)
        deadline = time.monotonic() + STOP_GRACE_S
        for process in processes:
            try:
                process.wait(timeout=max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                process.kill()
                process.wait()


def node_name():
    """This machine, and the Ray node when inside a Ray worker (several nodes may share a machine)."""
    name = socket.gethostname()
    if "ray" in sys.modules:
        import ray
        if ray.is_initialized():
            name += ":" + ray.get_runtime_context().get_node_id()[:8]
    return name


def _prepare(spec):
    """Check the interpreter, clear the run's directory and write its scenario there; returns the scenario's path."""
    python = spec["python"]
    if not os.access(python, os.X_OK):
        raise RuntimeError("%s has no %s: every machine of the cluster needs the workspace built at the same path "
                           "(make build)" % (socket.gethostname(), python))
    out_dir = spec["out_dir"]
    _clear(out_dir)
    scenario_path = spec["file"]
    if spec.get("scenario_text") is not None:
        scenario_path = os.path.join(out_dir, "scenario.yaml")
        with open(scenario_path, "w") as stream:
            stream.write(spec["scenario_text"])
    return scenario_path


def _collect(spec, outcome):
    """``outcome`` with the run's result.json read in (or ``failure`` saying why there is none)."""
    # run_scenario writes result.json whatever happened to the run (an aborted one says why); without it the run
    # failed before its scenario was read, or was killed.
    result_file = os.path.join(spec["out_dir"], "result.json")
    if os.path.isfile(result_file):
        try:
            with open(result_file) as stream:
                outcome["result"] = json.load(stream)
        except ValueError as err:
            outcome["failure"] = "unreadable %s: %s" % (result_file, err)
    elif outcome["failure"] is None:
        outcome["failure"] = "run_scenario exited with %s without a result; see %s" % (outcome["returncode"],
                                                                                       spec["log"])
    # Stopped from outside, not by this pool's wall limit (the sweep's Ctrl-C reached the run too): no result of
    # the scenario, to be run again.
    outcome["interrupted"] = outcome["result"] is not None and outcome["failure"] is None and \
        outcome["result"].get("outcome") == "aborted" and str(outcome["result"].get("error") or "").startswith(INTERRUPTED)
    if outcome["result"] is not None and outcome["failure"]:
        outcome["result"]["error"] = "; ".join(filter(None, [outcome["result"].get("error"), outcome["failure"]]))
    return outcome


def _stop(process):
    """SIGINT, then SIGKILL after STOP_GRACE_S."""
    process.send_signal(signal.SIGINT)
    try:
        process.wait(timeout=STOP_GRACE_S)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


def execute_run(spec):
    """One run of a scenario on this machine. ``spec``: ``python`` (interpreter of the workspace's venv),
    ``file`` (scenario path) and ``scenario_text`` (its YAML, written beside the run's output, so that a node
    need not have the file), ``out_dir``, ``log`` (path of the runner's output), ``wall_timeout`` (flight's
    wall limit [s]), ``realism`` (a profile replacing the scenario's, or None) and ``env`` (environment overrides, or None). Returns ``{"returncode", "result",
    "node", "failure"}``: ``result`` is result.json's content, or None with ``failure`` saying why."""
    scenario_path = _prepare(spec)
    command = [spec["python"], "-m", "landing_eval.runner_cli", scenario_path, "--out", spec["out_dir"],
               "--wall-timeout", str(spec["wall_timeout"])]
    if spec.get("realism"):
        command += ["--realism", spec["realism"]]
    env = dict(os.environ, **spec["env"]) if spec.get("env") else None
    outcome = {"returncode": None, "result": None, "node": node_name(), "failure": None}
    with open(spec["log"], "w") as log:
        process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, env=env,
                                   preexec_fn=_prepare_child)
        with _Running.lock:
            _Running.processes.add(process)
        try:
            outcome["returncode"] = process.wait(timeout=spec["wall_timeout"] + START_STOP_MARGIN_S)
        except subprocess.TimeoutExpired:
            _stop(process)
            outcome["failure"] = "run_scenario did not finish within %.0f s" % (
                spec["wall_timeout"] + START_STOP_MARGIN_S)
        finally:
            with _Running.lock:
                _Running.processes.discard(process)
    return _collect(spec, outcome)


class WarmWorker:
    """A landing_eval.warm_worker process: the scenarios given to it fly one after another on one warm graph, the
    next one's reset beside the previous one's recorder stopping. ``log_dir``: its graph's logs and its own output
    (worker.log)."""

    def __init__(self, python, log_dir, env=None):
        import queue
        os.makedirs(log_dir, exist_ok=True)
        self.log_dir = log_dir
        self._log = open(os.path.join(log_dir, "worker.log"), "w")
        self.process = subprocess.Popen([python, "-m", "landing_eval.warm_worker", "--log-dir", log_dir],
                                        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self._log, text=True,
                                        env=env, preexec_fn=_prepare_child)
        with _Running.lock:
            _Running.processes.add(self.process)
        self.answers = queue.Queue()
        self.reader = threading.Thread(target=self._read, name="warm_worker_replies", daemon=True)
        self.reader.start()

    def _read(self):
        from .warm_worker import REPLY_MARKER
        for line in self.process.stdout:
            if line.startswith(REPLY_MARKER):
                self.answers.put(json.loads(line[len(REPLY_MARKER):]))
            else:
                self._log.write(line)
        self.answers.put(None)  # (the worker ended)

    def send(self, spec):
        """Give the worker ``spec`` (as execute_run's); False when it has ended."""
        scenario_path = _prepare(spec)
        request = {"scenario": scenario_path, "out_dir": spec["out_dir"], "wall_timeout": spec["wall_timeout"],
                   "realism": spec.get("realism")}
        try:
            self.process.stdin.write(json.dumps(request) + "\n")
            self.process.stdin.flush()
        except (BrokenPipeError, ValueError):
            return False
        return True

    def answer(self, timeout):
        """The worker's next answer (warm_worker's replies), None once it has ended; raises queue.Empty after
        ``timeout`` seconds without one."""
        return self.answers.get(timeout=timeout)

    def run_all(self, specs):
        """Fly ``specs`` one after another as a warm sweep does, and wait for their outcomes (as
        execute_run's, in order; None for a run the worker could not fly: another graph was needed, or it ended)."""
        import queue
        outcomes, waiting = {}, list(specs)
        timeout = max([s["wall_timeout"] for s in specs] or [0.0]) + START_STOP_MARGIN_S
        ahead, sent = 0, set()  # (one run flying, the next read ahead: see warm_worker)
        try:
            while len(outcomes) < len(specs):
                while ahead < 2 and waiting:
                    spec = waiting.pop(0)
                    if not self.send(spec):
                        break
                    sent.add(spec["out_dir"])
                    ahead += 1
                answer = self.answer(timeout)
                if answer is None:
                    break
                if answer.get("status") == "ready":
                    ahead -= 1
                elif answer.get("out_dir") in sent:
                    spec = next(s for s in specs if s["out_dir"] == answer["out_dir"])
                    outcomes[spec["out_dir"]] = None if answer["status"] == "mismatch" else _outcome_of(spec, answer)
        except queue.Empty:
            self.close()
            for spec in specs:
                if spec["out_dir"] in sent and spec["out_dir"] not in outcomes:
                    outcomes[spec["out_dir"]] = _collect(spec, _outcome(
                        "the warm worker did not finish the run within %.0f s" % timeout))
        return [outcomes.get(s["out_dir"]) for s in specs]

    def close(self):
        """End the worker once its runs have their results (its graph stops); bounded by STOP_GRACE_S, then SIGKILL.
        Its answers stay readable (answer) until the None that marks its end."""
        try:
            self.process.stdin.close()
        except OSError:
            pass
        try:
            self.process.wait(timeout=STOP_GRACE_S)
        except subprocess.TimeoutExpired:
            _stop(self.process)
        self.reader.join(timeout=STOP_GRACE_S)
        with _Running.lock:
            _Running.processes.discard(self.process)
        self._log.close()


def _outcome(failure=None):
    return {"returncode": None, "result": None, "node": node_name(), "failure": failure}


def _outcome_of(spec, answer):
    """The outcome of ``spec`` from the worker's final answer about it (done or error)."""
    failure = None if answer.get("status") == "done" else "the warm worker refused the run: %s" % answer.get("reason")
    return _collect(spec, _outcome(failure))


def warm_local_runs(specs, jobs, log_root):
    """Yields (spec, outcome) as the runs finish, ``jobs`` at a time on this machine, each job slot flying its runs
    on a warm graph (a WarmWorker; another one for a run that needs other nodes). Logs of the graphs: ``log_root``
    (DATE-TIME_worker_N/)."""
    import queue
    pending, finished = queue.Queue(), queue.Queue()
    for spec in specs:
        pending.put(spec)
    counter = iter(range(1, 1 << 30))
    started = time.strftime("%Y%m%d-%H%M%S")  # (a resumed sweep's workers log beside the first ones, not over them)
    stop = threading.Event()

    def slot():
        worker, flying = None, {}  # the worker, and its runs sent and not finished, by out_dir
        retry, retried = [], set()  # runs a worker could not fly (another graph needed), for a fresh worker, once

        def settle(spec, answer):
            if answer.get("status") == "mismatch" and spec["out_dir"] not in retried:
                retried.add(spec["out_dir"])
                retry.append(spec)
            elif answer.get("status") == "mismatch":
                finished.put((spec, _outcome("a fresh warm worker could not fly the run either: %s"
                                             % answer.get("reason"))))
            else:
                finished.put((spec, _outcome_of(spec, answer)))

        def retire():
            """End the worker once it has flown what it was given; every run of it is settled."""
            worker.close()
            while True:
                answer = worker.answers.get()
                if answer is None:
                    break
                if answer.get("out_dir") in flying:
                    settle(flying.pop(answer["out_dir"]), answer)
            for spec in flying.values():
                finished.put((spec, _collect(spec, _outcome("the warm worker ended without its result; see %s"
                                                            % worker.log_dir))))
            flying.clear()
        try:
            ahead = 0  # runs sent that have not left the graph yet: one flying, one read ahead
            while not stop.is_set():
                while ahead < 2:
                    spec = retry.pop(0) if retry else None
                    if spec is None:
                        try:
                            spec = pending.get_nowait()
                        except queue.Empty:
                            break
                    if worker is None:
                        worker = WarmWorker(spec["python"], os.path.join(log_root, "%s_worker_%d" % (
                            started, next(counter))))
                    flying[spec["out_dir"]] = spec
                    if not worker.send(spec):
                        break
                    ahead += 1
                if not flying:
                    return
                timeout = max(s["wall_timeout"] for s in flying.values()) + START_STOP_MARGIN_S
                try:
                    answer = worker.answer(timeout)
                except queue.Empty:
                    answer = None  # (a worker that answers nothing for that long is ended)
                status = (answer or {}).get("status")
                if answer is None or status == "mismatch":
                    if answer is not None:
                        settle(flying.pop(answer["out_dir"]), answer)
                    retire()
                    worker, ahead = None, 0
                elif status == "ready":
                    ahead -= 1
                elif answer.get("out_dir") in flying:
                    settle(flying.pop(answer["out_dir"]), answer)
        finally:
            if worker is not None:
                retire()
            finished.put(None)

    threads = [threading.Thread(target=slot, name="warm_slot_%d" % i, daemon=True) for i in range(max(1, jobs))]
    for thread in threads:
        thread.start()
    running = len(threads)
    try:
        while running:
            item = finished.get()
            if item is None:
                running -= 1
            else:
                yield item
    finally:
        stop.set()
        _Running.stop_all()
        for thread in threads:
            thread.join()


def local_runs(specs, jobs):
    """Yields (spec, outcome) as the runs finish, ``jobs`` at a time on this machine."""
    import concurrent.futures
    pool = concurrent.futures.ThreadPoolExecutor(max_workers=max(1, jobs))
    futures = {pool.submit(execute_run, spec): spec for spec in specs}
    try:
        for future in concurrent.futures.as_completed(futures):
            yield futures[future], future.result()
    finally:
        for future in futures:
            future.cancel()
        _Running.stop_all()
        pool.shutdown(wait=True)


WORKSPACE_MODULES = ("rospy", "landing_msgs.msg", "landing_eval.run_pool")  # what a run's worker must import


def _check_ray_workers(ray, timeout):
    """Once, before any run: every alive node's workers can import the workspace (a node whose Ray was started
    without `source env.sh` failed every task of a sweep with "No module named 'landing_msgs'"). Raises
    ConnectionError naming the nodes and how to start their Ray."""
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    def probe(modules):  # pickled by value (a nested function): it runs even where the workspace is not importable
        import importlib
        import socket
        missing = []
        for module in modules:
            try:
                importlib.import_module(module)
            except ImportError as err:
                missing.append(str(err))
        return socket.gethostname(), missing

    remote = ray.remote(probe)
    refs = [remote.options(num_cpus=0, scheduling_strategy=NodeAffinitySchedulingStrategy(node["NodeID"], soft=False))
            .remote(WORKSPACE_MODULES) for node in ray.nodes() if node.get("Alive")]
    ready, pending = ray.wait(refs, num_returns=len(refs), timeout=timeout)
    problems = ["%s: %s" % (host, "; ".join(missing)) for host, missing in ray.get(ready) if missing]
    if pending:
        problems.append("%d node(s) did not answer within %.0f s" % (len(pending), timeout))
    if problems:
        raise ConnectionError("the Ray cluster's workers cannot run the workspace (%s): on every node, start Ray "
                              "from a shell where the workspace is sourced, at the same path: cd WORKSPACE && source "
                              "env.sh && ray start --address=HEAD:6379 (the head: ray start --head)"
                              % " | ".join(problems))


def ray_runs(specs, address, cpus_per_run, idle_timeout):
    """Yields (spec, outcome) as Ray tasks finish: one task per run, ``cpus_per_run`` CPUs each, on any node of
    the cluster at ``address`` ('auto': the one this machine belongs to). A task whose worker or node dies is
    run again (up to RAY_MAX_RETRIES times, on any node); only its one returned result counts. Raises
    TimeoutError when no task has finished for ``idle_timeout`` seconds."""
    import logging

    import ray
    try:
        ray.init(address=address, log_to_driver=False, logging_level=logging.ERROR, configure_logging=True)
    except (ConnectionError, RuntimeError, ValueError) as err:
        raise ConnectionError("cannot connect to the Ray cluster at %s: %s (start it with 'ray start --head', "
                              "see the README)" % (address, err)) from err
    refs = {}
    try:
        _check_ray_workers(ray, idle_timeout)
        task = ray.remote(execute_run).options(num_cpus=cpus_per_run, max_retries=RAY_MAX_RETRIES,
                                               retry_exceptions=False)
        refs = {task.remote(dict(spec, env=forwarded_environment())): spec for spec in specs}
        pending = list(refs)
        while pending:
            done, pending = ray.wait(pending, num_returns=1, timeout=idle_timeout)
            if not done:
                raise TimeoutError("no run finished on the Ray cluster for %.0f s (%d still pending); is it up? "
                                   "('ray status')" % (idle_timeout, len(pending)))
            for ref in done:
                try:
                    outcome = ray.get(ref)
                except ray.exceptions.RayError as err:  # retries used up, or the run raised
                    message = str(err).strip().splitlines()
                    outcome = {"returncode": None, "result": None, "node": None,
                               "failure": "Ray: %s" % (message[-1] if message else type(err).__name__)}
                yield refs[ref], outcome
    finally:
        if ray.is_initialized():
            for ref in refs:  # those still running when the sweep is interrupted
                try:
                    ray.cancel(ref, force=True)
                except Exception:  # already finished, or the cluster is gone
                    pass
            ray.shutdown()
