"""Evaluation: scenario schema and runner, benchmark (local or Ray), reliability runs, isolated-master tooling, and
the `analyze` entry point of the flight analysis (package flight_analysis)."""
