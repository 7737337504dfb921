"""The take-off / tracking / landing state machine and its controller (ROS-free core + a thin node); the drone's
own estimate comes from the package drone_estimator."""
