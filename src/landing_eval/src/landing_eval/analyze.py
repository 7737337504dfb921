"""`analyze`: report of one flight from its bag, without ROS: the analysis is flight_analysis.analyze; this entry
point hands it landing_eval.scenario's reader, for the scenario beside the bag (run_scenario's result.json).

    rosrun landing_eval analyze BAG --out DIR
    .venv/bin/python -m landing_eval.analyze BAG --out DIR     # plain shell: no ROS sourced, no master (the .pth)
"""
import sys

from flight_analysis import analyze as _analysis


def load_scenario(path):
    from landing_eval import scenario
    return scenario.load(path)


def analyze(bag_path, out_dir, **options):
    return _analysis.analyze(bag_path, out_dir, load_scenario=load_scenario, **options)


def main(argv=None):
    return _analysis.main(argv, load_scenario=load_scenario)


if __name__ == "__main__":
    sys.exit(main())
