"""The flight recorder of a run: its command line, the recorder and its successors after a death, the bags they
wrote (one per recorder, or its --split parts) and the repair of a bag whose recorder was killed."""
import glob
import os
import subprocess

from .isolated_ros import IsolatedProcess

RECORDER = "flight_recorder"
# A run whose time limit is over LONG_RUN_S records a bag per RECORDER_SPLIT_S of sim time: rosbag record holds
# its whole bag's index in memory (about 1 MB a minute of flight) and frees it only when it starts the next bag [s].
LONG_RUN_S = 600.0
RECORDER_SPLIT_S = 120


def recorder_command(bag, split_s=0):
    """(command, environment) of the flight recorder (flight_recorder's record: rosbag record's options, half its CPU
    per message) of the topics interface/record.launch records (its record_regex, in its chunk_kb chunks, with its
    allocator and settings), started directly: through a second roslaunch it took 0.4 s longer to start and to stop,
    through rosrun (a shell script that runs catkin_find) 0.2 s longer to start. With ``split_s`` > 0 a new bag every
    split_s seconds of sim time (NAME_0.bag, NAME_1.bag, ...; see split_bags)."""
    import xml.etree.ElementTree as ElementTree
    import roslib.packages
    import rospkg
    launch = os.path.join(rospkg.RosPack().get_path("interface"), "launch", "record.launch")
    defaults = {arg.get("name"): arg.get("default") for arg in ElementTree.parse(launch).getroot().iter("arg")}
    split = ["--split", "--duration=%d" % split_s] if split_s > 0 else []
    record = roslib.packages.find_node("flight_recorder", "record")
    if not record:
        raise FileNotFoundError("flight_recorder's record executable was not found (build the workspace: make build)")
    return [record[0], "--output-name=" + bag] + split + [
        "--lz4", "--chunksize=" + defaults["chunk_kb"], "-e", defaults["record_regex"], "__name:=" + RECORDER], {
        "LD_PRELOAD": defaults["allocator"], "MALLOC_CONF": defaults["allocator_conf"],
        "GLIBC_TUNABLES": defaults["malloc_tunables"]}


def split_bags(bag):
    """The bags rosbag record --split wrote for ``--output-name=bag``, in order (NAME_0.bag, NAME_1.bag, ...;
    the last one still NAME_N.bag.active if its recorder was killed), as the names they have once repaired."""
    stem = bag[:-len(".bag")]
    found = {}
    for path in glob.glob(glob.escape(stem) + "_*.bag") + glob.glob(glob.escape(stem) + "_*.bag.active"):
        number = path[len(stem) + 1:].split(".bag", 1)[0]
        if number.isdigit():
            found[int(number)] = "%s_%s.bag" % (stem, number)
    return [found[k] for k in sorted(found)]


class Recorders:
    """The flight recorder (rosbag record) and, after it died, its successors (flight.2.bag, ...)."""

    def __init__(self, out_dir, master_uri, stack, split_s=0):
        self.out_dir, self.master_uri, self.stack, self.split_s = out_dir, master_uri, stack, split_s
        self.bags, self.current = [], None

    def start(self):
        index = len(self.bags) + 1
        bag = os.path.abspath(os.path.join(self.out_dir, "flight.bag" if index == 1 else "flight.%d.bag" % index))
        log = os.path.join(self.out_dir, "recorder.log" if index == 1 else "recorder.%d.log" % index)
        command, env = recorder_command(bag, self.split_s)
        self.current = self.stack.enter_context(IsolatedProcess(command, log, self.master_uri, env))
        self.bags.append(bag)
        return self.current

    def written(self):
        """Every bag written so far, in order (each recorder's splits in turn)."""
        return [part for bag in self.bags for part in (split_bags(bag) if self.split_s > 0 else [bag])]

    def pids(self):
        return [self.current.process.pid] if self.current is not None and self.current.process else []


def repair_bags(bags, timeout=30.0):
    """A bag whose recorder was killed is left as NAME.active without an index: reindex it (rosbag reindex)
    and give it its name. Returns the bags as they are now (an unrepaired one keeps its .active name: the
    analysis reads it record by record)."""
    repaired = []
    for bag in bags:
        active = bag + ".active"
        if os.path.isfile(bag) or not os.path.isfile(active):
            repaired.append(bag if os.path.isfile(bag) else None)
            continue
        try:
            done = subprocess.run(["rosbag", "reindex", "--quiet", active], capture_output=True, text=True,
                                  timeout=timeout).returncode == 0
        except (OSError, subprocess.TimeoutExpired):
            done = False
        backup = bag + ".orig.active"
        if done:
            os.replace(active, bag)
            if os.path.isfile(backup):
                os.remove(backup)
            repaired.append(bag)
        else:
            repaired.append(active)
    return repaired
