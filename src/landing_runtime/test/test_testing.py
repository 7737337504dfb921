"""landing_runtime.testing.wait_for and resend_until: the shared waits of the tests."""
import subprocess
import sys
import time

import pytest

from landing_runtime.testing import resend_until, wait_for


def test_returns_the_first_true_value():
    values = iter([0, None, [], "ready", "later"])
    assert wait_for(lambda: next(values), "a value", timeout=10, poll=0.001) == "ready"


def test_fails_naming_what_it_waited_for_after_the_timeout():
    start = time.monotonic()
    with pytest.raises(AssertionError, match=r"timed out after 0 s \(wall\) waiting for the moon"):
        wait_for(lambda: False, "the moon", timeout=0.2, poll=0.01)
    assert time.monotonic() - start < 10


def test_fails_at_once_when_the_process_it_depends_on_exits():
    process = subprocess.Popen([sys.executable, "-c", "import sys; sys.exit(3)"])
    process.wait(timeout=60)
    with pytest.raises(AssertionError, match="exited \\(code 3\\) while waiting for its output"):
        wait_for(lambda: False, "its output", timeout=600, process=process)


def test_resend_until_sends_at_once_and_again_until_the_condition_holds():
    sent = []
    value = resend_until(lambda: sent.append(time.monotonic()), lambda: len(sent) >= 3 and "met", "three sends",
                         timeout=60, period_s=0.05)
    assert value == "met" and len(sent) == 3
    assert all(b - a > 0.05 for a, b in zip(sent, sent[1:]))


def test_resend_until_fails_naming_what_it_waited_for():
    with pytest.raises(AssertionError, match="waiting for an answer"):
        resend_until(lambda: None, lambda: False, "an answer", timeout=0.2)
