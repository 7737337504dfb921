"""Parameters of the drone's estimator and of its model of the optical flow over the vehicle, ROS-free.

Each parameter is a dataclass field with a unit and an allowed range (landing_runtime.params.spec). The dataclass
defaults are the shipped defaults (config/estimator.yaml and config/flow_surface_<vehicle>.yaml repeat them,
documented); the node loads them with landing_runtime.params.load_params, which requires every key.
"""
import dataclasses

from landing_runtime.params import ParamError, spec


@dataclasses.dataclass(frozen=True)
class EstimatorParams:
    """See config/estimator.yaml for the meaning of each key."""
    gps_position_std: float = spec(0.3, 0.001, 50.0, "m")
    gps_gate_sigma: float = spec(5.0, 1.0, 100.0, "-")
    gps_max_rejections: int = spec(10, 1, 1000, "fixes")
    use_gps_altitude: bool = spec(True)
    use_gps_velocity: bool = spec(True)
    gps_velocity_std: float = spec(0.1, 0.001, 50.0, "m/s")
    flow_velocity_std: float = spec(0.05, 0.0, 5.0, "m/s")
    flow_timeout: float = spec(0.5, 0.01, 10.0, "s")
    resting_gps_timeout: float = spec(1.0, 0.01, 10.0, "s")
    position_process_noise: float = spec(0.0003, 0.0, 10.0, "m^2/s")
    flow_bias_process_noise: float = spec(1e-6, 0.0, 1.0, "(m/s)^2/s")
    initial_flow_bias_std: float = spec(0.05, 0.0, 5.0, "m/s")
    flow_scale_process_noise: float = spec(1e-5, 0.0, 1.0, "1/s")
    initial_flow_scale_std: float = spec(0.03, 0.0, 1.0, "-")
    correction_smoothing_time: float = spec(3.0, 0.0, 10.0, "s")
    correction_max_speed: float = spec(0.2, 0.001, 100.0, "m/s")
    inertial_gain: float = spec(20.0, 0.0, 1000.0, "1/s")
    inertial_reference_std: float = spec(0.5, 0.001, 50.0, "m/s")
    weight_position_std: float = spec(0.1, 0.0, 5.0, "m")
    measured_weight_min_speed: float = spec(4.0, 0.0, 100.0, "m/s")
    spread_hold_time: float = spec(0.5, 0.001, 10.0, "s")
    relative_fix_gain: float = spec(0.5, 0.0, 1.0, "-")
    relative_max_age: float = spec(2.0, 0.0, 10.0, "s")
    altimeter_std: float = spec(0.1, 0.001, 50.0, "m")
    altitude_process_noise: float = spec(0.001, 0.0, 10.0, "m^2/s")
    climb_bias_process_noise: float = spec(0.01, 0.0, 10.0, "m^2/s^3")
    initial_climb_bias_std: float = spec(0.2, 0.0, 10.0, "m/s")
    altimeter_max_rejections: int = spec(10, 1, 1000, "altitudes")
    sonar_std: float = spec(0.02, 0.001, 1.0, "m")
    sonar_ground_gate: float = spec(0.15, 0.0, 5.0, "m")
    sonar_max_range: float = spec(6.0, 0.1, 50.0, "m")
    foot_clearance: float = spec(0.065, 0.0, 1.0, "m")
    frame_id: str = spec("world")
    child_frame_id: str = spec("ardrone/base_link")


@dataclasses.dataclass(frozen=True)
class FlowSurfaceParams:
    """See config/flow_surface_summit_xl.yaml for the meaning of each key."""
    enabled: bool = spec(True)
    camera_hfov_deg: float = spec(64.0, 1.0, 179.0, "deg")
    image_aspect: float = spec(4.0 / 3.0, 0.1, 10.0, "-")
    camera_below_base_link: float = spec(0.035, 0.0, 1.0, "m")
    coverage_low: float = spec(0.4, 0.0, 1.0, "-")
    coverage_high: float = spec(0.7, 0.0, 1.0, "-")
    flow_time_constant: float = spec(0.17, 0.001, 10.0, "s")
    top_x_min: float = spec(-0.5, -50.0, 50.0, "m")
    top_x_max: float = spec(0.5, -50.0, 50.0, "m")
    top_y_min: float = spec(-0.5, -50.0, 50.0, "m")
    top_y_max: float = spec(0.5, -50.0, 50.0, "m")

    def check(self, source="flow surface parameters"):
        if not (self.coverage_low < self.coverage_high and self.top_x_min < self.top_x_max and
                self.top_y_min < self.top_y_max):
            raise ParamError("%s: expected coverage_low < coverage_high, top_x_min < top_x_max and top_y_min < "
                             "top_y_max" % source)
        return self
