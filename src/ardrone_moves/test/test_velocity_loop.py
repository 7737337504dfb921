"""TiltVelocityLoop and CommandRate (ROS-free), flown on a model of the AR.Drone firmware.

The model: the cmd_vel tilt fraction times euler_angle_max is the attitude reference (all-zero = the
firmware's own hover, a P loop on its velocity estimate); the attitude follows with a first-order
lag of 0.15 s; acceleration = g*tan(tilt) - drag*v + wind, with the drag chosen so 0.21 rad of tilt
holds 5 m/s. Navdata is sampled at 50 Hz and arrives 50 ms late; the node updates the loop on each
navdata, publishes the latest command at the configured fixed rate (30 Hz) and each command reaches
the drone 30 ms later. Integrated with 1 ms Euler steps: deterministic and fast.
"""
import collections
import math
import os

import pytest
import yaml

from ardrone_moves.velocity_loop import (AUTO_HOVER, FLYING, GRAVITY, GROUNDED, HOVER, HOVER_BLOCKER, REJECTED,
                                         CommandRate, TiltCommand, TiltVelocityLoop, validated_parameters)

CONFIG = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config", "ardrone_adapter.yaml")
DRAG = GRAVITY * math.tan(0.21) / 5.0  # 0.21 rad of tilt holds 5 m/s, as on the real drone
SIM_STEP = 0.001
NAVDATA_PERIOD_MS, NAVDATA_DELAY, COMMAND_DELAY = 20, 0.05, 0.03


def shipped_params(**overrides):
    with open(CONFIG) as stream:
        params = yaml.safe_load(stream)
    params.update(overrides)
    return params


# The arithmetic tests below fix their own numbers, so that tuning the shipped gains does not move them.
UNIT_PARAMS = dict(euler_angle_max=0.21, control_vz_max=700.0, velocity_p_gain=3.0, velocity_i_gain=1.5,
                   integral_limit=2.0, integral_error_limit=10.0, velocity_feedforward_gain=0.5,
                   prediction_horizon=0.1, command_rate=30.0)


def unit_params(**overrides):
    return shipped_params(**dict(UNIT_PARAMS, **overrides))


class FirmwareModel:
    """Horizontal dynamics of the AR.Drone under its attitude controller, heading frame (x fwd, y left)."""

    def __init__(self, euler_angle_max, wind=(0.0, 0.0), attitude_lag=0.15, drag=DRAG, hover_gain=0.15):
        self.euler_angle_max = euler_angle_max  # the driver's setting: what a tilt fraction of 1 means [rad]
        self.velocity = [0.0, 0.0]
        self.tilt = [0.0, 0.0]  # pitch nose-down (accelerates +x), tilt to the left (accelerates +y)
        self.wind, self.attitude_lag, self.drag, self.hover_gain = wind, attitude_lag, drag, hover_gain

    def step(self, command, dt):
        if command.is_hover():  # the firmware's own hover: brake on its velocity estimate
            limit = self.euler_angle_max
            reference = [max(-limit, min(limit, -self.hover_gain * v)) for v in self.velocity]
        else:
            reference = [max(-1.0, min(1.0, command.linear_x)) * self.euler_angle_max,
                         max(-1.0, min(1.0, command.linear_y)) * self.euler_angle_max]
        for axis in (0, 1):
            self.tilt[axis] += (reference[axis] - self.tilt[axis]) * dt / self.attitude_lag
            self.velocity[axis] += (GRAVITY * math.tan(self.tilt[axis]) - self.drag * self.velocity[axis]
                                    + self.wind[axis]) * dt

    def navdata(self):
        """What navdata reports, already in SI (navdata_units' job): roll > 0 = right side down."""
        return self.velocity[0], self.velocity[1], -self.tilt[1], self.tilt[0]


def fly(params, desired, duration, wind=(0.0, 0.0), **model):
    """Closed loop; desired(t) -> (forward, left). Returns rows (t, v_forward, v_left, cmd_x, cmd_y)."""
    loop, drone = TiltVelocityLoop(params), FirmwareModel(params["euler_angle_max"], wind, **model)
    rate = CommandRate(params["command_rate"])
    in_flight_navdata, in_flight_commands = collections.deque(), collections.deque()
    applied = latest = HOVER
    last_stamp, rows = None, []
    for tick in range(int(round(duration / SIM_STEP)) + 1):
        now = tick * SIM_STEP
        if tick % NAVDATA_PERIOD_MS == 0:
            in_flight_navdata.append((now + NAVDATA_DELAY, now, drone.navdata()))
        while in_flight_navdata and in_flight_navdata[0][0] <= now + 1e-9:
            _, stamp, (v_forward, v_left, roll, pitch) = in_flight_navdata.popleft()
            dt = 0.02 if last_stamp is None else stamp - last_stamp
            last_stamp = stamp
            forward, left = desired(now)
            result = loop.update(forward, left, 0.0, 0.0, v_forward, v_left, roll, pitch, dt)
            latest = result.command if result.command is not None else HOVER
        if rate.due(now):
            in_flight_commands.append((now + COMMAND_DELAY, latest))
        while in_flight_commands and in_flight_commands[0][0] <= now + 1e-9:
            applied = in_flight_commands.popleft()[1]
        drone.step(applied, SIM_STEP)
        rows.append((now, drone.velocity[0], drone.velocity[1], applied.linear_x, applied.linear_y))
    return rows


