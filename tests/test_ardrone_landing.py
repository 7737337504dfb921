"""The closed-loop landing through the AR.Drone 2.0's real interface, for real: run_scenario flies the simulator's
ardrone2 (its emulated ardrone_autonomy driver) in the realistic world, the stack behind its adapters. The drone
must land on the moving pad, and the bag must show the driver's own types on the driver's topics: what a real
AR.Drone would have carried."""
import json
import math
import os
import subprocess

import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
WALL_TIMEOUT_S = 600  # one flight of about 30 sim seconds; a loaded 2-core machine needs 1-2 min


def test_ardrone2_lands_on_the_moving_pad_through_its_drivers_interface(tmp_path):
    with open(os.path.join(ROOT, "scenarios", "summit_circle_1ms.yaml")) as stream:
        scenario = yaml.safe_load(stream)
    scenario.update(name="ardrone2_summit_circle_1ms", time_limit_s=90.0)
    scenario["drone"] = {"start": "on_pad", "model": "ardrone2"}
    path = tmp_path / "ardrone2.yaml"
    path.write_text(yaml.safe_dump(scenario))
    out = tmp_path / "out"
    run = subprocess.run(["rosrun", "landing_eval", "run_scenario", str(path), "--out", str(out)],
                         capture_output=True, text=True, timeout=WALL_TIMEOUT_S, stdin=subprocess.DEVNULL)
    result = json.loads((out / "result.json").read_text())
    assert result["outcome"] == "landed_on_pad", run.stdout[-2000:] + run.stderr[-2000:]
    assert result["touchdown_error_m"] < 0.25 and result["callback_errors"] == {}

    import rosbag
    with rosbag.Bag(result["bag"]) as bag:
        topics = bag.get_type_and_topic_info()[1]
        assert topics["/ardrone/navdata"].msg_type == "ardrone_autonomy/Navdata"
        assert topics["/cmd_vel"].msg_type == "geometry_msgs/Twist"
        assert topics["/ardrone/gps/fix"].msg_type == "sensor_msgs/NavSatFix"
        assert topics["/drone/navdata"].msg_type == "landing_msgs/Navdata"  # the adapter's SI units for the stack
        commands = [m for _, m, _ in bag.read_messages(topics=["/cmd_vel"])]
    # The driver's commands are normalised tilts, climbs and yaw rates, never velocities: all within [-1, 1].
    assert len(commands) > 500
    for command in commands:
        values = (command.linear.x, command.linear.y, command.linear.z, command.angular.z)
        assert all(math.isfinite(v) and abs(v) <= 1.0 for v in values), values
    assert any(abs(c.linear.x) > 0.05 or abs(c.linear.y) > 0.05 for c in commands)  # it did fly on tilts
