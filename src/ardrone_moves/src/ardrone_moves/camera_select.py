"""Start-up selection of the AR.Drone's bottom camera, as a ROS-free state machine driven by calls.

The node asks the driver (service ardrone/setcamchannel, CamSelect channel 1) and then needs frames
on the bottom camera's topic: the service only queues the change, so an accepted request proves
nothing until a frame arrives. A request that is refused, unanswered or followed by no frame is
retried up to ``max_attempts`` times in all, then the selection fails with what to check.

    select = BottomCameraSelect(...)
    every tick: if select.request_due: call the service (async), select.request_sent(now)
    service reply: select.service_answered(result, now); bottom image: select.frame_arrived(now)
    select.tick(now) -> 'waiting' | 'selected' | 'failed: ...'
"""
import math

BOTTOM_CHANNEL = 1  # CamSelect channel of the AR.Drone 2.0's bottom (vertical) camera

WAITING, SELECTED, FAILED = "waiting", "selected", "failed"
# internal phases while WAITING
_REQUEST_DUE, _AWAITING_ANSWER, _AWAITING_FRAME = "request due", "awaiting answer", "awaiting frame"


def _checked(name, value, kind, meaning):
    """``value`` as ``kind`` when it is a positive whole/finite number, else ValueError naming ``name``."""
    try:
        converted = kind(value)
        valid = 0 < converted < math.inf and converted == value and not isinstance(value, bool)
    except (TypeError, ValueError, OverflowError):
        valid = False
    if not valid:
        raise ValueError("parameter '%s' = %r must be %s" % (name, value, meaning))
    return converted


class BottomCameraSelect:
    """Request channel 1, then wait for a bottom frame; retry, and report 'selected' or why it failed.

    frame_timeout [s] after an accepted request, service_timeout [s] for the answer, max_attempts
    requests in all. Times are whatever clock the caller uses (rospy time in the node)."""

    def __init__(self, frame_timeout=3.0, service_timeout=2.0, max_attempts=3,
                 service_name="ardrone/setcamchannel", frame_topic="ardrone/bottom/image_raw"):
        self.frame_timeout = _checked("camera_frame_timeout", frame_timeout, float, "a time > 0 s")
        self.service_timeout = _checked("camera_service_timeout", service_timeout, float, "a time > 0 s")
        self.max_attempts = _checked("camera_select_attempts", max_attempts, int, "an integer >= 1")
        self.service_name, self.frame_topic = service_name, frame_topic
        self.channel = BOTTOM_CHANNEL
        self.restart()

    def restart(self):
        """A fresh selection with all attempts (e.g. after the operator fixed the video link)."""
        self.attempts, self._phase, self._deadline = 0, _REQUEST_DUE, None
        self._first_request_time, self._last_failure, self.status = None, "", WAITING

    @property
    def request_due(self):
        """True when the node should call the service now."""
        return self.status == WAITING and self._phase == _REQUEST_DUE

    def request_sent(self, now):
        if not self.request_due:
            return
        self.attempts += 1
        if self._first_request_time is None:
            self._first_request_time = now
        self._phase, self._deadline = _AWAITING_ANSWER, now + self.service_timeout

    def service_answered(self, ok, now):
        """The driver's reply; answers that come after their timeout are ignored (a retry is under way)."""
        if self.status != WAITING or self._phase != _AWAITING_ANSWER:
            return
        if ok:
            self._phase, self._deadline = _AWAITING_FRAME, now + self.frame_timeout
        else:
            self._attempt_failed("the driver refused the request (%s returned false)" % self.service_name,
                                 "check that the driver is ardrone_autonomy on an AR.Drone 2.0 and accepts channel %d"
                                 % self.channel)

    def frame_arrived(self, now):
        """A bottom-camera image: proof the camera is selected, whatever the service said."""
        if self.status == WAITING and self._first_request_time is not None and now >= self._first_request_time:
            self.status = SELECTED

    def tick(self, now):
        """Check the deadlines; returns 'waiting', 'selected' or 'failed: <reason and what to do>'."""
        if self.status == WAITING and self._deadline is not None and now >= self._deadline:
            if self._phase == _AWAITING_ANSWER:
                self._attempt_failed("no answer from %s within %.1f s" % (self.service_name, self.service_timeout),
                                     "check that the driver (ardrone_autonomy) is running and advertises %s"
                                     % self.service_name)
            elif self._phase == _AWAITING_FRAME:
                self._attempt_failed("no frame on %s within %.1f s of an accepted request"
                                     % (self.frame_topic, self.frame_timeout),
                                     "check the driver's video stream (Wi-Fi link, no other client holding the "
                                     "drone's video) and that %s is published, then restart the selection"
                                     % self.frame_topic)
        return self.report()

    def report(self):
        if self.status == FAILED:
            return "%s: %s" % (FAILED, self._last_failure)
        return self.status

    def _attempt_failed(self, reason, advice):
        """Retry while attempts remain; the last failure's reason and advice become the report."""
        self._deadline = None
        if self.attempts < self.max_attempts:
            self._phase = _REQUEST_DUE
            return
        self.status = FAILED
        self._last_failure = "%s (attempt %d of %d); %s" % (reason, self.attempts, self.max_attempts, advice)
