"""ROS-free tests of the simulator core: model, autopilot, wind, battery, touchdown, camera."""
import math
import os

import numpy as np
import pytest

from mujoco_sim.autopilot import FlightMode
from mujoco_sim.config import ConfigError
from mujoco_sim.schema import load_sim_config
from mujoco_sim.simulator import SURFACE_GROUND, SURFACE_PAD, Simulator, classify_touchdown

PKG = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
CONFIG = os.path.join(PKG, "config", "sim.yaml")


def model(vehicle="summit_xl"):
    return os.path.join(PKG, "models", "world_%s.xml" % vehicle)


def make_sim(vehicle="summit_xl", seed=1, realism="ideal", **overrides):
    """A world of the given realism profile; these tests of the physics and the autopilot use the ideal one
    (true state, no latency) unless they say otherwise."""
    overrides.setdefault("realism", {"profile": realism})
    return Simulator(load_sim_config(CONFIG, overrides), model(vehicle), vehicle, seed)


def run(sim, seconds, command=(0.0, 0.0, 0.0, 0.0), until=None):
    for _ in range(int(round(seconds / sim.model.opt.timestep))):
        sim.set_velocity_command(*command)
        sim.step()
        if until is not None and until(sim):
            return True
    return False


def airborne(sim):
    sim.takeoff()
    assert run(sim, 10.0, until=lambda s: s.autopilot.mode == FlightMode.FLYING)
    run(sim, 2.0)


@pytest.mark.parametrize("vehicle", ["summit_xl", "car"])
def test_model_loads_with_drone_resting_on_the_pad(vehicle):
    sim = make_sim(vehicle)
    run(sim, 1.0)
    position, _ = sim.drone_pose()
    pad = sim.pad_position()
    assert sim.autopilot.mode == FlightMode.LANDED
    assert abs(position[2] - pad[2] - 0.065) < 0.01
    assert math.hypot(position[0] - pad[0], position[1] - pad[1]) < 0.01
    assert sim.touchdown is None


def test_pad_top_height_matches_the_thesis():
    assert make_sim().pad_position()[2] == pytest.approx(0.497, abs=1e-6)


def test_missing_and_malformed_model_files_name_the_file(tmp_path):
    config = load_sim_config(CONFIG)
    with pytest.raises(ConfigError, match="nope.xml: model file not found"):
        Simulator(config, str(tmp_path / "nope.xml"), "summit_xl", 0)
    broken = tmp_path / "broken.xml"
    broken.write_text("<mujoco><worldbody><body></mujoco>")
    with pytest.raises(ConfigError, match="broken.xml: cannot load"):
        Simulator(config, str(broken), "summit_xl", 0)
    empty = tmp_path / "empty.xml"
    empty.write_text("<mujoco/>")
    with pytest.raises(ConfigError, match="no body named 'ardrone'"):
        Simulator(config, str(empty), "summit_xl", 0)


def test_bad_parameters_are_rejected_with_the_key_and_the_expectation(tmp_path):
    with pytest.raises(ConfigError, match=r"'conditions/drone_battery': got 150.0, expected a number in \[0, 100\]"):
        load_sim_config(CONFIG, {"conditions": {"drone_battery": 150}})
    with pytest.raises(ConfigError, match=r"'conditions/wind_speed': got -3.0"):
        load_sim_config(CONFIG, {"conditions": {"wind_speed": -3}})
    with pytest.raises(ConfigError, match="unknown parameter"):
        load_sim_config(CONFIG, {"camera": {"fps": 30}})
    text = open(CONFIG).read().replace("  land_speed: 0.5", "")
    partial = tmp_path / "sim.yaml"
    partial.write_text(text)
    with pytest.raises(ConfigError, match="'drone/land_speed' is missing"):
        load_sim_config(str(partial))
    bad = tmp_path / "bad.yaml"
    bad.write_text("seed: [1, 2\n")
    with pytest.raises(ConfigError, match="bad.yaml: not valid YAML"):
        load_sim_config(str(bad))


