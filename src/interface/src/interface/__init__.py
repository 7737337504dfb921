"""Supervisor, emergency module, cmd_vel mux, operator console and the launch files of the landing system."""
