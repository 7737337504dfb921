"""The pad's face (mujoco_sim.pads): the AprilTag pad's world, its foreign pad, and an unknown pad refused."""
import math
import os

import mujoco
import numpy as np
import pytest

from mujoco_sim import pads
from mujoco_sim.config import ConfigError
from mujoco_sim.simulator import load_model

MODELS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "models")


@pytest.mark.parametrize("vehicle", ["summit_xl", "car"])
def test_the_apriltag_world_textures_the_pad_and_drops_the_strip_and_the_marker(vehicle):
    world = os.path.join(MODELS, "world_%s.xml" % vehicle)
    red = load_model(world)
    tags = load_model(world, "apriltag")
    geom = lambda m, name: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, name)  # noqa: E731
    assert geom(red, "landing_pad_heading") >= 0 and geom(tags, "landing_pad_heading") < 0
    assert geom(tags, "landing_pad_marker") < 0
    pad = geom(tags, "landing_pad")
    material = tags.geom_matid[pad]
    assert material >= 0
    texture = tags.mat_texid[material][mujoco.mjtTextureRole.mjTEXROLE_RGB]
    assert texture >= 0 and tags.tex_width[texture] == tags.tex_height[texture] == 400
    values = set(np.unique(tags.tex_data[tags.tex_adr[texture]:tags.tex_adr[texture] + 400 * 400 * 3]))
    assert values == {pads.BLACK, pads.WHITE}
    # The pad itself is the same box (size, place, contacts): only its face changed.
    assert np.allclose(red.geom_size[geom(red, "landing_pad")], tags.geom_size[pad])
    assert np.allclose(red.geom_pos[geom(red, "landing_pad")], tags.geom_pos[pad])
    assert mujoco.mj_name2id(tags, mujoco.mjtObj.mjOBJ_BODY, pads.FOREIGN_PAD_BODY) >= 0
    assert mujoco.mj_name2id(red, mujoco.mjtObj.mjOBJ_BODY, pads.FOREIGN_PAD_BODY) < 0


def test_the_texture_is_the_top_view_turned_onto_the_box_face():
    import cv2
    top = cv2.imread(pads.PAD_TEXTURE, cv2.IMREAD_GRAYSCALE)
    rgb, width, height = pads._texture_rgb(pads.PAD_TEXTURE)
    # MuJoCo's texture column runs along the pad's forward (x), its row from the left (+y) to the right: the top view's
    # front row (row 0) is the texture's last column, the top view's left column the texture's first row.
    assert (width, height) == (top.shape[1], top.shape[0])
    assert np.array_equal(rgb[:, -1, 0] > 127, top[0, :] > 127)
    assert np.array_equal(rgb[0, :, 0] > 127, top[::-1, 0] > 127)


def test_an_unknown_pad_is_refused_with_the_choices():
    with pytest.raises(ConfigError, match="pad: expected one of red_square | apriltag, got 'aruco'"):
        load_model(os.path.join(MODELS, "world_summit_xl.xml"), "aruco")
    with pytest.raises(ConfigError, match="red_square | apriltag"):
        pads.check_pad(None)


def test_the_false_target_fault_puts_the_foreign_pad_beside_the_vehicle_opposite_the_red_target():
    from mujoco_sim.schema import load_sim_config
    from mujoco_sim.simulator import Simulator
    config = load_sim_config(os.path.join(MODELS, "..", "config", "sim.yaml"))
    config["pad"] = "apriltag"
    sim = Simulator(config, os.path.join(MODELS, "world_summit_xl.xml"), "summit_xl", seed=1)
    try:
        assert sim.foreign_pad_mocap >= 0
        sim.inject_fault("detection_false_target", 5.0)
        sim._place_false_target(sim.time)
        x, y, yaw = sim.vehicle_pose()
        foreign = sim.data.mocap_pos[sim.foreign_pad_mocap]
        red = sim.data.mocap_pos[sim.false_target_mocap]
        right = np.array([math.sin(yaw), -math.cos(yaw)])
        assert np.allclose(foreign[:2], np.array([x, y]) + pads.FOREIGN_PAD_OFFSET * right)
        assert np.dot(red[:2] - np.array([x, y]), right) < 0  # the red target on the other side
        sim.false_target_until = -1.0
        sim._place_false_target(sim.time + 10.0)
        assert sim.data.mocap_pos[sim.foreign_pad_mocap][2] < -1.0
    finally:
        sim.close()
