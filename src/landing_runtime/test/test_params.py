"""Typed node parameters (landing_runtime.params): every key required, each within its range, and the error naming
the parameter and, from the node, where the shipped files are."""
import dataclasses
import types

import pytest

from landing_runtime.params import ParamError, from_mapping, load_params, spec


@dataclasses.dataclass(frozen=True)
class Example:
    rate_hz: float = spec(30.0, 1.0, 500.0, "Hz")
    enabled: bool = spec(True)

    def check(self, source="example"):
        if not self.enabled and self.rate_hz > 100.0:
            raise ParamError("%s: a disabled example runs at 100 Hz at most" % source)
        return self


def test_every_key_is_required_checked_and_none_unknown():
    assert from_mapping(Example, {"rate_hz": 20, "enabled": False}, "x") == Example(20.0, False)
    with pytest.raises(ParamError, match=r"x: required parameter 'enabled' is missing \(true or false\)"):
        from_mapping(Example, {"rate_hz": 20.0}, "x")
    with pytest.raises(ParamError, match=r"parameter 'rate_hz': got 0.5, expected a number in \[1, 500\] Hz"):
        from_mapping(Example, {"rate_hz": 0.5, "enabled": True}, "x")
    with pytest.raises(ParamError, match=r"unknown parameter\(s\) rate"):
        from_mapping(Example, {"rate_hz": 20.0, "enabled": True, "rate": 1}, "x")


@pytest.fixture
def fake_rospy(monkeypatch):
    """rospy's parameter server replaced by a dict (``~`` the private namespace)."""
    rospy = pytest.importorskip("rospy")
    params = {"~": {"rate_hz": 200.0, "enabled": False, "sub": {"x": 1}}}
    monkeypatch.setattr(rospy, "get_param", lambda name, default=None: params.get(name, default))
    monkeypatch.setattr(rospy, "resolve_name", lambda name: "/node/" if name == "~" else name)
    return types.SimpleNamespace(params=params)


def test_load_params_reads_the_private_namespace_without_the_excluded_ones(fake_rospy):
    assert load_params(Example, exclude=("sub",)) == Example(200.0, False)
    with pytest.raises(ParamError, match="unknown parameter"):
        load_params(Example)


def test_load_params_checks_and_names_where_the_shipped_files_are(fake_rospy):
    with pytest.raises(ParamError, match=r"^/node/ parameters: a disabled example .* \(see my_package/config/\)$"):
        load_params(Example, check=True, exclude=("sub",), see="my_package/config/")
    with pytest.raises(ParamError, match=r"100 Hz at most$"):
        load_params(Example, check=True, exclude=("sub",))