def step_figures(rows, start, target, column):
    """(time to 90 % after start, overshoot as a fraction, steady error over the last second as a fraction)."""
    rise = next((t - start for t, *values in rows if t >= start and values[column - 1] / target >= 0.9), math.inf)
    peak = max(row[column] / target for row in rows if row[0] >= start)
    tail = [row[column] for row in rows if row[0] >= rows[-1][0] - 1.0]
    return rise, peak - 1.0, abs(sum(tail) / len(tail) - target) / abs(target)


def step_command(forward=0.0, left=0.0, start=1.0):
    return lambda t: (forward, left) if t >= start else (0.0, 0.0)


@pytest.mark.parametrize("axis", ["forward", "left"])
def test_one_metre_per_second_step_is_fast_damped_and_exact(axis):
    rows = fly(shipped_params(), step_command(**{axis: 1.0}), 8.0)
    rise, overshoot, steady_error = step_figures(rows, 1.0, 1.0, column=1 if axis == "forward" else 2)
    print("1 m/s %s step: 90%% after %.2f s, overshoot %.1f %%, steady error %.2f %%"
          % (axis, rise, 100 * overshoot, 100 * steady_error))
    assert rise < 1.5 and overshoot < 0.20 and steady_error < 0.05
    other = 2 if axis == "forward" else 1
    assert max(abs(row[other]) for row in rows) < 0.01  # no cross-coupling between the axes


def test_backward_step_mirrors_the_forward_step():
    rise, overshoot, steady_error = step_figures(fly(shipped_params(), step_command(forward=-1.0), 8.0),
                                                 1.0, -1.0, column=1)
    assert rise < 1.5 and overshoot < 0.20 and steady_error < 0.05


def test_integral_removes_the_steady_error_of_a_constant_wind():
    params = shipped_params(auto_hover=False)  # our loop holds zero against the wind for 4 s, then steps
    for wind in ((1.0, 0.0), (-1.0, 0.0)):
        rows = fly(params, step_command(forward=1.0, start=4.0), 12.0, wind=wind)
        rise, overshoot, steady_error = step_figures(rows, 4.0, 1.0, column=1)
        print("1 m/s step, wind %+.0f m/s^2: 90%% after %.2f s, overshoot %.1f %%, steady error %.2f %%"
              % (wind[0], rise, 100 * overshoot, 100 * steady_error))
        assert steady_error < 0.05
    rows = fly(dict(params, velocity_i_gain=0.0), step_command(forward=1.0, start=4.0), 12.0, wind=(-1.0, 0.0))
    _, _, without_integral = step_figures(rows, 4.0, 1.0, column=1)
    assert without_integral > 0.2  # the wind is really there; the integral is what removes it


def test_step_survives_a_wrong_drag_model():
    for plant_drag in (0.6 * DRAG, 1.6 * DRAG):
        rise, overshoot, steady_error = step_figures(
            fly(shipped_params(), step_command(forward=1.0), 10.0, drag=plant_drag), 1.0, 1.0, column=1)
        assert rise < 1.5 and overshoot < 0.25 and steady_error < 0.05


@pytest.mark.parametrize("auto_hover", [False, True])
def test_saturated_request_does_not_wind_up(auto_hover):
    params = shipped_params(auto_hover=auto_hover)
    rows = fly(params, lambda t: (10.0, 0.0) if 1.0 <= t < 9.0 else (0.0, 0.0), 16.0)
    saturated = [row[3] for row in rows if 2.0 <= row[0] < 9.0]
    assert min(saturated) == pytest.approx(1.0) and max(saturated) == pytest.approx(1.0)
    top_speed = max(row[1] for row in rows)
    undershoot = min(row[1] for row in rows if row[0] >= 9.0)
    print("10 m/s request (auto_hover %s): top speed %.2f m/s, after return to 0: min %.3f m/s"
          % (auto_hover, top_speed, undershoot))
    model_top_speed = GRAVITY * math.tan(params["euler_angle_max"]) / DRAG
    assert 0.9 * model_top_speed < top_speed < model_top_speed and undershoot > -0.5
    assert abs(rows[-1][1]) < 0.05


