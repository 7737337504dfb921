"""tests/list_failures.py: what the end of `make test`'s output says when something failed."""
import subprocess
import sys
from pathlib import Path

SCRIPT = Path(__file__).with_name("list_failures.py")

ROSTEST_RESULT = """<?xml version="1.0" encoding="utf-8"?>
<testsuite errors="1" failures="1" name="recorder" tests="3">
  <testcase classname="flight_recorder.RecorderTest" name="test_counts_and_types_per_topic">
    <failure message="AssertionError: {'/imu': 149} != {'/imu': 150}&#10;- {'/imu': 149}" type="">...</failure>
  </testcase>
  <testcase classname="flight_recorder.RecorderTest" name="test_nothing_is_written_before_the_clock_is_valid"/>
  <testcase classname="flight_recorder.RecorderTest" name="testrecorder"><error type="">timed out</error></testcase>
</testsuite>
"""
PASSED_RESULT = """<testsuite errors="0" failures="0" name="ok" tests="1"><testcase classname="a" name="b"/></testsuite>"""


def run(*paths):
    return subprocess.run([sys.executable, str(SCRIPT), *map(str, paths)], capture_output=True, text=True,
                          timeout=60, check=True).stdout


def test_each_failed_case_is_named_with_the_first_line_of_its_message(tmp_path):
    results = tmp_path / "test_results" / "flight_recorder"
    results.mkdir(parents=True)
    (results / "rostest-test_recorder.xml").write_text(ROSTEST_RESULT)
    (results / "gtest-ok.xml").write_text(PASSED_RESULT)
    lines = run(tmp_path / "test_results", tmp_path / "absent.xml").splitlines()
    assert lines == [
        "== failed tests (2)",
        "FAILED rostest-test_recorder.xml: flight_recorder.RecorderTest.test_counts_and_types_per_topic: "
        "AssertionError: {'/imu': 149} != {'/imu': 150}",
        "FAILED rostest-test_recorder.xml: flight_recorder.RecorderTest.testrecorder: timed out"]


def test_nothing_is_printed_when_everything_passed_and_a_truncated_file_is_reported(tmp_path):
    (tmp_path / "ok.xml").write_text(PASSED_RESULT)
    assert run(tmp_path) == ""
    (tmp_path / "cut.xml").write_text(ROSTEST_RESULT[:120])
    assert run(tmp_path).startswith("== failed tests (1)\nFAILED cut.xml: (the whole file): unreadable result file: ")
