"""`python -m landing_eval.runner_cli SCENARIO --out DIR`: run_scenario for subprocesses of the benchmark."""
import sys

from .runner import main

if __name__ == "__main__":
    sys.exit(main())
