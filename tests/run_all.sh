#!/usr/bin/env bash
# Every test of the workspace: ROS-free unit tests (pytest), then catkin's gtest and rostest targets.
# Exits non-zero if anything fails. Logs go to logs/.
cd "$(dirname "$0")/.."
source env.sh  # before 'set -u': Debian's catkin profile scripts read unset variables
set -uo pipefail
export MUJOCO_GL=osmesa LP_NUM_THREADS=0
export LANDING_TESTS_STRICT_IMPORTS=1  # a test that would skip for want of a module fails (conftest.py)
mkdir -p logs
status=0

echo "== catkin run_tests (gtest, rostest)"
rm -rf build/test_results
if ! catkin_make -C . run_tests -j2 > logs/catkin_run_tests.log 2>&1; then
  echo "catkin run_tests failed to run; see logs/catkin_run_tests.log"; tail -n 40 logs/catkin_run_tests.log; status=1
fi
if ! catkin_test_results build/test_results --verbose > logs/catkin_test_results.log 2>&1; then
  status=1; cat logs/catkin_test_results.log
fi
tail -n 1 logs/catkin_test_results.log

echo "== pytest (unit and system tests)"
python -m pytest -q -rs -p no:cacheprovider --junitxml=logs/pytest.xml src/*/test tests || status=1  # -rs: why skipped
# last, so that the tail of the output (all that CI shows) names what failed
[ $status -eq 0 ] || python tests/list_failures.py build/test_results logs/pytest.xml
exit $status
