"""Parameter validation: every parameter has a type, a range and a unit; a missing or bad one
is an error that names the source file (or namespace), the key and what is expected."""
import math
import os

import yaml


class ConfigError(ValueError):
    """A parameter file or tree is missing, unreadable or has a bad value."""


class Param:
    """One expected parameter: ``kind`` is float, int, bool or str; ``choices`` for strings."""

    def __init__(self, kind, low=None, high=None, unit="", choices=None):
        self.kind, self.low, self.high, self.unit, self.choices = kind, low, high, unit, choices

    def describe(self):
        if self.choices:
            return "one of %s" % ", ".join(self.choices)
        text = {float: "a number", int: "an integer", bool: "true or false", str: "a string"}[self.kind]
        if self.low is not None and self.high is not None:
            text += " in [%g, %g]" % (self.low, self.high)
        elif self.low is not None:
            text += " >= %g" % self.low
        return text + (" %s" % self.unit if self.unit else "")

    def check(self, value, where):
        kind = self.kind
        ok = isinstance(value, kind) and not (kind is int and isinstance(value, bool))
        if kind is float and isinstance(value, int) and not isinstance(value, bool):
            value, ok = float(value), True
        if ok and kind is float and not math.isfinite(value):
            ok = False
        if ok and self.choices and value not in self.choices:
            ok = False
        if ok and self.low is not None and value < self.low:
            ok = False
        if ok and self.high is not None and value > self.high:
            ok = False
        if not ok:
            raise ConfigError("%s: got %r, expected %s" % (where, value, self.describe()))
        return value


def validate(tree, schema, source, prefix=""):
    """Check ``tree`` (nested dicts) against ``schema`` (nested dicts of Param); return a copy with
    numbers converted. Unknown keys are errors too: a typo must not silently fall back to a default."""
    if not isinstance(tree, dict):
        raise ConfigError("%s: '%s' must be a mapping, got %r" % (source, prefix or "<root>", tree))
    out = {}
    for key, spec in schema.items():
        where = "%s: parameter '%s%s'" % (source, prefix, key)
        if key not in tree:
            raise ConfigError("%s is missing (expected %s)" % (
                where, "a section" if isinstance(spec, dict) else spec.describe()))
        if isinstance(spec, dict):
            out[key] = validate(tree[key], spec, source, prefix + key + "/")
        else:
            out[key] = spec.check(tree[key], where)
    unknown = sorted(set(tree) - set(schema))
    if unknown:
        raise ConfigError("%s: unknown parameter(s) %s under '%s' (known: %s)" % (
            source, ", ".join(unknown), prefix or "<root>", ", ".join(sorted(schema))))
    return out


def load_yaml(path):
    """Read a YAML file into a dict, with errors that name the file and the problem."""
    if not os.path.isfile(path):
        raise ConfigError("%s: file not found" % path)
    try:
        with open(path) as stream:
            data = yaml.safe_load(stream)
    except yaml.YAMLError as err:
        raise ConfigError("%s: not valid YAML: %s" % (path, err)) from err
    if not isinstance(data, dict):
        raise ConfigError("%s: expected a mapping of parameters at the top level" % path)
    return data
