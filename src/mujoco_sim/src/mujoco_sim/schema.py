"""The simulator's parameters: names, types, ranges and units (documented in config/sim.yaml)."""
from . import realism
from .config import ConfigError, Param, load_yaml, validate
from .pads import PADS

F, I, B, S = float, int, bool, str

_VEHICLE = {
    "max_speed": Param(F, 0.0, 40.0, "m/s"),
    "max_accel": Param(F, 0.01, 20.0, "m/s^2"),
    "max_yaw_rate": Param(F, 0.0, 5.0, "rad/s"),
    "max_yaw_accel": Param(F, 0.01, 20.0, "rad/s^2"),
    "command_timeout": Param(F, 0.05, 60.0, "s"),
    "wheel_radius": Param(F, 0.01, 1.0, "m"),
    "track_width": Param(F, 0.1, 3.0, "m"),
    "gps_rate_hz": Param(F, 0.1, 100.0, "Hz"),
    "odom_rate_hz": Param(F, 1.0, 500.0, "Hz"),
}

DRONE_MODELS = ("velocity_quad", "ardrone2", "px4_quad")

SIM_SCHEMA = {
    "seed": Param(I, 0),
    "vehicle": Param(S, choices=("summit_xl", "car")),
    "pad": Param(S, choices=PADS),
    "drone_model": Param(S, choices=DRONE_MODELS),
    "real_time_factor": Param(F, 0.0, 1000.0),
    "lockstep": {
        "enabled": Param(B),
        "max_lead_s": Param(F, 0.005, 10.0, "s"),
        "stale_after_wall_s": Param(F, 0.05, 60.0, "s"),
        "realtime_priority": Param(I, 0, 99),
    },
    "camera": {
        "enabled": Param(B),
        "width": Param(I, 16, 1920, "px"),
        "height": Param(I, 16, 1080, "px"),
        "rate_hz": Param(F, 0.1, 120.0, "Hz"),
        "noise": Param(F, 0.0, 1.0),
        "shadow_map_size": Param(I, 64, 4096, "px"),
        "shadow_clip_m": Param(F, 0.5, 50.0, "m"),
    },
    "rates": {
        "clock_hz": Param(F, 10.0, 1000.0, "Hz"),
        "ground_truth_hz": Param(F, 1.0, 500.0, "Hz"),
        "sonar_hz": Param(F, 1.0, 100.0, "Hz"),
        "altimeter_hz": Param(F, 1.0, 100.0, "Hz"),
        "gps_hz": Param(F, 0.1, 100.0, "Hz"),
        "joint_states_hz": Param(F, 1.0, 200.0, "Hz"),
        "tf_hz": Param(F, 1.0, 200.0, "Hz"),
        "conditions_hz": Param(F, 0.5, 50.0, "Hz"),
    },
    "firmware": {
        "flow_rate_hz": Param(F, 1.0, 250.0, "Hz"),
        "flow_gain": Param(F, 0.1, 100.0, "1/s"),
        "height_gain": Param(F, 0.1, 100.0, "1/s"),
        "climb_gain": Param(F, 0.1, 100.0, "1/s^2"),
        "climb_bias_gain": Param(F, 0.0, 100.0, "1/s^3"),
        "baro_offset_gain": Param(F, 0.0, 100.0, "1/s"),
        "surface_step": Param(F, 0.01, 10.0, "m"),
        "surface_step_time": Param(F, 0.0, 10.0, "s"),
        "coverage_low": Param(F, 0.0, 1.0),
        "coverage_high": Param(F, 0.0, 1.0),
    },
    "noise": {
        "enabled": Param(B),
        "imu_gyro_std": Param(F, 0.0, 1.0, "rad/s"),
        "imu_accel_std": Param(F, 0.0, 5.0, "m/s^2"),
        "imu_orientation_std_deg": Param(F, 0.0, 10.0, "deg"),
        "sonar_std": Param(F, 0.0, 1.0, "m"),
        "altimeter_std": Param(F, 0.0, 5.0, "m"),
        "gps_position_std": Param(F, 0.0, 10.0, "m"),
        "gps_velocity_std": Param(F, 0.0, 5.0, "m/s"),
        "vehicle_heading_std_deg": Param(F, 0.0, 30.0, "deg"),
        "vehicle_yaw_rate_std": Param(F, 0.001, 5.0, "rad/s"),
        "vehicle_speed_std": Param(F, 0.0, 5.0, "m/s"),
        "flow_velocity_std": Param(F, 0.0, 5.0, "m/s"),
    },
    "sensors": {
        "sonar_min_range": Param(F, 0.0, 1.0, "m"),
        "sonar_max_range": Param(F, 0.5, 20.0, "m"),
    },
    "drone": {
        "start_on_pad": Param(B),
        "start_position": Param(list),
        "start_yaw_deg": Param(F, -360.0, 360.0, "deg"),
        "max_horizontal_speed": Param(F, 0.1, 40.0, "m/s"),
        "max_vertical_speed": Param(F, 0.1, 10.0, "m/s"),
        "max_yaw_rate": Param(F, 0.1, 10.0, "rad/s"),
        "max_tilt_deg": Param(F, 1.0, 60.0, "deg"),
        "takeoff_height": Param(F, 0.1, 10.0, "m"),
        "takeoff_speed": Param(F, 0.1, 5.0, "m/s"),
        "land_speed": Param(F, 0.05, 3.0, "m/s"),
        "command_timeout": Param(F, 0.05, 10.0, "s"),
        "motor_time_constant": Param(F, 0.001, 1.0, "s"),
        "velocity_gain": Param(F, 0.0, 50.0, "1/s"),
        "vertical_velocity_gain": Param(F, 0.0, 50.0, "1/s"),
        "velocity_integral_gain": Param(F, 0.0, 50.0, "1/s^2"),
        "velocity_integral_limit": Param(F, 0.0, 100.0, "m"),
        "altitude_gain": Param(F, 0.0, 50.0, "1/s"),
        "attitude_gain": Param(F, 0.0, 2000.0, "1/s^2"),
        "rate_gain": Param(F, 0.0, 200.0, "1/s"),
        "drag_area_horizontal": Param(F, 0.0, 1.0, "m^2"),
        "drag_area_vertical": Param(F, 0.0, 1.0, "m^2"),
    },
    # The driver's and firmware's parameters: ranges as the firmware accepts them (ardrone_autonomy's docs).
    "ardrone2": {
        "euler_angle_max": Param(F, 0.0, 0.52, "rad"),
        "control_vz_max": Param(F, 200.0, 2000.0, "mm/s"),
        "control_yaw": Param(F, 0.7, 6.11, "rad/s"),
        "altitude_max": Param(I, 500, 100000, "mm"),
        "altitude_min": Param(I, 0, 100000, "mm"),
        "takeoff_height": Param(F, 0.3, 2.0, "m"),
        "takeoff_speed": Param(F, 0.1, 2.0, "m/s"),
        "land_speed": Param(F, 0.1, 2.0, "m/s"),
        "rotor_drag": Param(F, 0.0, 2.0, "N/(m/s)"),
        "driver_resend_hz": Param(F, 0.0, 200.0, "Hz"),
        "watchdog_hover_s": Param(F, 0.1, 60.0, "s"),
        "watchdog_land_s": Param(F, 0.0, 600.0, "s"),
        "navdata_demo": Param(I, 0, 1),
        "looprate": Param(I, 1, 1000, "Hz"),
        "realtime_navdata": Param(B),
        "altd_unit": Param(S, choices=("mm", "cm")),
        "video_channel": Param(I, 0, 1),
        "camera_switch_delay_s": Param(F, 0.0, 5.0, "s"),
    },
    # PX4 behind MAVROS: the airframe, PX4's parameters (their PX4 names in config/sim.yaml), the emulated MAVROS.
    "px4_quad": {
        "mass": Param(F, 0.5, 10.0, "kg"),
        "inertia": Param(list),
        "arm_length": Param(F, 0.05, 1.0, "m"),
        "max_rotor_thrust": Param(F, 1.0, 100.0, "N"),
        "drag_area_horizontal": Param(F, 0.0, 1.0, "m^2"),
        "drag_area_vertical": Param(F, 0.0, 1.0, "m^2"),
        "rotor_drag": Param(F, 0.0, 5.0, "N/(m/s)"),
        "max_horizontal_speed": Param(F, 0.5, 40.0, "m/s"),
        "max_climb_speed": Param(F, 0.5, 10.0, "m/s"),
        "max_descent_speed": Param(F, 0.3, 10.0, "m/s"),
        "max_tilt_deg": Param(F, 10.0, 80.0, "deg"),
        "max_yaw_rate": Param(F, 0.1, 10.0, "rad/s"),
        "velocity_p_gain_xy": Param(F, 0.0, 20.0, "1/s"),
        "velocity_i_gain_xy": Param(F, 0.0, 20.0, "1/s^2"),
        "velocity_d_gain_xy": Param(F, 0.0, 5.0),
        "velocity_p_gain_z": Param(F, 0.0, 20.0, "1/s"),
        "velocity_i_gain_z": Param(F, 0.0, 20.0, "1/s^2"),
        "velocity_d_gain_z": Param(F, 0.0, 5.0),
        "velocity_integral_limit": Param(F, 0.0, 20.0, "m/s^2"),
        "velocity_derivative_time_constant": Param(F, 0.001, 1.0, "s"),
        "position_gain_xy": Param(F, 0.0, 10.0, "1/s"),
        "position_gain_z": Param(F, 0.0, 10.0, "1/s"),
        "yaw_gain": Param(F, 0.0, 20.0, "1/s"),
        "takeoff_altitude": Param(F, 0.5, 50.0, "m"),
        "takeoff_speed": Param(F, 0.2, 5.0, "m/s"),
        "takeoff_trigger_speed": Param(F, 0.05, 3.0, "m/s"),
        "takeoff_clear_height": Param(F, 0.1, 5.0, "m"),
        "land_speed": Param(F, 0.1, 3.0, "m/s"),
        "initial_mode": Param(S, choices=("MANUAL", "STABILIZED", "ALTCTL", "POSCTL", "AUTO.LOITER")),
        "pilot_takeover_mode": Param(S, choices=("MANUAL", "STABILIZED", "ALTCTL", "POSCTL")),
        "offboard_stream_period_s": Param(F, 0.01, 5.0, "s"),
        "offboard_loss_timeout_s": Param(F, 0.05, 60.0, "s"),
        "offboard_loss_hold_s": Param(F, 0.0, 600.0, "s"),
        "position_loss_timeout_s": Param(F, 0.1, 600.0, "s"),
        "land_detector_s": Param(F, 0.0, 10.0, "s"),
        "disarm_after_land_s": Param(F, 0.0, 600.0, "s"),
        "disarm_preflight_s": Param(F, 0.0, 600.0, "s"),
        "arm_min_battery": Param(F, 0.0, 100.0, "%"),
        "battery_land_percent": Param(F, 0.0, 100.0, "%"),
        "gps_rate_hz": Param(F, 0.5, 50.0, "Hz"),
        "ekf_gps_position_gain": Param(F, 0.0, 50.0, "1/s"),
        "ekf_gps_velocity_gain": Param(F, 0.0, 50.0, "1/s"),
        "ekf_accel_bias_gain": Param(F, 0.0, 50.0, "1/s^2"),
        "ekf_baro_gain": Param(F, 0.0, 50.0, "1/s"),
        "ekf_baro_climb_gain": Param(F, 0.0, 50.0, "1/s^2"),
        "heartbeat_hz": Param(F, 0.1, 50.0, "Hz"),
        "extended_state_hz": Param(F, 0.1, 100.0, "Hz"),
        "local_position_hz": Param(F, 0.5, 250.0, "Hz"),
        "global_position_hz": Param(F, 0.1, 100.0, "Hz"),
        "imu_hz": Param(F, 0.5, 250.0, "Hz"),
        "battery_hz": Param(F, 0.1, 50.0, "Hz"),
        "connection_timeout_s": Param(F, 0.1, 120.0, "s"),
        "command_timeout_s": Param(F, 0.1, 120.0, "s"),
    },
    "vehicle_start": {
        "x": Param(F, -1e4, 1e4, "m"),
        "y": Param(F, -1e4, 1e4, "m"),
        "yaw_deg": Param(F, -360.0, 360.0, "deg"),
    },
    "vehicles": {"summit_xl": _VEHICLE, "car": _VEHICLE},
    "conditions": {
        "wind_speed": Param(F, 0.0, 60.0, "m/s"),
        "wind_direction_deg": Param(F, -360.0, 360.0, "deg"),
        "wind_gust": Param(F, 0.0, 30.0, "m/s"),
        "temp": Param(F, -60.0, 70.0, "deg C"),
        "drone_battery": Param(F, 0.0, 100.0, "%"),
    },
    "wind": {"gust_time_constant": Param(F, 0.05, 60.0, "s")},
    "battery": {
        "initial_percent": Param(F, 0.0, 100.0, "%"),
        "idle_drain": Param(F, 0.0, 10.0, "%/s"),
        "thrust_drain": Param(F, 0.0, 10.0, "%/s at full thrust"),
        "cold_reference_temp": Param(F, -60.0, 70.0, "deg C"),
        "cold_factor_per_deg": Param(F, 0.0, 1.0, "1/deg C"),
    },
    "touchdown": {
        "crash_speed": Param(F, 0.1, 50.0, "m/s"),
        "crash_tilt_deg": Param(F, 1.0, 180.0, "deg"),
    },
}


