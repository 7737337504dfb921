"""Shared pytest set-up for every package's tests (`tests/run_all.sh` runs them from here)."""
import os

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