def test_feedforward_cuts_the_lag_on_a_ramp():
    def ramp(t):
        return min(max(t - 1.0, 0.0), 2.0), 0.0  # 1 m/s^2 to 2 m/s: a platform speeding up

    def mean_lag(params):
        errors = [ramp(row[0])[0] - row[1] for row in fly(params, ramp, 3.5) if 2.0 <= row[0] <= 3.0]
        return sum(errors) / len(errors)
    with_feedforward, without = mean_lag(unit_params()), mean_lag(unit_params(velocity_feedforward_gain=0.0))
    assert 0.0 < with_feedforward < 0.6 * without


def loop(**overrides):
    return TiltVelocityLoop(unit_params(**overrides))


def flying_step(controller, forward=0.0, left=0.0, climb=0.0, yaw_rate=0.0, measured=(0.0, 0.0), roll=0.0,
                pitch=0.0, dt=0.02, **kwargs):
    return controller.update(forward, left, climb, yaw_rate, measured[0], measured[1], roll, pitch, dt, **kwargs)


def test_climb_and_yaw_are_scaled_by_the_drivers_limits():
    command = flying_step(loop(), climb=0.35, yaw_rate=0.875).command
    assert command.linear_z == pytest.approx(0.5)  # 0.35 m/s of control_vz_max 700 mm/s
    assert command.angular_z == pytest.approx(0.5)  # 0.875 rad/s of control_yaw 1.75 rad/s
    command = flying_step(loop(control_vz_max=1000.0, control_yaw=3.5), climb=-5.0, yaw_rate=-1.75).command
    assert command.linear_z == -1.0 and command.angular_z == pytest.approx(-0.5)
    assert flying_step(loop(), climb=2.0, yaw_rate=9.0).command.angular_z == 1.0


def test_tilt_is_atan_of_the_desired_acceleration_over_g():
    controller = loop(velocity_i_gain=0.0, velocity_feedforward_gain=0.0, linear_drag=0.0, prediction_horizon=0.0)
    result = flying_step(controller, forward=0.3, left=-0.2)  # P 3/s: 0.9 and -0.6 m/s^2
    assert result.acceleration == pytest.approx((0.9, -0.6))
    assert result.command.linear_x == pytest.approx(math.atan(0.9 / GRAVITY) / 0.21)
    assert result.command.linear_y == pytest.approx(math.atan(-0.6 / GRAVITY) / 0.21)


def test_clipping_keeps_the_direction_of_the_horizontal_tilt():
    result = flying_step(loop(), forward=8.0, left=-4.0)
    wanted = [math.atan(a / GRAVITY) for a in result.acceleration]
    assert result.saturated and result.command.linear_x == pytest.approx(1.0)
    assert result.command.linear_y / result.command.linear_x == pytest.approx(wanted[1] / wanted[0])
    assert -1.0 < result.command.linear_y < -0.3


def test_integral_is_clamped_and_frozen_while_saturated():
    controller = loop(integral_limit=0.5, velocity_feedforward_gain=0.0)
    for _ in range(500):
        flying_step(controller, forward=0.4, measured=(0.0, 0.0))  # unsaturated: grows to the clamp
    assert controller.integral[0] == pytest.approx(0.5)
    controller.reset()
    for _ in range(500):
        assert flying_step(controller, forward=10.0).saturated  # pushes into the limit: frozen
    assert controller.integral == (0.0, 0.0)


def test_zero_command_and_slow_drone_hands_over_to_the_firmware_hover():
    controller = loop()
    for _ in range(100):
        flying_step(controller, forward=0.5, measured=(0.0, 0.0))
    assert controller.integral[0] > 0.0
    result = flying_step(controller, forward=0.01, measured=(0.2, 0.1))
    assert result.mode == AUTO_HOVER and result.command == HOVER and result.command.as_tuple() == (0.0,) * 6
    assert controller.integral == (0.0, 0.0)  # reset on hover
    # hysteresis: stays in hover up to hover_exit_speed, then brakes with its own loop
    assert flying_step(controller, measured=(0.5, 0.0)).mode == AUTO_HOVER
    braking = flying_step(controller, measured=(0.7, 0.0))
    assert braking.mode == FLYING and braking.command.linear_x < 0.0
    assert flying_step(controller, measured=(0.4, 0.0)).mode == FLYING  # re-enters only below hover_enter_speed


@pytest.mark.parametrize("nonzero", [dict(climb=0.1), dict(yaw_rate=0.1), dict(left=0.1)])
def test_any_nonzero_command_component_keeps_our_loop_flying(nonzero):
    assert flying_step(loop(), **nonzero).mode == FLYING