def validate_sim_config(tree, source):
    """Validate a parameter tree against SIM_SCHEMA; ConfigError names ``source`` and the key. The realism
    section becomes ``config["realism"] = {"profile": name, "values": {key: value}, "profiles": table}``."""
    if not isinstance(tree, dict):
        raise ConfigError("%s: expected a mapping of parameters, got %r" % (source, tree))
    tree = dict(tree)
    realism_tree = tree.pop("realism", None)
    config = validate(tree, SIM_SCHEMA, source)
    config["realism"] = validate_realism(realism_tree, source)
    if config["firmware"]["coverage_low"] >= config["firmware"]["coverage_high"]:
        raise ConfigError("%s: parameter 'firmware/coverage_low' must be below 'firmware/coverage_high'" % source)
    ardrone = config["ardrone2"]
    if ardrone["altitude_min"] >= ardrone["altitude_max"]:
        raise ConfigError("%s: parameter 'ardrone2/altitude_min' (%d mm) must be below 'ardrone2/altitude_max' (%d mm)"
                          % (source, ardrone["altitude_min"], ardrone["altitude_max"]))
    px4 = config["px4_quad"]
    inertia = px4["inertia"]
    if len(inertia) != 3 or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and v > 0 for v in inertia):
        raise ConfigError("%s: parameter 'px4_quad/inertia': got %r, expected [Ixx, Iyy, Izz] > 0 in kg m^2" % (
            source, inertia))
    px4["inertia"] = [float(v) for v in inertia]
    if 4 * px4["max_rotor_thrust"] <= 1.2 * px4["mass"] * 9.81:
        raise ConfigError("%s: parameter 'px4_quad/max_rotor_thrust' (%g N) cannot lift 'px4_quad/mass' (%g kg) with "
                          "a margin: four rotors need more than 1.2 m g" % (source, px4["max_rotor_thrust"], px4["mass"]))
    start = config["drone"]["start_position"]
    if len(start) != 3 or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in start):
        raise ConfigError("%s: parameter 'drone/start_position': got %r, expected [x, y, z] in m" % (source, start))
    config["drone"]["start_position"] = [float(v) for v in start]
    config["battery"]["initial_percent"] = config["conditions"]["drone_battery"]
    return config