def test_hover_holds_altitude_within_5_cm():
    sim = make_sim()
    airborne(sim)
    start = sim.drone_pose()[0].copy()
    heights = []
    for _ in range(10):
        run(sim, 1.0)
        heights.append(sim.drone_pose()[0][2])
    assert max(abs(h - start[2]) for h in heights) < 0.05
    assert start[2] == pytest.approx(0.562 + 1.0, abs=0.1)


def test_velocity_step_response_settles():
    sim = make_sim()
    airborne(sim)
    run(sim, 3.0, command=(2.0, 0.0, 0.0, 0.0))
    samples = []
    for _ in range(20):
        run(sim, 0.1, command=(2.0, 0.0, 0.0, 0.0))
        samples.append(sim.drone_velocity()[0])
    samples = np.array(samples)
    assert np.all(np.abs(samples[:, 0] - 2.0) < 0.1)
    assert np.all(np.abs(samples[:, 1]) < 0.05)


def test_velocity_ramps_are_followed_alike_both_ways():
    """Back and forth at 3 m/s with 1 m/s^2 ramps (summit_back_and_forth_3ms): the drone lags a rising
    and a falling speed command alike. The velocity integral once skipped the large errors of one side
    and built up a 1.1 m/s^2 bias in the other direction (lag 0.9 m/s one way, 0.05 m/s the other)."""
    sim = make_sim(noise={"enabled": False})
    airborne(sim)
    lags = {1: [], -1: []}
    dt = 0.02
    for k in range(int(48.0 / dt)):
        phase = (k * dt) % 12.0
        command = -3.0 + phase if phase < 6.0 else 9.0 - phase  # triangle wave, +-1 m/s^2
        run(sim, dt, command=(command, 0.0, 0.0, 0.0))
        if k * dt > 12.0 and 1.0 < phase % 6.0 < 5.0:
            slope = 1 if phase < 6.0 else -1
            lags[slope].append(slope * (command - sim.drone_velocity()[0][0]))
    rising, falling = np.mean(lags[1]), np.mean(lags[-1])
    assert rising < 0.6 and falling < 0.6, (rising, falling)
    assert abs(rising - falling) < 0.15, (rising, falling)


def test_commands_are_in_the_heading_frame_and_capped_at_max_speed():
    sim = make_sim(drone={"max_horizontal_speed": 5.0})
    airborne(sim)
    run(sim, 1.6, command=(0.0, 0.0, 0.0, 1.0))  # turn left by about 90 deg
    run(sim, 6.0, command=(30.0, 0.0, 0.0, 0.0))
    velocity = sim.drone_velocity()[0]
    assert math.hypot(velocity[0], velocity[1]) == pytest.approx(5.0, abs=0.3)
    assert velocity[1] > 4.0  # forward after a left turn is +y


