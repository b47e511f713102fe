"""An eccentric orbit (e = 0.01, perigee 700 km, issue 21): flown from an element set and internally.

The horizon's nadir angle changes with altitude (≈ 0.1° per 10 km at 835 km),
and this orbit's altitude swings by 2ae ≈ 143 km: the geometry, the
closed-form oblateness model and the on-board compensation must take the
altitude and argument of latitude of each sample.
"""

from __future__ import annotations

import math
from datetime import datetime, timezone

import numpy as np
import pytest

from pmv_ros.physics.attitude_profile import AttitudeProfile
from pmv_ros.physics.constants import ARCMIN_RAD, EARTH_MEAN_RADIUS_M, GM_EARTH_M3_S2
from pmv_ros.physics.orbit.ephemeris import Epoch
from pmv_ros.physics.instrument.oblateness import closed_form_oblateness, sensed_roll_pitch
from pmv_ros.physics.orbit.two_body import CircularOrbit, KeplerOrbit
from pmv_ros.physics.instrument.sensor import SensorConfig, SensorModel
from pmv_ros.physics.orbit.tle import TleOrbit, make_element_set

PERIGEE_M, ECCENTRICITY, INCLINATION_DEG, ARG_PERIGEE_DEG = 700e3, 0.01, 98.8, 45.0
SEMI_MAJOR_AXIS_M = (EARTH_MEAN_RADIUS_M + PERIGEE_M) / (1.0 - ECCENTRICITY)
EPOCH = datetime(2016, 11, 11, tzinfo=timezone.utc)

#: The bound of the closed-form model against ray geometry on circular orbits (tests/physics/test_geometry.py:
#: the issue's 0.5′; ≈ 0.06′ is seen there).
CLOSED_FORM_BOUND_ARCMIN = 0.5


def eccentric_tle() -> TleOrbit:
    mean_motion = math.sqrt(GM_EARTH_M3_S2 / SEMI_MAJOR_AXIS_M**3) * 86400.0 / (2.0 * math.pi)
    lines = make_element_set(EPOCH, INCLINATION_DEG, 0.0, ECCENTRICITY, ARG_PERIGEE_DEG, 0.0, mean_motion)
    return TleOrbit(*lines, Epoch(2457703.5), 0.0)  # 2016-11-11T00:00Z, the element set's epoch


def internal_twin(tle: TleOrbit) -> KeplerOrbit:
    """The same orbit flown internally: two-body motion with the secular J2 rates, from SGP4's mean elements."""
    satrec = tle._satrec
    a_m = satrec.a * satrec.radiusearthkm * 1e3
    return KeplerOrbit(a_m * (1.0 - satrec.ecco) - EARTH_MEAN_RADIUS_M, satrec.ecco, satrec.inclo,
                       tle.raan_rad, satrec.argpo, satrec.mo, 0.0, j2_secular=True)


@pytest.fixture(scope="module")
def tle():
    return eccentric_tle()


def test_kepler_orbit_without_eccentricity_is_the_circular_orbit():
    circular = CircularOrbit(835e3, math.radians(98.8), 0.3, 0.7)
    kepler = KeplerOrbit(835e3, 0.0, math.radians(98.8), 0.3, 0.7, 0.0)
    t = np.linspace(0.0, 2.0 * circular.period_s, 97)
    for mine, theirs in zip(kepler.state_eci(t), circular.state_eci(t)):
        assert np.max(np.abs(mine - theirs)) < 1e-6 * np.max(np.abs(theirs))  # rounding only
    assert np.allclose(kepler.orbital_frame_eci(t), circular.orbital_frame_eci(t), atol=1e-12)


def test_the_element_set_flies_the_eccentric_orbit_asked_for(tle):
    t = np.arange(0.0, tle.period_s, 10.0)
    _, _, altitude = tle.orbit_angles(t)
    # perigee ≈ 700 km, apogee ≈ 843 km: SGP4's short-period J2 terms move the radius by up to
    # ≈ (3/4) J2 (R/a)² a ≈ 5 km, more with the sin² i terms (7 km seen): 10 km allowed
    assert abs(altitude.min() - PERIGEE_M) < 10e3
    assert abs(altitude.max() - (SEMI_MAJOR_AXIS_M * (1 + ECCENTRICITY) - EARTH_MEAN_RADIUS_M)) < 10e3
    # and the internal twin stays within SGP4's short-period J2 terms of it over the orbit (≈ 10 km)
    twin = internal_twin(tle)
    assert np.max(np.linalg.norm(tle.state_eci(t)[0] - twin.state_eci(t)[0], axis=0)) < 25e3