def test_flying_command_is_never_the_all_zero_hover():
    result = flying_step(loop(auto_hover=False))  # zero command, zero speed, but hover handed off: no
    assert result.mode == FLYING and not result.command.is_hover()
    assert result.command == TiltCommand(angular_x=HOVER_BLOCKER)
    assert HOVER_BLOCKER >= 1e-6  # the driver's hover test is |component| < 1e-6


@pytest.mark.parametrize("name", ["forward", "left", "climb", "yaw_rate", "measured_forward", "measured_left",
                                  "roll", "pitch", "dt"])
@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf"), None])
def test_non_finite_input_gives_no_command_and_names_it(name, bad):
    controller = loop()
    flying_step(controller, forward=0.5)
    before = controller.integral
    values = dict(forward=0.5, left=0.0, climb=0.0, yaw_rate=0.0, measured_forward=0.0, measured_left=0.0,
                  roll=0.0, pitch=0.0, dt=0.02)
    values[name] = bad
    result = controller.update(**values)
    assert result.command is None and result.mode == REJECTED and "'%s'" % name in result.reason
    assert controller.integral == before


def test_non_positive_dt_is_rejected_and_a_long_gap_resets_the_loop():
    controller = loop()
    assert flying_step(controller, dt=0.0).command is None
    for _ in range(50):
        flying_step(controller, forward=0.5)
    assert controller.integral[0] > 0.0
    result = flying_step(controller, forward=0.5, dt=5.0)
    assert result.mode == FLYING  # restarted from zero, then one max_dt (0.2 s) step of 0.5 m/s error:
    assert controller.integral[0] == pytest.approx(1.5 * 0.5 * 0.2)


def test_grounded_drone_resets_and_gets_hover():
    controller = loop()
    for _ in range(50):
        flying_step(controller, forward=0.5)
    result = flying_step(controller, forward=0.5, airborne=False)
    assert result.mode == GROUNDED and result.command == HOVER and controller.integral == (0.0, 0.0)


def test_measured_attitude_predicts_the_velocity_over_the_horizon():
    controller = loop(velocity_i_gain=0.0, velocity_feedforward_gain=0.0, linear_drag=0.0, prediction_horizon=0.05)
    nose_down = flying_step(controller, forward=1.0, pitch=0.1).acceleration[0]
    right_down = flying_step(controller, left=1.0, roll=0.1).acceleration[1]
    level = flying_step(controller, forward=1.0).acceleration[0]
    predicted_gain = 3.0 * GRAVITY * math.tan(0.1) * 0.05  # P gain times the predicted velocity change
    assert level - nose_down == pytest.approx(predicted_gain)  # nose down: already faster than measured
    assert right_down - level == pytest.approx(predicted_gain)  # right side down: drifting right, push left more


def test_parameters_are_validated_by_name():
    for key in ("euler_angle_max", "velocity_p_gain", "auto_hover", "hover_exit_speed"):
        params = shipped_params()
        del params[key]
        with pytest.raises(ValueError, match="'%s'" % key):
            TiltVelocityLoop(params)
    for key, value in (("euler_angle_max", 0.6), ("control_vz_max", 70.0), ("control_yaw", 0.0),
                       ("velocity_p_gain", -1.0), ("prediction_horizon", float("nan")), ("integral_limit", "big"),
                       ("velocity_i_gain", True), ("auto_hover", "yes"), ("hover_exit_speed", 0.1)):
        with pytest.raises(ValueError, match="'%s'" % key):
            TiltVelocityLoop(shipped_params(**{key: value}))


def test_shipped_config_is_complete_and_every_key_commented():
    validated_parameters(shipped_params())
    with open(CONFIG) as stream:
        lines = stream.read().splitlines()
    for number, line in enumerate(lines):
        if line.strip() and not line.lstrip().startswith("#"):
            # The key's comment: on its line, carried on by the indented comment lines below it.
            comment = [line.split("#", 1)[1]] if "#" in line else []
            for more in lines[number + 1:]:
                if not (more.startswith(" ") and more.lstrip().startswith("#")):
                    break
                comment.append(more)
            assert comment and "[" in comment[-1], "key without comment or unit: " + line


def test_command_rate_is_fixed_skips_missed_slots_and_survives_a_clock_reset():
    rate = CommandRate(30.0)
    sent = [tick / 1000.0 for tick in range(2000) if rate.due(tick / 1000.0)]
    assert len(sent) == 60 and max(b - a for a, b in zip(sent, sent[1:])) < 0.035
    assert rate.due(5.0) and not rate.due(5.01) and rate.due(5.034)  # after a stall: one send, then on schedule
    assert rate.due(1.0)  # the clock went back (simulation reset): restart at once
    with pytest.raises(ValueError, match="command_rate"):
        CommandRate(0.0)
