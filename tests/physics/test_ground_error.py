"""Attitude error → ground error of a nadir imager (physics.md §7)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pmv_ros.physics.constants import ARCMIN_RAD, EARTH_MEAN_RADIUS_M
from pmv_ros.physics.ground_error import GroundError, combine_in_quadrature, ground_error, nadir_ground_error

R = EARTH_MEAN_RADIUS_M


def spherical_offset_m(nadir_angle_rad, altitude_m, sphere_radius_m=R):
    """Arc from the sub-satellite point to where a ray at a nadir angle meets the sphere (sine rule)."""
    central = math.asin((R + altitude_m) / sphere_radius_m * math.sin(nadir_angle_rad)) - nadir_angle_rad
    return sphere_radius_m * central


def test_one_arcminute_from_500_km_is_about_145_m():
    # physics.md §7: "A 1′ attitude error is ≈ 145 m on the ground from 500 km at nadir".
    # 1 m slack: the paper rounds; H·tan(1′) = 145.4 m.
    for roll, pitch in ((ARCMIN_RAD, 0.0), (0.0, ARCMIN_RAD)):
        error = ground_error(roll, pitch, 500e3)
        assert error.circular_m == pytest.approx(145.0, abs=1.0)


def test_signs_follow_the_attitude_convention():
    # REP-103 (attitude.py): a body turned right-hand about +Y_O (positive pitch) tilts its −Z
    # boresight back, to −X_O; right-hand about +X_O (positive roll) tilts it to +Y_O.
    back = ground_error(0.0, ARCMIN_RAD, 500e3)
    assert back.along_track_m < -140.0 and abs(back.cross_track_m) < 1e-6
    sideways = ground_error(ARCMIN_RAD, 0.0, 500e3)
    assert sideways.cross_track_m > 140.0 and abs(sideways.along_track_m) < 1e-6


@pytest.mark.parametrize("angle_deg, altitude_km, height_km", [(10.0, 500.0, 0.0), (25.0, 835.0, 0.0),
                                                                (0.5, 500.0, 5.0)])
def test_large_roll_matches_the_spherical_sine_rule(angle_deg, altitude_km, height_km):
    angle = math.radians(angle_deg)
    error = ground_error(angle, 0.0, altitude_km * 1e3, target_height_m=height_km * 1e3)
    expected = spherical_offset_m(angle, altitude_km * 1e3, R + height_km * 1e3)
    assert error.cross_track_m == pytest.approx(expected, rel=1e-9)


def test_yaw_matters_only_off_nadir():
    psi = 10 * ARCMIN_RAD
    assert ground_error(0.0, 0.0, 500e3, psi).circular_m < 1e-6
    look = math.radians(30.0)
    error = ground_error(0.0, 0.0, 500e3, psi, look_across_rad=look)
    # The pixel's ground point turns about the Earth's axis through the sub-satellite point by ψ,
    # right-hand about +Z_O, so a pixel towards +Y goes to −X: X′ = −R sin λ sin ψ and
    # P_X = −R asin(sin λ sin ψ), λ the pixel's central angle.
    central = spherical_offset_m(look, 500e3) / R
    assert error.along_track_m == pytest.approx(-R * math.asin(math.sin(central) * math.sin(psi)), rel=1e-9)


def test_vectorised_and_off_earth():
    roll = np.array([[0.0, ARCMIN_RAD], [2 * ARCMIN_RAD, math.radians(80.0)]])
    error = ground_error(roll, 0.0, 500e3)
    assert error.circular_m.shape == (2, 2)
    assert error.circular_m[0, 1] * 2 == pytest.approx(error.circular_m[1, 0], rel=1e-6)
    assert math.isnan(error.circular_m[1, 1])        # 80° from nadir at 500 km misses the Earth


def test_independent_sources_add_in_quadrature():
    total = combine_in_quadrature([GroundError(12.0, 15.0, 19.2), GroundError(-16.0, 0.0, 16.0)])
    assert total.along_track_m == pytest.approx(20.0) and total.cross_track_m == pytest.approx(15.0)
    assert total.circular_m == pytest.approx(25.0)


def test_closed_form_nadir_path_matches_the_general_chain():
    # The monitor's per-sample path re-derives the boresight direction; it must agree with the chain
    # through attitude.py (rotation matrices) for any roll, pitch, altitude and target height at
    # zero yaw (the residuals it gets have none), and in the circular error for any yaw (a REP-103
    # yaw, applied last about the vertical, only turns the boresight's tilt about it).
    rng = np.random.default_rng(11)
    roll, pitch, yaw = rng.uniform(-0.2, 0.2, (3, 200))
    altitude = rng.uniform(300e3, 1200e3, 200)
    height = rng.uniform(0.0, 8e3, 200)
    general = ground_error(roll, pitch, altitude, 0.0, target_height_m=height)
    fast = nadir_ground_error(roll, pitch, altitude, target_height_m=height)
    for a, b in zip(general, fast):
        assert np.allclose(a, b, rtol=1e-9, atol=1e-6)
    yawed = ground_error(roll, pitch, altitude, yaw, target_height_m=height)
    # Not to rounding: P_X and P_Y are arcs taken axis by axis (physics.md §7), so their root sum
    # square turns with the tilt only to ≈ 1e-5 relative at these 10° tilts.
    assert np.allclose(yawed.circular_m, fast.circular_m, rtol=1e-4, atol=1e-3)
    scalar = nadir_ground_error(ARCMIN_RAD, 0.0, 500e3)
    assert isinstance(scalar.circular_m, float) and scalar.cross_track_m == pytest.approx(145.4, abs=0.1)


def test_one_sample_path_matches_the_array_path():
    # Plain floats take a math-only path (the monitor's per-residual call); it must give the array
    # path's numbers, including NaN when the line of sight misses the Earth.
    rng = np.random.default_rng(12)
    roll, pitch = rng.uniform(-0.3, 0.3, (2, 300))
    roll[:5] = 1.2  # far off nadir from a high orbit: no intersection
    altitude = rng.uniform(300e3, 36000e3, 300)
    height = rng.choice([0.0, 5e3], 300)
    arrays = nadir_ground_error(roll, pitch, altitude, target_height_m=height)
    for k in range(roll.size):
        one = nadir_ground_error(float(roll[k]), float(pitch[k]), float(altitude[k]), float(height[k]))
        assert all(isinstance(value, float) for value in one)
        np.testing.assert_allclose(one, [component[k] for component in arrays], rtol=1e-12, atol=1e-9)
    assert any(math.isnan(nadir_ground_error(float(r), 0.0, 36000e3).circular_m) for r in roll[:5])
    for bad in ((math.inf, 0.0, 500e3), (0.0, math.nan, 500e3), (0.0, 0.0, math.nan)):
        assert all(math.isnan(value) for value in nadir_ground_error(*bad))
        with np.errstate(invalid="ignore"):  # the array path warns on cos(inf), then gives NaN
            assert all(np.isnan(value) for value in nadir_ground_error(*(np.array([v]) for v in bad)))
    with pytest.raises(ValueError, match="altitude"):
        nadir_ground_error(0.0, 0.0, -1.0)
