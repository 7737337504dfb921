"""Vehicle path generators: every path, its geometry and its bad inputs."""
import math
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
from summit_moves.paths import PATHS, Path, PathError  # noqa: E402


def integrate(path, seconds, dt=0.01):
    """Unicycle integration of the commands: final (x, y, heading) and the speeds seen."""
    x = y = heading = 0.0
    speeds = []
    for i in range(int(seconds / dt)):
        v, w = path.command(i * dt)
        speeds.append(v)
        x += v * math.cos(heading) * dt
        y += v * math.sin(heading) * dt
        heading += w * dt
    return x, y, heading, speeds


def test_straight_goes_straight():
    x, y, heading, _ = integrate(Path("straight", 2.0), 10.0)
    assert (x, y, heading) == pytest.approx((20.0, 0.0, 0.0), abs=0.05)


def test_circle_closes_with_the_given_radius():
    path = Path("circle", 3.0, radius=10.0)
    period = 2 * math.pi * 10.0 / 3.0
    x, y, heading, _ = integrate(path, period / 2)
    assert y == pytest.approx(20.0, abs=0.1)  # diametrically opposite after half a turn
    x, y, heading, _ = integrate(path, period)
    assert math.hypot(x, y) < 0.1


def test_figure8_returns_to_the_start():
    path = Path("figure8", 1.0, radius=5.0)
    x, y, _, _ = integrate(path, 2 * 2 * math.pi * 5.0)
    assert math.hypot(x, y) < 0.1


def test_back_and_forth_and_stop_and_go_change_speed():
    _, _, _, speeds = integrate(Path("back_and_forth", 1.0, radius=5.0), 30.0)
    assert min(speeds) == -1.0 and max(speeds) == 1.0
    _, _, _, speeds = integrate(Path("stop_and_go", 2.0), 20.0)
    assert 0.0 in speeds and 2.0 in speeds


def test_square_turns_by_quarter_turns():
    path = Path("square", 1.0, radius=5.0)
    side, corner = 10.0, 1.0
    lap = 4 * (side + math.pi / 2 * corner)
    x, y, heading, _ = integrate(path, lap, dt=0.001)
    assert heading == pytest.approx(2 * math.pi, abs=0.02)
    assert math.hypot(x, y) < 0.1


def test_random_path_is_seeded():
    a = [Path("random", 2.0, seed=3).command(t) for t in range(0, 60, 2)]
    b = [Path("random", 2.0, seed=3).command(t) for t in range(0, 60, 2)]
    c = [Path("random", 2.0, seed=4).command(t) for t in range(0, 60, 2)]
    assert a == b and a != c
    assert all(0.0 < v <= 2.0 and abs(w) <= 2.0 / 10.0 + 1e-9 for v, w in a)


def test_every_path_waits_for_its_start_and_bad_inputs_are_refused():
    for kind in PATHS:
        assert Path(kind, 1.0).command(-1.0) == (0.0, 0.0)
    with pytest.raises(PathError, match="unknown path 'zigzag'"):
        Path("zigzag", 1.0)
    with pytest.raises(PathError, match="speed"):
        Path("straight", float("nan"))
    with pytest.raises(PathError, match="radius"):
        Path("circle", 1.0, radius=0.0)
