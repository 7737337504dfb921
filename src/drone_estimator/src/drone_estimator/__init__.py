"""The drone's own pose/velocity estimate on ardrone/odom_estimate (ROS-free core + a thin node)."""
