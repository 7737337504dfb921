"""rendered_benchmark: the close-range views and a short end-to-end run through detector_benchmark."""
import math

import numpy as np
import pytest

from landing_bench import rendered_benchmark


class _Renderer:
    vehicle = "summit_xl"


def test_close_views_are_the_last_half_metre_near_the_centre():
    rng = np.random.default_rng(3)
    views = [rendered_benchmark.sample_close_view(rng, _Renderer()) for _ in range(300)]
    heights = [v.camera_height for v in views]
    offsets = [math.hypot(*v.camera_offset) for v in views]
    assert 0.3 <= min(heights) and max(heights) <= 0.7
    assert max(offsets) <= 0.3 and min(offsets) < 0.05
    assert not any(v.false_target for v in views)


def test_a_short_close_range_run_prints_the_close_range_recall(capfd):
    status = rendered_benchmark.main(["--frames", "6", "--views", "close", "--profiles", "realistic", "--worst", "0"])
    out = capfd.readouterr().out
    assert status == 0, out
    assert "6 close views" in out
    assert "recall, close range, marker wholly in view" in out and "recall, close range, marker cut" in out


def test_an_unknown_kind_of_view_is_refused_with_the_choices(capsys):
    with pytest.raises(SystemExit) as exit_:
        rendered_benchmark.main(["--views", "sideways"])
    assert exit_.value.code == 2
    assert "approach" in capsys.readouterr().err


def test_the_apriltag_pad_views_reach_six_metres_and_bring_the_foreign_pad():
    class _TagRenderer:
        vehicle, pad = "summit_xl", "apriltag"
        towards_sun = np.array([0.3, 0.2, 0.93])
    rng = np.random.default_rng(5)
    views = [rendered_benchmark.sample_view(rng, _TagRenderer()) for _ in range(600)]
    assert max(v.camera_height for v in views) > 5.5
    share = np.mean([v.foreign_pad for v in views])
    assert 0.25 < share < 0.42
    # The red square's views: up to 5 m, no foreign pad.

    class _RedRenderer(_TagRenderer):
        pad = "red_square"
    rng = np.random.default_rng(5)
    red = [rendered_benchmark.sample_view(rng, _RedRenderer()) for _ in range(200)]
    assert not any(v.foreign_pad for v in red) and max(v.camera_height for v in red) <= 5.0


def test_a_short_apriltag_run_prints_the_apriltag_figures(capfd):
    status = rendered_benchmark.main(["--frames", "4", "--pad", "apriltag", "--profiles", "realistic", "--worst", "0"])
    out = capfd.readouterr().out
    assert status == 0, out
    assert "views of the apriltag pad" in out
    assert "AprilTag pad (4 frames)" in out and "false detections, foreign pad in view" in out
    assert "targets (issue 44, AprilTag pad)" in out
