"""The closed loop's plant and law (pmv_ros/physics/rigid_body.py) against closed-form rigid-body results.

Sources: Wertz (ed.), *Spacecraft Attitude Determination and Control* (1978), §16.1–16.2 (quaternion
kinematics, Euler's equations: a torque-free body keeps its inertial angular momentum and its kinetic
energy), §17.2 (gravity-gradient torque); the small-angle pitch libration of a gravity-gradient satellite,
J_y·θ̈ + 3n²(J_x − J_z)·θ = 0 (Hughes, *Spacecraft Attitude Dynamics*, 1986, ch. 9); the standard
second-order loop of a PD law on a rigid axis, H(s) = ω_n²/(s² + 2ζω_n·s + ω_n²).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pmv_ros.physics.attitude import (body_axes_in_orbital, quaternion_from_roll_pitch_yaw,
                                      roll_pitch_yaw_from_quaternion,
                                      true_roll_pitch, true_yaw)
from pmv_ros.physics.orbit.two_body import circular_mean_motion_rad_s
from pmv_ros.physics.rigid_body import PdGains, RigidBody, pd_torque, settling_time_s, tracking_response

INERTIA = (900.0, 1100.0, 600.0)
N_500KM = circular_mean_motion_rad_s(500e3)


def _q(roll, pitch, yaw=0.0):
    return tuple(float(c) for c in quaternion_from_roll_pitch_yaw(roll, pitch, yaw))


def test_pitch_libration_period_is_the_gravity_gradient_one():
    # J_y θ̈ = −3n²(J_x − J_z) θ: period 2π / (n √(3 (J_x − J_z) / J_y)) — 6266 s for this body at 500 km.
    body = RigidBody(INERTIA, N_500KM, gravity_gradient=True)
    q, rate = _q(0.0, 1e-3), (0.0, 0.0, 0.0)
    pitch = []
    for _ in range(20_000):
        q, rate = body.step(q, rate, (0.0, 0.0, 0.0), 1.0)
        pitch.append(true_roll_pitch(q)[1])
    pitch = np.array(pitch)
    upward = np.flatnonzero((pitch[:-1] < 0.0) & (pitch[1:] >= 0.0))
    period = np.diff(upward).mean()  # 1 s steps
    expected = 2.0 * math.pi / (N_500KM * math.sqrt(3.0 * (INERTIA[0] - INERTIA[2]) / INERTIA[1]))
    # Zero crossings counted on whole seconds over three periods: ±1 s; the 1e-3 rad amplitude's
    # non-linearity moves the period by ≈ 1e-7 of it.
    assert period == pytest.approx(expected, abs=1.0)
    # Without gravity gradient the body stays where it was put (at rest in the orbital frame).
    free = RigidBody(INERTIA, N_500KM, gravity_gradient=False)
    q, rate = _q(0.0, 1e-3), (0.0, 0.0, 0.0)
    for _ in range(2000):
        q, rate = free.step(q, rate, (0.0, 0.0, 0.0), 1.0)
    assert true_roll_pitch(q)[1] == pytest.approx(1e-3, abs=1e-12)


def test_a_torque_free_tumbling_body_keeps_its_angular_momentum_and_energy():
    # Inertially fixed frame (n = 0): Euler's equations conserve H = R·J·ω and T = ½ωᵀJω (Wertz §16.2).
    # 20 s of a fast tumble (≈ 0.5 rad/s) in 0.01 s RK4 steps: each step's error ≈ (ω dt)⁵ ≈ 3e-12 relative.
    body = RigidBody(INERTIA, 0.0, gravity_gradient=False)
    q, rate = _q(0.3, -0.2, 1.0), (0.2, 0.4, -0.3)

    def momentum_energy(q, rate):
        h_body = np.array(INERTIA) * np.array(rate)
        return body_axes_in_orbital(np.array(q)) @ h_body, 0.5 * float(np.dot(rate, h_body))

    h0, t0 = momentum_energy(q, rate)
    for _ in range(2000):
        q, rate = body.step(q, rate, (0.0, 0.0, 0.0), 0.01)
    h1, t1 = momentum_energy(q, rate)
    assert np.allclose(h1, h0, rtol=0.0, atol=1e-9 * np.linalg.norm(h0))
    assert t1 == pytest.approx(t0, rel=1e-9)
    assert sum(c * c for c in q) == pytest.approx(1.0, abs=1e-15)


def test_a_steady_turn_about_the_orbit_normal_is_what_the_kinematics_give():
    # A torque applied to nothing: a body turning at 1e-3 rad/s about its Y axis relative to the orbital frame
    # (n = 0, no coupling) reaches pitch 1e-3·t; the quaternion kinematics q̇ = ½ q ⊗ ω alone (Wertz §16.1).
    body = RigidBody(INERTIA, 0.0, gravity_gradient=False)
    q, rate = _q(0.0, 0.0), (0.0, 1e-3, 0.0)
    for _ in range(100):
        q, rate = body.step(q, rate, (0.0, 0.0, 0.0), 1.0)
    assert true_roll_pitch(q)[1] == pytest.approx(0.1, abs=1e-12)
    assert rate == pytest.approx((0.0, 1e-3, 0.0), abs=1e-15)


def test_the_same_operators_serve_one_body_and_many():
    body = RigidBody(INERTIA, N_500KM)
    q1, r1 = _q(0.01, -0.02, 0.03), (1e-4, -2e-4, 3e-5)
    many_q = np.tile(np.array(q1)[:, None], (1, 3))
    many_r = np.tile(np.array(r1)[:, None], (1, 3))
    torque = (1e-3, -2e-3, 5e-4)
    one_q, one_r = body.step(q1, r1, torque, 0.1)
    all_q, all_r = body.step(many_q, many_r, tuple(np.full(3, t) for t in torque), 0.1)
    assert np.array_equal(np.asarray(all_q)[:, 1], np.array(one_q))
    assert np.array_equal(np.asarray(all_r)[:, 2], np.array(one_r))
    assert isinstance(one_q[0], float) and isinstance(true_yaw(one_q), float)


def test_true_yaw_is_the_convention_s_yaw():
    q = quaternion_from_roll_pitch_yaw(np.array([0.1, -0.5, 1.2]), np.array([0.2, 0.3, -1.0]),
                                       np.array([0.3, -2.0, 3.0]))
    assert np.allclose(true_yaw(q), roll_pitch_yaw_from_quaternion(q)[2], atol=1e-15)


def test_a_pd_loop_follows_minus_the_measurement_error_as_the_second_order_response_says():
    # Each axis of a rigid body under τ = −K_p (θ + e) − K_d θ̇ with e = sin(ω t): the steady true angle is
    # −H(jω)·e. Eight frequencies from 0.1 to 3 ω_n at once (one body each), 0.02 Hz, ζ = 0.7, the orbital
    # frame inertially fixed (no coupling). Amplitude and phase from a fit over the last 5 periods, after
    # 15 time constants. RK4 at ω_n·dt = 0.013 is exact to ≈ 1e-10; the torque held over each step delays the
    # loop by dt/2, a phase of ω·dt/2 ≤ 0.019 rad at 3 ω_n, which moves the response by up to ≈ 2 % of it
    # where the loop is resonant (the bound: 2.5 %).
    gains = PdGains(0.02, 0.7, INERTIA)
    body = RigidBody(INERTIA, 0.0, gravity_gradient=False)
    wn = gains.natural_frequency_rad_s
    omega = wn * np.array([0.1, 0.3, 0.5, 0.8, 1.0, 1.5, 2.0, 3.0])
    dt = 0.1
    q = tuple(np.array([0.0, 0.0, 0.0, 1.0])[:, None].repeat(omega.size, axis=1))
    rate = tuple(np.zeros(omega.size) for _ in range(3))
    settle = 15.0 / (0.7 * wn)
    span = 5 * 2 * math.pi / omega.min()
    steps = int((settle + span) / dt)
    record_t, record_pitch = [], []
    for k in range(steps):
        t = k * dt
        error = np.sin(omega * t)
        pitch = true_roll_pitch(np.asarray(q))[1]  # the law sees the measured pitch: true pitch + error
        torque = pd_torque(gains, (np.zeros(omega.size), pitch + error, np.zeros(omega.size)), rate)
        q, rate = body.step(q, rate, torque, dt)
        if t >= settle:
            record_t.append(t + dt)
            record_pitch.append(true_roll_pitch(np.asarray(q))[1])
    t = np.array(record_t)
    pitch = np.array(record_pitch)
    expected = -tracking_response(omega, 0.02, 0.7)
    for i, w in enumerate(omega):
        design = np.stack([np.cos(w * t), np.sin(w * t)], axis=1)
        a, b = np.linalg.lstsq(design, pitch[:, i], rcond=None)[0]
        measured = b + 1j * a  # the response to sin(ωt) as a complex gain: b·sin + a·cos
        assert abs(measured - expected[i]) <= 0.025 * abs(expected[i]), (w / wn, measured, expected[i])


def test_gains_settling_and_validation():
    gains = PdGains(0.02, 0.7, INERTIA)
    wn = 2 * math.pi * 0.02
    assert gains.proportional == pytest.approx(tuple(j * wn * wn for j in INERTIA))
    assert gains.derivative == pytest.approx(tuple(2 * 0.7 * j * wn for j in INERTIA))
    assert settling_time_s(0.02, 0.7) == pytest.approx(4.0 / (0.7 * wn))
    assert settling_time_s(0.02, 2.0) == pytest.approx(4.0 / (wn * (2.0 - math.sqrt(3.0))))
    # ζ = 1/√2: H's −3 dB point is ω_n.
    assert abs(tracking_response(wn, 0.02, 1 / math.sqrt(2))) == pytest.approx(1 / math.sqrt(2))
    with pytest.raises(ValueError, match="inertia_kg_m2"):
        RigidBody((1.0, 1.0, 3.0), N_500KM)  # no body has J_z > J_x + J_y
    with pytest.raises(ValueError, match="inertia_kg_m2"):
        RigidBody((1.0, -1.0, 1.0), N_500KM)
    with pytest.raises(ValueError, match="mean_motion"):
        RigidBody(INERTIA, float("nan"))
    with pytest.raises(ValueError, match="bandwidth_hz"):
        PdGains(0.0, 0.7, INERTIA)
