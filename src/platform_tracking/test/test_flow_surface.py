"""What the drone's own velocity means over the vehicle (flow_surface.py): the weight, its forecast."""

import pytest

from platform_tracking.flow_surface import FlowSurface
from platform_tracking.params import FlowSurfaceParams

LEVEL = (1.0, 0.0, 0.0, 0.0)


def test_the_weight_is_one_low_over_the_pad_zero_high_above_it_and_off_when_disabled():
    surface = FlowSurface(FlowSurfaceParams())
    pad = (0.0, 0.0, 0.5)
    assert surface.weight((0.0, 0.0, 1.3), LEVEL, pad, (2.0, 0.0)) == 1.0
    assert surface.weight((0.0, 0.0, 4.5), LEVEL, pad, (2.0, 0.0)) == 0.0
    assert surface.weight((3.0, 0.0, 1.3), LEVEL, pad, (2.0, 0.0)) == 0.0  # beside the vehicle
    assert surface.weight((0.0, 0.0, 0.5), LEVEL, pad, (2.0, 0.0)) == 1.0  # resting on the pad
    off = FlowSurface(FlowSurfaceParams(enabled=False))
    assert off.weight((0.0, 0.0, 1.3), LEVEL, pad, (2.0, 0.0)) == 0.0
    assert surface.seen_pad_velocity((0.0, 0.0, 1.3), LEVEL, pad, (2.0, 0.5)) == pytest.approx((2.0, 0.5))
