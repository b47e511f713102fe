"""attitude_controller_node's runtime without ROS: the loop, its inputs, its grid, its health, its pointing."""

from __future__ import annotations

import math

import pytest

from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw, true_roll_pitch, true_yaw
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.orbit.two_body import circular_mean_motion_rad_s
from pmv_ros.runtime.common.assembly import CONTROLLER_PARAMS
from pmv_ros.runtime.common.records import HealthAt, Level
from pmv_ros.runtime.control import ControllerRuntime, LoopSettings, TruthPublication
from pmv_ros.runtime.control.controller import MAX_STEPS_PER_CALL

SENSOR_FRAME = "pmv_sensor"


def values(**changes) -> dict:
    """The node's defaults, with ``changes`` (``control__bandwidth_hz`` for ``control.bandwidth_hz``)."""
    result = {spec.name: spec.default for spec in CONTROLLER_PARAMS}
    result.update({name.replace("__", "."): value for name, value in changes.items()})
    return result


def close_on_biased_sensor(runtime: ControllerRuntime, bias_rad: tuple, until_s: float, period_s: float = 0.1):
    """Fly the loop with a sensor that reads the true roll and pitch plus ``bias_rad``; returns the last state."""
    t = runtime.time_s
    state = None
    while t < until_s:
        roll, pitch = true_roll_pitch(runtime.q)
        runtime.add_measurement(SENSOR_FRAME, t, roll + bias_rad[0], pitch + bias_rad[1], t)
        t += period_s
        for item in runtime.step_to(t).published:
            if isinstance(item, TruthPublication):
                state = item
    return state


def test_the_loop_settles_to_minus_the_sensor_s_error_and_holds_yaw_on_the_truth():
    # physics.md §2.1 in its simplest form: a constant sensor error e → true attitude −e. Yaw starts 30′ off
    # and is closed on the true yaw. 30 settling times: the transient is gone to e^-30.
    runtime = ControllerRuntime(values(body__initial_attitude_arcmin=[0.0, 0.0, 30.0]), start_s=0.0)
    bias = (10.0 * ARCMIN_RAD, -5.0 * ARCMIN_RAD)
    state = close_on_biased_sensor(runtime, bias, 30 * runtime.settings.settling_time_s)
    roll, pitch = true_roll_pitch(state.q_xyzw)
    # The gravity gradient stiffens pitch and roll by 3n²ΔJ and 4n²ΔJ against K_p = J ω_n²: a steady part of
    # (3 n² ΔJ / J ω_n²) ≈ 3e-4 of the error is not followed (≈ 0.003′ of 10′): 0.01′ allowed.
    assert roll / ARCMIN_RAD == pytest.approx(-10.0, abs=0.01)
    assert pitch / ARCMIN_RAD == pytest.approx(5.0, abs=0.01)
    assert true_yaw(state.q_xyzw) / ARCMIN_RAD == pytest.approx(0.0, abs=0.01)
    assert max(abs(r) for r in state.rate_rad_s) < 1e-7


def test_yaw_free_is_not_controlled():
    # No yaw torque: a body started 30′ off in yaw, at rest in the orbital frame, keeps its yaw but for what the
    # roll–yaw coupling at the orbital rate and gravity gradient move (≈ n² t² scale: well under 30′ in 600 s).
    runtime = ControllerRuntime(values(body__initial_attitude_arcmin=[0.0, 0.0, 30.0], control__yaw="free"),
                                start_s=0.0)
    state = close_on_biased_sensor(runtime, (0.0, 0.0), 600.0)
    assert true_yaw(state.q_xyzw) / ARCMIN_RAD == pytest.approx(30.0, abs=3.0)
    closed = ControllerRuntime(values(body__initial_attitude_arcmin=[0.0, 0.0, 30.0]), start_s=0.0)
    assert abs(true_yaw(close_on_biased_sensor(closed, (0.0, 0.0), 600.0).q_xyzw)) / ARCMIN_RAD < 0.1


def test_a_constant_disturbance_torque_gives_the_steady_offset_of_a_pd_loop():
    # J θ̈ + K_d θ̇ + (K_p + 3n²(J_x − J_z)) θ = τ: θ = τ / (K_p + 3n²(J_x − J_z)) in pitch (gravity gradient adds its
    # stiffness). At 0.005 Hz and τ = 1e-4 N·m: ≈ 0.39′ — a low bandwidth lets a disturbance through.
    torque = 1e-4
    runtime = ControllerRuntime(values(control__bandwidth_hz=0.005,
                                       disturbance__constant_torque_nm=[0.0, torque, 0.0]), start_s=0.0)
    state = close_on_biased_sensor(runtime, (0.0, 0.0), 20 * runtime.settings.settling_time_s)
    n = circular_mean_motion_rad_s(500e3)
    jx, jy, jz = runtime.body.inertia_kg_m2
    expected = torque / (runtime.settings.gains.proportional[1] + 3 * n * n * (jx - jz))
    assert true_roll_pitch(state.q_xyzw)[1] == pytest.approx(expected, rel=2e-3)


