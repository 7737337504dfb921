"""Drone state estimator and take-off / tracking / landing state machine (ROS-free core + thin nodes)."""
