"""Under make test (LANDING_TESTS_STRICT_IMPORTS=1, set by tests/run_all.sh) a test that
pytest.importorskip()s a module that is not installed fails; elsewhere it is skipped as usual."""
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
AT_COLLECTION = """import pytest
pytest.importorskip("landing_no_such_module")


def test_never_runs():
    pass
"""
IN_A_TEST = """import pytest


def test_needs_it():
    pytest.importorskip("landing_no_such_module")
"""


def run(tmp_path, code, strict):
    (tmp_path / "test_probe.py").write_text(code)
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""),
               LANDING_TESTS_STRICT_IMPORTS="1" if strict else "0")
    # -p conftest: the workspace's conftest.py, which holds the rule, as a plugin
    return subprocess.run([sys.executable, "-m", "pytest", "-p", "conftest", "-p", "no:cacheprovider", "-q",
                           "--rootdir", str(tmp_path), str(tmp_path / "test_probe.py")],
                          capture_output=True, text=True, timeout=300, env=env, cwd=str(tmp_path))


def test_a_module_level_importorskip_fails_under_make_test(tmp_path):
    result = run(tmp_path, AT_COLLECTION, strict=True)
    assert result.returncode != 0 and "landing_no_such_module" in result.stdout, result.stdout
    assert "1 error" in result.stdout, result.stdout


def test_an_importorskip_inside_a_test_fails_under_make_test(tmp_path):
    result = run(tmp_path, IN_A_TEST, strict=True)
    assert result.returncode == 1 and "1 failed" in result.stdout, result.stdout


def test_elsewhere_both_are_skipped(tmp_path):
    for code in (AT_COLLECTION, IN_A_TEST):
        result = run(tmp_path, code, strict=False)
        assert result.returncode in (0, 5) and "skipped" in result.stdout, result.stdout  # 5: no test ran
