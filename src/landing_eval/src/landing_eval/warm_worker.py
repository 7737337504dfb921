"""`python -m landing_eval.warm_worker --log-dir DIR`: a runner process that flies scenarios one after another on one
warm graph (landing_eval.warm_graph), for a job slot of `benchmark --warm`.

It reads one request per line on stdin, JSON ``{"scenario": path, "out_dir": dir, "wall_timeout": s, "realism":
profile or null}``, flies it (runner.run) and answers on stdout with a line ``REPLY_MARKER`` + JSON: ``{"status":
"done", "outcome": ...}`` once out_dir/result.json is written, or ``{"status": "mismatch", "reason": ...}`` when
the scenario needs another graph (nothing was written: it must fly in another worker). It stops its graph and ends
at the end of its input, or on SIGINT/SIGTERM."""
import argparse
import faulthandler
import json
import signal
import sys

from landing_msgs.rospy_node import exit_promptly

from . import runner
from . import scenario as scenario_mod
from .warm_graph import GraphMismatch, WarmGraph

REPLY_MARKER = "warm_worker reply: "  # (rospy writes its log lines to stdout too)


def reply(answer):
    sys.stdout.write(REPLY_MARKER + json.dumps(answer) + "\n")
    sys.stdout.flush()


def serve(requests, graph):
    """Fly each request of ``requests`` (an iterable of JSON lines) on ``graph``."""
    for line in requests:
        if not line.strip():
            continue
        try:
            request = json.loads(line)
            scenario, out_dir = request["scenario"], request["out_dir"]
        except (ValueError, KeyError, TypeError) as err:
            reply({"status": "error", "reason": "malformed request %r: %s" % (line[:200], err)})
            continue
        try:
            result = runner.run(scenario, out_dir, request.get("wall_timeout"), realism=request.get("realism"),
                                warm=graph)
        except GraphMismatch as err:
            reply({"status": "mismatch", "reason": str(err)})
            continue
        except scenario_mod.ScenarioError as err:
            reply({"status": "error", "reason": str(err)})
            continue
        reply({"status": "done", "outcome": result["outcome"]})


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
