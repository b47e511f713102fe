"""The orbit a sensor follows (issue 21, ``orbit.source: follow``): the user's odometry at the sensor's times.

The reference is an eccentric orbit (e = 0.01, perigee 700 km) flown
internally (:class:`pmv_ros.physics.orbit.two_body.KeplerOrbit`); the user's stack is
played by its states sampled at the stack's own rate and stamps. Two-body
motion, without the secular J2 rates: with them, KeplerOrbit's velocity is
the osculating ellipse's, which differs from the time derivative of its
position by the drift of ω and Ω (≈ 3.5 m/s here) — a user's propagator
gives a velocity that is the derivative of its position.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pmv_ros.physics.attitude_profile import AttitudeProfile
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.physics.orbit.two_body import KeplerOrbit
from pmv_ros.physics.instrument.sensor import SensorConfig, SensorModel
from pmv_ros.runtime.common.orbit_buffer import (FollowedOrbit, OrbitAt, OrbitBuffer, OrbitUnavailable, hermite_state,
                                          two_body_taylor)

ECCENTRIC = KeplerOrbit(700e3, 0.01, math.radians(98.8), 0.4, math.radians(45.0), 0.0, 0.0)


def _fed(rate_hz: float, start_s: float, end_s: float, **options) -> OrbitBuffer:
    buffer = OrbitBuffer(**options)
    for t in np.arange(start_s, end_s, 1.0 / rate_hz):
        position, velocity = ECCENTRIC.state_eci(t)
        buffer.add(t, position, velocity)
    return buffer


@pytest.mark.parametrize("rate_hz, bound_m", [(10.0, 1e-4), (1.0, 1e-3), (0.1, 1.0)])
def test_between_states_the_hermite_curve_is_the_orbit(rate_hz, bound_m):
    # The module's bound ≈ h⁴ n⁴ r / 384 (n ≈ 1.06e-3 rad/s, r ≈ 7.1e6 m): 2.3e-11 m at h = 0.1 s,
    # 2.3e-7 m at 1 s, 2.3e-3 m at 10 s — the bounds here allow rounding (≈ 1e-9 of 7e6 m) and 400×.
    buffer = _fed(rate_hz, 100.0, 100.0 + 220.0 / rate_hz, capacity=256)
    t = np.linspace(110.0 / rate_hz + 100.0, 100.0 + 200.0 / rate_hz, 997)
    mine_r, mine_v = FollowedOrbit(buffer, 700e3).state_eci(t)
    true_r, true_v = ECCENTRIC.state_eci(t)
    assert np.max(np.linalg.norm(mine_r - true_r, axis=0)) < bound_m
    assert np.max(np.linalg.norm(mine_v - true_v, axis=0)) < bound_m  # m/s: the derivative is as good


def test_past_the_newest_state_two_body_motion_for_the_horizon_then_stale():
    buffer = _fed(1.0, 0.0, 30.0, extrapolation_s=2.0)
    newest = buffer.newest_stamp_s
    for dt, bound_m in ((0.5, 1e-4), (2.0, 1e-3)):  # the series' dt⁴·n⁴·r/24: 2.4e-8, 6.2e-6 m (and rounding)
        position, velocity, reason = buffer.state_at(newest + dt)
        assert reason is OrbitAt.EXTRAPOLATED
        assert np.linalg.norm(position - ECCENTRIC.state_eci(newest + dt)[0]) < bound_m
    assert buffer.state_at(newest + 2.01)[2] is OrbitAt.STALE
    with pytest.raises(OrbitUnavailable, match="orbit stale"):
        FollowedOrbit(buffer, 700e3).state_eci(np.array([newest, newest + 3.0]))


def test_the_taylor_series_is_two_body_motion():
    # Point-mass check of the series alone: a circular orbit's radius stays, to the series' dt⁴ term.
    r, v = np.array([7.0e6, 0.0, 0.0]), np.array([0.0, math.sqrt(3.986005e14 / 7.0e6), 0.0])
    position, velocity = two_body_taylor(r, v, 2.0)
    assert abs(np.linalg.norm(position) - 7.0e6) < 1e-4 and abs(np.linalg.norm(velocity) - v[1]) < 1e-6


def test_nothing_across_a_gap_before_the_oldest_or_before_the_first_state():
    buffer = OrbitBuffer(max_gap_s=5.0)
    assert buffer.state_at(0.0)[2] is OrbitAt.NO_ORBIT
    for t in (0.0, 1.0, 10.0, 11.0):
        buffer.add(t, *ECCENTRIC.state_eci(t))
    assert buffer.state_at(5.0)[2] is OrbitAt.ORBIT_GAP
    assert buffer.state_at(0.5)[2] is OrbitAt.INTERPOLATED and buffer.state_at(10.5)[2] is OrbitAt.INTERPOLATED
    assert buffer.state_at(-0.1)[2] is OrbitAt.TOO_OLD
    position, _, reason = buffer.state_at(10.0)
    assert reason is OrbitAt.INTERPOLATED and np.array_equal(position, ECCENTRIC.state_eci(10.0)[0])
    # A stamp at or before the newest is a new timeline: what came before is forgotten.
    buffer.add(3.0, *ECCENTRIC.state_eci(3.0))
    assert len(buffer) == 1 and buffer.state_at(0.5)[2] is OrbitAt.TOO_OLD


def test_memory_is_bounded():
    buffer = _fed(10.0, 0.0, 100.0, capacity=64)
    assert len(buffer) == 64


def test_hermite_ends_are_the_states():
    state0, state1 = ECCENTRIC.state_eci(0.0), ECCENTRIC.state_eci(3.0)
    for t, (position, velocity) in ((0.0, state0), (3.0, state1)):
        mine = hermite_state(0.0, state0, 3.0, state1, t)
        assert np.allclose(mine[0], position, rtol=0, atol=1e-6) and np.allclose(mine[1], velocity, rtol=0, atol=1e-9)


def _residual_statistics(orbit, t, profile):
    model = SensorModel(orbit, SensorConfig(oblateness_compensation=False))
    reading = model.sense(t, profile.quaternion(t))
    residuals = (reading.sensed_roll_rad - reading.true_roll_rad, reading.sensed_pitch_rad - reading.true_pitch_rad)
    return np.array([[np.mean(r), np.std(r)] for r in residuals]) / ARCMIN_RAD, reading


def test_a_sensor_following_the_users_odometry_measures_as_on_the_orbit_itself():
    # Issue 21: statistics equal within 0.05′ (σ) to the same orbit flown internally. The user's stack
    # publishes at 5 Hz on its own stamps (0.07 s off the sensor's 1 Hz grid); the sensor senses each
    # 10 s block once odometry has arrived to 0.5 s short of its end (the block's last samples are
    # extrapolated), as a node does at its ticks. One orbit, oblateness uncompensated (the largest
    # altitude-dependent error: a few arcmin of σ).
    profile = AttitudeProfile(roll_offset_rad=2.0 * ARCMIN_RAD, pitch_offset_rad=-1.5 * ARCMIN_RAD,
                              roll_amplitude_rad=3.0 * ARCMIN_RAD, pitch_amplitude_rad=2.0 * ARCMIN_RAD,
                              oscillation_period_s=1200.0)
    buffer = OrbitBuffer(extrapolation_s=1.0)
    followed = FollowedOrbit(buffer, 700e3)
    odometry_t = iter(np.arange(0.07, ECCENTRIC.period_s + 20.0, 0.2))
    pending = next(odometry_t)
    blocks, times = [], []
    for start in np.arange(1.0, ECCENTRIC.period_s - 10.0, 10.0):
        t = start + np.arange(10.0)
        while pending <= t[-1] - 0.5:
            buffer.add(pending, *ECCENTRIC.state_eci(pending))
            pending = next(odometry_t)
        blocks.append(SensorModel(followed, SensorConfig(oblateness_compensation=False))
                      .sense(t, profile.quaternion(t)))
        times.append(t)
    t = np.concatenate(times)
    sensed = {name: np.concatenate([getattr(block, name) for block in blocks])
              for name in ("sensed_roll_rad", "sensed_pitch_rad", "true_roll_rad", "true_pitch_rad")}
    mine = np.array([[np.mean(r), np.std(r)] for r in (sensed["sensed_roll_rad"] - sensed["true_roll_rad"],
                                                        sensed["sensed_pitch_rad"] - sensed["true_pitch_rad"])])
    mine /= ARCMIN_RAD
    theirs, reading = _residual_statistics(ECCENTRIC, t, profile)
    assert np.max(np.abs(mine - theirs)) < 0.05, (mine, theirs)
    # Sample by sample, too: the followed geometry is the orbit's to far below an arcsecond.
    assert np.max(np.abs(sensed["sensed_pitch_rad"] - reading.sensed_pitch_rad)) / ARCMIN_RAD < 1e-3
    assert theirs[1, 1] > 1.0  # the altitude-dependent oblateness error is there to be followed
