"""How late the pad's detections arrive after their image was taken, measured by the tracker (ROS-free).

The camera link (encoding, Wi-Fi, decoding) delays every frame; its detections keep the image's capture stamp,
so arrival minus stamp is the delay. The median of the last few is robust to a frame held up by a retry.
"""
import collections

import numpy as np


class CameraLatency:
    """The median of the last ``samples`` arrival-minus-capture delays of detections [s] (``value``; 0 before the
    first), and when it is due to be reported again (every ``report_period`` seconds)."""

    def __init__(self, samples=15, report_period=1.0):
        self.delays = collections.deque(maxlen=samples)
        self.report_period = report_period
        self.value = 0.0
        self.reported_at = None  # time of the latest report

    def add(self, arrival, capture):
        """A detection that arrived at ``arrival`` from an image taken at ``capture`` (same clock) [s]."""
        self.delays.append(max(0.0, arrival - capture))
        self.value = float(np.median(self.delays))

    def report_due(self, t):
        """True, and remembered as reported, when ``t`` is a report period after the latest report (or before it:
        time went back)."""
        if self.reported_at is None or not 0.0 <= t - self.reported_at < self.report_period:
            self.reported_at = t
            return True
        return False
