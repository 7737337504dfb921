"""ROS-free tests of drone_model ardrone2: the AR.Drone 2.0 firmware behind ardrone_autonomy, its navdata,
navdata rates and camera channel. Short flights in the ideal world unless a test says otherwise."""
import math
import os

import pytest

from mujoco_sim.ardrone_firmware import (STATE_FLYING, STATE_HOVERING, STATE_LANDED, STATE_LANDING,
                                         STATE_TAKING_OFF, ArdroneDriver, CameraChannel, NavdataSchedule)
from mujoco_sim.autopilot import FlightMode
from mujoco_sim.config import ConfigError
from mujoco_sim.schema import load_sim_config
from mujoco_sim.simulator import SURFACE_PAD, Simulator

PKG = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..")
CONFIG = os.path.join(PKG, "config", "sim.yaml")
HOVER = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


# The driver's indoor defaults, which the figures of the tests below are worked out with.
DRIVER_DEFAULTS = {"euler_angle_max": 0.21, "control_vz_max": 700.0}


def make_sim(realism="ideal", seed=1, ardrone2=None, **overrides):
    overrides.setdefault("realism", {"profile": realism})
    overrides["drone_model"] = "ardrone2"
    if ardrone2:
        overrides["ardrone2"] = ardrone2
    return Simulator(load_sim_config(CONFIG, overrides), os.path.join(PKG, "models", "world_summit_xl.xml"),
                     "summit_xl", seed)


def run(sim, seconds, command=HOVER, until=None):
    """Step ``seconds``, sending ``command`` (cmd_vel's six components) every step unless it is None."""
    for _ in range(int(round(seconds / sim.dt))):
        if command is not None:
            sim.set_ardrone_command(*command)
        sim.step()
        if until is not None and until(sim):
            return True
    return False


def airborne(sim):
    sim.takeoff()
    assert run(sim, 4.0, until=lambda s: s.autopilot.navdata_state == STATE_HOVERING)


def heading_velocity(sim):
    """True velocity in the heading frame (forward, left, up) [m/s]."""
    (vx, vy, vz), _ = sim.drone_velocity()
    w, x, y, z = sim.drone_pose()[1]
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return math.cos(yaw) * vx + math.sin(yaw) * vy, -math.sin(yaw) * vx + math.cos(yaw) * vy, vz


def yaw_of(sim):
    w, x, y, z = sim.drone_pose()[1]
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


# ----- configuration ---------------------------------------------------------------------------------
def test_the_velocity_quad_stays_the_default_and_the_firmware_ranges_are_enforced():
    config = load_sim_config(CONFIG)
    assert config["drone_model"] == "velocity_quad"
    # The firmware's outdoor settings (its indoor defaults are 0.21 rad and 700 mm/s; see sim.yaml).
    assert config["ardrone2"]["euler_angle_max"] == 0.35 and config["ardrone2"]["control_vz_max"] == 1000.0
    # altitude_max above the stack's 4 m (the driver's default, 3000 mm, is below it).
    assert config["ardrone2"]["control_yaw"] == 1.75 and config["ardrone2"]["altitude_max"] == 6000
    with pytest.raises(ValueError, match=r"'ardrone2/euler_angle_max': got 0.6, expected a number in \[0, 0.52\] rad"):
        load_sim_config(CONFIG, {"ardrone2": {"euler_angle_max": 0.6}})
    with pytest.raises(ValueError, match=r"'ardrone2/control_vz_max': got 100.0, .*\[200, 2000\] mm/s"):
        load_sim_config(CONFIG, {"ardrone2": {"control_vz_max": 100}})
    with pytest.raises(ValueError, match=r"'ardrone2/control_yaw': .*\[0.7, 6.11\] rad/s"):
        load_sim_config(CONFIG, {"ardrone2": {"control_yaw": 7.0}})
    with pytest.raises(ValueError, match="'ardrone2/altitude_min' .* must be below 'ardrone2/altitude_max'"):
        load_sim_config(CONFIG, {"ardrone2": {"altitude_min": 7000}})
    with pytest.raises(ConfigError, match="'drone_model': got 'bebop'"):
        load_sim_config(CONFIG, {"drone_model": "bebop"})


