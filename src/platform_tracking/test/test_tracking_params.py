"""The shipped parameter files: complete, documented, equal to the code defaults; and the errors a
user gets for a missing, mistyped, unknown or inconsistent parameter."""
import dataclasses
import os
import re

import pytest
import yaml

from landing_runtime.params import ParamError, from_mapping
from landing_runtime.testing import yaml_key_comments
from platform_tracking.params import TrackingParams

CONFIG = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config")
FILES = {"tracking.yaml": TrackingParams}  # the estimator's: drone_estimator/test/test_estimator_params.py


@pytest.mark.parametrize("name", sorted(FILES))
def test_config_files_load_and_equal_the_code_defaults(name):
    with open(os.path.join(CONFIG, name)) as stream:
        tree = yaml.safe_load(stream)
    params = from_mapping(FILES[name], tree, name)
    assert params == FILES[name]()


@pytest.mark.parametrize("name", sorted(FILES))
def test_every_key_is_commented_with_its_meaning_and_unit(name):
    comments = yaml_key_comments(os.path.join(CONFIG, name))
    assert set(comments) == {f.name for f in dataclasses.fields(FILES[name])}
    for key, comment in comments.items():
        assert comment, "%s: '%s' has no comment" % (name, key)
        assert re.search(r"\[[^\]]+\]$", comment), "%s: '%s' has no [unit] at the end of its comment" % (name, key)


def defaults(cls):
    return {f.name: f.default for f in dataclasses.fields(cls)}


def test_missing_parameter_is_named():
    tree = defaults(TrackingParams)
    del tree["gate_height"]
    with pytest.raises(ParamError, match=r"/platform_tracking: required parameter 'gate_height' is missing "
                                         r"\(a number in \[0.05, 5\] m\)"):
        from_mapping(TrackingParams, tree, "/platform_tracking")


def test_bad_values_and_unknown_keys_are_named():
    tree = defaults(TrackingParams)
    with pytest.raises(ParamError, match=r"parameter 'nominal_height': got -1.0"):
        from_mapping(TrackingParams, dict(tree, nominal_height=-1.0), "x")
    with pytest.raises(ParamError, match=r"parameter 'auto_land': got 'yes', expected true or false"):
        from_mapping(TrackingParams, dict(tree, auto_land="yes"), "x")
    with pytest.raises(ParamError, match=r"parameter 'rate_hz': got True"):
        from_mapping(TrackingParams, dict(tree, rate_hz=True), "x")
    with pytest.raises(ParamError, match=r"parameter 'lookahead': got nan"):
        from_mapping(TrackingParams, dict(tree, lookahead=float("nan")), "x")
    with pytest.raises(ParamError, match=r"unknown parameter\(s\) gate_hieght"):
        from_mapping(TrackingParams, dict(tree, gate_hieght=0.3), "x")
    assert from_mapping(TrackingParams, dict(tree, rate_hz=20), "x").rate_hz == 20.0  # int is a number


def test_inconsistent_parameters_are_rejected_by_check():
    with pytest.raises(ParamError, match="gate_error"):
        TrackingParams(gate_error=0.5).check()
    with pytest.raises(ParamError, match="retry_height"):
        TrackingParams(retry_height=5.0).check()
    with pytest.raises(ParamError, match="found_max_age"):
        TrackingParams(found_max_age=2.0).check()
    with pytest.raises(ParamError, match="hold_max_error"):
        TrackingParams(hold_max_error=2.0).check()
    with pytest.raises(ParamError, match="descend_error_per_metre .* must not exceed hold_error_per_metre"):
        TrackingParams(descend_error_per_metre=0.5).check()
