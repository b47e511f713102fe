"""What the sensor keeps on grids fixed on the clock: the orbit along the track, the fields along the horizon.

pmv_ros/physics/instrument/track.py interpolates the orbit's state (and the Sun's and Moon's positions) from
nodes 2 s apart; pmv_ros/physics/instrument/horizon_fields.py keeps the weather and the window-layer height on
a (time, azimuth) grid of the horizon circle. These tests check both against the quantities evaluated
directly, and the parts they are made of.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pmv_ros.physics.constants import EARTH_MEAN_RADIUS_M
from pmv_ros.physics.environment import EnvironmentParameters
from pmv_ros.physics.instrument.horizon_fields import EMPTY, NodeTable, _slot
from pmv_ros.physics.instrument.sensor import ChainDetector, RadianceConfig, SensorConfig, SensorModel
from pmv_ros.physics.instrument.track import OrbitTrack, carried_state
from pmv_ros.physics.orbit.ephemeris import Epoch, moon_position_eci_m, sun_position_eci_m
from pmv_ros.physics.orbit.two_body import CircularOrbit, KeplerOrbit, eci_to_ecef, geocentric_latitude_longitude, \
    orbital_frame_from_state

ORBITS = {
    "circular with the J2 drift": CircularOrbit(835e3, math.radians(98.8), j2_node_drift=True),
    "eccentric, e = 0.3": KeplerOrbit(400e3, 0.3, math.radians(63.4), j2_secular=True),
}


@pytest.mark.parametrize("name", list(ORBITS))
def test_the_track_interpolates_the_orbit_far_below_what_a_sensor_sees(name):
    # A cubic through nodes 2 s apart: ≈ (n·h)⁴·r·9/384 in position — micrometres in low orbit, ≈ 1 mm at the
    # perigee of the eccentric orbit —, and the orbital frame to ≈ 1e-10 rad (a horizon sensor resolves
    # ≈ 1e-5 rad; 1e-8 rad is 3e-5′). Times off the nodes at random, over an hour.
    orbit = ORBITS[name]
    epoch = Epoch.from_utc("2016-11-11T00:00:00Z")
    track = OrbitTrack(orbit, epoch)
    t = np.sort(np.random.default_rng(1).uniform(10.0, 3600.0, 500))
    rows = track.rows(t)
    position, velocity = orbit.state_eci(t)
    assert np.max(np.linalg.norm(rows[:, 0:3].T - position, axis=0)) < 5e-3
    assert np.max(np.linalg.norm(rows[:, 3:6].T - velocity, axis=0)) < 5e-6
    frame = np.abs(orbital_frame_from_state(rows[:, 0:3].T, rows[:, 3:6].T)
                   - orbital_frame_from_state(position, velocity))
    assert np.max(frame) < 1e-8
    jd_tt = epoch.julian_date_tt(t)
    # The Sun and the Moon to metres of their millions of kilometres.
    assert np.max(np.abs(rows[:, 6:9].T - sun_position_eci_m(jd_tt))) < 1.0
    assert np.max(np.abs(rows[:, 9:12].T - moon_position_eci_m(jd_tt))) < 1.0
    # And a node is the orbit there, exactly.
    nodes = np.array([100.0, 102.0, 1000.0])
    np.testing.assert_array_equal(track.rows(nodes)[:, 0:3].T, orbit.state_eci(nodes)[0])


def test_a_carried_state_follows_two_body_motion_for_the_seconds_a_field_node_needs():
    # A followed orbit's field nodes are placed from the nearest sample's state carried a few seconds (angle and
    # radius to second order in time). Against the Keplerian orbit itself (no J2): to a millimetre on a circle,
    # to 2 m after 8 s at the perigee of an orbit of e = 0.3 (measured 0.58 m) — against field scales of ≥ 100 km.
    circle = KeplerOrbit(700e3, 0.0, math.radians(51.6))
    eccentric = KeplerOrbit(400e3, 0.3, math.radians(63.4))
    for orbit, bound_m in ((circle, 1e-3), (eccentric, 2.0)):
        for t0 in (0.0, 1500.0, 2900.0):
            for dt in (-4.0, 2.0, 8.0):
                position, velocity = carried_state(*orbit.state_eci(t0), dt)
                assert np.linalg.norm(position - orbit.state_eci(t0 + dt)[0]) < bound_m, (orbit, t0, dt)


def test_the_node_table_finds_what_it_holds_and_grows_keeping_what_it_is_told():
    table = NodeTable(capacity=16)
    keys = np.array([5, -7, 2**40 + 3, 123456789012], np.int64)
    table.insert(keys, np.array([1.0, 2.0, 3.0, 4.0]))
    for key, value in zip(keys.tolist(), [1.0, 2.0, 3.0, 4.0]):
        assert table.values[_slot(table.keys, key)] == value
    assert table.keys[_slot(table.keys, 99)] == EMPTY
    # More than half full: rebuilt, only the entries kept says, and grown as needed.
    many = np.arange(1000, 1100, dtype=np.int64)
    table.insert(many, many * 0.5, keep=lambda k: k > 0)
    assert table.count == 3 + many.size and table.keys.size >= 2 * table.count  # -7 dropped
    assert table.keys[_slot(table.keys, -7)] == EMPTY and table.values[_slot(table.keys, 2**40 + 3)] == 3.0
    assert table.values[_slot(table.keys, 1050)] == 525.0
    table.drop(lambda k: k % 2 == 0)
    assert table.keys[_slot(table.keys, 1050)] == EMPTY and table.values[_slot(table.keys, 1051)] == 525.5


def test_on_a_node_the_sensor_reads_the_fields_at_its_horizon_point_itself():
    # A sample at a time node of both grids, at zero attitude (each chord on an azimuth node): the interpolation
    # gives the node's value, which is the field where the chord's horizon point is — computed here directly
    # from the environment at the limb point, independently of the grid (1e-9 r.u. and 1e-6 m: the node's
    # horizon circle comes from the track's interpolated orbit, micrometres off).
    environment = EnvironmentParameters(relative_variability=0.3, synoptic_fraction=0.55,
                                        height_correlation_radius_m=100e3, seed=7, field_time_origin_s=5.3e8)
    orbit = CircularOrbit(835e3, math.radians(98.8))
    detector = ChainDetector(835e3, RadianceConfig(source="environment", environment=environment,
                                                   earth_rotation_at_epoch_rad=0.4, field_grid_s=2.0))
    model = SensorModel(orbit, SensorConfig(), detector)
    t = (np.round((5.3e8 + np.array([400.0, 2500.0, 4100.0])) / 2.0) * 2.0 - 5.3e8)  # nodes of the 2 s grids
    reading = model.sense(t, np.tile(np.array([[0.0], [0.0], [0.0], [1.0]]), t.size))
    position, _ = orbit.state_eci(t)
    frame = orbit.orbital_frame_eci(t)
    radius = np.linalg.norm(position, axis=0)
    angle = np.arccos(EARTH_MEAN_RADIUS_M / radius)
    env = detector.environment
    for chord, (axis, sign) in enumerate(((0, 1.0), (1, 1.0), (0, -1.0), (1, -1.0))):
        point = np.cos(angle) * position / radius + np.sin(angle) * sign * frame[:, axis]
        lat, lon = geocentric_latitude_longitude(eci_to_ecef(point, t, 0.4))
        expected = env.sample(lat, lon, t)
        np.testing.assert_allclose(reading.horizon_radiance_ru[chord], expected.horizon_radiance_ru, rtol=0, atol=1e-9)
        np.testing.assert_allclose(reading.window_height_m[chord], expected.window_height_m, rtol=0, atol=1e-6)
