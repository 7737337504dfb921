"""Parameters of the tracker (take-off / tracking / landing state machine and its controller), ROS-free.

Each parameter is a dataclass field with a unit and an allowed range (landing_runtime.params.spec). The dataclass
defaults are the shipped defaults (config/tracking.yaml repeats them, documented); the node loads them with
landing_runtime.params.load_params, which requires every key: a typo or a forgotten key stops the node with a
message naming it instead of silently flying with a default.
"""
import dataclasses

from landing_runtime.params import ParamError, spec


@dataclasses.dataclass(frozen=True)
class TrackingParams:
    """See config/tracking.yaml for the meaning of each key."""
    rate_hz: float = spec(30.0, 1.0, 500.0, "Hz")
    # take-off and heights
    nominal_height: float = spec(4.0, 0.5, 50.0, "m")
    takeoff_climb_rate: float = spec(1.0, 0.1, 5.0, "m/s")
    takeoff_timeout: float = spec(3.0, 0.1, 60.0, "s")
    takeoff_resend_interval: float = spec(1.0, 0.1, 60.0, "s")
    height_gain: float = spec(1.0, 0.0, 20.0, "1/s")
    max_climb_rate: float = spec(1.0, 0.1, 5.0, "m/s")
    fallback_pad_height: float = spec(0.497, 0.0, 10.0, "m")
    foot_clearance: float = spec(0.065, 0.0, 1.0, "m")
    sonar_pad_radius: float = spec(0.35, 0.0, 5.0, "m")
    sonar_consistency: float = spec(0.4, 0.0, 10.0, "m")
    # horizontal controller
    position_gain: float = spec(1.2, 0.0, 20.0, "1/s")
    along_track_gain: float = spec(2.4, 0.0, 20.0, "1/s")
    along_track_gain_latency: float = spec(0.26, 0.0, 10.0, "-")
    along_track_gain_max_pad_speed: float = spec(8.0, 0.0, 100.0, "m/s")
    integral_gain: float = spec(0.5, 0.0, 20.0, "1/s^2")
    integral_speed_limit: float = spec(2.0, 0.0, 20.0, "m/s")
    integral_error_limit: float = spec(2.0, 0.0, 100.0, "m")
    integral_max_pad_acceleration: float = spec(0.5, 0.0, 100.0, "m/s^2")
    integral_turn_settle_time: float = spec(1.0, 0.0, 60.0, "s")
    lookahead: float = spec(0.3, 0.0, 5.0, "s")
    velocity_lead: float = spec(0.15, 0.0, 5.0, "s")
    flow_time_lead: float = spec(0.17, 0.0, 5.0, "s")
    flow_weight_lead: float = spec(0.05, 0.0, 1.0, "s")
    acceleration_window: float = spec(0.5, 0.0, 10.0, "s")
    max_correction_speed: float = spec(3.0, 0.0, 40.0, "m/s")
    max_horizontal_speed: float = spec(20.0, 0.1, 40.0, "m/s")
    # target lost / relocating
    lost_timeout: float = spec(1.0, 0.05, 60.0, "s")
    found_max_age: float = spec(0.5, 0.01, 60.0, "s")
    relocate_height: float = spec(6.0, 0.5, 50.0, "m")
    # tracking -> landing
    auto_land: bool = spec(True)
    autostart: bool = spec(False)
    require_preflight: bool = spec(False)
    preflight_max_age: float = spec(3.0, 0.5, 60.0, "s")
    min_tracking_time: float = spec(10.0, 0.0, 600.0, "s")
    settle_error: float = spec(0.3, 0.01, 10.0, "m")
    settle_time: float = spec(1.0, 0.0, 60.0, "s")
    # landing
    landing_descent_rate: float = spec(0.5, 0.05, 3.0, "m/s")
    descend_max_error: float = spec(0.25, 0.01, 10.0, "m")
    descend_error_per_metre: float = spec(0.2, 0.0, 10.0, "m/m")
    descend_max_relative_speed: float = spec(0.5, 0.01, 10.0, "m/s")
    hold_max_error: float = spec(0.35, 0.01, 10.0, "m")
    hold_error_per_metre: float = spec(0.4, 0.0, 10.0, "m/m")
    retry_climb_rate: float = spec(0.5, 0.05, 5.0, "m/s")
    retry_height: float = spec(1.5, 0.2, 50.0, "m")
    abort_error: float = spec(1.5, 0.05, 50.0, "m")
    gate_height: float = spec(0.35, 0.05, 5.0, "m")
    commit_height: float = spec(0.45, 0.05, 5.0, "m")
    gate_error: float = spec(0.1, 0.01, 5.0, "m")
    gate_relative_speed: float = spec(0.25, 0.01, 10.0, "m/s")
    gate_ready_time: float = spec(0.2, 0.0, 10.0, "s")
    gate_timeout: float = spec(4.0, 0.1, 120.0, "s")
    vision_timeout: float = spec(0.3, 0.01, 10.0, "s")
    search_view_after: float = spec(0.5, 0.0, 60.0, "s")
    search_climb_after: float = spec(2.0, 0.0, 600.0, "s")
    gate_vision_age: float = spec(0.1, 0.0, 10.0, "s")
    gate_max_speed_change: float = spec(1.2, 0.0, 50.0, "m/s^2")
    gate_max_speed_change_change: float = spec(0.3, 0.0, 50.0, "m/s^2")
    final_descent_rate: float = spec(1.0, 0.05, 3.0, "m/s")
    land_height: float = spec(0.06, 0.0, 5.0, "m")
    commit_abort_error: float = spec(0.2, 0.01, 5.0, "m")
    commit_abort_lookahead: float = spec(0.3, 0.0, 2.0, "s")
    commit_abort_min_height: float = spec(0.1, 0.0, 5.0, "m")
    abort_to_gate: bool = spec(True)
    blind_height: float = spec(0.35, 0.0, 5.0, "m")
    land_ack_timeout: float = spec(1.0, 0.05, 30.0, "s")
    blend_weight_low: float = spec(0.1, 0.0, 1.0, "-")
    blend_weight_high: float = spec(0.9, 0.0, 1.0, "-")
    blend_min_pad_speed: float = spec(4.0, 0.0, 50.0, "m/s")
    blend_descent_rate: float = spec(0.8, 0.05, 3.0, "m/s")
    locked_vision_age: float = spec(1.0, 0.0, 10.0, "s")
    blind_drift_per_speed: float = spec(0.01, 0.0, 1.0, "-")
    aim_height: float = spec(0.6, 0.0, 10.0, "m")
    aim_lean_time: float = spec(2.0, 0.01, 60.0, "s")
    relative_fix_gain: float = spec(0.5, 0.0, 1.0, "-")
    relative_max_age: float = spec(1.0, 0.0, 10.0, "s")

    def check(self, source="tracking parameters"):
        """Relations between parameters that a single range cannot express."""
        problems = []
        if self.gate_error > self.descend_max_error:
            problems.append("gate_error (%g m) must not exceed descend_max_error (%g m)" % (
                self.gate_error, self.descend_max_error))
        if not self.descend_max_error <= self.hold_max_error <= self.abort_error:
            problems.append("expected descend_max_error <= hold_max_error <= abort_error, got %g, %g, %g m" % (
                self.descend_max_error, self.hold_max_error, self.abort_error))
        if self.descend_error_per_metre > self.hold_error_per_metre:
            problems.append("descend_error_per_metre (%g m/m) must not exceed hold_error_per_metre (%g m/m): the "
                            "drone would descend where it must climb" % (self.descend_error_per_metre,
                                                                         self.hold_error_per_metre))
        if not self.gate_height <= self.commit_height < self.retry_height:
            problems.append("expected gate_height <= commit_height < retry_height, got %g, %g, %g m" % (
                self.gate_height, self.commit_height, self.retry_height))
        if not self.land_height < self.gate_height:
            problems.append("expected land_height < gate_height, got %g, %g m" % (self.land_height, self.gate_height))
        if not self.land_height <= self.commit_abort_min_height < self.gate_height:
            problems.append("expected land_height <= commit_abort_min_height < gate_height, got %g, %g, %g m" % (
                self.land_height, self.commit_abort_min_height, self.gate_height))
        if not self.gate_error < self.commit_abort_error:
            problems.append("expected gate_error < commit_abort_error, got %g, %g m" % (
                self.gate_error, self.commit_abort_error))
        if not self.gate_height < self.retry_height <= self.nominal_height:
            problems.append("expected gate_height < retry_height <= nominal_height, got %g, %g, %g m" % (
                self.gate_height, self.retry_height, self.nominal_height))
        if self.found_max_age > self.lost_timeout:
            problems.append("found_max_age (%g s) must not exceed lost_timeout (%g s)" % (
                self.found_max_age, self.lost_timeout))
        if problems:
            raise ParamError("%s: %s" % (source, "; ".join(problems)))
        return self
