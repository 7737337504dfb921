"""Condition table of the supervisor, ROS-free: loading config/conditions.yaml and evaluating one row.

A row says where a value comes from (a global parameter or a measurement of the supervisor node),
which values are physically possible, the threshold beyond which the adverse condition holds, its
flag (thesis 2.3) and whether it makes a landing on the pad no-go. A value that cannot be read
(deleted parameter, 'abc', NaN, out of the possible range) makes the row present: unknown is unsafe.
"""
import math

import yaml

FLAGS = (1, 2, 3)
REASONS = ("weather", "battery", "controller_battery", "drone_speed", "platform_too_fast", "target_lost",
           "sensor_missing")
# Values the supervisor node measures itself (everything else comes from a global parameter).
MEASURES = ("platform_speed", "target_lost_s", "camera_silence_s", "imu_silence_s", "odometry_silence_s",
            "sonar_silence_s")
THRESHOLDS = {"below": "lower", "at_or_below": "lower", "above": "upper", "at_or_above": "upper"}
ROW_KEYS = {"param", "measure", "unit", "valid", "flag", "blocks_landing", "reason", "message"} | set(THRESHOLDS)
TOP_KEYS = {"conditions", "drone_max_horizontal_speed", "sensor_timeout_s", "gps_timeout_s"}


class ConditionTableError(ValueError):
    """The condition file is malformed; the message names the file and the key."""


class Missing:
    """Marker of a value that is not there at all (deleted parameter, never measured)."""

    def __repr__(self):
        return "<missing>"


MISSING = Missing()


class Pending:
    """Marker of a measurement that has not had time to arrive yet (start-up): neither safe nor unsafe.
    The supervisor holds operator commands until it is known."""

    def __repr__(self):
        return "<pending>"


PENDING = Pending()


class ConditionRow:
    __slots__ = ("name", "param", "measure", "unit", "valid", "thresholds", "flag", "blocks_landing", "reason",
                 "message")

    def __init__(self, name, param, measure, unit, valid, thresholds, flag, blocks_landing, reason, message):
        self.name, self.param, self.measure, self.unit = name, param, measure, unit
        self.valid, self.thresholds = valid, thresholds  # thresholds: {"below": 40.0, ...}
        self.flag, self.blocks_landing, self.reason, self.message = flag, blocks_landing, reason, message

    @property
    def source(self):
        """Key of the value in the readings: the parameter name or the measure name."""
        return self.param if self.param is not None else self.measure

    def describe_source(self):
        return "parameter /%s" % self.param if self.param is not None else "measured %s" % self.measure


class ConditionTable:
    def __init__(self, rows, path="<table>", sensor_timeout_s=None, drone_max_horizontal_speed=None, gps_timeout_s=None):
        self.rows, self.path = list(rows), path
        self.sensor_timeout_s, self.drone_max_horizontal_speed = sensor_timeout_s, drone_max_horizontal_speed
        self.gps_timeout_s = gps_timeout_s
        self.initial_conditions = {}  # the drone model's start-up values of its parameters (over the supervisor's)

    def __iter__(self):
        return iter(self.rows)

    def __len__(self):
        return len(self.rows)

    def row(self, name):
        for row in self.rows:
            if row.name == name:
                return row
        raise KeyError(name)

    def sources(self):
        """Every parameter and measure the table needs, in table order, without repeats."""
        seen = []
        for row in self.rows:
            if row.source not in seen:
                seen.append(row.source)
        return seen

    def params(self):
        """Global parameters the table reads (without the leading '/')."""
        return list(dict.fromkeys(row.param for row in self.rows if row.param is not None))


def _number(value, where, path):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ConditionTableError("%s: key '%s' must be a finite number, got %r" % (path, where, value))
    return float(value)


