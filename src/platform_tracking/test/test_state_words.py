"""The tracker's states are the words landing_msgs/TrackerState defines (the supervisor and the station check
platform_tracking/state against the message's list, not against this package's enum)."""
from landing_msgs.msg import TrackerState
from landing_runtime.message_constants import message_constants
from platform_tracking.state_machine import Nav, State


def test_every_state_the_tracker_publishes_is_a_word_of_the_message():
    assert [state.value for state in State] == list(message_constants(TrackerState))


def test_the_navdata_codes_mirrored_in_the_state_machine_are_the_messages():
    from landing_msgs.msg import Navdata
    assert {code.name: code.value for code in Nav} == {
        name[len("STATE_"):]: value for name, value in vars(Navdata).items() if name.startswith("STATE_")}
