"""Evaluation: scenario schema and runner, benchmark (local or Ray), flight analysis, isolated-master tooling."""
