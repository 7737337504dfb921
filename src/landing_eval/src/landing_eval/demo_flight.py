"""Headless demo flight: take off from the pad on the moving Summit XL, hover, fly clear of the
vehicle and land on the ground; prints what the simulator measured."""
import argparse
import json
import os
import sys
import tempfile
import time

from .isolated_ros import IsolatedLaunch


def fly(timeout):
    import rospy
    from geometry_msgs.msg import Twist
    from landing_msgs.msg import Navdata, Touchdown
    from nav_msgs.msg import Odometry
    from std_msgs.msg import Empty

    rospy.init_node("demo_flight", disable_signals=True)
    latest = {}
    rospy.Subscriber("drone/navdata", Navdata, lambda m: latest.update(navdata=m))
    rospy.Subscriber("ardrone/ground_truth/state", Odometry, lambda m: latest.update(truth=m))
    rospy.Subscriber("ardrone/touchdown", Touchdown, lambda m: latest.update(touchdown=m))
    cmd = rospy.Publisher("ardrone/cmd_vel", Twist, queue_size=1)
    takeoff = rospy.Publisher("ardrone/takeoff", Empty, queue_size=1, latch=True)
    land = rospy.Publisher("ardrone/land", Empty, queue_size=1, latch=True)
    deadline = time.monotonic() + timeout

    def wait(condition, what):
        while not condition():
            if time.monotonic() > deadline or rospy.is_shutdown():
                raise TimeoutError("demo timed out waiting for %s" % what)
            time.sleep(0.01)

    def fly_for(seconds, vx=0.0, vy=0.0, vz=0.0):
        end = rospy.get_time() + seconds
        heights = []
        while rospy.get_time() < end:
            msg = Twist()
            msg.linear.x, msg.linear.y, msg.linear.z = vx, vy, vz
            cmd.publish(msg)
            heights.append(latest["truth"].pose.pose.position.z)
            wait(lambda: True, "")
            rospy.sleep(0.05)
        return heights

    wait(lambda: "navdata" in latest and "truth" in latest, "the simulator's first messages")
    battery_start = latest["navdata"].battery_percent
    print("drone on the pad of the moving Summit XL; battery %.1f %%; taking off" % battery_start)
    takeoff.publish(Empty())
    wait(lambda: latest["navdata"].state in (Navdata.STATE_FLYING, Navdata.STATE_HOVERING), "take-off")
    print("t=%5.1f s  airborne at %.2f m" % (rospy.get_time(), latest["truth"].pose.pose.position.z))
    fly_for(2.0, vz=1.0)
    fly_for(1.0)  # settle after the climb
    heights = fly_for(5.0)
    mean = sum(heights) / len(heights)
    spread = max(abs(h - mean) for h in heights)
    print("t=%5.1f s  hovered 5 s at %.2f m (max deviation %.3f m) while the vehicle drove on"
          % (rospy.get_time(), mean, spread))
    fly_for(3.0, vy=1.0)
    print("t=%5.1f s  moved clear of the vehicle's path; landing on the ground" % rospy.get_time())
    land.publish(Empty())
    wait(lambda: "touchdown" in latest, "touchdown")
    t = latest["touchdown"]
    surface = {Touchdown.SURFACE_PAD: "pad", Touchdown.SURFACE_GROUND: "ground", Touchdown.SURFACE_VEHICLE: "vehicle"}
    result = {"outcome": "crashed" if t.crashed else "landed_on_%s" % surface[t.surface],
              "touchdown_time_s": round(t.header.stamp.to_sec(), 2), "impact_speed_mps": round(t.impact_speed, 3),
              "touchdown_position": [round(t.position.x, 2), round(t.position.y, 2), round(t.position.z, 3)],
              "distance_from_pad_m": round(t.pad_error, 2), "hover_height_m": round(mean, 3),
              "hover_max_deviation_m": round(spread, 3),
              "battery_used_percent": round(battery_start - latest["navdata"].battery_percent, 2)}
    rospy.signal_shutdown("demo done")
    return result


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--timeout", type=float, default=300.0, help="wall-clock limit [s]")
    parser.add_argument("--out", default=None, help="directory for the launch log and result.json")
    args = parser.parse_args(argv)
    out = args.out or tempfile.mkdtemp(prefix="demo_flight_")
    os.makedirs(out, exist_ok=True)
    launch = ["mujoco_sim", "demo.launch"]
    start = time.monotonic()
    with IsolatedLaunch(launch, os.path.join(out, "launch.log")) as ros:
        os.environ["ROS_MASTER_URI"] = ros.master_uri
        ros.wait_for_master()
        try:
            result = fly(args.timeout)
        except TimeoutError as err:
            print("demo failed: %s; see %s" % (err, os.path.join(out, "launch.log")), file=sys.stderr)
            return 1
    result["wall_time_s"] = round(time.monotonic() - start, 1)
    with open(os.path.join(out, "result.json"), "w") as stream:
        json.dump(result, stream, indent=2)
    print("outcome: %(outcome)s at t=%(touchdown_time_s)s s, impact %(impact_speed_mps)s m/s, "
          "%(distance_from_pad_m)s m from the pad" % result)
    print("report: %s" % os.path.join(out, "result.json"))
    return 0 if result["outcome"] == "landed_on_ground" else 1