def test_measurements_are_checked_and_a_lost_axis_is_held():
    runtime = ControllerRuntime(values(), start_s=0.0)
    runtime.add_measurement("base_link", 1.0, 0.0, 0.0, 1.0)
    runtime.add_measurement(SENSOR_FRAME, None, 0.0, 0.0, 1.0)
    runtime.add_measurement(SENSOR_FRAME, 1.0, math.inf, 0.0, 1.0)
    runtime.add_measurement(SENSOR_FRAME, 1.0, math.radians(31.0), 0.0, 1.0)  # beyond input.max_abs_angle_deg
    runtime.add_measurement(SENSOR_FRAME, 5.0, 0.0, 0.0, 1.0)  # later than the clock + future_tolerance_s
    runtime.add_measurement(SENSOR_FRAME, 1.0, 1e-3, -2e-3, 1.0)
    runtime.add_measurement(SENSOR_FRAME, 1.0, 1e-3, -2e-3, 1.0)  # duplicate
    runtime.add_measurement(SENSOR_FRAME, 0.9, 1e-3, -2e-3, 1.0)  # backwards
    runtime.add_measurement(SENSOR_FRAME, 1.1, math.nan, 4e-3, 1.1)  # roll's pair lost: roll held, pitch taken
    counters = runtime.counters
    assert counters["measurements"] == 2
    for reason in ("wrong_frame", "zero_stamp", "non_finite", "implausible_angle", "future_stamp", "duplicate",
                   "backwards"):
        assert counters[f"rejected_measurement_{reason}"] == 1, reason
    health = runtime.health(1.1)
    assert health.values["measurement_roll_held"] == 1 and health.values["measurement_pitch_held"] == 0
    assert health.level is Level.WARN and "rejected pmv/attitude" in health.message
    # The law acts on the held roll and the new pitch (a step's torque: −K_p e on a body at rest).
    q0 = runtime.q
    runtime.step_to(0.1)
    assert runtime.q != q0


def test_the_plant_moves_on_its_grid_and_a_leap_restarts_it():
    runtime = ControllerRuntime(values(), start_s=10.0)
    out = runtime.step_to(10.35)
    stamps = [item.t_s for item in out.truth]
    assert stamps == pytest.approx([10.1, 10.2, 10.3, 10.4])
    assert runtime.step_to(10.4 + 1e-10).truth == []  # within a nanosecond: there already
    assert [item.t_s for item in runtime.step_to(10.5).truth] == pytest.approx([10.5])
    leap = 10.5 + (MAX_STEPS_PER_CALL + 5) * 0.1
    out = runtime.step_to(leap)
    assert out.truth == [] and runtime.time_s == leap and runtime.counters["clock_jumps"] == 1
    assert any("restarts" in line.text for line in out.log)


def test_the_timer_steps_to_the_clock_and_a_confirmed_jump_back_restarts_the_grid():
    runtime = ControllerRuntime(values(), start_s=100.0)
    assert [s.t_s for s in runtime.tick(100.25).truth] == pytest.approx([100.1, 100.2])
    assert runtime.tick(50.0).truth == []  # suspected: not acted on
    assert runtime.tick(50.05).truth == []  # confirmed back: the grid restarts at 50.05
    assert runtime.counters["clock_jumps"] == 1
    assert [s.t_s for s in runtime.tick(50.3).truth] == pytest.approx([50.15, 50.25])


def test_a_step_deferred_to_the_next_measurement_is_taken_with_it():
    runtime = ControllerRuntime(values(), start_s=0.0)
    runtime.step_at_next_measurement(0.2)
    assert runtime.deferred_s == 0.2 and runtime.time_s == 0.0
    out = runtime.add_measurement(SENSOR_FRAME, 0.05, 1e-3, 0.0, 0.05)
    assert [s.t_s for s in out.truth] == pytest.approx([0.1, 0.2]) and runtime.deferred_s is None
    runtime.step_at_next_measurement(0.3)
    assert runtime.add_measurement("wrong", 0.1, 0.0, 0.0, 0.1) is None  # refused: the step still waits
    assert [s.t_s for s in runtime.step_to(0.3).truth] == pytest.approx([0.3]) and runtime.deferred_s is None


