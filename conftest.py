"""Shared pytest set-up for every package's tests (`tests/run_all.sh` runs them from here)."""
import os
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


def pytest_configure(config):
    config.addinivalue_line("markers", "needs_pty: the test types into a pseudo-terminal")


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
