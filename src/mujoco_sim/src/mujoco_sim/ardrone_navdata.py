"""The AR.Drone 2.0's navdata as ardrone_autonomy publishes it (ardrone_autonomy/Navdata), ROS-free.

``navdata_fields(sim)`` returns the message's fields by name, in the driver's units, from the simulator's
state and the firmware's estimates. It runs at up to 200 Hz, so it works on plain floats: numpy's per-call
overhead on 3-vectors would cost more than the arithmetic.
"""
import math

G = 9.81  # [m/s^2] per g of ax, ay, az
# Earth's field for magX..magZ, in milligauss (what the firmware's magneto_raw reports): a mid-latitude field,
# 20 uT horizontal towards world +y (north, as in ROS's east-north-up) and 43 uT downwards.
MAG_NORTH_MG, MAG_DOWN_MG = 200.0, 430.0
PWM_MAX = 255  # motor1..motor4 are the PWM commands, 0..255


def motor_pwm(thrust, max_thrust):
    """PWM [0..255] of a rotor's thrust [N]: thrust grows with the square of the speed, which the PWM sets, so
    the square root (hover, 40 % of the maximum thrust, is about 160, as a real AR.Drone 2.0 reports)."""
    fraction = thrust / max_thrust if max_thrust > 0.0 else 0.0
    return int(PWM_MAX * math.sqrt(max(0.0, min(1.0, fraction))) + 0.5)


def attitude_estimate(sim, w, x, y, z):
    """(roll, pitch, yaw) [rad] and the accelerometer's specific force (body frame) [m/s^2] as the drone
    measures them, from the true attitude (w, x, y, z): turned by the yaw drift and tilted by the
    accelerometer's bias (the estimate is levelled on it) and noise, as Simulator.imu() builds them."""
    d = sim.data
    sim._step_biases(sim.time)
    bias_x, bias_y, bias_z = sim.accel_bias.value.tolist()
    fx, fy, fz = d.sensordata[sim.accel_adr:sim.accel_adr + 3].tolist()
    fx, fy, fz = fx + bias_x, fy + bias_y, fz + bias_z
    ex, ey, ez = bias_y / G, -bias_x / G, 0.0
    noise = sim.noise
    if noise is not None:
        accel_std = noise["imu_accel_std"]
        angle_std = math.radians(noise["imu_orientation_std_deg"])
        if accel_std > 0.0 or angle_std > 0.0:
            n = sim.rng["imu"].standard_normal(6).tolist()
            fx, fy, fz = fx + accel_std * n[0], fy + accel_std * n[1], fz + accel_std * n[2]
            ex, ey, ez = ex + angle_std * n[3], ey + angle_std * n[4], ez + angle_std * n[5]
    drift = sim.yaw_drift()
    if drift:
        # Turned about world z: (cos d/2, 0, 0, sin d/2) * q.
        c, s = math.cos(drift / 2.0), math.sin(drift / 2.0)
        w, x, y, z = c * w - s * z, c * x - s * y, c * y + s * x, c * z + s * w
    if ex or ey or ez:
        # Tilted about the body axes: q * (1, e/2) normalised.
        n = 1.0 / math.sqrt(1.0 + 0.25 * (ex * ex + ey * ey + ez * ez))
        hx, hy, hz = 0.5 * ex * n, 0.5 * ey * n, 0.5 * ez * n
        w, x, y, z = (w * n - x * hx - y * hy - z * hz, w * hx + x * n + y * hz - z * hy,
                      w * hy - x * hz + y * n + z * hx, w * hz + x * hy - y * hx + z * n)
    roll = math.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x))))
    yaw = math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    return (roll, pitch, yaw), (fx, fy, fz)


