"""compute_budget's arithmetic (ROS-free): the frame -> command chains from arrival times, their percentiles, the
stack's CPU apart from the simulator's, and the probe's reading of a serialised header."""
import os
import struct
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
from landing_bench.frame_latency import ArrivalLog, chains, percentile, summary  # noqa: E402


def _log(frames, detections, estimates, stack, drone):
    log = ArrivalLog()
    for stamp, wall in frames.items():
        log.frame(stamp, wall)
    for stamp, wall in detections.items():
        log.detection(stamp, wall)
    for wall in estimates:
        log.estimate(wall)
    for wall in stack:
        log.stack_command(wall)
    for wall in drone:
        log.drone_command(wall)
    return log


def test_each_step_takes_the_first_message_after_the_previous_one():
    # Frame 1 at 10.000 s, detected at 10.002; the filter publishes at 10.000 (too early), 10.030; the tracker at
    # 10.020 (too early), 10.040; the drone's link at 10.035 (too early), 10.045, 10.060.
    log = _log({1: 10.000}, {1: 10.002}, [10.000, 10.030], [10.020, 10.040], [10.035, 10.045, 10.060])
    [chain] = chains(log)
    assert chain == {"frame": 10.000, "detection": 10.002, "estimate": 10.030, "stack_command": 10.040,
                     "drone_command": 10.045}
    figures = summary(log)
    assert figures["total"]["p50_ms"] == pytest.approx(45.0)
    assert figures["estimate"]["p50_ms"] == pytest.approx(28.0)  # from the detection, not from the frame


def test_frames_without_a_pad_or_without_a_complete_chain_are_not_counted():
    log = _log({1: 1.0, 2: 2.0, 3: 3.0}, {1: 1.01, 3: 3.01}, [1.02, 3.02], [1.03, 3.03], [1.04])
    assert [c["frame"] for c in chains(log)] == [1.0]  # 2: no pad seen; 3: the flight ended before a command
    figures = summary(log)
    assert (figures["frames"], figures["detected"], figures["chains"]) == (3, 2, 1)


def test_a_detection_heard_before_its_frame_is_the_probe_s_delay_and_is_left_out():
    assert chains(_log({1: 1.05}, {1: 1.0}, [1.1], [1.2], [1.3])) == []


def test_no_chain_gives_no_percentile_rather_than_zero():
    figures = summary(ArrivalLog())
    assert figures["chains"] == 0 and figures["total"] == {"p50_ms": None, "p99_ms": None}


def test_percentiles_interpolate_between_ranks():
    assert percentile([4.0, 1.0, 3.0, 2.0], 50) == pytest.approx(2.5)
    assert percentile(list(range(101)), 99) == pytest.approx(99.0)
    assert percentile([7.0], 99) == 7.0


def test_the_probe_reads_the_stamp_of_a_serialised_header():
    pytest.importorskip("rospy")
    from landing_bench.latency_probe import header_stamp_ns
    raw = struct.pack("<III", 42, 12, 500) + b"frame_id and pixels"
    assert header_stamp_ns(raw) == 12 * 10 ** 9 + 500
    assert header_stamp_ns(b"\x00" * 8) is None


def test_the_budget_counts_the_stack_apart_from_the_simulator_and_the_recorder():
    pytest.importorskip("rospy")
    from landing_bench.compute_budget import budget, probe_command, render, table

    def sample(sim_s, cpu):
        return {"sim_s": sim_s, "nodes": {name: {"pid": 1, "cpu_s": v} for name, v in cpu.items()}}
    result = {"name": "s", "outcome": "landed_on_pad", "real_time_factor": 0.99, "resources": {"samples": [
        sample(0.0, {"mujoco_sim": 0.0, "flight_recorder": 0.0, "platform_tracking": 0.0, "platform_detection": 0.0}),
        sample(10.0, {"mujoco_sim": 4.0, "flight_recorder": 0.5, "platform_tracking": 0.6, "platform_detection": 0.4})]}}
    figures = budget(result, None)
    assert figures["cpu_per_flight_s"] == {"platform_tracking": 0.06, "platform_detection": 0.04}
    assert figures["cpu_stack_total"] == pytest.approx(0.1)
    assert set(figures["cpu_not_the_stack"]) == {"mujoco_sim", "flight_recorder"}
    assert "no complete chain" in render(figures)
    figures["drone_model"] = "ardrone2"
    text = table([figures])
    assert "| CPU per flight second, the stack [s/s] | **0.100** |" in text
    assert "| ... its largest node | 0.060 (`platform_tracking`) |" in text
    assert "| frame -> drone command, p50 / p99 [ms] | **-** |" in text  # no latency measured: said, not zero
    assert "drone_command:=/cmd_vel" in probe_command("/tmp/l.json", "ardrone2")
    with pytest.raises(ValueError, match="no command topic known for drone model 'bebop'"):
        probe_command("/tmp/l.json", "bebop")
