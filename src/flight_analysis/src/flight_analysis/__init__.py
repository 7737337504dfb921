"""Flight analysis of one bag, ROS-free (rosbags, numpy, matplotlib): metrics, time series, plots, report, and the
ROS-free scoring of a flight. Imports nothing of the workspace's other packages; landing_eval's `analyze` is its
entry point."""
