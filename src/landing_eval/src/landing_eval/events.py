"""The scenario's events in the order they fire: the scenario's own, and the operator's choice of the landing mode
when the scenario leaves it out. (Applying an event is the FlightMonitor's: it publishes through the monitor's
publishers and opens the monitor's missions.)"""


def scenario_events(s):
    """The events of the validated scenario ``s`` as the flight applies them, in sim-time order."""
    # Without an operator event the operator chooses the landing mode at once, unless the scenario tests
    # what happens when nobody chooses (supervisor: {no_operator: true}).
    no_operator = bool(s["supervisor"].get("no_operator"))
    return s["events"] if no_operator or any("operator" in e for e in s["events"]) else \
        [{"at_s": 0.0, "operator": "landing"}] + s["events"]


class EventSchedule:
    """Scenario events in sim-time order; ``due(t)`` pops those whose time has come."""

    def __init__(self, events):
        self.pending = list(events)

    def due(self, t):
        fired = []
        while self.pending and self.pending[0]["at_s"] <= t:
            fired.append(self.pending.pop(0))
        return fired
