"""The stand-in's types are wire-identical to the real AR.Drone driver's (ardrone_autonomy, AutonomyLab).

ROS-free: genmsg computes the MD5 sums from msg/Navdata.msg and srv/CamSelect.srv as roscpp/rospy
would, and they must equal the sums the real driver's generated code carries. Any change to a
field name, type, order or constant breaks the connection to a real driver and fails here.
"""
import os

import pytest

genmsg = pytest.importorskip("genmsg")
from genmsg import gentools, msg_loader  # noqa: E402

PKG = "ardrone_autonomy"
HERE = os.path.dirname(os.path.abspath(__file__))
PKG_DIR = os.path.dirname(HERE)
STD_MSGS_DIR = "/usr/share/std_msgs/msg"

# Published MD5 sums of the real driver's types, all read in genmsg-generated code of a build of the
# real driver committed to GitHub: pavankumarbn/DroneGUIROS at commit
# 13b8c9c1e38867a18e6f197ee61f0d2fcf01f5e1,
#   devel/share/common-lisp/ros/ardrone_autonomy/msg/Navdata.lisp   (Navdata)
#   devel/share/common-lisp/ros/ardrone_autonomy/srv/CamSelect.lisp (CamSelect service)
#   devel/include/ardrone_autonomy/CamSelectRequest.h               (request)
#   devel/include/ardrone_autonomy/CamSelectResponse.h              (response)
# The Navdata sum also appears in rosserial (ros_lib) and gennodejs code generated from the driver.
NAVDATA_MD5 = "e1169f766234363125ac62c9a3f87eeb"
CAMSELECT_MD5 = "bbeb5212f8ee1d6da7ff0d1169124280"
CAMSELECT_REQUEST_MD5 = "c27320df100593b008f1bb2e1302dbb6"
CAMSELECT_RESPONSE_MD5 = "eb13ac1f1354ccecb7941ee8fa2192e8"

# The driver's documented field list (docs.ros.org .../ardrone_autonomy/html/msg/Navdata.html,
# "Compact Message Definition"), as (type, name) in order.
NAVDATA_FIELDS = [
    ("std_msgs/Header", "header"), ("float32", "batteryPercent"), ("uint32", "state"),
    ("int32", "magX"), ("int32", "magY"), ("int32", "magZ"), ("int32", "pressure"), ("int32", "temp"),
    ("float32", "wind_speed"), ("float32", "wind_angle"), ("float32", "wind_comp_angle"),
    ("float32", "rotX"), ("float32", "rotY"), ("float32", "rotZ"), ("int32", "altd"),
    ("float32", "vx"), ("float32", "vy"), ("float32", "vz"),
    ("float32", "ax"), ("float32", "ay"), ("float32", "az"),
    ("uint8", "motor1"), ("uint8", "motor2"), ("uint8", "motor3"), ("uint8", "motor4"),
    ("uint32", "tags_count"), ("uint32[]", "tags_type"), ("uint32[]", "tags_xc"), ("uint32[]", "tags_yc"),
    ("uint32[]", "tags_width"), ("uint32[]", "tags_height"), ("float32[]", "tags_orientation"),
    ("float32[]", "tags_distance"), ("float32", "tm"),
]


def _search_path():
    return {PKG: [os.path.join(PKG_DIR, "msg")], "std_msgs": [STD_MSGS_DIR]}


@pytest.fixture(scope="module")
def navdata():
    if not os.path.isdir(STD_MSGS_DIR):
        pytest.skip("std_msgs definitions not found at %s" % STD_MSGS_DIR)
    ctx = genmsg.MsgContext.create_default()
    spec = msg_loader.load_msg_from_file(ctx, os.path.join(PKG_DIR, "msg", "Navdata.msg"), PKG + "/Navdata")
    msg_loader.load_depends(ctx, spec, _search_path())
    return ctx, spec


@pytest.fixture(scope="module")
def camselect():
    ctx = genmsg.MsgContext.create_default()
    spec = msg_loader.load_srv_from_file(ctx, os.path.join(PKG_DIR, "srv", "CamSelect.srv"), PKG + "/CamSelect")
    msg_loader.load_depends(ctx, spec, _search_path())
    return ctx, spec


def test_navdata_md5_matches_the_real_driver(navdata):
    ctx, spec = navdata
    assert gentools.compute_md5(ctx, spec) == NAVDATA_MD5


def test_navdata_fields_are_the_documented_ones_and_there_are_no_constants(navdata):
    _, spec = navdata
    assert list(zip(spec.types, spec.names)) == NAVDATA_FIELDS
    assert spec.constants == []  # the real message has none; one would change the MD5 sum


def test_camselect_md5s_match_the_real_driver(camselect):
    ctx, spec = camselect
    assert gentools.compute_md5(ctx, spec.request) == CAMSELECT_REQUEST_MD5
    assert gentools.compute_md5(ctx, spec.response) == CAMSELECT_RESPONSE_MD5
    assert gentools.compute_md5(ctx, spec) == CAMSELECT_MD5


def test_camselect_fields(camselect):
    _, spec = camselect
    assert list(zip(spec.request.types, spec.request.names)) == [("uint8", "channel")]
    assert list(zip(spec.response.types, spec.response.names)) == [("bool", "result")]
    assert spec.request.constants == [] and spec.response.constants == []
