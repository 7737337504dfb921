"""The venv's pinned packages live with Debian's ROS modules: Ray (benchmark --ray) must not have pulled a
numpy 2 over Debian's numpy 1.24, which cv_bridge is built against."""
import importlib.metadata
import os
import re

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def pinned():
    with open(os.path.join(ROOT, "requirements.txt")) as stream:
        return dict(re.findall(r"^([A-Za-z0-9_.\-]+)==(\S+)", stream.read(), flags=re.M))


def test_numpy_is_debians_1_x_and_cv_bridge_converts_an_image():
    import cv_bridge
    import numpy as np
    assert np.__version__.split(".")[0] == "1", np.__version__
    image = cv_bridge.CvBridge().cv2_to_imgmsg(np.zeros((2, 3, 3), np.uint8), "rgb8")
    assert (image.width, image.height) == (3, 2)


def test_ray_is_the_pinned_version():
    import ray
    assert ray.__version__ == pinned()["ray"]
    assert importlib.metadata.version("protobuf") == pinned()["protobuf"]
