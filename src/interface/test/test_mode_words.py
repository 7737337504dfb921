"""The supervisor's modes are the words landing_msgs/SupervisorMode defines: the mux, the emergency module, the console
and the station read supervisor/mode against the message, so the supervisor's enum must not drift from it."""
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "src"))
from interface.cmd_vel_mux import ALLOWED  # noqa: E402
from interface.supervisor import Mode  # noqa: E402

SupervisorMode = pytest.importorskip("landing_msgs.msg").SupervisorMode


def test_the_supervisor_s_modes_are_the_message_s_words():
    from landing_runtime.message_constants import message_constants
    assert [mode.value for mode in Mode] == list(message_constants(SupervisorMode))


def test_the_mux_knows_every_mode_and_no_other():
    from landing_runtime.message_constants import message_constants
    assert set(ALLOWED) - {None} == set(message_constants(SupervisorMode))
