"""MuJoCo stand-in for the thesis' Gazebo world: quadrotor, ground vehicle with landing pad, sensors.

ROS-free core: :mod:`config`, :mod:`autopilot`, :mod:`environment`, :mod:`simulator`.
ROS wrapper: :mod:`node`.
"""
