"""When a periodic output of the simulator is due, in sim time (the node's topics and the emulated drivers')."""


class Schedule:
    """Fires every ``period`` seconds of sim time."""

    def __init__(self, rate_hz):
        self.period, self.next = 1.0 / rate_hz, 0.0

    def due(self, t):
        if t + 1e-9 >= self.next:
            self.next = max(self.next + self.period, t)
            return True
        return False