def test_health_says_when_the_measurements_stop_and_reports_the_pointing():
    runtime = ControllerRuntime(values(control__measurement_timeout_s=0.5), start_s=0.0)
    reports = [item for item in runtime.step_to(1.0).published if isinstance(item, HealthAt)]
    assert reports[0].health.level is Level.OK  # at 0.1 s: within the timeout of the start
    health = runtime.health(1.0)
    assert health.level is Level.WARN and "no pmv/attitude roll or pitch" in health.message
    runtime.add_measurement(SENSOR_FRAME, 1.0, 0.0, 0.0, 1.0)
    health = runtime.health(1.1)
    assert health.level is Level.OK and health.values["measurements"] == 1
    assert set(health.values) >= {"pointing_roll_arcmin", "pointing_pitch_arcmin", "steps", "bandwidth_hz"}
    # /diagnostics once a diagnostics_period_s of plant time (1 s): at 0.1, 1.1, 2.1 over 21 steps.
    reports = [item for item in runtime.step_to(3.0).published if isinstance(item, HealthAt)]
    assert [r.stamp_s for r in reports] == pytest.approx([1.1, 2.1])


def test_the_pointing_leaves_out_the_settling_time():
    runtime = ControllerRuntime(values(body__initial_attitude_arcmin=[20.0, 0.0, 0.0]), start_s=0.0)
    settle = runtime.settings.settling_time_s
    steps = round(2 * settle / 0.1)
    close_on_biased_sensor(runtime, (0.0, 0.0), 2 * settle)
    roll, _ = runtime.pointing.channels()
    assert runtime.pointing.skipped == pytest.approx(settle / 0.1, abs=1)
    assert roll.count == pytest.approx(steps - settle / 0.1, abs=2)
    # The 20′ start is gone to ≈ 2 % after the settling time: every counted roll is small.
    assert roll.max_abs_rad / ARCMIN_RAD < 0.05 * 20.0


def test_a_host_that_keeps_its_own_pointing_flies_the_same_plant():
    # The campaign's flight takes the pointing at its sample times (keep_pointing False): the controller then
    # keeps no statistics of its own, and its plant, truth and reported pointing are the same as the node's.
    kept = ControllerRuntime(values(body__initial_attitude_arcmin=[20.0, -10.0, 5.0]), start_s=0.0)
    bare = ControllerRuntime(values(body__initial_attitude_arcmin=[20.0, -10.0, 5.0]), start_s=0.0,
                             keep_pointing=False)
    assert bare.pointing is None
    assert close_on_biased_sensor(bare, (1e-3, -2e-3), 30.0) == close_on_biased_sensor(kept, (1e-3, -2e-3), 30.0)
    assert kept.pointing.roll.count + kept.pointing.skipped == 300
    roll, pitch = true_roll_pitch(bare.q)
    for runtime in (kept, bare):
        health = runtime.health(30.0).values
        assert health["pointing_roll_arcmin"] == roll / ARCMIN_RAD
        assert health["pointing_pitch_arcmin"] == pitch / ARCMIN_RAD
    # A host's own statistics of this loop: the same orbit and transient as the node's.
    own = bare.new_pointing()
    assert (own.period_s, own.skip_until_s) == (kept.pointing.period_s, kept.pointing.skip_until_s)


def test_bad_combinations_are_refused_with_their_names():
    with pytest.raises(ValueError, match="control.bandwidth_hz"):
        LoopSettings.from_values(values(control__bandwidth_hz=0.6))  # above 10 Hz / 20
    with pytest.raises(ValueError, match="body.inertia_kg_m2"):
        ControllerRuntime(values(body__inertia_kg_m2=[1.0, 1.0, 5.0]), start_s=0.0)
    with pytest.raises(ValueError, match="body.inertia_kg_m2 has 2 elements"):
        ControllerRuntime(values(body__inertia_kg_m2=[1.0, 1.0]), start_s=0.0)
    runtime = ControllerRuntime(values(), start_s=0.0)
    runtime.step_to(1.0)
    q = runtime.q
    with pytest.raises(ValueError, match="control.bandwidth_hz"):
        runtime.reconfigure(values(control__bandwidth_hz=0.9))
    assert runtime.settings.gains.bandwidth_hz == 0.02 and runtime.q == q  # nothing changed
    runtime.reconfigure(values(control__bandwidth_hz=0.05))
    assert runtime.settings.gains.bandwidth_hz == 0.05 and runtime.q == q and runtime.time_s == pytest.approx(1.0)


def test_the_initial_attitude_is_the_parameter_s():
    runtime = ControllerRuntime(values(body__initial_attitude_arcmin=[3.0, -4.0, 5.0]), start_s=0.0)
    expected = quaternion_from_roll_pitch_yaw(3 * ARCMIN_RAD, -4 * ARCMIN_RAD, 5 * ARCMIN_RAD)
    assert runtime.q == pytest.approx(tuple(expected))
