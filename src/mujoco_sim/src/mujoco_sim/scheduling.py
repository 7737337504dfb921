"""The CPU scheduling of the simulator's stepping thread and its camera's rendering thread.

In the lock-step loop the simulator's stepping thread is the critical path, and on a 2-core machine it
waited for a core about half of the flight: every message it sends wakes a node, which took its core
(/proc schedstat of its thread: on a core 42 % of the flight, runnable but waiting 49-52 %). At a real-time
priority (SCHED_FIFO) a woken node no longer preempts it; it still yields the core whenever it waits for a
lagging node's acknowledgement, so the nodes get the cores the loop needs them on. So does the camera's thread,
whose frames the stepping thread waits for when they are due.

The price: the simulator then runs as far ahead of the nodes as lock-step allows (max_lead_s) all the time, as it
does on a loaded machine, instead of letting each woken node run first. So it is off by default
(lockstep/realtime_priority in config/sim.yaml).
"""
import contextlib
import os


def stepping_priority(configured, lockstep_on, real_time_factor, cores):
    """(the real-time priority for the stepping and camera threads, why it is 0 or None): ``configured`` only when
    lock-step paces the world at full speed (the stepping thread then waits for the nodes whenever it is ahead;
    without lock-step it would keep a core to itself) and with a second core for the nodes."""
    if not lockstep_on:
        return 0, "lock-step is off"
    if real_time_factor > 0.0:
        return 0, "real_time_factor %g paces the world" % real_time_factor
    if cores < 2:
        return 0, "one core only"
    return configured, None if configured > 0 else "lockstep/realtime_priority is 0"


@contextlib.contextmanager
def fifo_priority(priority, other_threads=()):
    """The calling thread and ``other_threads`` (native thread ids) at SCHED_FIFO ``priority`` (1..99) inside the
    block, and each at the scheduling it had before after it (a thread gone meanwhile is skipped). Yields None when
    the priority is in force, else why it is not: ``priority`` 0, or the system refused it (raising a priority
    needs CAP_SYS_NICE, e.g. root, or an RLIMIT_RTPRIO of at least ``priority``: ``ulimit -r``). Threads the
    calling thread starts inside the block inherit the priority."""
    if priority <= 0:
        yield "real-time priority 0 asked: normal scheduling"
        return
    raised = []  # (thread id, its policy and parameters before)
    try:
        for thread in [0] + list(other_threads):  # 0: the calling thread
            before = os.sched_getscheduler(thread), os.sched_getparam(thread)
            os.sched_setscheduler(thread, os.SCHED_FIFO, os.sched_param(priority))
            raised.append((thread, before))
    except OSError as err:  # PermissionError without the capability or limit
        _restore(raised)
        yield "SCHED_FIFO %d refused (%s): it needs CAP_SYS_NICE (root) or 'ulimit -r %d'" % (
            priority, err.strerror or err, priority)
        return
    try:
        yield None
    finally:
        _restore(raised)


def _restore(raised):
    for thread, (policy, param) in raised:
        try:
            os.sched_setscheduler(thread, policy, param)
        except ProcessLookupError:  # that thread has ended
            pass


def normal_scheduling():
    """Put the calling thread at normal scheduling (SCHED_OTHER; lowering needs no privilege): for a worker
    thread that may have been started by a thread at a real-time priority."""
    if os.sched_getscheduler(0) != os.SCHED_OTHER:
        os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))


def thread_cpu_and_wait():
    """(seconds on a core, seconds runnable but waiting for one) of the calling thread since it started, from the
    kernel's scheduler statistics (/proc/thread-self/schedstat), or None where they are not kept."""
    try:
        with open("/proc/thread-self/schedstat") as stream:
            on_core_ns, waiting_ns = stream.read().split()[:2]
    except (OSError, ValueError):
        return None
    return int(on_core_ns) / 1e9, int(waiting_ns) / 1e9
