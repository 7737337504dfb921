import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
from interface.trails import Trail  # noqa: E402


def test_trail_keeps_recent_spaced_points_and_resets_when_time_goes_back():
    trail = Trail(seconds=10.0, spacing=0.5)
    assert trail.add(0.0, 0, 0, 0)
    assert not trail.add(0.1, 0.1, 0, 0)  # closer than the spacing
    for t in range(1, 30):
        trail.add(float(t), float(t), 0.0, 0.0)
    assert trail.points[0][0] >= 19.0 and trail.points[-1][0] == 29.0
    trail.add(1.0, 5.0, 5.0, 0.0)
    assert trail.points == [(1.0, 5.0, 5.0, 0.0)]
