from landing_msgs.msg import Navdata, TrackerState
from landing_runtime.message_constants import message_constants


def test_the_navdata_states_are_the_messages_codes_in_order():
    assert message_constants(Navdata, "STATE_") == tuple(range(11))


def test_the_tracker_states_are_the_words_the_message_defines():
    states = message_constants(TrackerState)
    assert states[0] == "LANDED" and "TRACKING" in states and "FORCE_LANDING" in states
    assert len(states) == 6  # no field name, type name or md5 slipped in


def test_a_prefix_that_matches_nothing_gives_nothing():
    assert message_constants(Navdata, "NO_SUCH_") == ()
