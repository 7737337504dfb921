"""`python -m landing_eval.runner_cli SCENARIO --out DIR`: run_scenario for subprocesses of the benchmark."""
from landing_runtime.rospy_node import exit_promptly

from .runner import main

if __name__ == "__main__":
    exit_promptly(main())
