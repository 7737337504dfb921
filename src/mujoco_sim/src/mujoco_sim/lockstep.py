"""Lock-step gate, ROS-free: keeps simulated time from running away from the nodes that close the loop.

At full speed the simulator could step far ahead of a starved consumer (a Python node on a loaded
2-core machine): the drone would then fly on stale commands and the watchdogs would see sensors go
silent that never were, so a run would depend on the machine's load rather than on its seed. With the
gate, every node that matters acknowledges what it has processed (landing_msgs/LockstepAck) and the
simulator does not step while one of them lags by more than ``max_lead`` sim seconds.

Two kinds of acknowledgement:
- a topic the simulator publishes (``input`` = its resolved name, ``period`` = 0): the sender has
  processed that topic's messages up to ``stamp``. The gate blocks once a message published more than
  ``max_lead`` ago is still unacknowledged, so a topic that is not being published (camera blackout)
  never blocks. A message is stamped when it was measured and may be published later (a link's latency):
  the lead counts from its publication.
- a timer-driven step (``input`` = ``/clock``, ``period`` > 0): the sender stepped at ``stamp`` and
  steps again at ``stamp + period``; the gate blocks beyond ``stamp + period + max_lead``.

A sender that has blocked the gate for ``stale_after_wall`` wall seconds (it died, or it was
restarted and is not back yet) is dropped with a log line; its next acknowledgement adds it again.
"""
import collections
import dataclasses
import threading
from typing import Callable, Deque, Dict, Optional, Tuple

CLOCK_INPUT = "/clock"


@dataclasses.dataclass
class _Sender:
    stamp: float
    period: float


@dataclasses.dataclass
class Blocker:
    """Why the gate is closed: who lags, on what, by how much [sim s]."""
    node: str
    input: str
    lag: float

    def describe(self):
        return "%s lags %.3f s on %s" % (self.node, self.lag, self.input)


class LockstepGate:
    def __init__(self, max_lead: float, stale_after_wall: float, log: Callable[[str], None] = lambda line: None):
        if not max_lead > 0.0 or not stale_after_wall > 0.0:
            raise ValueError("lockstep max_lead and stale_after_wall must be positive")
        self.max_lead = max_lead
        self.stale_after_wall = stale_after_wall
        self.log = log
        self._lock = threading.Lock()
        self._senders: Dict[Tuple[str, str], _Sender] = {}
        # (stamp, sim time of publication) of messages on acknowledged topics that may still be
        # unacknowledged, oldest first.
        self._published: Dict[str, Deque[Tuple[float, float]]] = {}
        self._blocked_since: Dict[Tuple[str, str], float] = {}
        self.acknowledged = threading.Event()  # set on every acknowledgement: a waiting loop wakes up

    def acknowledge(self, node: str, input_topic: str, stamp: float, period: float = 0.0):
        key = (node, input_topic)
        with self._lock:
            if key not in self._senders:
                self.log("lockstep: waiting for %s on %s from now on" % (node, input_topic))
            self._senders[key] = _Sender(stamp, max(0.0, period))
            if period <= 0.0:
                self._published.setdefault(input_topic, collections.deque(maxlen=256))
        self.acknowledged.set()

    def published(self, topic: str, stamp: float, at: Optional[float] = None):
        """The simulator published a message stamped ``stamp`` on ``topic`` at sim time ``at`` (default: the
        stamp); only topics someone acknowledges are remembered."""
        stamps = self._published.get(topic)
        if stamps is not None:
            stamps.append((stamp, stamp if at is None else at))

    def waits_for(self, topic: str) -> bool:
        return topic in self._published

    def blocker(self, sim_time: float, wall_time: float) -> Optional[Blocker]:
        """The sender that forbids stepping to ``sim_time`` now, or None. Drops senders that have
        blocked for longer than ``stale_after_wall`` wall seconds."""
        with self._lock:
            self._forget_acknowledged()
            worst = None
            for key, sender in list(self._senders.items()):
                lag = self._lag(key[1], sender, sim_time)
                if lag <= self.max_lead + 1e-6:
                    self._blocked_since.pop(key, None)
                    continue
                since = self._blocked_since.setdefault(key, wall_time)
                if wall_time - since > self.stale_after_wall:
                    del self._senders[key]
                    del self._blocked_since[key]
                    self.log("lockstep: %s has not acknowledged %s for %.1f s (wall); no longer waiting for it "
                             "until it does" % (key[0], key[1], wall_time - since))
                    continue
                if worst is None or lag > worst.lag:
                    worst = Blocker(key[0], key[1], lag)
            return worst

    def _forget_acknowledged(self):
        """Drop published stamps that every sender on their topic has acknowledged."""
        for topic, stamps in self._published.items():
            acks = [s.stamp for (_, i), s in self._senders.items() if i == topic]
            if not acks:
                stamps.clear()
                continue
            slowest = min(acks)
            while stamps and stamps[0][0] <= slowest + 1e-6:
                stamps.popleft()

    def _lag(self, input_topic, sender, sim_time):
        if sender.period > 0.0:
            return sim_time - (sender.stamp + sender.period)
        oldest_unacknowledged = next((at for stamp, at in self._published[input_topic] if stamp > sender.stamp + 1e-6),
                                     None)
        return 0.0 if oldest_unacknowledged is None else sim_time - oldest_unacknowledged