@pytest.mark.parametrize("flown", ["tle", "internal"])
def test_closed_form_agrees_with_ray_geometry_on_the_eccentric_orbit(tle, flown):
    orbit = tle if flown == "tle" else internal_twin(tle)
    t = np.arange(0.0, orbit.period_s, 15.0)
    roll, pitch = sensed_roll_pitch(orbit, t)
    u, inclination, altitude = orbit.orbit_angles(t)
    _, model_roll, model_pitch = closed_form_oblateness(u, altitude, inclination)
    assert np.ptp(altitude) > 130e3  # the altitude really swings
    assert np.max(np.abs(roll - model_roll)) / ARCMIN_RAD < CLOSED_FORM_BOUND_ARCMIN
    assert np.max(np.abs(pitch - model_pitch)) / ARCMIN_RAD < CLOSED_FORM_BOUND_ARCMIN
    assert np.max(np.abs(roll)) / ARCMIN_RAD > 1.0  # the error is there to be modelled


def residual_statistics(orbit, compensation: bool):
    """Mean and σ (arcmin) of sensed − true roll and pitch over one orbit at 1 Hz, ideal detector, a moving body."""
    t = np.arange(0.0, orbit.period_s, 1.0)
    profile = AttitudeProfile(roll_offset_rad=2.0 * ARCMIN_RAD, pitch_offset_rad=-1.5 * ARCMIN_RAD,
                              roll_amplitude_rad=3.0 * ARCMIN_RAD, pitch_amplitude_rad=2.0 * ARCMIN_RAD,
                              oscillation_period_s=1200.0)
    model = SensorModel(orbit, SensorConfig(oblateness_compensation=compensation))
    reading = model.sense(t, profile.quaternion(t))
    residuals = (reading.sensed_roll_rad - reading.true_roll_rad, reading.sensed_pitch_rad - reading.true_pitch_rad)
    return np.array([[np.mean(r), np.std(r)] for r in residuals]) / ARCMIN_RAD


@pytest.mark.parametrize("compensation", [False, True])
def test_statistics_flown_as_an_element_set_equal_the_internal_orbits(tle, compensation):
    # Issue 21: statistics equal within 0.05′ (σ) whether the orbit is flown as a TLE or internally.
    # The two differ by SGP4's periodic terms (≈ 10 km); the oblateness error moves by ≈ 0.01′ for that.
    mine = residual_statistics(tle, compensation)
    theirs = residual_statistics(internal_twin(tle), compensation)
    assert np.max(np.abs(mine[:, 1] - theirs[:, 1])) < 0.05
    assert np.max(np.abs(mine[:, 0] - theirs[:, 0])) < 0.05
    if compensation:  # what is left after the on-board model with each sample's altitude and u
        assert np.max(mine[:, 1]) < CLOSED_FORM_BOUND_ARCMIN
    else:  # the oblateness error itself: a few arcmin of σ
        assert np.max(mine[:, 1]) > 1.0


def test_on_board_compensation_takes_each_samples_altitude(tle):
    t = np.arange(0.0, tle.period_s, 15.0)
    q = np.tile(np.array([[0.0], [0.0], [0.0], [1.0]]), t.size)
    reading = SensorModel(tle, SensorConfig(oblateness_compensation=True)).sense(t, q)
    left = np.hypot(reading.sensed_roll_rad, reading.sensed_pitch_rad) / ARCMIN_RAD
    assert left.max() < CLOSED_FORM_BOUND_ARCMIN
    # With the nominal (mean) altitude instead, the model would leave more behind.
    roll, pitch = sensed_roll_pitch(tle, t)
    u, inclination, _ = tle.orbit_angles(t)
    _, nominal_roll, nominal_pitch = closed_form_oblateness(u, tle.altitude_m, inclination)
    nominal_left = np.hypot(roll - nominal_roll, pitch - nominal_pitch) / ARCMIN_RAD
    assert nominal_left.max() > left.max()