def heading_frame_velocity(sim, yaw):
    """The firmware's velocity estimate in its heading frame (forward, left, up) [m/s], ``yaw`` the true
    heading [rad]: the same quantity as Simulator.flow_velocity()."""
    firmware = sim.firmware
    if firmware is not None:
        vx, vy = firmware.velocity.tolist()
        vz = float(firmware.climb)
    elif sim.realism["flow_surface_coupling"]:
        return tuple(float(v) for v in sim.flow_velocity())  # the flow over the vehicle: the full model
    else:
        # Without a firmware estimate: the optical flow's measurement, velocity over the ground, noisy.
        v = sim.drone_qvel
        vx, vy, vz = sim.data.qvel[v:v + 3].tolist()
        vx, vy = vx * sim.flow_scale, vy * sim.flow_scale
        std = sim.noise["flow_velocity_std"] if sim.noise is not None else 0.0
        if std > 0.0:
            n = sim.rng["flow"].standard_normal(3).tolist()
            vx, vy, vz = vx + std * n[0], vy + std * n[1], vz + std * n[2]
    c, s = math.cos(yaw), math.sin(yaw)
    return c * vx + s * vy, -s * vx + c * vy, vz


def magnetometer(w, x, y, z):
    """Earth's field in the body frame [mG] (x forward, y left, z up) for the true attitude (w, x, y, z)."""
    # Rows of the world-to-body rotation are the body axes in the world frame; the field is (0, N, -D).
    return (int(round(2 * (x * y + w * z) * MAG_NORTH_MG - 2 * (x * z - w * y) * MAG_DOWN_MG)),
            int(round((1 - 2 * (x * x + z * z)) * MAG_NORTH_MG - 2 * (y * z + w * x) * MAG_DOWN_MG)),
            int(round(2 * (y * z - w * x) * MAG_NORTH_MG - (1 - 2 * (x * x + y * y)) * MAG_DOWN_MG)))


def navdata_fields(sim):
    """The fields of ardrone_autonomy/Navdata (header aside) for the drone's state now, by field name."""
    q = sim.drone_qpos
    w, x, y, z = sim.data.qpos[q + 3:q + 7].tolist()
    (roll, pitch, yaw), (fx, fy, fz) = attitude_estimate(sim, w, x, y, z)
    vx, vy, vz = heading_frame_velocity(sim, math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))
    mag_x, mag_y, mag_z = magnetometer(w, x, y, z)
    autopilot = sim.autopilot
    front_left, front_right, rear_left, rear_right = autopilot.motor_thrust.tolist()
    max_thrust = autopilot.max_rotor_thrust
    _, pressure_hpa = sim.altimeter()
    return {
        "batteryPercent": float(sim.battery.level),
        "state": autopilot.navdata_state,
        "magX": mag_x, "magY": mag_y, "magZ": mag_z,
        "pressure": int(round(pressure_hpa * 100.0)),     # [Pa]
        # The barometer's temperature, in 0.1 deg C as its BMP180-type sensor reports it (the driver passes the raw
        # value on and documents no unit); the air's, as the simulator knows no hull heating.
        "temp": int(round(sim.temperature * 10.0)),
        # The firmware's wind estimator is not modelled: 0, as a drone that has not estimated any wind reports.
        "wind_speed": 0.0, "wind_angle": 0.0, "wind_comp_angle": 0.0,
        # Attitude estimate [deg], counter-clockwise positive about x (roll), y (pitch: nose down) and z (yaw).
        "rotX": math.degrees(roll), "rotY": math.degrees(pitch), "rotZ": math.degrees(yaw),
        "altd": int(round(max(0.0, sim.ardrone_altitude()) * sim.altd_scale)),  # mm or cm (ardrone2/altd_unit)
        "vx": vx * 1000.0, "vy": vy * 1000.0, "vz": vz * 1000.0,   # heading frame: forward, left, up [mm/s]
        "ax": fx / G, "ay": fy / G, "az": fz / G,                   # body frame [g]; az is +1 at rest
        # motor1 front left, motor2 front right, motor3 rear right, motor4 rear left (the AR.Drone's numbering).
        "motor1": motor_pwm(front_left, max_thrust), "motor2": motor_pwm(front_right, max_thrust),
        "motor3": motor_pwm(rear_right, max_thrust), "motor4": motor_pwm(rear_left, max_thrust),
        "tags_count": 0, "tags_type": [], "tags_xc": [], "tags_yc": [], "tags_width": [], "tags_height": [],
        "tags_orientation": [], "tags_distance": [],
        "tm": sim.time * 1e6,   # the drone's clock, microseconds since it started
    }
