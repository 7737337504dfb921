"""Python tools of uav_vision: rendered test frames and the detection benchmark (the detector is C++)."""