def test_each_model_takes_only_its_own_commands():
    velocity_world = Simulator(load_sim_config(CONFIG, {"realism": {"profile": "ideal"}}),
                               os.path.join(PKG, "models", "world_summit_xl.xml"), "summit_xl", 1)
    with pytest.raises(RuntimeError, match="drone_model ardrone2"):
        velocity_world.set_ardrone_command(*HOVER)
    assert velocity_world.camera_channel is None and velocity_world.navdata_schedule is None
    with pytest.raises(RuntimeError, match="use set_ardrone_command"):
        make_sim().set_velocity_command(1.0, 0.0, 0.0, 0.0)


# ----- cmd_vel at the driver ---------------------------------------------------------------------------
def test_the_driver_clips_to_one_and_refuses_a_non_finite_command_whole():
    driver = ArdroneDriver()
    assert driver.receive((0.5, -2.0, 3.0, 0.0, 0.0, -1.5)) is None
    assert driver.command.as_tuple() == (0.5, -1.0, 1.0, 0.0, 0.0, -1.0) and driver.clipped == 1
    problem = driver.receive((0.1, float("nan"), 0.0, 0.0, 0.0, 0.0))
    assert "non-finite linear.y" in problem and "refused" in problem
    assert driver.command.as_tuple() == (0.5, -1.0, 1.0, 0.0, 0.0, -1.0) and driver.refused == 1
    assert driver.receive((0.0, 0.0, 0.0, 0.0, 0.0, float("inf"))) is not None
    assert not driver.command.hover and ArdroneDriver().command.hover

    sim = make_sim()
    assert sim.set_ardrone_command(5.0, 0.0, 0.0, 0.0, 0.0, 0.0) is None
    assert sim.ardrone_driver.clipped == 1 and sim.ardrone_driver.command.lx == 1.0
    assert "non-finite angular.x" in sim.set_ardrone_command(0.0, 0.0, 0.0, float("nan"), 0.0, 0.0)
    assert sim.ardrone_driver.command.lx == 1.0


# ----- flight --------------------------------------------------------------------------------------------
def test_take_off_climbs_to_the_take_off_height_and_hovers_then_landing_touches_down():
    sim = make_sim()
    assert sim.autopilot.navdata_state == STATE_LANDED
    sim.takeoff()
    run(sim, 0.3)
    assert sim.autopilot.navdata_state == STATE_TAKING_OFF
    assert run(sim, 4.0, until=lambda s: s.autopilot.navdata_state != STATE_TAKING_OFF)
    assert sim.autopilot.navdata_state == STATE_HOVERING
    run(sim, 1.0)
    assert sim.ardrone_navdata()["altd"] == pytest.approx(900, abs=40)  # mm above the pad
    sim.land()
    run(sim, 0.3)
    assert sim.autopilot.navdata_state == STATE_LANDING
    assert run(sim, 4.0, until=lambda s: s.autopilot.navdata_state == STATE_LANDED)
    assert sim.touchdown.surface == SURFACE_PAD and not sim.touchdown.crashed


def test_all_zero_holds_zero_velocity_in_hover():
    sim = make_sim()
    airborne(sim)
    run(sim, 1.0, command=(0.6, 0.0, 0.0, 0.0, 0.0, 0.0))
    assert sim.autopilot.navdata_state == STATE_FLYING and heading_velocity(sim)[0] > 0.5
    run(sim, 3.0)
    assert sim.autopilot.navdata_state == STATE_HOVERING
    start = sim.drone_pose()[0].copy()
    run(sim, 1.0)
    assert math.hypot(*sim.drone_velocity()[0][:2]) < 0.05
    assert math.hypot(*(sim.drone_pose()[0][:2] - start[:2])) < 0.05


