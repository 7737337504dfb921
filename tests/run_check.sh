#!/usr/bin/env bash
# The fast tier (make check): the ROS-free unit tests (pytest, without the tests marked slow: those that need a ROS
# master, a terminal or minutes) and every package's gtests. Under 2 minutes on 2 cores; make test runs everything.
cd "$(dirname "$0")/.."
source env.sh  # before 'set -u': Debian's catkin profile scripts read unset variables
set -uo pipefail
export MUJOCO_GL=osmesa LP_NUM_THREADS=0
export LANDING_TESTS_STRICT_IMPORTS=1
mkdir -p logs
status=0

echo "== gtests"
rm -rf build/test_results
targets=$(grep -l "catkin_add_gtest" src/*/CMakeLists.txt | xargs -n1 dirname | xargs -n1 basename | sed 's/.*/run_tests_&_gtest/')
if ! catkin_make -C . $targets -j2 > logs/catkin_gtests.log 2>&1; then
  echo "the gtests failed to build or run; see logs/catkin_gtests.log"; tail -n 40 logs/catkin_gtests.log; status=1
fi
catkin_test_results build/test_results > logs/catkin_gtest_results.log 2>&1 || { status=1; cat logs/catkin_gtest_results.log; }
tail -n 1 logs/catkin_gtest_results.log

echo "== pytest (unit tests)"
python -m pytest -q -rs -p no:cacheprovider -m "not slow" --junitxml=logs/pytest_check.xml src/*/test || status=1
[ $status -eq 0 ] || python tests/list_failures.py build/test_results logs/pytest_check.xml
exit $status
