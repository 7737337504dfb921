"""shutdown_on_signals: the signal only starts a thread; rospy is shut down there, not in the handler."""
import os
import signal
import threading

import rospy

from landing_runtime.shutdown import shutdown_on_signals


def test_a_signal_shuts_rospy_down_from_another_thread_while_the_interrupted_thread_holds_a_lock(monkeypatch):
    held = threading.Lock()
    calls, done = [], threading.Event()

    def signal_shutdown(reason):
        with held:  # what rospy's close callbacks do: take the lock of a connection being written to
            calls.append((reason, threading.current_thread() is threading.main_thread()))
        done.set()

    monkeypatch.setattr(rospy, "signal_shutdown", signal_shutdown)
    previous = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        shutdown_on_signals()
        with held:  # the main thread is mid-publish when the signal arrives
            os.kill(os.getpid(), signal.SIGTERM)
        assert done.wait(5.0), "rospy was not shut down"
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    assert calls == [("signal SIGTERM", False)]
