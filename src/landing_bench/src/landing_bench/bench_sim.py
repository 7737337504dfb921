"""Benchmark of the simulator node: real-time factor with the camera streaming, and where the time goes.

Runs sim.launch headless at full speed under its own master with a subscriber on the camera,
for a given span of sim time, and prints the node's own accounting (/sim_stats)."""
import argparse
import json
import os
import tempfile
import time

from landing_eval.isolated_ros import IsolatedLaunch


def measure(sim_seconds, camera_rate, timeout):
    import rospy
    from sensor_msgs.msg import Image
    from std_msgs.msg import String

    rospy.init_node("bench_sim", disable_signals=True)
    frames, stats = [], {}
    rospy.Subscriber("ardrone/bottom/image_raw", Image, lambda m: frames.append(m.header.stamp.to_sec()),
                     queue_size=100, buff_size=2 ** 24)
    rospy.Subscriber("sim_stats", String, lambda m: stats.update(json.loads(m.data)))
    deadline = time.monotonic() + timeout
    while (not frames or stats.get("sim_time", 0.0) < sim_seconds) and time.monotonic() < deadline:
        time.sleep(0.05)
    received = [t for t in frames if t > 1.0]
    rate = (len(received) - 1) / (received[-1] - received[0]) if len(received) > 2 else 0.0
    rospy.signal_shutdown("bench done")
    return stats, rate


def run(sim_seconds=60.0, camera_rate=30.0, timeout=600.0, realism="realistic", vehicle="summit_xl"):
    """(the simulator's /sim_stats, the camera rate a subscriber received) of one run of sim.launch alone."""
    log = os.path.join(tempfile.mkdtemp(prefix="bench_sim_"), "launch.log")
    launch = ["mujoco_sim", "sim.launch", "real_time_factor:=0", "output:=log", "camera_rate:=%g" % camera_rate,
              "realism:=%s" % realism, "vehicle:=%s" % vehicle]
    with IsolatedLaunch(launch, log) as ros:
        os.environ["ROS_MASTER_URI"] = ros.master_uri
        ros.wait_for_master()
        stats, rate = measure(sim_seconds, camera_rate, timeout)
    return stats, rate, log


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sim-seconds", type=float, default=60.0, help="span of sim time to run [s]")
    parser.add_argument("--camera-rate", type=float, default=30.0, help="camera frame rate [Hz]")
    parser.add_argument("--timeout", type=float, default=600.0, help="wall-clock limit [s]")
    parser.add_argument("--realism", choices=("ideal", "realistic", "harsh"), default="realistic",
                        help="realism profile of the simulated world")
    parser.add_argument("--json", action="store_true", help="print the figures as one JSON line (for bench_loop)")
    args = parser.parse_args(argv)
    stats, rate, log = run(args.sim_seconds, args.camera_rate, args.timeout, args.realism)
    if args.json:
        print(json.dumps(dict(stats, camera_rate_received=rate, log=log)))
        return 0 if stats else 1
    if not stats:
        print("no statistics received from the simulator; see %s" % log)
        return 1
    print("simulator benchmark: %.0f s of sim time in %.1f s wall" % (stats["sim_time"], stats["wall_time"]))
    print("  real-time factor      %.2f x (target >= 5)" % stats["real_time_factor"])
    print("  camera frames (sim)   %.1f Hz received by a subscriber (set %.0f Hz)" % (rate, args.camera_rate))
    print("  where the wall time goes (shares of the simulator process):")
    print("    physics + autopilot %.0f %%" % (100 * stats["physics_share"]))
    print("    camera rendering    %.0f %%" % (100 * stats["render_share"]))
    print("    other publishing    %.0f %%" % (100 * (stats["publish_share"] - stats["render_share"])))
    print("    idle / pacing / ROS %.0f %%" % (100 * (1 - stats["physics_share"] - stats["publish_share"])))
    return 0
