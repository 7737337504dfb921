"""Missions of one run, ROS-free: when each started, how it ended (scored from the simulator's ground truth,
as scoring.outcome does for a single flight), and what the operator does before the next one (the scenario's
`missions:` block: a pause on the pad, new conditions, a fresh battery).

The outcome of a run with several missions is the worst of its missions' outcomes, so that an `expect:`
block asking for landed_on_pad holds only if every mission landed on the pad."""
from flight_analysis import scoring

# From the worst to the best: the run's outcome is its worst mission's.
SEVERITY = ("crashed", "landed_off_pad", "aborted", "timeout", "emergency_landed", "landed_on_pad")
GUST_PARAM = {"gust_mps": "wind_gust"}  # scenario names whose parameter is named otherwise


def worst(outcomes):
    outcomes = list(outcomes)
    return min(outcomes, key=SEVERITY.index) if outcomes else "timeout"


class MissionLog:
    """``start(t)`` opens a mission, ``finish(...)`` closes it with its touchdown; ``records`` holds them."""

    def __init__(self):
        self.records = []
        self.current = None

    def start(self, t, conditions=None, battery_swapped=False):
        self.current = {"mission": len(self.records) + 1, "start_s": round(t, 3), "conditions": conditions or {},
                        "battery_swapped": battery_swapped, "emergency_ordered": False}
        return self.current

    def emergency(self):
        if self.current is not None:
            self.current["emergency_ordered"] = True

    def finish(self, touchdown, resting_error, landed_decision=None):
        """Close the open mission with the simulator's ``touchdown`` (None: it never touched down) and the resting
        distance from the pad; ``landed_decision``: the supervisor's judgement of it, if any."""
        record, self.current = self.current, None
        if record is None:
            return None
        outcome, error = scoring.outcome(touchdown, resting_error, record["emergency_ordered"])
        record.update(outcome=outcome, touchdown_error_m=error, landed_decision=landed_decision)
        if touchdown is not None:
            t = touchdown.header.stamp.to_sec()
            record.update(touchdown_s=round(t, 3), time_to_land_s=round(t - record["start_s"], 3),
                          surface={1: "pad", 2: "ground", 3: "vehicle"}.get(touchdown.surface, "unknown"),
                          resting_pad_error_m=None if resting_error is None else round(resting_error, 4))
        self.records.append(record)
        return record

    def abandon(self, outcome):
        """Close the open mission without a touchdown (``outcome``: timeout or aborted)."""
        record, self.current = self.current, None
        if record is not None:
            record.update(outcome=outcome, touchdown_error_m=None, landed_decision=None)
            self.records.append(record)
        return record


def next_mission_settings(plan, index, battery_percent):
    """What the operator sets before mission ``index`` (1-based) of the `missions:` ``plan``: ({parameter:
    value}, battery swapped). The conditions cycle through the plan's list; a battery below
    ``battery_swap_below`` (or unreadable) is replaced by a full one."""
    params = {}
    if plan["conditions"]:
        for key, value in plan["conditions"][(index - 1) % len(plan["conditions"])].items():
            params[GUST_PARAM.get(key, key)] = value
    try:
        low = float(battery_percent) < plan["battery_swap_below"]
    except (TypeError, ValueError):
        low = True
    if low:
        params["drone_battery"] = 100.0
    return params, low
