"""The shipped parameter files of the estimator: complete, documented and equal to the code defaults
(estimator.yaml); complete, within their ranges and consistent (flow_surface_<vehicle>.yaml)."""
import dataclasses
import os
import re

import pytest
import yaml

from drone_estimator.params import EstimatorParams, FlowSurfaceParams
from landing_runtime.params import ParamError, from_mapping
from landing_runtime.testing import yaml_key_comments

CONFIG = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config")
VEHICLES = ("summit_xl", "car")


def load(name):
    with open(os.path.join(CONFIG, name)) as stream:
        return yaml.safe_load(stream)


def test_the_estimator_file_loads_and_equals_the_code_defaults():
    assert from_mapping(EstimatorParams, load("estimator.yaml"), "estimator.yaml") == EstimatorParams()


@pytest.mark.parametrize("vehicle", VEHICLES)
def test_the_flow_surface_files_load_and_are_consistent(vehicle):
    name = "flow_surface_%s.yaml" % vehicle
    from_mapping(FlowSurfaceParams, load(name), name).check(name)


def test_every_key_of_the_estimator_file_is_commented_with_its_meaning_and_unit():
    name, cls = "estimator.yaml", EstimatorParams
    comments = yaml_key_comments(os.path.join(CONFIG, name))
    assert set(comments) == {f.name for f in dataclasses.fields(cls)}
    for key, comment in comments.items():
        assert comment, "%s: '%s' has no comment" % (name, key)
        assert re.search(r"\[[^\]]+\]$", comment), "%s: '%s' has no [unit] at the end of its comment" % (name, key)


def test_an_inconsistent_flow_surface_is_refused():
    with pytest.raises(ParamError, match="coverage_low < coverage_high"):
        FlowSurfaceParams(coverage_low=0.9).check()
