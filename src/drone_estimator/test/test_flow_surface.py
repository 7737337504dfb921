"""What the drone's own velocity means over the vehicle (flow_surface.py): the weight, its forecast."""

import pytest

from drone_estimator.flow_surface import FlowSurface, WeightForecast
from drone_estimator.params import FlowSurfaceParams

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


def test_the_flow_weight_is_forecast_along_its_slope_and_kept_within_0_and_1():
    forecast = WeightForecast(window=0.1)
    assert forecast.at(1.0) == 0.0
    for k in range(6):
        forecast.add(1.0 + 0.02 * k, 0.1 + 0.04 * k)  # rising 2 per second
    assert forecast.at(1.15) == pytest.approx(0.3 + 2.0 * 0.05)
    assert forecast.at(2.0) == 1.0
    forecast.add(0.5, 0.7)  # time went back: start again
    assert forecast.at(0.6) == 0.7
