"""Shared pytest set-up for every package's tests (`tests/run_all.sh` runs them from here)."""
import os
import signal
import subprocess
import time

import pytest


def _can_open_a_pty():
    try:
        master, slave = os.openpty()
    except OSError:
        return False
    os.close(master)
    os.close(slave)
    return True


# tests/run_all.sh (make test) sets this: everything the tests need is installed there, so a test that
# pytest.importorskip()s a missing module fails instead of passing as skipped.
STRICT_IMPORTS = os.environ.get("LANDING_TESTS_STRICT_IMPORTS") == "1"


def pytest_configure(config):
    config.addinivalue_line("markers", "needs_pty: the test types into a pseudo-terminal")
    config.addinivalue_line("markers", "slow: needs a ROS master, a terminal or minutes: make check leaves it out "
                                       "(make test runs it)")
    # Tests stop their children with SIGINT as Ctrl-C does. Started in the background of a script (`make test &`,
    # nohup), this process begins with SIGINT ignored, which every child would inherit and so shrug the test's
    # Ctrl-C off (a benchmark sweep ran on to its end): here it is Ctrl-C's own again, and so in the children.
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def _as_import_failure(report):
    """Turn ``report``, a skip for want of a module (pytest.importorskip), into a failure under make test."""
    if STRICT_IMPORTS and report.skipped:
        reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
        if "could not import" in reason:
            report.outcome = "failed"
            report.longrepr = "%s: under make test every module the tests need is installed (%s)" % (
                report.nodeid or "collection", reason)


@pytest.hookimpl(hookwrapper=True)
def pytest_make_collect_report(collector):
    outcome = yield
    _as_import_failure(outcome.get_result())


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    _as_import_failure(outcome.get_result())


def pytest_collection_modifyitems(config, items):
    """Containers without /dev/pts cannot run the terminal tests: say so instead of failing."""
    if _can_open_a_pty():
        return
    skip = pytest.mark.skip(reason="this machine cannot open a pseudo-terminal (is /dev/pts mounted?)")
    for item in items:
        if "needs_pty" in item.keywords:
            item.add_marker(skip)


@pytest.fixture
def ros_master():
    """A bare ROS master on a free port: (rosgraph.Master proxy, environment for nodes that use it)."""
    rosgraph = pytest.importorskip("rosgraph")
    from landing_eval.isolated_ros import free_port
    port = free_port()
    uri = "http://127.0.0.1:%d" % port
    env = dict(os.environ, ROS_MASTER_URI=uri, ROS_HOSTNAME="127.0.0.1")
    core = subprocess.Popen(["rosmaster", "--core", "-p", str(port)], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True)
    proxy = rosgraph.Master("/test", master_uri=uri)
    deadline = time.monotonic() + 60
    while True:
        try:
            proxy.getPid()
            break
        except Exception:  # not up yet
            assert time.monotonic() < deadline, "the ROS master did not start within 60 s"
            time.sleep(0.05)
    yield proxy, env
    core.terminate()
    core.wait(timeout=30)
