"""Supervisor, operator console, launch files, scenario runner, benchmark and flight analysis."""