def _parse_row(name, spec, path):
    where = "conditions.%s" % name
    if not isinstance(spec, dict):
        raise ConditionTableError("%s: key '%s' must be a mapping (param/measure, thresholds, flag, ...), got %r"
                                  % (path, where, spec))
    unknown = sorted(set(spec) - ROW_KEYS)
    if unknown:
        raise ConditionTableError("%s: key '%s.%s' is not known; a row has: %s"
                                  % (path, where, unknown[0], ", ".join(sorted(ROW_KEYS))))
    if ("param" in spec) == ("measure" in spec):
        raise ConditionTableError("%s: key '%s' needs exactly one of 'param' (a global parameter) or 'measure' "
                                  "(one of %s)" % (path, where, ", ".join(MEASURES)))
    param, measure = spec.get("param"), spec.get("measure")
    if param is not None and (not isinstance(param, str) or not param.strip("/")):
        raise ConditionTableError("%s: key '%s.param' must be a parameter name, got %r" % (path, where, param))
    if measure is not None and measure not in MEASURES:
        raise ConditionTableError("%s: key '%s.measure' must be one of %s, got %r"
                                  % (path, where, ", ".join(MEASURES), measure))
    for key in ("unit", "valid", "flag", "blocks_landing", "reason", "message"):
        if key not in spec:
            raise ConditionTableError("%s: key '%s.%s' is missing" % (path, where, key))
    valid = spec["valid"]
    if not isinstance(valid, list) or len(valid) != 2:
        raise ConditionTableError("%s: key '%s.valid' must be [lowest, highest], got %r" % (path, where, valid))
    valid = (_number(valid[0], where + ".valid", path), _number(valid[1], where + ".valid", path))
    if valid[0] >= valid[1]:
        raise ConditionTableError("%s: key '%s.valid' must be [lowest, highest] with lowest < highest, got %r"
                                  % (path, where, list(valid)))
    thresholds = {key: _number(spec[key], "%s.%s" % (where, key), path) for key in THRESHOLDS if key in spec}
    if not thresholds:
        raise ConditionTableError("%s: key '%s' needs a threshold: one of %s" % (path, where, ", ".join(THRESHOLDS)))
    for side in ("lower", "upper"):
        keys = [k for k in thresholds if THRESHOLDS[k] == side]
        if len(keys) > 1:
            raise ConditionTableError("%s: key '%s' has two %s thresholds (%s); keep one"
                                      % (path, where, side, " and ".join(keys)))
    flag = spec["flag"]
    if isinstance(flag, bool) or flag not in FLAGS:
        raise ConditionTableError("%s: key '%s.flag' must be 1, 2 or 3, got %r" % (path, where, flag))
    if not isinstance(spec["blocks_landing"], bool):
        raise ConditionTableError("%s: key '%s.blocks_landing' must be true or false, got %r"
                                  % (path, where, spec["blocks_landing"]))
    if spec["reason"] not in REASONS:
        raise ConditionTableError("%s: key '%s.reason' must be one of %s, got %r"
                                  % (path, where, ", ".join(REASONS), spec["reason"]))
    if not isinstance(spec["message"], str) or not spec["message"]:
        raise ConditionTableError("%s: key '%s.message' must be a text for the operator" % (path, where))
    return ConditionRow(name, param.strip("/") if param else None, measure, str(spec["unit"]), valid, thresholds,
                        int(flag), spec["blocks_landing"], spec["reason"], spec["message"])


def parse_table(data, path="<table>"):
    """Condition table from the loaded YAML ``data``; ``path`` names the file in errors."""
    if not isinstance(data, dict) or "conditions" not in data:
        raise ConditionTableError("%s: key 'conditions' is missing (the table of adverse conditions)" % path)
    unknown = sorted(set(data) - TOP_KEYS)
    if unknown:
        raise ConditionTableError("%s: key '%s' is not known; top-level keys are: %s"
                                  % (path, unknown[0], ", ".join(sorted(TOP_KEYS))))
    rows = data["conditions"]
    if not isinstance(rows, dict) or not rows:
        raise ConditionTableError("%s: key 'conditions' must be a non-empty mapping name -> row" % path)
    extras = {key: _number(data[key], key, path) for key in ("sensor_timeout_s", "drone_max_horizontal_speed",
                                                             "gps_timeout_s") if key in data}
    return ConditionTable([_parse_row(str(name), spec, path) for name, spec in rows.items()], path, **extras)


# What a drone model's file (config/drone_models/MODEL.yaml) may set: the thresholds and messages of the rows whose
# limit is the drone's (its top speed, the platform speed it can land on, the wind it can fly in).
DRONE_TOP_KEYS = {"drone_max_horizontal_speed", "conditions", "initial_conditions"}
DRONE_ROW_KEYS = set(THRESHOLDS) | {"message"}


def apply_drone_model(data, drone, path="<table>", drone_path="<drone model>"):
    """The condition table's YAML ``data`` with the drone model's ``drone`` laid over it (a new mapping): its
    drone_max_horizontal_speed and, per existing row, thresholds that replace the row's and a message."""
    if not isinstance(drone, dict):
        raise ConditionTableError("%s: must be a mapping with %s" % (drone_path, " and ".join(sorted(DRONE_TOP_KEYS))))
    unknown = sorted(set(drone) - DRONE_TOP_KEYS)
    if unknown:
        raise ConditionTableError("%s: key '%s' is not known; a drone model sets: %s"
                                  % (drone_path, unknown[0], ", ".join(sorted(DRONE_TOP_KEYS))))
    merged = dict(data)
    if "drone_max_horizontal_speed" in drone:
        merged["drone_max_horizontal_speed"] = drone["drone_max_horizontal_speed"]
    rows = drone.get("conditions") or {}
    if not isinstance(rows, dict):
        raise ConditionTableError("%s: key 'conditions' must be a mapping row -> thresholds" % drone_path)
    table_rows = dict(data.get("conditions") or {})
    for name, spec in rows.items():
        where = "conditions.%s" % name
        if name not in table_rows:
            raise ConditionTableError("%s: key '%s' names no row of %s (rows: %s)"
                                      % (drone_path, where, path, ", ".join(table_rows)))
        if not isinstance(spec, dict) or not spec or set(spec) - DRONE_ROW_KEYS:
            raise ConditionTableError("%s: key '%s' may set only %s, got %r"
                                      % (drone_path, where, ", ".join(sorted(DRONE_ROW_KEYS)), spec))
        row = dict(table_rows[name])
        if set(spec) & set(THRESHOLDS):  # the drone's thresholds replace the row's
            row = {k: v for k, v in row.items() if k not in THRESHOLDS}
        row.update(spec)
        table_rows[name] = row
    merged["conditions"] = table_rows
    return merged


