"""The tracker's measure of the camera link's delay: a median robust to a late frame, reported once a period."""
import pytest

from platform_tracking.camera_latency import CameraLatency


def test_the_latency_is_the_median_of_the_recent_delays_and_ignores_one_late_frame():
    latency = CameraLatency(samples=5)
    assert latency.value == 0.0  # nothing seen yet
    for i, delay in enumerate([0.10, 0.11, 0.09, 0.60, 0.10]):  # one frame held up by a Wi-Fi retry
        latency.add(arrival=i + delay, capture=i)
    assert latency.value == pytest.approx(0.10)
    for i in range(5, 10):  # the link got slower: the oldest samples leave the window
        latency.add(arrival=i + 0.2, capture=i)
    assert latency.value == pytest.approx(0.2)
    latency.add(arrival=10.0, capture=10.01)  # a stamp from a clock slightly ahead: no negative delay
    assert latency.delays[-1] == 0.0


def test_a_report_is_due_once_a_period_and_again_after_time_went_back():
    latency = CameraLatency(report_period=1.0)
    assert [latency.report_due(t) for t in (5.0, 5.5, 5.99, 6.0, 6.5)] == [True, False, False, True, False]
    assert latency.report_due(0.1)  # the simulation started again
    assert not latency.report_due(0.5)
