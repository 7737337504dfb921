"""`python -m landing_eval.warm_worker --log-dir DIR`: a runner process that flies scenarios one after another on one
warm graph (landing_eval.warm_graph), for a job slot of `benchmark --warm`.

It reads one request per line on stdin, JSON ``{"scenario": path, "out_dir": dir, "wall_timeout": s, "realism":
profile or null}``, flies it (runner.run) and answers on stdout with lines ``REPLY_MARKER`` + JSON:
- ``{"status": "ready"}`` once a run has left the graph free and the request after it has taken it (so a
  client keeps one request ahead: it is read, and its launch configuration too, while the run before it flies);
- then, for the run ``out_dir``: ``{"status": "done", "out_dir": ..., "outcome": ...}`` once its result.json is
  written; ``{"status": "mismatch", ...}`` when the scenario needs another graph (nothing was written: it must fly
  in another worker); or ``{"status": "error", ..., "reason": ...}`` (a scenario file that cannot be read).
It stops its graph and ends at the end of its input, once every run has its result, or on SIGINT/SIGTERM."""
import argparse
import concurrent.futures
import faulthandler
import json
import os
import signal
import sys
import threading

from landing_runtime.rospy_node import exit_promptly

from . import runner
from . import scenario as scenario_mod
from . import warm_graph
from .warm_graph import GraphMismatch, WarmGraph

REPLY_MARKER = "warm_worker reply: "  # (rospy writes its log lines to stdout too)
_replies = threading.Lock()


def reply(answer):
    with _replies:
        sys.stdout.write(REPLY_MARKER + json.dumps(answer) + "\n")
        sys.stdout.flush()


def serve(requests, graph):
    """Fly each request of ``requests`` (an iterable of JSON lines) on ``graph``. A run flies in a thread of its
    own: once its flight is scored the graph is free ("ready"), and the next request resets it while the run's
    recorder still stops and its result is written ("done"). A request read while the run before it flies has its
    graph's launch configuration read meanwhile."""
    reader = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="read_ahead")
    runs, flying = [], None  # the runs' threads; the free-event of the run on the graph
    for line in requests:
        if not line.strip():
            continue
        try:
            request = json.loads(line)
            request["scenario"], request["out_dir"]
        except (ValueError, KeyError, TypeError) as err:
            reply({"status": "error", "out_dir": None, "reason": "malformed request %r: %s" % (line[:200], err)})
            continue
        config = reader.submit(_launch_config, request)
        if flying is not None:
            flying.wait()
            reply({"status": "ready"})
        flying = threading.Event()
        runs.append(threading.Thread(target=_fly, args=(request, config, graph, flying), daemon=True,
                                     name="run " + os.path.basename(request["out_dir"])))
        runs[-1].start()
    if flying is not None:
        flying.wait()
        reply({"status": "ready"})
    for thread in runs:
        thread.join()
    reader.shutdown()


def _launch_config(request):
    return warm_graph.launch_config(runner.plan(request["scenario"], request.get("realism"))[1])


def _fly(request, config, graph, free):
    out_dir = request["out_dir"]
    try:
        result = runner.run(request["scenario"], out_dir, request.get("wall_timeout"), realism=request.get("realism"),
                            warm=graph, on_flown=free.set, launch_config=config.result())
        reply({"status": "done", "out_dir": out_dir, "outcome": result["outcome"]})
    except GraphMismatch as err:
        reply({"status": "mismatch", "out_dir": out_dir, "reason": str(err)})
    except scenario_mod.ScenarioError as err:
        reply({"status": "error", "out_dir": out_dir, "reason": str(err)})
    except Exception as err:  # noqa: BLE001 (whatever it is, the client must hear of this run)
        reply({"status": "error", "out_dir": out_dir, "reason": "%s: %s" % (type(err).__name__, err)})
        raise
    finally:
        free.set()


def main(argv=None):
    parser = argparse.ArgumentParser(description="Fly scenarios read from stdin on one warm graph.")
    parser.add_argument("--log-dir", required=True, help="directory of the graph's master and launch logs")
    args = parser.parse_args(argv)
    runner.stop_on_sigterm()
    faulthandler.register(signal.SIGUSR1, all_threads=True)
    graph = WarmGraph(args.log_dir)
    try:
        serve(sys.stdin, graph)
    except KeyboardInterrupt:
        return 130
    finally:
        graph.close("the worker ended")
    return 0


if __name__ == "__main__":
    exit_promptly(main())
