"""How far the drone's published heading and its IMU's yaw are from the true heading, bag by bag: the IMU's yaw
drifts (no magnetometer), the drone estimator corrects it with the turn it learns from its flow against the GPS.
The soak's check of that correction; ground truth is read here for scoring only.

    rosrun landing_eval heading_error DIR/flight_*.bag
"""
import argparse
import math
import sys

import numpy as np
import rosbag

from landing_runtime.geometry import yaw_from_quaternion

ESTIMATE, IMU, TRUTH = "/ardrone/odom_estimate", "/ardrone/imu", "/groundtruth/ardrone"


class HeadingError(ValueError):
    pass


def _yaws(bag, topic, orientation_of):
    """(stamp [s], yaw [rad]) rows of ``topic``, the yaw unwrapped."""
    rows = []
    for _, msg, _ in bag.read_messages(topics=[topic]):
        q = orientation_of(msg)
        rows.append((msg.header.stamp.to_sec(), yaw_from_quaternion(q.w, q.x, q.y, q.z)))
    if not rows:
        raise HeadingError("%s has no %s messages: record it (the soak's and run_scenario's bags do)"
                           % (bag.filename, topic))
    rows = np.array(rows)
    rows[:, 1] = np.unwrap(rows[:, 1])
    return rows


def _wrapped_degrees(angle):
    return np.degrees(np.angle(np.exp(1j * angle)))


def heading_errors(bag_path, step=0.5):
    """Over one bag, sampled every ``step`` seconds of the estimate's stamps: (first, last stamp [s], published yaw
    minus true yaw as (mean, min, max) [deg], IMU yaw minus true yaw, mean [deg])."""
    try:
        bag = rosbag.Bag(bag_path)
    except (OSError, rosbag.ROSBagException) as error:
        raise HeadingError("cannot read %s (%s): a bag still being written is *.bag.active; a truncated one "
                           "can be repaired with `rosbag reindex`" % (bag_path, error))
    with bag:
        estimate = _yaws(bag, ESTIMATE, lambda m: m.pose.pose.orientation)
        imu = _yaws(bag, IMU, lambda m: m.orientation)
        truth = _yaws(bag, TRUTH, lambda m: m.pose.orientation)
    times = np.arange(estimate[0, 0], estimate[-1, 0] + 1e-9, step)
    true_yaw = np.interp(times, truth[:, 0], truth[:, 1])
    published = _wrapped_degrees(np.interp(times, estimate[:, 0], estimate[:, 1]) - true_yaw)
    reported = _wrapped_degrees(np.interp(times, imu[:, 0], imu[:, 1]) - true_yaw)
    return (float(times[0]), float(times[-1]), (float(published.mean()), float(published.min()),
                                                float(published.max())), float(reported.mean()))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("bags", nargs="+", help="flight bags, in the order of their time")
    args = parser.parse_args(argv)
    worst, read, failed = [math.inf, -math.inf], 0, 0
    print("bag | sim time [s] | published - true yaw, mean (min..max) [deg] | IMU - true yaw, mean [deg]")
    for path in args.bags:
        try:
            start, end, (mean, low, high), imu = heading_errors(path)
        except HeadingError as error:  # the other bags are still read
            print("heading_error: %s" % error, file=sys.stderr)
            failed += 1
            continue
        worst, read = [min(worst[0], low), max(worst[1], high)], read + 1
        print("%s | %.0f-%.0f | %+.1f (%+.1f..%+.1f) | %+.1f" % (path, start, end, mean, low, high, imu))
    if read:
        print("published heading within %+.1f..%+.1f deg of the truth over %d bag(s)" % (worst[0], worst[1], read))
    return 2 if failed else 0