def _read_yaml(path, what):
    try:
        with open(path) as stream:
            return yaml.safe_load(stream)
    except OSError as err:
        raise ConditionTableError("%s: cannot read the %s: %s" % (path, what, err.strerror or err))
    except yaml.YAMLError as err:
        raise ConditionTableError("%s: not valid YAML: %s" % (path, err))


def load_table(path, drone_model_path=None):
    """Load config/conditions.yaml, with the drone model's thresholds (config/drone_models/MODEL.yaml) over it if
    given; ConditionTableError names the file and the key on any problem."""
    data = _read_yaml(path, "condition table")
    if drone_model_path:
        where = "%s + %s" % (path, drone_model_path)
        drone = _read_yaml(drone_model_path, "drone model's limits")
        table = parse_table(apply_drone_model(data, drone, path, drone_model_path), where)
        initial = drone.get("initial_conditions") or {}
        if not isinstance(initial, dict) or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                    for v in initial.values()):
            raise ConditionTableError("%s: key 'initial_conditions' must map condition parameters to numbers, got %r"
                                      % (drone_model_path, initial))
        table.initial_conditions = {str(k): float(v) for k, v in initial.items()}
        return table
    return parse_table(data, path)


# ----- reading and evaluating values -------------------------------------------------------------
def read_value(raw, row):
    """(value, problem): the number, or None and why it is unreadable (then the row counts as present)."""
    what = row.describe_source()
    hint = " (set it with e.g. 'rosparam set /%s <number>')" % row.param if row.param else ""
    if raw is MISSING or raw is None or raw == {}:
        return None, "%s is not set%s" % (what, hint)
    if isinstance(raw, bool) or not isinstance(raw, (int, float)):
        return None, "%s is %r, not a number%s" % (what, raw, hint)
    value = float(raw)
    if not math.isfinite(value):
        return None, "%s is %r, not a finite number%s" % (what, raw, hint)
    low, high = row.valid
    if not low <= value <= high:
        return None, "%s is %g %s, impossible (valid %g..%g)%s" % (what, value, row.unit, low, high, hint)
    return value, None


def crossed(value, row):
    """The threshold the value crosses, as text ('>= 12 m/s'), or None when the value is on the safe side."""
    t = row.thresholds
    if "below" in t and value < t["below"]:
        return "< %g %s" % (t["below"], row.unit)
    if "at_or_below" in t and value <= t["at_or_below"]:
        return "<= %g %s" % (t["at_or_below"], row.unit)
    if "above" in t and value > t["above"]:
        return "> %g %s" % (t["above"], row.unit)
    if "at_or_above" in t and value >= t["at_or_above"]:
        return ">= %g %s" % (t["at_or_above"], row.unit)
    return None


class Evaluation:
    """One row evaluated: present or not, the value (a number, or the raw unreadable thing) and why."""

    __slots__ = ("row", "present", "value", "unreadable", "detail")

    def __init__(self, row, present, value, unreadable, detail):
        self.row, self.present, self.value, self.unreadable, self.detail = row, present, value, unreadable, detail

    def json_value(self):
        """The value as strict JSON can carry it: a rounded number, None when absent, else its repr
        (an unreadable 'abc' or NaN is shown as the operator typed it)."""
        value = self.value
        if value is MISSING or value is None or value == {}:
            return None
        if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
            return round(float(value), 3)
        return repr(value)


def evaluate(row, raw):
    if raw is PENDING:
        return Evaluation(row, False, None, False, "%s not measured yet" % row.describe_source())
    value, problem = read_value(raw, row)
    if problem is not None:
        return Evaluation(row, True, raw, True, "%s: treated as unsafe" % problem)
    threshold = crossed(value, row)
    if threshold is None:
        return Evaluation(row, False, value, False, "%s %g %s" % (row.source, value, row.unit))
    return Evaluation(row, True, value, False, "%s %g %s %s" % (row.source, value, row.unit, threshold))