def test_the_heading_holds_while_the_drone_rolls_at_car_speed():
    """Pitched 15 deg forward at 15 m/s, rolling to and fro for +-2 m/s side steps: the heading (the yaw of the
    yaw-pitch-roll angles, the frame of cmd_vel) moves by less than 0.02 rad. The attitude built from the yaw
    reference projected onto the tilted plane swung it by +-0.11 rad."""
    sim = make_sim(noise={"enabled": False}, drone={"max_horizontal_speed": 20.0})
    airborne(sim)
    run(sim, 8.0, command=(15.0, 0.0, 0.0, 0.0))

    def heading():
        w, x, y, z = sim.drone_pose()[1]
        return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))

    start, swing = heading(), []
    for k in range(60):
        run(sim, 0.05, command=(15.0, 2.0 if (k // 10) % 2 else -2.0, 0.0, 0.0))
        swing.append(heading() - start)
    assert sim.drone_velocity()[0][0] > 14.0
    assert max(np.abs(swing)) < 0.02, (min(swing), max(swing))


def test_absurd_commands_are_refused_and_the_drone_holds():
    sim = make_sim()
    airborne(sim)
    assert "non-finite" in sim.set_velocity_command(float("nan"), 0, 0, 0)
    assert "absurd" in sim.set_velocity_command(1e6, 0, 0, 0)
    assert sim.set_vehicle_command(float("inf"), 0) is not None
    before = sim.drone_pose()[0].copy()
    for _ in range(500):
        sim.set_velocity_command(float("nan"), 0, 0, 0)
        sim.step()
    assert np.linalg.norm(sim.drone_pose()[0] - before) < 0.1


def test_wind_pushes_the_drone_downwind():
    drift = {}
    for wind in (0.0, 8.0):
        sim = make_sim()
        sim.set_conditions(wind_speed=wind, wind_direction_deg=90.0)
        airborne(sim)
        start = sim.drone_pose()[0].copy()
        run(sim, 1.0)
        drift[wind] = sim.drone_pose()[0] - start
    assert drift[8.0][1] > drift[0.0][1] + 0.05
    assert abs(drift[8.0][0]) < 0.05


def test_battery_drains_with_flight_and_faster_in_the_cold():
    levels = {}
    for temp in (15.0, -10.0):
        sim = make_sim()
        sim.set_conditions(temp=temp, battery=80.0)
        idle_start = sim.battery.level
        run(sim, 5.0)
        idle = idle_start - sim.battery.level
        airborne(sim)
        flying_start = sim.battery.level
        run(sim, 10.0)
        levels[temp] = (idle, flying_start - sim.battery.level)
    idle, flying = levels[15.0]
    assert 0.0 < idle < 0.1
    assert flying > 0.5  # about 0.14 %/s in hover
    assert levels[-10.0][1] > 1.5 * flying


def test_landing_on_the_moving_pad_is_a_pad_touchdown():
    sim = make_sim()
    sim.takeoff()
    run(sim, 4.0)
    sim.land()
    assert run(sim, 10.0, until=lambda s: s.touchdown is not None)
    assert sim.touchdown.surface == SURFACE_PAD and not sim.touchdown.crashed
    assert sim.touchdown.pad_error < 0.1
    assert sim.autopilot.mode == FlightMode.LANDED


def test_landing_beside_the_vehicle_is_a_ground_touchdown():
    sim = make_sim()
    airborne(sim)
    run(sim, 4.0, command=(0.0, 1.0, 0.0, 0.0))
    sim.land()
    assert run(sim, 10.0, command=(0.0, 0.0, 0.0, 0.0), until=lambda s: s.touchdown is not None)
    assert sim.touchdown.surface == SURFACE_GROUND and not sim.touchdown.crashed
    assert sim.touchdown.pad_error > 1.0


def test_falling_with_an_empty_battery_is_a_crash():
    sim = make_sim()
    airborne(sim)
    run(sim, 2.0, command=(0.0, 0.0, 2.0, 0.0))
    sim.set_conditions(battery=0.0)
    assert run(sim, 5.0, until=lambda s: s.touchdown is not None)
    assert sim.touchdown.crashed and sim.autopilot.mode == FlightMode.CRASHED
    assert not sim.takeoff()
    sim.set_conditions(battery=50.0)
    sim.reset()
    assert sim.autopilot.mode == FlightMode.LANDED


def test_the_pads_ground_truth_is_where_the_vehicle_is_now_at_car_speed():
    """Positions MuJoCo derives from the joints (the pad's site, the scene the camera renders) belong to the
    same instant as the joints themselves: after a plain mj_step they lagged by a step, 6 cm at 15 m/s."""
    sim = make_sim("car")
    for _ in range(60):  # the vehicle stops without a command every command_timeout
        sim.set_vehicle_command(15.0, 0.0)
        run(sim, 0.1)
    assert sim.vehicle_velocity()[0] > 14.0
    x, y, yaw = sim.vehicle_pose()
    offset = sim.pad_offset_in_vehicle()
    expected = (x + math.cos(yaw) * offset[0] - math.sin(yaw) * offset[1],
                y + math.sin(yaw) * offset[0] + math.cos(yaw) * offset[1])
    assert sim.pad_position()[:2] == pytest.approx(expected, abs=0.002)


def test_touchdown_classification_limits():
    assert classify_touchdown(SURFACE_PAD, 0.5, 3.0, 2.5, 45.0) == (SURFACE_PAD, False)
    assert classify_touchdown(SURFACE_PAD, 3.0, 3.0, 2.5, 45.0) == (SURFACE_PAD, True)
    assert classify_touchdown(SURFACE_GROUND, 0.5, 60.0, 2.5, 45.0) == (SURFACE_GROUND, True)


def test_vehicle_follows_commands_within_its_acceleration_limit():
    sim = make_sim()
    sim.set_vehicle_command(2.0, 0.0)
    run(sim, 0.5)
    assert sim.vehicle_velocity()[0] == pytest.approx(0.5, abs=0.05)  # 1 m/s^2
    for _ in range(10):
        sim.set_vehicle_command(2.0, 0.0)
        run(sim, 0.25)
    assert sim.vehicle_velocity()[0] == pytest.approx(2.0, abs=0.05)
    assert sim.drone_pose()[0][0] == pytest.approx(sim.pad_position()[0], abs=0.02)  # rides along


def red_mask(image):
    r, g, b = (image[..., i].astype(int) for i in range(3))
    return (r > 100) & (r > 2.5 * g) & (r > 2.5 * b)


def test_camera_shows_the_pad_where_it_should_be():
    sim = make_sim()
    airborne(sim)
    run(sim, 3.0, command=(0.0, 0.0, 1.0, 0.0))
    image = sim.render_camera()
    width, height, fx, fy, cx, cy = sim.camera_intrinsics()
    assert image.shape == (240, 320, 3) and fx == pytest.approx(256.0, abs=0.5)
    mask = red_mask(image)
    rows, cols = np.nonzero(mask)
    # The pad seen from straight above at height h: side of fx * 1 m / h pixels, centred.
    camera_height = sim.drone_pose()[0][2] - 0.035 - 0.497
    expected_side = fx * 1.0 / camera_height
    assert math.sqrt(mask.sum()) == pytest.approx(expected_side, rel=0.15)
    pad_in_camera = sim.pad_position() - sim.drone_pose()[0]
    # image up is body +x, image right is body -y
    assert cols.mean() == pytest.approx(cx - fx * pad_in_camera[1] / camera_height, abs=3)
    assert rows.mean() == pytest.approx(cy - fy * pad_in_camera[0] / camera_height, abs=3)
    green = (image[..., 1] > 120) & (image[..., 0] < 80)
    assert green.sum() > 20
    assert np.nonzero(green)[0].mean() < rows.mean()  # heading strip at the front = image top


def test_sensors_measure_height_and_attitude():
    sim = make_sim()
    airborne(sim)
    assert sim.sonar() == pytest.approx(1.0, abs=0.1)  # above the pad
    quat, gyro, accel = sim.imu()
    assert accel[2] == pytest.approx(9.81, abs=0.3)
    assert abs(quat[0]) == pytest.approx(1.0, abs=0.01)
    altitude, pressure = sim.altimeter()
    assert altitude == pytest.approx(sim.drone_pose()[0][2], abs=0.5)
    assert 1000 < pressure < 1014


def test_same_seed_same_noise():
    a, b = make_sim(seed=5), make_sim(seed=5)
    assert [a.sonar() for _ in range(5)] == [b.sonar() for _ in range(5)]
    assert make_sim(seed=6).gps()[0][0] != make_sim(seed=5).gps()[0][0]


def test_faults_black_out_the_camera_and_show_a_false_target():
    sim = make_sim()
    airborne(sim)
    run(sim, 3.0, command=(0.0, 0.0, 1.0, 0.0))
    assert not sim.inject_fault("meteor", 1.0)
    assert sim.inject_fault("camera_blackout", 1.0) and sim.camera_blacked_out()
    run(sim, 1.1)
    assert not sim.camera_blacked_out()
    before = red_mask(sim.render_camera()).sum()
    assert sim.inject_fault("detection_false_target", 5.0)
    run(sim, 0.1)
    during = red_mask(sim.render_camera()).sum()
    assert during > before * 1.3  # a 1.0 x 0.6 m red object beside the 1 m pad
    run(sim, 5.0)
    assert red_mask(sim.render_camera()).sum() == pytest.approx(before, rel=0.1)


# ----- realism (profile realistic unless a test says otherwise) ---------------------------------------------
def hover_above_pad(sim, height, vehicle_velocity=(2.0, 0.0)):
    """Place the drone ``height`` above the pad centre, level, and give the vehicle a velocity (kinematic)."""
    pad = sim.pad_position()
    sim._set_drone_pose((pad[0], pad[1], pad[2] + height), 0.0)
    sim.data.qvel[sim.vehicle_qvel:sim.vehicle_qvel + 2] = vehicle_velocity
    sim._mj.mj_forward(sim.model, sim.data)


def test_the_optical_flow_follows_the_vehicle_when_it_fills_the_view():
    sim = make_sim(realism="realistic", noise={"enabled": False})
    sim.flow_scale = 1.0
    for height, expected_weight in ((0.8, 1.0), (4.0, 0.0)):
        hover_above_pad(sim, height)
        measured = sim._flow_measurement(np.eye(3))
        # The drone stands still: over the ground the flow reads 0, over the vehicle minus its velocity.
        assert measured == pytest.approx((-2.0 * expected_weight, 0.0), abs=1e-6)
        assert sim.surface_weight == pytest.approx(expected_weight)
    ideal = make_sim(realism="ideal", noise={"enabled": False})
    hover_above_pad(ideal, 0.8)
    assert ideal._flow_measurement(np.eye(3)) == pytest.approx((0.0, 0.0))


def test_the_reported_yaw_drifts_by_the_drift_process_and_the_attitude_tilts_with_the_accelerometer_bias():
    sim = make_sim(realism="realistic", seed=4, noise={"enabled": True, "imu_orientation_std_deg": 0.0})
    run(sim, 5.0)
    quat, _, _ = sim.imu()
    true_yaw = math.atan2(2 * (sim.drone_pose()[1][0] * sim.drone_pose()[1][3]), 1 - 2 * sim.drone_pose()[1][3] ** 2)
    reported = math.atan2(2 * (quat[0] * quat[3] + quat[1] * quat[2]), 1 - 2 * (quat[2] ** 2 + quat[3] ** 2))
    assert sim.yaw_drift() != 0.0
    assert reported - true_yaw == pytest.approx(sim.yaw_drift(), abs=0.002)
    drifts = []
    for seed in range(25):
        s = make_sim(realism="realistic", seed=seed)
        s.data.time = 60.0
        drifts.append(s.yaw_drift())
    # The drift rate's std is 0.0005 rad/s: 0.03 rad after 60 s (the walk adds 0.004 rad once stepped).
    assert np.std(drifts) == pytest.approx(0.03, rel=0.4)


def test_sonar_outliers_come_at_their_rate():
    sim = make_sim(realism="realistic", seed=2, noise={"enabled": False})
    hover_above_pad(sim, 1.5, (0.0, 0.0))
    readings = np.array([sim.sonar() for _ in range(4000)])
    off = np.mean(~(np.abs(readings - 1.5 + 0.065) < 0.02))
    assert off == pytest.approx(0.02, abs=0.008)


def test_gps_drifts_slowly_and_drops_out_now_and_then():
    sim = make_sim(realism="harsh", seed=3, noise={"enabled": False})
    errors, missing = [], 0
    for _ in range(3000):  # 10 minutes at 5 Hz, the physics not stepped: only time moves
        sim.data.time += 0.2
        fix = sim.gps()
        if fix is None:
            missing += 1
            continue
        errors.append(fix[0][:2] - sim.drone_pose()[0][:2])
    errors = np.array(errors)
    assert 0.01 < missing / 3000.0 < 0.2  # harsh: an outage of 6 s a minute
    assert 0.8 < np.std(errors) < 3.0     # 2 m Gauss-Markov, one long record
    ten_seconds = 50  # fixes
    correlation = np.corrcoef(errors[:-ten_seconds, 0], errors[ten_seconds:, 0])[0, 1]
    assert correlation > 0.6               # slowly drifting: exp(-10 / 60) = 0.85 apart 10 s


def test_commands_reach_the_drone_after_the_link_latency_and_some_are_lost():
    sim = make_sim(realism="realistic", seed=5)
    sim.takeoff()
    run(sim, 0.5)
    assert sim.autopilot.mode != FlightMode.LANDED
    sim.set_velocity_command(1.0, 0.0, 0.0, 0.0)
    assert sim.command.vx == 0.0          # not there yet
    sent = 0
    while sim.command.vx == 0.0 and sent < 100:
        sim.step()
        sent += 1
    assert 0.0 < sent * sim.dt < 0.1      # 30 ms +- 10 ms
    link = sim.command_link
    before = link.lost
    for _ in range(3000):
        sim.set_velocity_command(0.5, 0.0, 0.0, 0.0)
    assert (link.lost - before) / 3000.0 == pytest.approx(0.03, abs=0.01)


def test_the_realistic_camera_is_distorted_wider_rendered_and_its_brightness_wanders():
    sim = make_sim(realism="realistic")
    run(sim, 0.2)
    image = sim.render_camera()
    assert image.shape == (240, 320, 3)
    assert sim.lens.render_fovy_deg > sim.camera_fovy  # barrel distortion: the corners see further out
    assert sim.camera_distortion()[0] == pytest.approx(-0.2)
    # The sun (a light that travels with the drone) shines from where the seed put it, 1 m towards it.
    assert sim.data.light_xdir[0] == pytest.approx(sim.sun_direction, abs=1e-6)
    assert sim.data.light_xpos[0] - sim.drone_pose()[0] == pytest.approx(-sim.sun_direction, abs=1e-6)
    gains = [sim.exposure.gain(t) for t in np.arange(0.0, 300.0, 0.5)]
    assert 0.05 < np.std(np.log(gains)) < 0.3
    ideal = make_sim(realism="ideal")
    run(ideal, 0.2)
    ideal.render_camera()
    assert ideal.lens.identity and ideal.exposure.gain(10.0) == 1.0


def test_a_surface_step_under_the_sonar_moves_the_firmware_height_not_the_drone():
    """Flying off a car's roof the sonar's surface drops 1.7 m: the firmware takes the new height, and its
    altitude hold keeps the drone's altitude instead of diving after the old height above the surface."""
    from mujoco_sim.firmware import FirmwareEstimator
    sim = make_sim(realism="realistic")
    fw = FirmwareEstimator(sim.cfg["firmware"])
    steps = [fw.sonar(k * 0.04, 0.04, 2.2, 4.0) for k in range(10)]
    assert not any(steps) and fw.height == pytest.approx(2.2, abs=0.01)
    steps = [fw.sonar(0.4 + k * 0.04, 0.04, 3.9, 4.0) for k in range(10)]
    assert sum(steps) == pytest.approx(1.7, abs=0.01) and steps[0] == 0.0  # an outlier at first, then a step
    assert fw.height == pytest.approx(3.9, abs=0.01)
    sim.autopilot.z_ref = 2.2
    sim.autopilot.shift_altitude_reference(1.7)
    assert sim.autopilot.z_ref == pytest.approx(3.9)


def test_a_sonar_alternating_between_pad_and_ground_leaves_the_climb_estimate_to_the_barometer():
    """At the pad's edge the sonar reads the pad and the ground by turns, each long enough to pass for a new
    surface. The climb estimate must not run away on the accelerometer's bias meanwhile: the barometer holds
    it, and the bias is estimated (a runaway climb estimate once made the drone descend onto the pad's edge
    believing it climbed: 0.41 m/s here before)."""
    from mujoco_sim.firmware import FirmwareEstimator
    sim = make_sim(realism="harsh")
    dt, bias, baro = 0.04, 0.2, 0.9  # a 0.2 m/s^2 vertical accelerometer bias; the drone holds its altitude

    def climb_estimates(alternating):
        fw = FirmwareEstimator(sim.cfg["firmware"])
        climbs = []
        for k in range(300):
            t = k * dt
            fw.predict(dt, (0.0, 0.0, bias))
            surface_is_pad = not alternating or int(t / 0.3) % 2 == 0  # 0.3 s each: longer than surface_step_time
            fw.sonar(t, dt, 0.2 if surface_is_pad else 0.7, baro)
            climbs.append(fw.climb)
        return np.array(climbs), fw.climb_bias

    steady, _ = climb_estimates(alternating=False)
    climbs, estimated_bias = climb_estimates(alternating=True)
    assert np.abs(climbs).max() < 1.3 * np.abs(steady).max() < 0.25
    assert abs(climbs[-100:].mean()) < 0.03 and estimated_bias == pytest.approx(bias, abs=0.02)
