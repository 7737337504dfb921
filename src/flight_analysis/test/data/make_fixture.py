"""Makes sim_flight.bag (the fixture of test_analysis_bag.py) from a run_scenario bag:

    .venv/bin/python src/flight_analysis/test/data/make_fixture.py RUN/flight.bag src/flight_analysis/test/data/sim_flight.bag

Keeps the topics the analysis reads, thins the 50 Hz ones to 10 Hz and the 30 Hz ones to 5 Hz, and copies
every connection's message definition as recorded (so the fixture carries the real landing_msgs
definitions written by rosbag record). The source was a 115 s simulator run (summit_xl, circle path,
radius 6 m, 1 m/s, wind 3 m/s) flown by a test pilot that also published stand-in landing-stack topics
(tracker state, vision, Kalman path, supervisor decisions) built from ground truth."""
import sys

from rosbags.rosbag1 import Reader, Writer

KEEP = {"/groundtruth/ardrone": 10.0, "/groundtruth/landing_pad": 10.0, "/ardrone/navdata": 10.0,
        "/platform/current_platform_position_in_world": 5.0, "/kalman_prediction_path": 2.0,
        "/ardrone/touchdown": None, "/ardrone/takeoff": None, "/ardrone/land": None, "/platform_tracking/state": None,
        "/supervisor/decisions": None, "/operator/command": None, "/platform_tracking/command": None,
        "/rosout_agg": None}


def main(source, target):
    writer = Writer(target)
    writer.set_compression(Writer.CompressionFormat.LZ4)
    writer.open()
    with Reader(source) as reader:
        out, last = {}, {}
        for c in reader.connections:
            if c.topic in KEEP and c.topic not in out:
                out[c.topic] = writer.add_connection(c.topic, c.msgtype, msgdef=c.msgdef.data, md5sum=c.digest,
                                                     callerid=c.ext.callerid, latching=c.ext.latching)
        for c, t, raw in reader.messages(connections=[c for c in reader.connections if c.topic in KEEP]):
            rate = KEEP[c.topic]
            if rate and t - last.get(c.topic, -10 ** 18) < 1e9 / rate - 1e6:
                continue
            last[c.topic] = t
            writer.write(out[c.topic], t, raw)
    writer.close()


if __name__ == "__main__":
    main(*sys.argv[1:3])
