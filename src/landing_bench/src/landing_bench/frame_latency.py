"""How long a camera frame takes to become a command to the drone, from wall-clock arrival times (ROS-free).

The chain a frame goes through: the image arrives (its capture stamp in the header) -> the detector publishes the pad
seen in it (the same stamp) -> the pad filter's next estimate after that -> the tracker's next velocity command after
that (through the supervisor's mux) -> the next command on the drone's link after that (the adapter's, for the
AR.Drone: the driver's normalised cmd_vel). Each "next after" is the first message that could carry the frame's
information; the whole chain is the latency a companion computer adds between the camera and the drone. Frames in
which no pad was found cause no command and are not counted.
"""
import bisect

STAGES = ("detection", "estimate", "stack_command", "drone_command")


class ArrivalLog:
    """Wall-clock arrival times [s] of the messages along the chain, as a probe heard them."""

    def __init__(self):
        self.frames = {}      # capture stamp [ns] -> arrival of the image
        self.detections = {}  # capture stamp [ns] -> arrival of the detection of that image
        self.estimates, self.stack_commands, self.drone_commands = [], [], []

    def frame(self, stamp_ns, wall):
        self.frames.setdefault(stamp_ns, wall)

    def detection(self, stamp_ns, wall):
        self.detections.setdefault(stamp_ns, wall)

    def estimate(self, wall):
        self.estimates.append(wall)

    def stack_command(self, wall):
        self.stack_commands.append(wall)

    def drone_command(self, wall):
        self.drone_commands.append(wall)


def _first_after(times, t):
    i = bisect.bisect_right(times, t)
    return times[i] if i < len(times) else None


def chains(log):
    """Per detected frame, the arrival of each stage after the frame's: [{"frame": t, "detection": t, ...}], in
    capture order; a frame whose chain does not complete (the flight ended first) is left out."""
    estimates, stack, drone = sorted(log.estimates), sorted(log.stack_commands), sorted(log.drone_commands)
    out = []
    for stamp in sorted(set(log.frames) & set(log.detections)):
        chain = {"frame": log.frames[stamp], "detection": log.detections[stamp]}
        if chain["detection"] < chain["frame"]:
            continue  # heard in the other order by the probe: its own delay, not the stack's
        chain["estimate"] = _first_after(estimates, chain["detection"])
        chain["stack_command"] = chain["estimate"] and _first_after(stack, chain["estimate"])
        chain["drone_command"] = chain["stack_command"] and _first_after(drone, chain["stack_command"])
        if chain["drone_command"] is not None:
            out.append(chain)
    return out


def percentile(values, q):
    """The q-th percentile (0..100) by linear interpolation between the closest ranks; None when empty."""
    if not values:
        return None
    ordered = sorted(values)
    position = (len(ordered) - 1) * q / 100.0
    low = int(position)
    high = min(low + 1, len(ordered) - 1)
    return ordered[low] + (ordered[high] - ordered[low]) * (position - low)


def summary(log):
    """{"frames": heard, "chains": completed, stage: {"p50_ms", "p99_ms"} for each step and "total"}: each stage is
    the time from the previous one, "total" from the frame's arrival to the drone's command."""
    done = chains(log)
    result = {"frames": len(log.frames), "detected": len(set(log.frames) & set(log.detections)),
              "chains": len(done)}
    previous = "frame"
    for stage in STAGES + ("total",):
        start = "frame" if stage == "total" else previous
        end = "drone_command" if stage == "total" else stage
        spans = [1000.0 * (c[end] - c[start]) for c in done]
        result[stage] = {"p50_ms": percentile(spans, 50), "p99_ms": percentile(spans, 99)}
        previous = stage
    return result
