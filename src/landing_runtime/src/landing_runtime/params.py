"""A node's parameters as a frozen dataclass with a unit and an allowed range per field, ROS-free (but for
``load_params``, which reads them from the parameter server).

    @dataclasses.dataclass(frozen=True)
    class MyParams:
        rate_hz: float = spec(30.0, 1.0, 500.0, "Hz")

    params = load_params(MyParams, see="my_package/config/")   # in the node: its private parameters

The dataclass defaults are the shipped defaults (the package's config/*.yaml repeats them, documented);
``from_mapping`` is what the nodes use: every key is required there, so a typo or a forgotten key stops the node
with a message naming it instead of silently flying with a default. A class may add ``check(source)`` for
relations between its fields that a single range cannot express (raising ParamError, returning itself).
"""
import dataclasses
import math


class ParamError(ValueError):
    """A parameter is missing, unknown or out of its range; the message names it."""


def spec(default, low=None, high=None, unit=""):
    return dataclasses.field(default=default, metadata={"low": low, "high": high, "unit": unit})


def from_mapping(cls, mapping, source):
    """Build ``cls`` from a flat mapping in which every field must be present (``source`` names
    where the mapping came from, for the error message)."""
    if not isinstance(mapping, dict):
        raise ParamError("%s: expected a mapping of parameters, got %r" % (source, mapping))
    values = {}
    for field in dataclasses.fields(cls):
        if field.name not in mapping:
            raise ParamError("%s: required parameter '%s' is missing (%s)" % (source, field.name, _describe(field)))
        values[field.name] = _check(field, mapping[field.name], source)
    unknown = sorted(set(mapping) - set(values))
    if unknown:
        raise ParamError("%s: unknown parameter(s) %s (known: %s)" % (
            source, ", ".join(unknown), ", ".join(f.name for f in dataclasses.fields(cls))))
    return cls(**values)


def _describe(field):
    kind = type(field.default)
    low, high, unit = field.metadata["low"], field.metadata["high"], field.metadata["unit"]
    text = {float: "a number", int: "an integer", bool: "true or false", str: "a string"}[kind]
    if low is not None and high is not None:
        text += " in [%g, %g]" % (low, high)
    return text + (" %s" % unit if unit else "")


def _check(field, value, source):
    kind = type(field.default)
    ok = isinstance(value, kind) and not (kind is not bool and isinstance(value, bool))
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        value, ok = float(value), True
    if ok and kind is float and not math.isfinite(value):
        ok = False
    low, high = field.metadata["low"], field.metadata["high"]
    if ok and low is not None and value < low:
        ok = False
    if ok and high is not None and value > high:
        ok = False
    if not ok:
        raise ParamError("%s: parameter '%s': got %r, expected %s" % (source, field.name, value, _describe(field)))
    return value


def load_params(cls, check=None, namespace="~", exclude=(), see=None):
    """The node's private parameters (or those of a sub-namespace) as ``cls``, through ``cls.check`` when ``check``;
    a missing or bad one raises a ParamError naming it (fatal at start-up, a refused ~reset later:
    landing_runtime.rospy_node.run_node), followed by "(see ``see``)" when given (where the shipped files are).
    Sub-namespaces in ``exclude`` are another class's."""
    import rospy  # here, not at the top: the rest of this module is ROS-free
    source = "%s parameters" % rospy.resolve_name(namespace)
    try:
        mapping = rospy.get_param(namespace, {})
        if isinstance(mapping, dict):
            mapping = {k: v for k, v in mapping.items() if k not in exclude}
        params = from_mapping(cls, mapping, source)
        return params.check(source) if check else params
    except ParamError as err:
        if see is None:
            raise
        raise ParamError("%s (see %s)" % (err, see)) from None