def test_hovering_on_its_own_flow_estimate_the_drone_follows_the_moving_pad_while_the_pad_fills_the_view():
    """The optical flow measures the motion relative to what the camera sees: above the moving pad, holding zero
    velocity on that estimate means going along with the pad (realistic); on true velocity it stops (ideal)."""
    speeds = {}
    for realism in ("ideal", "realistic"):
        sim = make_sim(realism, noise={"enabled": False})
        pad = sim.pad_position()
        sim._set_drone_pose((pad[0], pad[1], pad[2] + 0.065 + 0.9), 0.0)
        sim.data.qvel[sim.vehicle_qvel] = sim.data.qvel[sim.drone_qvel] = 1.5  # both at 1.5 m/s along x
        sim.vehicle_command = [1.5, 0.0]
        sim._mj.mj_forward(sim.model, sim.data)
        sim.autopilot.set_mode(FlightMode.FLYING, "test: hovering above the driving pad")
        for _ in range(10):
            sim.set_vehicle_command(1.5, 0.0)
            run(sim, 0.1)
        assert sim.autopilot.navdata_state == STATE_HOVERING
        speeds[realism] = sim.drone_velocity()[0][0]
    assert speeds["ideal"] < 0.3 and speeds["realistic"] > 1.0, speeds


def test_tilt_commands_move_the_drone_in_its_heading_frame_and_climb_and_yaw_at_their_rates():
    sim = make_sim(noise={"enabled": False}, ardrone2=DRIVER_DEFAULTS)
    airborne(sim)
    # Yaw: counter-clockwise at az * control_yaw.
    run(sim, 0.4, command=(0.0, 0.0, 0.0, 0.0, 0.0, 0.5))
    before = yaw_of(sim)
    run(sim, 0.6, command=(0.0, 0.0, 0.0, 0.0, 0.0, 0.5))
    assert (yaw_of(sim) - before) / 0.6 == pytest.approx(0.5 * 1.75, rel=0.05)
    heading = yaw_of(sim)
    # Forward: nose down (positive pitch, rotY), moving forward in the heading frame.
    run(sim, 1.5, command=(0.5, 0.0, 0.0, 0.0, 0.0, 0.0))
    navdata = sim.ardrone_navdata()
    assert navdata["state"] == STATE_FLYING
    assert navdata["rotY"] == pytest.approx(math.degrees(0.5 * 0.21), abs=0.3)
    forward, left, _ = heading_velocity(sim)
    assert forward > 1.0 and abs(left) < 0.05
    velocity = sim.drone_velocity()[0]
    assert math.atan2(velocity[1], velocity[0]) == pytest.approx(heading, abs=0.03)
    # Left: roll to the left (negative rotX), moving left.
    run(sim, 2.0, command=(0.0, 0.5, 0.0, 0.0, 0.0, 0.0))
    assert sim.ardrone_navdata()["rotX"] == pytest.approx(-math.degrees(0.5 * 0.21), abs=0.3)
    assert heading_velocity(sim)[1] > 1.0
    # Climb at lz * control_vz_max.
    run(sim, 0.8, command=(0.0, 0.0, 0.5, 0.0, 0.0, 0.0))
    assert heading_velocity(sim)[2] == pytest.approx(0.35, abs=0.03)


