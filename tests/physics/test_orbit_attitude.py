"""Circular orbit, orbital frame and the attitude convention (issue 2)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pmv_ros.physics.attitude import (
    body_axes_in_orbital,
    nadir_in_body,
    quaternion_conjugate,
    quaternion_from_roll_pitch_yaw,
    quaternion_from_rotation_vector,
    quaternion_product,
    roll_pitch_from_nadir,
    roll_pitch_yaw_from_quaternion,
    rotation_vector_from_quaternion,
    true_roll_pitch,
)
from pmv_ros.physics.orbit.two_body import CircularOrbit, eci_to_ecef, geocentric_latitude_longitude


def test_period_matches_the_reference_orbits():
    # physics.md §2: Kondor ≈ 95 min, Meteor-M ≈ 101 min.
    assert CircularOrbit(500e3, math.radians(74.5)).period_s / 60 == pytest.approx(94.6, abs=0.5)
    assert CircularOrbit(835e3, math.radians(98.8)).period_s / 60 == pytest.approx(101.3, abs=0.5)


def test_orbital_frame_is_right_handed_with_z_up_and_x_along_velocity():
    orbit = CircularOrbit(700e3, math.radians(63.0), raan_rad=0.4, arg_latitude_at_epoch_rad=1.0)
    t = np.linspace(0.0, 6000.0, 17)
    frame = orbit.orbital_frame_eci(t)
    position, velocity = orbit.state_eci(t)
    for k in range(t.size):
        m = frame[:, :, k]
        np.testing.assert_allclose(m.T @ m, np.eye(3), atol=1e-12)
        assert np.linalg.det(m) == pytest.approx(1.0)
        np.testing.assert_allclose(m[:, 2], position[:, k] / np.linalg.norm(position[:, k]), atol=1e-12)
        np.testing.assert_allclose(m[:, 0], velocity[:, k] / np.linalg.norm(velocity[:, k]), atol=1e-12)
    # velocity is the time derivative of position
    dt = 1e-2
    ahead, _ = orbit.state_eci(t + dt)
    behind, _ = orbit.state_eci(t - dt)
    np.testing.assert_allclose((ahead - behind) / (2 * dt), velocity, rtol=1e-7, atol=1e-5)


def test_subsatellite_latitude_peaks_at_the_inclination():
    orbit = CircularOrbit(500e3, math.radians(74.5))
    position, _ = orbit.state_eci(orbit.time_of_argument_of_latitude(math.pi / 2))
    latitude, _ = geocentric_latitude_longitude(position)
    assert math.degrees(latitude) == pytest.approx(74.5, abs=1e-9)


def test_j2_node_drift_of_a_sun_synchronous_orbit():
    # Meteor-M is sun-synchronous: with J2 the node drifts ≈ +0.9856°/day.
    orbit = CircularOrbit(835e3, math.radians(98.8), j2_node_drift=True)
    assert math.degrees(orbit.raan_rate_rad_s) * 86400 == pytest.approx(0.9856, abs=0.03)
    assert CircularOrbit(835e3, math.radians(98.8)).raan_rate_rad_s == 0.0


def test_earth_rotation_moves_a_fixed_point_westward_in_ecef():
    point = np.array([1.0, 0.0, 0.0])
    _, lon = geocentric_latitude_longitude(eci_to_ecef(point, 3600.0))
    assert math.degrees(lon) == pytest.approx(-15.04, abs=0.01)


@pytest.mark.parametrize("bad", [dict(altitude_m=-5e3, inclination_rad=1.0), dict(altitude_m=1e9, inclination_rad=1.0),
                                 dict(altitude_m=500e3, inclination_rad=4.0)])
def test_bad_orbit_raises_a_value_error_naming_the_range(bad):
    with pytest.raises(ValueError, match="allowed range"):
        CircularOrbit(**bad)


def test_quaternion_round_trip_and_vectorisation():
    rng = np.random.default_rng(1)
    roll, pitch, yaw = rng.uniform(-0.5, 0.5, (3, 50))
    q = quaternion_from_roll_pitch_yaw(roll, pitch, yaw)
    assert q.shape == (4, 50)
    np.testing.assert_allclose(np.linalg.norm(q, axis=0), 1.0)
    back = roll_pitch_yaw_from_quaternion(q)
    np.testing.assert_allclose(back, [roll, pitch, yaw], atol=1e-12)


def test_convention_is_rep_103():
    # physics.md "Sign conventions": roll, pitch, yaw are tf2's, R = R_z(yaw)·R_y(pitch)·R_x(roll),
    # the body's axes in the orbital frame. A body turned by +1° right-hand about the orbital +X
    # reads roll = +1°, about +Y pitch = +1°. The rotation is built here from an axis and an
    # angle (scipy's rotation vectors), independently of the Euler angles under test.
    one_degree = math.radians(1.0)
    for axis, expected in (((1.0, 0.0, 0.0), (one_degree, 0.0, 0.0)), ((0.0, 1.0, 0.0), (0.0, one_degree, 0.0)),
                           ((0.0, 0.0, 1.0), (0.0, 0.0, one_degree))):
        q = Rotation.from_rotvec(one_degree * np.array(axis)).as_quat()
        np.testing.assert_allclose(roll_pitch_yaw_from_quaternion(q), expected, atol=1e-12)
        np.testing.assert_allclose(true_roll_pitch(q), expected[:2], atol=1e-12)
        np.testing.assert_allclose(quaternion_from_roll_pitch_yaw(*expected), q, atol=1e-12)
    # The nadir moves the other way: turned about +X, the body sees the nadir on its −Y side.
    n_roll = nadir_in_body(quaternion_from_roll_pitch_yaw(0.01, 0.0))
    n_pitch = nadir_in_body(quaternion_from_roll_pitch_yaw(0.0, 0.01))
    assert n_roll[1] < 0 and abs(n_roll[0]) < 1e-12
    assert n_pitch[0] > 0 and abs(n_pitch[1]) < 1e-12
    # tf2's order: yaw applied last in the orbital frame (R_z outermost).
    roll, pitch, yaw = 0.1, -0.2, 0.3
    expected = (Rotation.from_rotvec([0, 0, yaw]) * Rotation.from_rotvec([0, pitch, 0])
                * Rotation.from_rotvec([roll, 0, 0])).as_matrix()
    np.testing.assert_allclose(body_axes_in_orbital(quaternion_from_roll_pitch_yaw(roll, pitch, yaw)), expected,
                               atol=1e-12)


def test_roll_pitch_reading_inverts_the_convention_at_any_yaw():
    # With R = R_z·R_y·R_x the nadir in the body frame does not depend on yaw: a horizon sensor
    # reads tf2's roll and pitch exactly, whatever the yaw.
    roll, pitch = np.radians([3.0, -7.0, 0.2]), np.radians([-2.0, 1.0, 0.0])
    for yaw in (0.0, 0.4, -2.5):
        q = quaternion_from_roll_pitch_yaw(roll, pitch, yaw)
        np.testing.assert_allclose(roll_pitch_from_nadir(nadir_in_body(q)), [roll, pitch], atol=1e-12)
        np.testing.assert_allclose(true_roll_pitch(q), [roll, pitch], atol=1e-12)


def test_one_quaternion_reads_like_the_array_path():
    # A single quaternion takes a rotation-free path (the monitor converts every star-tracker
    # sample that way); it must read what the array path reads, for any attitude and either sign of q.
    rng = np.random.default_rng(5)
    q = rng.normal(size=(4, 500))
    q /= np.linalg.norm(q, axis=0)
    roll, pitch = true_roll_pitch(q)
    for k in range(q.shape[1]):
        for sign in (1.0, -1.0):
            one = true_roll_pitch(sign * q[:, k])
            assert all(isinstance(value, float) for value in one)
            np.testing.assert_allclose(one, [roll[k], pitch[k]], atol=1e-12)


def test_yaw_alone_is_not_observable():
    q = quaternion_from_roll_pitch_yaw(0.0, 0.0, math.radians(25.0))
    np.testing.assert_allclose(true_roll_pitch(q), [0.0, 0.0], atol=1e-12)


def test_quaternion_algebra_matches_scipy_rotations_for_tuples_and_arrays():
    # The star tracker composes its frames with these (one frame at a time, in plain floats);
    # scipy's Rotation is the reference. Rotation angles from 0 through the small-angle series
    # (below 1e-3 rad) to large ones.
    rng = np.random.default_rng(17)
    a, b = rng.normal(size=(4, 300)), rng.normal(size=(4, 300))
    a /= np.linalg.norm(a, axis=0)
    b /= np.linalg.norm(b, axis=0)
    product = quaternion_product(a, b)
    reference = (Rotation.from_quat(a.T) * Rotation.from_quat(b.T)).as_quat().T
    np.testing.assert_allclose(product * np.sign(np.sum(product * reference, axis=0)), reference, atol=1e-15)
    axes = rng.normal(size=(3, 300))
    axes /= np.linalg.norm(axes, axis=0)
    angles = np.concatenate([[0.0, 1e-12, 1e-6, 9.99e-4, 1e-3, 1.001e-3], rng.uniform(0.0, np.pi, 294)])
    vectors = axes * angles
    q = quaternion_from_rotation_vector(vectors)
    np.testing.assert_allclose(q, Rotation.from_rotvec(vectors.T).as_quat().T, atol=1e-15)
    back = rotation_vector_from_quaternion(q)
    np.testing.assert_allclose(back, Rotation.from_quat(q.T).as_rotvec().T, atol=1e-14)
    np.testing.assert_allclose(back, vectors, atol=1e-14)
    np.testing.assert_allclose(rotation_vector_from_quaternion(-q), vectors, atol=1e-14)  # q and −q: one rotation
    np.testing.assert_allclose(quaternion_product(quaternion_conjugate(a), a), np.tile([[0], [0], [0], [1.0]], 300),
                               atol=1e-15)
    for k in range(0, 300, 7):  # one quaternion as a tuple of floats: the same numbers, no arrays
        one = quaternion_product(tuple(a[:, k].tolist()), tuple(b[:, k].tolist()))
        assert type(one) is tuple and all(type(c) is float for c in one)
        np.testing.assert_allclose(one, product[:, k], atol=1e-16)
        one_q = quaternion_from_rotation_vector(tuple(vectors[:, k].tolist()))
        assert type(one_q) is tuple
        np.testing.assert_allclose(one_q, q[:, k], atol=1e-16)
        np.testing.assert_allclose(rotation_vector_from_quaternion(one_q), back[:, k], atol=1e-15)
        np.testing.assert_allclose(quaternion_conjugate(one_q), quaternion_conjugate(q[:, k]), atol=0)
