#!/usr/bin/env python3
"""rostest of the supervisor's ~reset: a reset supervisor starts as a fresh one (mode idle, the same first latched
outputs, no tracker command latched, the idle take-off timer from the reset on, its services answered by the new
state), with its parameters as they are then; a bad parameter is refused and it goes on as it was; and its
~recovery follows the reset: a crash after it carries on in the new scenario, not in the previous one."""
import json
import subprocess
import sys
import unittest

import rospy
import rostest
from landing_runtime import testing
from std_msgs.msg import Bool, String
from std_srvs.srv import Trigger

WALL_TIMEOUT = 120.0
NODE = "/supervisor"
IDLE_TAKEOFF_S = 600.0  # supervisor_reset.test: no auto take-off during the test
# A subscriber in a process of its own: one in this process would share this process's connection, which hands every
# new subscriber the last latched message it received (rospy #1852), whatever the publisher holds now.
NEWCOMER = """
import json, sys
import rospy
from std_msgs.msg import Bool, String
from landing_runtime import testing
rospy.init_node("newcomer", anonymous=True)
got = {name: [] for name, _topic, _type in json.loads(sys.argv[1])}
subscribers = [rospy.Subscriber(topic, {"Bool": Bool, "String": String}[kind],
                                lambda msg, name=name: got[name].append(msg.data))
               for name, topic, kind in json.loads(sys.argv[1])]
testing.wait_for(lambda: rospy.get_time() > 0 and all(s.get_num_connections() for s in subscribers),
                 "the clock and a connection on every topic", 60.0)
end = rospy.get_time() + 1.0
testing.wait_for(lambda: rospy.get_time() >= end, "1 s of sim time", 60.0)
print(json.dumps(got))
"""


class Recorder:
    """Every message of the supervisor's outputs, from one subscription each."""

    TOPICS = {"mode": ("/supervisor/mode", String), "warning": ("/supervisor/warning", String),
              "allowed": ("/landing_allowed", Bool), "flight_management": ("/supervisor/flight_management", String),
              "tracker": ("/platform_tracking/command", String), "decisions": ("/supervisor/decisions", String)}

    def __init__(self):
        self.messages = {name: [] for name in self.TOPICS}
        self.subscribers = [rospy.Subscriber(topic, kind, self._append(name), queue_size=100)
                            for name, (topic, kind) in self.TOPICS.items()]

    def _append(self, name):
        return lambda msg: self.messages[name].append(msg.data)



class SupervisorResetTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_supervisor_reset")
        cls.out = Recorder()
        rospy.wait_for_service(NODE + "/reset", timeout=WALL_TIMEOUT)
        testing.wait_for(lambda: rospy.get_time() > 0.5 and cls.out.messages["flight_management"][1:],
                         "the clock and the supervisor's first tick", WALL_TIMEOUT)
        cls.fresh = {name: list(messages) for name, messages in cls.out.messages.items()}

    def wait_for(self, condition, what):
        return testing.wait_for(condition, what, WALL_TIMEOUT)

    def sim_wait(self, seconds):
        end = rospy.get_time() + seconds
        self.wait_for(lambda: rospy.get_time() >= end, "%.1f s of sim time" % seconds)

    @staticmethod
    def call(service):
        return rospy.ServiceProxy(NODE + "/" + service, Trigger)()

    def command(self, word, mode):
        response = self.call(word)
        self.assertTrue(response.success, response.message)
        self.wait_for(lambda: self.out.messages["mode"][-1:] == [mode], "supervisor/mode %s" % mode)

    @staticmethod
    def saved_mode():
        saved = rospy.get_param(NODE + "/recovery", None)
        return json.loads(saved)["snapshot"]["mode"] if saved else None

    def reset(self):
        """Calls ~reset; returns (response, sim time before the call, its message counts before the call)."""
        before = {name: len(messages) for name, messages in self.out.messages.items()}
        t = rospy.get_time()
        return self.call("reset"), t, before

    def since(self, name, before):
        return self.out.messages[name][before[name]:]

    @staticmethod
    def latched_to_a_newcomer(names):
        """What a subscriber of another process connecting now receives within 1 s of sim time."""
        topics = [(name, Recorder.TOPICS[name][0], Recorder.TOPICS[name][1].__name__) for name in names]
        result = subprocess.run([sys.executable, "-c", NEWCOMER, json.dumps(topics)], capture_output=True, text=True,
                                timeout=WALL_TIMEOUT)
        if result.returncode != 0:
            raise AssertionError("the newcomer failed: %s" % result.stderr[-2000:])
        return json.loads(result.stdout.strip().splitlines()[-1])

    def crash(self):
        """Kills the supervisor (SIGKILL: nothing tidied); supervisor.launch respawns it. Returns its decisions after
        the respawn from the 'recovered' one on."""
        before = len(self.out.messages["decisions"])
        testing.crash_and_wait_for_respawn(NODE, WALL_TIMEOUT)
        self.wait_for(lambda: any(json.loads(d)["action"] == "recovered"
                                  for d in self.out.messages["decisions"][before:]), "the 'recovered' decision")
        return [json.loads(d) for d in self.out.messages["decisions"][before:]]

    def test_1_a_reset_supervisor_starts_afresh_with_its_new_parameters(self):
        self.assertEqual(self.fresh["mode"], ["idle"])
        self.assertEqual(self.fresh["tracker"], [])
        self.command("landing", "landing")
        self.wait_for(lambda: self.out.messages["tracker"][-1:] == ["takeoff"], "platform_tracking/command takeoff")
        self.wait_for(lambda: self.saved_mode() == "landing", "~recovery in mode landing")

        rospy.set_param(NODE + "/idle_takeoff_s", IDLE_TAKEOFF_S / 2)
        response, t_before, before = self.reset()
        t_after = rospy.get_time()
        self.assertTrue(response.success, response.message)
        self.assertEqual(self.saved_mode(), "idle", "~recovery must hold the fresh state at once")
        self.wait_for(lambda: len(self.since("flight_management", before)) >= 2, "two flight_management messages")
        # The same first outputs as the fresh supervisor's (its auto take-off time aside) ...
        for name in ("mode", "warning", "allowed"):
            self.wait_for(lambda: len(self.since(name, before)) >= len(self.fresh[name]), "the first %s" % name)
            self.assertEqual(self.since(name, before)[:len(self.fresh[name])], self.fresh[name], name)
        self.assertEqual(self.since("tracker", before), [])
        first, second = [json.loads(m) for m in self.since("flight_management", before)[:2]]
        self.assertEqual(first, json.loads(self.fresh["flight_management"][0]))
        # ... with the new idle take-off time, counted from the reset.
        self.assertTrue(t_before + IDLE_TAKEOFF_S / 2 - 0.1 <= second["auto_takeoff_at"] <=
                        t_after + IDLE_TAKEOFF_S / 2 + 1.0, (t_before, t_after, second))
        # Nothing of the previous scenario stays latched: a newcomer gets the fresh outputs alone.
        latched = self.latched_to_a_newcomer(("mode", "tracker", "allowed"))
        self.assertEqual(latched, {"mode": ["idle"], "tracker": [], "allowed": [False]})

    def test_2_the_reset_supervisor_answers_its_services_and_keeps_its_own_state_for_a_respawn(self):
        self.command("manual", "manual")
        self.wait_for(lambda: self.saved_mode() == "manual", "~recovery in mode manual")
        decisions = self.crash()
        recovered = next(d for d in decisions if d["action"] == "recovered")
        self.assertEqual(recovered["value"]["mode"], "manual")
        self.wait_for(lambda: self.out.messages["mode"][-1:] == ["manual"], "supervisor/mode manual after the respawn")

    def test_3_a_crash_right_after_a_reset_carries_on_in_the_new_scenario(self):
        self.command("landing", "landing")  # manual -> landing (test 2)
        self.wait_for(lambda: self.saved_mode() == "landing", "~recovery in mode landing")
        response, _t, before = self.reset()
        self.assertTrue(response.success, response.message)
        self.wait_for(lambda: self.since("mode", before) == ["idle"], "supervisor/mode idle after the reset")
        decisions = self.crash()
        recovered = next(d for d in decisions if d["action"] == "recovered")
        self.assertEqual(recovered["value"]["mode"], "idle")
        self.assertEqual(self.latched_to_a_newcomer(("mode", "tracker")), {"mode": ["idle"], "tracker": []})

    def test_4_a_bad_parameter_is_refused_and_the_supervisor_goes_on(self):
        self.command("manual", "manual")
        # The operator chose: no auto take-off pending (published right after the mode).
        fm_before = self.wait_for(lambda: [m for m in self.out.messages["flight_management"][-1:]
                                           if json.loads(m)["auto_takeoff_at"] is None], "no auto take-off pending")[0]
        rospy.set_param(NODE + "/rate_hz", 1000.0)
        try:
            response, _t, before = self.reset()
        finally:
            rospy.set_param(NODE + "/rate_hz", 10.0)
        self.assertFalse(response.success)
        self.assertIn("rate_hz", response.message)
        self.assertIn("not reset", response.message)
        # It goes on as it was: its latched outputs stay, its services answer, ~recovery holds its state.
        self.assertEqual(self.latched_to_a_newcomer(("mode", "tracker", "flight_management")),
                         {"mode": ["manual"], "tracker": ["hold"], "flight_management": [fm_before]})
        self.assertEqual(self.since("mode", before), [])
        self.assertEqual(self.saved_mode(), "manual")
        self.command("landing", "landing")
        self.wait_for(lambda: self.saved_mode() == "landing", "~recovery in mode landing")

    def test_5_the_previous_scenarios_operator_command_does_not_reach_the_reset_supervisor(self):
        # As the scenario runner does: its operator command is latched, and forgotten before the graph is reset.
        operator = rospy.Publisher("/operator/command", String, queue_size=1, latch=True)
        self.wait_for(lambda: operator.get_num_connections() > 0, "the supervisor on operator/command")
        operator.publish(String(data="manual"))
        self.wait_for(lambda: self.out.messages["mode"][-1:] == ["manual"], "supervisor/mode manual")
        operator.impl.latch = None
        response, _t, before = self.reset()
        self.assertTrue(response.success, response.message)
        self.sim_wait(1.0)
        # rospy keeps the last latched message of the supervisor's connection to this process, and would hand it
        # to the reset supervisor's new subscriber: it must be forgotten, as a fresh supervisor never got it.
        self.assertEqual(self.since("mode", before), ["idle"])


if __name__ == "__main__":
    rostest.rosrun("interface", "supervisor_reset", SupervisorResetTest)
