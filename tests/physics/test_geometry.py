"""Horizon geometry on the GRS80 ellipsoid and the oblateness error (issue 2).

Published reference: physics.md §2.1, the Kondor oblateness table
(H = 500 km, i = 74.5°, a quarter orbit).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pmv_ros.physics.published import KONDOR_OBLATENESS_TABLE

from pmv_ros.physics.attitude import quaternion_from_roll_pitch_yaw
from pmv_ros.physics.constants import ARCMIN_RAD, EARTH_MEAN_RADIUS_M, GRS80, SPHERE
from pmv_ros.physics.conventions import convert
from pmv_ros.physics.geometry import (
    CHORD_AZIMUTHS_RAD,
    chord_line_of_sight,
    ellipsoid_line_of_sight,
    sphere_nadir_angle_of_height,
    tangent_nadir_angles,
    vertical_from_horizon_angles,
)
from pmv_ros.physics.instrument.oblateness import (
    closed_form_oblateness,
    oblateness_error,
    sensed_roll_pitch,
    sensor_axes_eci,
)
from pmv_ros.physics.orbit.two_body import CircularOrbit

KONDOR_TABLE = KONDOR_OBLATENESS_TABLE  # physics.md §2.1, Kondor, a quarter orbit
KONDOR = CircularOrbit(500e3, math.radians(74.5))


@pytest.mark.parametrize("u_deg, meridional, pitch, roll", KONDOR_TABLE)
def test_ray_geometry_reproduces_kondor_table(u_deg, meridional, pitch, roll):
    # Tolerance 0.3′: the table is printed to 0.1′ and was computed with the
    # radii rounded to 6378/6357/6371 km; our exact GRS80 rays differ from it
    # by up to ≈ 0.2′ (roll at u = 45…90°).
    # The table is in the paper's signs, the core in REP-103: through the one conversion.
    got_roll, got_pitch = convert(*oblateness_error(KONDOR, math.radians(u_deg)), "ros", "paper")
    assert got_pitch / ARCMIN_RAD == pytest.approx(pitch, abs=0.3)
    assert got_roll / ARCMIN_RAD == pytest.approx(roll, abs=0.3)


def test_closed_form_reproduces_kondor_table_meridional_column():
    # Tolerance 0.3′, as above: the closed form is the published formula, the
    # table its rounded output (printed to 0.1′).
    u = np.radians([row[0] for row in KONDOR_TABLE])
    meridional, roll, pitch = closed_form_oblateness(u, 500e3, math.radians(74.5))
    roll, pitch = convert(roll, pitch, "ros", "paper")  # the table's signs
    np.testing.assert_allclose(meridional / ARCMIN_RAD, [row[1] for row in KONDOR_TABLE], atol=0.3)
    np.testing.assert_allclose(pitch / ARCMIN_RAD, [row[2] for row in KONDOR_TABLE], atol=0.3)
    np.testing.assert_allclose(roll / ARCMIN_RAD, [row[3] for row in KONDOR_TABLE], atol=0.3)


def test_closed_form_for_one_position_is_the_array_path_in_floats():
    # The monitor evaluates the model once per sample in plain floats; the array path is the reference.
    u = np.linspace(-7.0, 7.0, 301)
    for altitude, inclination in ((500e3, math.radians(74.5)), (835e3, math.radians(98.8)), (500e3, 0.0)):
        arrays = closed_form_oblateness(u, altitude, inclination)
        for k in range(0, u.size, 5):
            one = closed_form_oblateness(float(u[k]), altitude, inclination)
            assert all(type(value) is float for value in one)
            np.testing.assert_allclose(one, [column[k] for column in arrays], rtol=1e-12, atol=1e-15)
    # Input no orbit has (an altitude below the surface, say, from odometry in km): NaN, as the array path.
    with np.errstate(invalid="ignore"):
        for u, altitude, inclination in ((1.0, -5000.0, 1.3), (math.inf, 500e3, 1.3), (1.0, math.nan, 1.3)):
            one = closed_form_oblateness(u, altitude, inclination)
            assert all(type(value) is float and math.isnan(value) for value in one)
            assert np.all(np.isnan(closed_form_oblateness(np.array([u]), altitude, inclination)))


@pytest.mark.parametrize("altitude_km, inclination_deg", [(500, 74.5), (835, 98.8), (500, 30.0), (835, 51.6)])
def test_closed_form_agrees_with_ray_geometry_over_full_orbits(altitude_km, inclination_deg):
    # 0.5′ is the bound for the approximation; it holds with margin
    # (≈ 0.06′ seen), which also checks the sign convention in all 4 quarters.
    orbit = CircularOrbit(altitude_km * 1e3, math.radians(inclination_deg))
    u = np.radians(np.arange(0.0, 360.0, 1.0))
    roll, pitch = oblateness_error(orbit, u)
    _, model_roll, model_pitch = closed_form_oblateness(u, orbit.altitude_m, orbit.inclination_rad)
    assert np.max(np.abs(roll - model_roll)) / ARCMIN_RAD < 0.5
    assert np.max(np.abs(pitch - model_pitch)) / ARCMIN_RAD < 0.5
    # and the error is really there (not a zero-vs-zero agreement)
    assert np.max(np.abs(roll)) / ARCMIN_RAD > 1.0


def test_oblateness_signature_roll_at_orbital_and_pitch_at_twice_orbital_frequency():
    u = np.linspace(0.0, 2.0 * np.pi, 720, endpoint=False)
    roll, pitch = oblateness_error(KONDOR, u)
    roll_spectrum = np.abs(np.fft.rfft(roll))
    pitch_spectrum = np.abs(np.fft.rfft(pitch))
    assert np.argmax(roll_spectrum) == 1
    assert np.argmax(pitch_spectrum) == 2


@pytest.mark.parametrize("roll_deg, pitch_deg", [(1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.7, -0.4)])
def test_sign_convention_on_a_sphere(roll_deg, pitch_deg):
    # interfaces.md: a body roll of +1° must come out as +1° roll (pitch likewise).
    # On a sphere there is no methodical error, so 0.01′ is numerical slack only.
    u = np.radians([0.0, 33.0, 120.0, 250.0])
    t = KONDOR.time_of_argument_of_latitude(u)
    q = quaternion_from_roll_pitch_yaw(np.full(4, math.radians(roll_deg)), np.full(4, math.radians(pitch_deg)), 0.0)
    roll, pitch = sensed_roll_pitch(KONDOR, t, q, SPHERE)
    np.testing.assert_allclose(roll / ARCMIN_RAD, roll_deg * 60.0, atol=0.01)
    np.testing.assert_allclose(pitch / ARCMIN_RAD, pitch_deg * 60.0, atol=0.01)


def test_attitude_adds_to_oblateness_on_the_ellipsoid():
    u = np.radians([45.0])
    t = KONDOR.time_of_argument_of_latitude(u)
    base_roll, base_pitch = oblateness_error(KONDOR, u)
    q = quaternion_from_roll_pitch_yaw(np.radians([0.5]), np.radians([0.0]), 0.0)
    roll, pitch = sensed_roll_pitch(KONDOR, t, q)
    # A 30′ roll on top of a ≈ 4′ oblateness error: superposition to within
    # second-order coupling, well under 0.05′ at these angles.
    assert (roll - base_roll)[0] / ARCMIN_RAD == pytest.approx(30.0, abs=0.05)
    assert (pitch - base_pitch)[0] / ARCMIN_RAD == pytest.approx(0.0, abs=0.05)


@pytest.mark.parametrize("altitude_km, height_km", [(500, 0), (835, 40), (1500, 60)])
def test_tangent_angle_on_a_sphere_matches_the_spherical_formula(altitude_km, height_km):
    # physics.md §2: φ(h) = asin((R + h)/(R + H)); φ0 = 62°09′ at 835 km.
    orbit = CircularOrbit(altitude_km * 1e3, math.radians(50.0))
    t = np.array([0.0, 100.0])
    position, _ = orbit.state_eci(t)
    angles = tangent_nadir_angles(position, sensor_axes_eci(orbit, t), SPHERE, height_km * 1e3)
    expected = sphere_nadir_angle_of_height(height_km * 1e3, orbit.radius_m, EARTH_MEAN_RADIUS_M)
    np.testing.assert_allclose(angles, expected, atol=1e-9)


def test_hard_earth_horizon_at_835_km_is_62_deg_09_arcmin():
    # physics.md §2: φ0 = 62°09′ at H = 835 km (mean radius, rounded to 1′).
    phi0 = sphere_nadir_angle_of_height(0.0, EARTH_MEAN_RADIUS_M + 835e3, EARTH_MEAN_RADIUS_M)
    assert math.degrees(phi0) * 60.0 == pytest.approx(62 * 60 + 9, abs=1.0)


def test_tangent_rays_graze_the_ellipsoid():
    """Each returned line of sight touches the raised ellipsoid exactly once."""
    u = np.radians(np.arange(0.0, 360.0, 20.0))
    t = KONDOR.time_of_argument_of_latitude(u)
    position, _ = KONDOR.state_eci(t)
    axes = sensor_axes_eci(KONDOR, t)
    height = 40e3
    angles = tangent_nadir_angles(position, axes, GRS80, height)
    for chord, azimuth in enumerate(CHORD_AZIMUTHS_RAD):
        los_sensor = chord_line_of_sight(angles[chord], azimuth)
        los = np.einsum("ij...,j...->i...", axes, los_sensor)
        result = ellipsoid_line_of_sight(position, los, GRS80, height)
        assert np.all(np.abs(result["tangent_height_m"] - height) < 1.0)
        # 1 mrad further in, the ray hits; 1 mrad further out, it misses.
        inner = np.einsum("ij...,j...->i...", axes, chord_line_of_sight(angles[chord] - 1e-3, azimuth))
        outer = np.einsum("ij...,j...->i...", axes, chord_line_of_sight(angles[chord] + 1e-3, azimuth))
        assert np.all(ellipsoid_line_of_sight(position, inner, GRS80, height)["hits"])
        assert not np.any(ellipsoid_line_of_sight(position, outer, GRS80, height)["hits"])


def test_lost_horizon_is_nan_not_an_exception():
    # A body turned 120° away from nadir: the boresight misses the Earth.
    t = np.array([0.0])
    q = quaternion_from_roll_pitch_yaw(np.radians([120.0]), np.radians([0.0]), 0.0)
    position, _ = KONDOR.state_eci(t)
    angles = tangent_nadir_angles(position, sensor_axes_eci(KONDOR, t, q))
    assert np.all(np.isnan(angles))
    assert np.all(np.isnan(vertical_from_horizon_angles(angles)))


def test_one_orbit_at_one_second_steps_in_one_call():
    """Issue 2: ≈ 5,700 positions × 4 chords in one vectorised call."""
    t = np.arange(0.0, KONDOR.period_s, 1.0)
    assert 5600 < t.size < 5800
    roll, pitch = sensed_roll_pitch(KONDOR, t)
    assert roll.shape == t.shape and np.all(np.isfinite(roll)) and np.all(np.isfinite(pitch))
    # The same values as evaluating the first few samples on their own.
    one_roll, one_pitch = sensed_roll_pitch(KONDOR, t[:3])
    np.testing.assert_allclose(roll[:3], one_roll, rtol=0, atol=1e-15)