def test_the_steady_speed_is_bounded_by_the_maximum_tilt():
    """No velocity loop: full forward tilt (0.21 rad, 12 deg) settles where the drag balances it, about 5 m/s
    as a real AR.Drone 2.0."""
    sim = make_sim(noise={"enabled": False}, ardrone2=DRIVER_DEFAULTS)
    airborne(sim)
    run(sim, 9.0, command=(1.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    speed = heading_velocity(sim)[0]
    run(sim, 1.0, command=(1.0, 0.0, 0.0, 0.0, 0.0, 0.0))
    assert heading_velocity(sim)[0] == pytest.approx(5.0, abs=0.3)
    assert heading_velocity(sim)[0] - speed < 0.1  # settled


def test_auto_hover_holds_against_the_wind_unless_angular_x_or_y_disables_it():
    drift = {}
    for command in (HOVER, (0.0, 0.0, 0.0, 1.0, 0.0, 0.0)):
        sim = make_sim(noise={"enabled": False})
        sim.set_conditions(wind_speed=4.0, wind_direction_deg=90.0)
        airborne(sim)
        run(sim, 0.5, command=command)
        start = sim.drone_pose()[0].copy()
        run(sim, 2.0, command=command)
        drift[command] = sim.drone_pose()[0][1] - start[1]
        assert sim.autopilot.navdata_state == (STATE_HOVERING if command == HOVER else STATE_FLYING)
    assert drift[(0.0, 0.0, 0.0, 1.0, 0.0, 0.0)] > 1.0  # level, blown downwind
    assert abs(drift[HOVER]) < 0.25 * drift[(0.0, 0.0, 0.0, 1.0, 0.0, 0.0)]


def test_the_firmware_does_not_climb_above_altitude_max():
    sim = make_sim(ardrone2={"altitude_max": 1500})
    airborne(sim)
    run(sim, 3.5, command=(0.0, 0.0, 1.0, 0.0, 0.0, 0.0))
    assert sim.ardrone_altitude() == pytest.approx(1.5, abs=0.05)
    assert abs(sim.drone_velocity()[0][2]) < 0.05


# ----- the link ---------------------------------------------------------------------------------------------
def test_the_driver_repeats_the_last_command_so_a_silent_controller_leaves_the_drone_flying_it():
    sim = make_sim(ardrone2={"watchdog_hover_s": 0.5, "watchdog_land_s": 1.0})
    airborne(sim)
    sim.set_ardrone_command(0.3, 0.0, 0.0, 0.0, 0.0, 0.0)
    run(sim, 2.0, command=None)  # nothing more from the controller
    assert sim.autopilot.navdata_state == STATE_FLYING and heading_velocity(sim)[0] > 0.6


def test_without_commands_the_watchdog_hovers_then_lands():
    sim = make_sim(ardrone2={"watchdog_hover_s": 0.5, "watchdog_land_s": 1.0})
    airborne(sim)
    run(sim, 0.5, command=(0.5, 0.0, 0.0, 0.0, 0.0, 0.0))
    assert sim.inject_fault("link_loss", 10.0)
    run(sim, 0.4, command=(0.5, 0.0, 0.0, 0.0, 0.0, 0.0))
    assert sim.autopilot.navdata_state == STATE_FLYING  # not yet
    run(sim, 0.3, command=(0.5, 0.0, 0.0, 0.0, 0.0, 0.0))
    assert sim.autopilot.navdata_state == STATE_HOVERING and sim.autopilot.link_lost
    run(sim, 0.9, command=(0.5, 0.0, 0.0, 0.0, 0.0, 0.0))
    assert sim.autopilot.navdata_state == STATE_LANDING
    assert run(sim, 4.0, until=lambda s: s.autopilot.navdata_state == STATE_LANDED)
    # Without the driver's repetition a controller that falls silent trips it as well.
    sim = make_sim(ardrone2={"watchdog_hover_s": 0.5, "watchdog_land_s": 1.0, "driver_resend_hz": 0.0})
    airborne(sim)
    run(sim, 0.3, command=(0.5, 0.0, 0.0, 0.0, 0.0, 0.0))
    run(sim, 0.6, command=None)
    assert sim.autopilot.navdata_state == STATE_HOVERING


# ----- navdata ------------------------------------------------------------------------------------------------
def test_navdata_fields_come_in_the_drivers_units():
    sim = make_sim(noise={"enabled": False})
    run(sim, 0.2)
    resting = sim.ardrone_navdata()
    assert resting["state"] == STATE_LANDED and resting["az"] == pytest.approx(1.0, abs=0.01)
    assert resting["motor1"] == 0 and resting["altd"] == pytest.approx(0, abs=5)
    assert resting["pressure"] == pytest.approx(101325 - 12 * 0.56, abs=30)  # [Pa] at 0.56 m
    assert resting["temp"] == 150 and resting["tm"] == pytest.approx(sim.time * 1e6)
    assert resting["tags_count"] == 0 and resting["tags_xc"] == []
    airborne(sim)
    run(sim, 1.0, command=(0.0, 0.0, 0.0, 0.0, 0.0, 0.8))  # turn left
    run(sim, 1.0, command=(0.5, 0.0, 0.0, 0.0, 0.0, 0.0))
    navdata = sim.ardrone_navdata()
    assert navdata["rotZ"] == pytest.approx(math.degrees(yaw_of(sim)), abs=0.01) and navdata["rotZ"] > 50.0
    assert navdata["vx"] == pytest.approx(1000.0 * heading_velocity(sim)[0], abs=60)  # mm/s, flow noise aside
    assert navdata["altd"] == pytest.approx(1000.0 * sim.ardrone_altitude(), abs=1)
    assert 140 < navdata["motor1"] < 200
    assert isinstance(navdata["state"], int) and isinstance(navdata["altd"], int)
    in_cm = make_sim(noise={"enabled": False}, ardrone2={"altd_unit": "cm"})
    airborne(in_cm)
    assert in_cm.ardrone_navdata()["altd"] == pytest.approx(90, abs=4)


def test_navdata_on_the_firmware_estimate_is_what_the_estimator_holds():
    sim = make_sim(realism="realistic")
    airborne(sim)
    run(sim, 0.5, command=(0.5, 0.0, 0.0, 0.0, 0.0, 0.0))
    navdata = sim.ardrone_navdata()
    vx, vy, vz = sim.flow_velocity()
    assert navdata["vx"] == pytest.approx(1000.0 * vx) and navdata["vy"] == pytest.approx(1000.0 * vy)
    assert navdata["altd"] == pytest.approx(1000.0 * (sim.firmware.height - 0.065), abs=1)


def step_schedule(schedule, seconds, dt=0.004):
    """Sample, deliver at once and publish as a node stepping at ``dt`` would; returns (sent, published ids)."""
    sent, published = 0, []
    for k in range(1, int(round(seconds / dt)) + 1):
        now = k * dt
        for _ in range(schedule.samples_due(now)):
            sent += 1
            packet = schedule.received(sent)
            if packet is not None:
                published.append(packet)
        packet = schedule.publish_due(now)
        if packet is not None:
            published.append(packet)
    return sent, published


def test_navdata_rates_demo_full_looprate_and_realtime():
    sent, published = step_schedule(NavdataSchedule(navdata_demo=1, looprate_hz=50, realtime_navdata=False), 2.0)
    assert sent == 31  # 15 Hz from t=0
    assert published == list(range(1, 32))  # each once, at the next loop tick: no repetition
    sent, published = step_schedule(NavdataSchedule(navdata_demo=0, looprate_hz=50, realtime_navdata=False), 2.0)
    assert sent == 401 and len(published) == 101  # the newest at each 50 Hz tick
    assert published == sorted(set(published)) and published[-1] == 401
    sent, published = step_schedule(NavdataSchedule(navdata_demo=0, looprate_hz=50, realtime_navdata=True), 2.0)
    assert published == list(range(1, sent + 1))
    assert NavdataSchedule(1, 50, False).publish_due(0.0) is None  # nothing received yet


def test_the_simulator_schedule_follows_the_config():
    sim = make_sim(ardrone2={"navdata_demo": 0, "looprate": 100, "realtime_navdata": True})
    schedule = sim.navdata_schedule
    assert schedule.drone_rate_hz == 200.0 and schedule.looprate_hz == 100.0 and schedule.realtime


# ----- camera channel -------------------------------------------------------------------------------------------
def test_one_camera_streams_at_a_time_and_a_switch_takes_its_delay():
    clock = [0.0]
    channel = CameraChannel(0.3, lambda: clock[0])
    assert channel.channel == CameraChannel.FRONT and not channel.bottom_streaming
    channel.select(1)
    clock[0] = 0.29
    assert not channel.bottom_streaming
    clock[0] = 0.31
    assert channel.bottom_streaming
    channel.select(1)  # the same channel: no new delay
    assert channel.bottom_streaming and channel.switches == 1
    assert channel.toggle() == 0 and not channel.bottom_streaming
    clock[0] = 1.0
    channel.toggle()
    assert not channel.bottom_streaming
    clock[0] = 1.3
    assert channel.bottom_streaming
    for bad in (2, -1, "1", True, 0.5):
        with pytest.raises(ValueError, match=r"expected 0 \(front\) or 1 \(bottom\)"):
            channel.select(bad)
    sim = make_sim(ardrone2={"video_channel": 1})
    assert sim.camera_channel.channel == 1 and sim.camera_channel.bottom_streaming
    sim.camera_channel.toggle()
    run(sim, 0.4)
    sim.camera_channel.toggle()
    assert not sim.camera_channel.bottom_streaming
    run(sim, 0.32)
    assert sim.camera_channel.bottom_streaming


def test_a_crash_reports_state_zero():
    sim = make_sim()
    airborne(sim)
    sim.set_conditions(battery=0.0)
    assert run(sim, 3.0, until=lambda s: s.touchdown is not None)
    assert sim.autopilot.mode == FlightMode.CRASHED and sim.ardrone_navdata()["state"] == 0