def load_sim_config(path, overrides=None):
    """Read config/sim.yaml (or another file) and apply nested ``overrides`` before validating."""
    tree = load_yaml(path)
    for section, values in (overrides or {}).items():
        if isinstance(values, dict):
            tree.setdefault(section, {}).update(values)
        else:
            tree[section] = values
    return validate_sim_config(tree, path)


def validate_realism(section, source):
    """The ``realism`` section: the table of profiles, the profile in force and its overrides."""
    if not isinstance(section, dict):
        raise ConfigError("%s: parameter 'realism' is missing or not a mapping (expected profile, overrides, "
                          "profiles, table; see config/sim.yaml)" % source)
    unknown = sorted(set(section) - {"profile", "overrides", "profiles", "table"})
    missing = sorted({"profile", "profiles", "table"} - set(section))
    if unknown or missing:
        raise ConfigError("%s: parameter 'realism': %s" % (source, "; ".join(
            (["unknown key(s) " + ", ".join(unknown)] if unknown else []) +
            (["missing key(s) " + ", ".join(missing)] if missing else []))))
    table = realism.validate_table(section["table"], section["profiles"], source)
    overrides = section.get("overrides") or {}
    if not isinstance(overrides, dict):
        raise ConfigError("%s: parameter 'realism/overrides' must be a mapping of realism keys, got %r" % (
            source, overrides))
    selection = dict(overrides, profile=section["profile"])
    name, values = realism.resolve(table, selection, "%s: parameter 'realism'" % source)
    return {"profile": name, "values": values, "profiles": table}
