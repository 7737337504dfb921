"""The landing pad's face: the red square of the model files (the thesis') or the AprilTag pad (a fiducial pad).

``red_square`` is the model file as it is: the red 1 m square with its green heading strip and white centre marker.
``apriltag`` puts the AprilTag layout of ``models/apriltag_pad.png`` on the pad's top (the pad seen from above, the
vehicle's front up: a 1 m tagCustom48h12 with a small tag36h11 in its central hole; made by uav_vision's
apriltag_pad_texture from libapriltag's family bitmaps), removes the strip and the marker, and adds a foreign pad
(``models/apriltag_foreign_pad.png``: the same families, other ids) that the ``detection_false_target`` fault puts
on the ground beside the vehicle, opposite the red false target. ROS-free.
"""
import os

import numpy as np

from .config import ConfigError

PADS = ("red_square", "apriltag")
MODELS_DIR = os.path.realpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "models"))
PAD_TEXTURE = os.path.join(MODELS_DIR, "apriltag_pad.png")
FOREIGN_PAD_TEXTURE = os.path.join(MODELS_DIR, "apriltag_foreign_pad.png")
FOREIGN_PAD_BODY = "foreign_pad"
FOREIGN_PAD_HALF = 0.5         # half the foreign pad's side [m]
FOREIGN_PAD_OFFSET = 1.8       # the foreign pad's centre to the vehicle's right while the fault lasts [m]
# A printed tag under the sun: white paint reflects about 85 % (the red pad's red channel too), black about 6 %.
WHITE, BLACK = 217, 15


def check_pad(pad, where="pad"):
    """``pad`` if it is one of PADS, else ConfigError naming ``where`` and the choices."""
    if pad not in PADS:
        raise ConfigError("%s: expected one of %s, got %r" % (where, " | ".join(PADS), pad))
    return pad


def _texture_rgb(path):
    """The top view at ``path`` as the RGB data of MuJoCo's 2-D texture on a box's top face, whose columns run
    along the geom's x (the pad's forward) and whose rows run from +y (the pad's left) to -y: the top view (rows
    from the front to the back, columns from the left to the right) turned a quarter clockwise."""
    import cv2
    top = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
    if top is None or top.shape[0] != top.shape[1]:
        raise ConfigError("%s: the AprilTag pad's texture is missing or not square; make it with `rosrun uav_vision "
                          "apriltag_pad_texture --out %s` (see that tool's header for the foreign pad's)" % (path, path))
    texture = np.rot90(top, k=-1)
    grey = np.where(texture > 127, WHITE, BLACK).astype(np.uint8)
    return np.ascontiguousarray(np.repeat(grey[:, :, None], 3, axis=2)), texture.shape[1], texture.shape[0]


def _add_texture(spec, mujoco, name, path):
    rgb, width, height = _texture_rgb(path)
    texture = spec.add_texture(name=name, type=mujoco.mjtTexture.mjTEXTURE_2D, width=width, height=height,
                               nchannel=3)
    texture.data = rgb.tobytes()
    material = spec.add_material(name=name, rgba=[1.0, 1.0, 1.0, 1.0])
    material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = name
    return name


def apply_apriltag_pad(spec, mujoco):
    """Turns the red pad of ``spec`` (an MjSpec of a world with a geom 'landing_pad') into the AprilTag pad and
    adds the foreign pad, parked below the ground."""
    pad = spec.geom("landing_pad")
    if pad is None:
        raise ConfigError("the model has no geom named 'landing_pad' to put the AprilTag pad on")
    pad.material = _add_texture(spec, mujoco, "landing_pad_apriltag", PAD_TEXTURE)
    pad.rgba = [1.0, 1.0, 1.0, 1.0]
    for name in ("landing_pad_heading", "landing_pad_marker"):
        geom = spec.geom(name)
        if geom is not None:
            spec.delete(geom)
    foreign = spec.worldbody.add_body(name=FOREIGN_PAD_BODY, mocap=True, pos=[0.0, 0.0, -50.0])
    foreign.add_geom(name=FOREIGN_PAD_BODY, type=mujoco.mjtGeom.mjGEOM_BOX,
                     size=[FOREIGN_PAD_HALF, FOREIGN_PAD_HALF, 0.003], contype=0, conaffinity=0,
                     material=_add_texture(spec, mujoco, "foreign_pad_apriltag", FOREIGN_PAD_TEXTURE))


def compile_world(model_file, pad):
    """The MuJoCo model of ``model_file`` with the pad ``pad`` (PADS); ValueError from MuJoCo as it comes."""
    import mujoco
    check_pad(pad)
    if pad == "red_square":
        return mujoco.MjModel.from_xml_path(model_file)
    spec = mujoco.MjSpec.from_file(model_file)
    apply_apriltag_pad(spec, mujoco)
    return spec.compile()
