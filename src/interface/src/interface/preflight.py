"""The pre-flight check, ROS-free: before any take-off, every input alive at its rate, the bottom camera selected
and calibrated, GPS fixes valid, the battery charged and the link's latency low. Each item that fails says what is
wrong and what to do; the take-off waits until all pass (the tracker reads the verdict, landing_msgs/PreflightStatus).
"""
import collections
import statistics

NO_FIX = -1  # sensor_msgs/NavSatStatus.STATUS_NO_FIX


class Item(collections.namedtuple("Item", "name ok problem advice")):
    def line(self):
        return "%s: ok" % self.name if self.ok else "%s: %s -- %s" % (self.name, self.problem, self.advice)


class RateMeter:
    """Arrival times of one topic's messages over the last ``window`` seconds."""

    def __init__(self, window):
        self.window = window
        self.times = collections.deque()

    def arrived(self, t):
        self.times.append(t)
        self._forget(t)

    def _forget(self, now):
        while self.times and self.times[0] < now - self.window:
            self.times.popleft()

    def rate(self, now):
        self._forget(now)
        return len(self.times) / self.window


class PreflightCheck:
    """``settings``: the validated parameters (config/preflight.yaml): window_s, topics {name: min_rate_hz},
    fix_topics [names], camera_info_topic, camera_status_topic ('' when the drone selects no camera),
    min_battery_percent, max_link_latency_s."""

    def __init__(self, settings):
        self.s = settings
        self.meters = {topic: RateMeter(settings["window_s"]) for topic in settings["topics"]}
        self.fix_status = {topic: None for topic in settings["fix_topics"]}
        self.camera_info = None       # (fx, distortion coefficients) of the last camera_info
        self.camera_status = None     # the drone adapter's word on the bottom camera
        self.battery = None           # [%]
        self.latencies = collections.deque(maxlen=50)  # arrival minus stamp of navdata [s]

    # ----- observations -----------------------------------------------------------------------------
    def arrived(self, topic, t):
        self.meters[topic].arrived(t)

    def fix(self, topic, status):
        self.fix_status[topic] = status

    def calibration(self, fx, distortion):
        self.camera_info = (fx, tuple(distortion))

    def camera_selection(self, status):
        self.camera_status = status

    def navdata(self, battery_percent, latency_s):
        self.battery = battery_percent
        self.latencies.append(latency_s)

    # ----- the verdict --------------------------------------------------------------------------------
    def items(self, now):
        s = self.s
        out = []
        for topic, minimum in s["topics"].items():
            rate = self.meters[topic].rate(now)
            out.append(Item("%s alive" % topic, rate >= minimum,
                            "%.1f Hz, expected at least %g Hz" % (rate, minimum),
                            "check that its driver runs and the link carries it (rostopic hz %s)" % topic))
        if s["camera_status_topic"]:
            selected = self.camera_status is not None and "bottom camera: selected" in self.camera_status
            out.append(Item("bottom camera selected", selected, self.camera_status or "no word from the adapter",
                            "the driver must stream the bottom camera: rosservice call /ardrone/setcamchannel 1"))
        calibrated = self.camera_info is not None and self.camera_info[0] > 0.0 and len(self.camera_info[1]) > 0
        out.append(Item("camera calibrated", calibrated,
                        "no camera_info yet" if self.camera_info is None else
                        "camera_info K[0] = %g, %d distortion coefficients" % (self.camera_info[0],
                                                                                len(self.camera_info[1])),
                        "calibrate the bottom camera (rosrun camera_calibration cameracalibrator.py with a "
                        "checkerboard) and give the driver its file"))
        for topic, status in self.fix_status.items():
            out.append(Item("%s fix" % topic, status is not None and status > NO_FIX,
                            "no fix yet" if status is None else "status %d (no fix)" % status,
                            "wait for the receiver's fix under open sky"))
        out.append(Item("battery", self.battery is not None and self.battery >= s["min_battery_percent"],
                        "no navdata yet" if self.battery is None else "%.0f %% < %g %%" % (
                            self.battery, s["min_battery_percent"]), "charge or change the drone's battery"))
        latency = statistics.median(self.latencies) if self.latencies else None
        out.append(Item("link latency", latency is not None and latency <= s["max_link_latency_s"],
                        "no navdata yet" if latency is None else "navdata %.0f ms old on arrival (at most %.0f ms)"
                        % (latency * 1e3, s["max_link_latency_s"] * 1e3),
                        "move closer to the drone, change the Wi-Fi channel, or check the clocks (NTP)"))
        return out
