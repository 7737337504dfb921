"""result.json of a run: the run's bookkeeping added to the flight's score (its repaired bags, the resources of its
processes, the nodes that died, where the wall time went) and the atomic write."""
import json
import os
import time

from .recorders import repair_bags

from . import processes


def finish(result, out_dir, wall_start, phases, monitor, recorders, steps=None):
    """Repair the bags, add the run's bookkeeping and write result.json."""
    bags = repair_bags(recorders.written() if recorders else [])
    result["bag"] = bags[0] if bags else None
    if len(bags) > 1:
        result["bags"] = bags
    if monitor is not None:
        result["resources"] = {"samples": monitor.resources.samples, "table": monitor.resources.table(
            baseline=1 if len(monitor.resources.samples) > 3 else 0)}
    graph = result.get("graph") or {}  # (a warm graph's launch log: this scenario's part of it)
    try:
        with open(graph.get("launch_log") or os.path.join(out_dir, "launch.log"), "rb") as stream:
            stream.seek(graph.get("launch_log_offset", 0))
            result["node_deaths"] = processes.deaths_in_launch_log(stream.read().decode(errors="replace"))
    except OSError:
        result["node_deaths"] = []
    result["wall_time_s"] = round(time.monotonic() - wall_start, 2)
    # Where the wall time went: starting the master, graph and recorder; the flight; stopping them.
    start_up = phases["start_up"] if phases["start_up"] is not None else result["wall_time_s"]
    result["wall_phases_s"] = {"start_up": round(start_up, 2), "flight": round(phases["flight"], 2),
                               "shut_down": round(result["wall_time_s"] - start_up - phases["flight"], 2)}
    # When each step of start-up and shut-down ended (wall s from the start): where the fixed overhead goes.
    result["wall_steps_s"] = dict(steps or {}, result=round(time.monotonic() - wall_start, 3))
    result.setdefault("sim_time_s", None)
    result.setdefault("real_time_factor", None)
    write_result(out_dir, result)
    return result


def write_result(out_dir, result):
    """result.json, atomically: a reader sees the old file or the whole new one, never a part."""
    path = os.path.join(out_dir, "result.json")
    temporary = path + ".tmp"
    with open(temporary, "w") as stream:
        json.dump(result, stream, indent=2)
        stream.flush()
        os.fsync(stream.fileno())
    os.replace(temporary, path)
    return path
