"""mujoco_sim.scheduling: the stepping thread at SCHED_FIFO inside the block and as before after it; a refusal
says why and leaves the thread as it was; a worker started inside the block can go back to normal."""
import os
import threading
import time

import pytest

from mujoco_sim.scheduling import fifo_priority, normal_scheduling, stepping_priority, thread_cpu_and_wait


def _fifo_allowed():
    try:
        with fifo_priority(1) as refused:
            return refused is None
    except OSError:
        return False


needs_fifo = pytest.mark.skipif(not _fifo_allowed(), reason="SCHED_FIFO needs CAP_SYS_NICE or 'ulimit -r'")


def _policy_in_a_thread(work):
    """What ``work()`` returns, called in a new thread (the test's own thread keeps its scheduling)."""
    result = {}
    thread = threading.Thread(target=lambda: result.update(value=work()))
    thread.start()
    thread.join(30)
    return result["value"]


@needs_fifo
def test_the_thread_is_at_fifo_inside_the_block_and_as_before_after_it():
    def work():
        with fifo_priority(3) as refused:
            inside = (refused, os.sched_getscheduler(0), os.sched_getparam(0).sched_priority)
        return inside, os.sched_getscheduler(0)
    (refused, policy, priority), after = _policy_in_a_thread(work)
    assert refused is None
    assert (policy, priority) == (os.SCHED_FIFO, 3)
    assert after == os.SCHED_OTHER


@needs_fifo
def test_a_worker_started_inside_the_block_goes_back_to_normal_scheduling():
    def work():
        with fifo_priority(1):
            inherited = _policy_in_a_thread(lambda: os.sched_getscheduler(0))
            lowered = _policy_in_a_thread(lambda: (normal_scheduling(), os.sched_getscheduler(0))[1])
        return inherited, lowered
    inherited, lowered = _policy_in_a_thread(work)
    assert inherited == os.SCHED_FIFO  # why the camera's worker lowers itself
    assert lowered == os.SCHED_OTHER


def test_priority_0_keeps_normal_scheduling():
    def work():
        with fifo_priority(0) as refused:
            return refused, os.sched_getscheduler(0)
    refused, policy = _policy_in_a_thread(work)
    assert "0" in refused and policy == os.SCHED_OTHER


def test_a_refusal_says_what_is_needed_and_leaves_the_thread_as_it_was(monkeypatch):
    def refuse(*_args):
        raise PermissionError(1, "Operation not permitted")
    monkeypatch.setattr(os, "sched_setscheduler", refuse)  # the system's answer to a user without the right

    def work():
        with fifo_priority(1) as refused:
            return refused, os.sched_getscheduler(0)
    refused, policy = _policy_in_a_thread(work)
    assert "CAP_SYS_NICE" in refused and "ulimit -r 1" in refused
    assert policy == os.SCHED_OTHER


def test_a_threads_time_on_a_core_grows_with_its_work_and_not_with_its_sleep():
    def work():
        before = thread_cpu_and_wait()
        end = time.thread_time() + 0.2
        while time.thread_time() < end:  # 0.2 s of this thread's CPU
            pass
        busy = thread_cpu_and_wait()
        time.sleep(0.3)
        return before, busy, thread_cpu_and_wait()
    before, busy, slept = _policy_in_a_thread(work)
    assert 0.15 < busy[0] - before[0] < 0.5
    assert slept[0] - busy[0] < 0.05  # asleep: neither on a core nor waiting for one
    assert slept[1] - busy[1] < 0.05


@needs_fifo
def test_another_thread_is_raised_with_the_calling_one_and_put_back_after():
    ready, done = threading.Event(), threading.Event()
    ids = {}

    def waiting():
        ids["worker"] = threading.get_native_id()
        ready.set()
        done.wait(30)
    worker = threading.Thread(target=waiting)
    worker.start()
    ready.wait(30)

    def work():
        with fifo_priority(2, other_threads=[ids["worker"]]) as refused:
            inside = refused, os.sched_getscheduler(ids["worker"]), os.sched_getparam(ids["worker"]).sched_priority
        return inside, os.sched_getscheduler(ids["worker"])
    try:
        (refused, policy, priority), after = _policy_in_a_thread(work)
    finally:
        done.set()
        worker.join(30)
    assert refused is None
    assert (policy, priority) == (os.SCHED_FIFO, 2)
    assert after == os.SCHED_OTHER


def test_the_priority_applies_only_to_a_world_paced_by_its_nodes_on_two_cores_or_more():
    assert stepping_priority(1, lockstep_on=True, real_time_factor=0.0, cores=2) == (1, None)
    assert stepping_priority(0, True, 0.0, 2)[0] == 0
    assert stepping_priority(1, False, 0.0, 2) == (0, "lock-step is off")
    assert stepping_priority(1, True, 1.0, 2) == (0, "real_time_factor 1 paces the world")
    assert stepping_priority(1, True, 0.0, 1) == (0, "one core only")
