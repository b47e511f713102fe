"""Sun/Moon ephemeris, run epoch and the bright-body-in-a-chord check (pmv_ros.physics.orbit.ephemeris, .bright_body).

Reference values and where they come from:

* J. Meeus, *Astronomical Algorithms*, 2nd ed. (Willmann-Bell, 1998):
  Example 12.a/12.b (GMST), Example 25.b (the Sun from VSOP87, apparent
  place), Example 47.a (the Moon from the full ELP-2000/82 table of ch. 47,
  geometric, mean equinox of date).
* The U.S. Naval Observatory's "Earth's Seasons" and "Phases of the Moon"
  tables for 2022–2025 (times rounded to the minute, UTC).

Development check, not repeated here (it needs ERFA): over 20 000 random
dates in 1950–2050, against ERFA's epv00 + aberration (Sun) and moon98 (Moon),
both precessed to the mean equator of date, the Sun is within 0.011°
(rms 0.003°), the Moon within 0.041° (rms 0.011°) and 81 km in distance, and
GMST within 1e-7° of gmst82. The tolerances below are set from those figures.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from pmv_ros.physics.attitude import body_axes_in_orbital, quaternion_from_roll_pitch_yaw
from pmv_ros.physics.instrument.bright_body import (
    angular_distance_to_scan_arc,
    bright_body_in_chords,
    chords_seeing_body,
    occulted_by_earth,
)
from pmv_ros.physics.constants import EARTH_MEAN_RADIUS_M, EARTH_ROTATION_RATE_RAD_S, SPHERE
from pmv_ros.physics.orbit.ephemeris import (
    ASTRONOMICAL_UNIT_M,
    Epoch,
    greenwich_mean_sidereal_angle,
    julian_date_from_utc,
    mean_obliquity,
    moon_direction_eci,
    moon_direction_from,
    moon_position_eci_m,
    sun_direction_eci,
    sun_direction_from,
    sun_position_eci_m,
    tt_minus_utc_s,
)
from pmv_ros.physics.geometry import (
    CHORD_AZIMUTHS_RAD,
    chord_line_of_sight,
    sphere_nadir_angle_of_height,
    tangent_nadir_angles,
)
from pmv_ros.physics.instrument.oblateness import sensor_axes_eci
from pmv_ros.physics.orbit.two_body import CircularOrbit

DEG = math.pi / 180.0
IFOV_HALF_ANGLE_RAD = 1.1 * DEG  # physics.md §1: 2γ = 2.2°


def _separation_deg(a, b):
    """Angle between two (3, ...) vectors, deg (atan2 form: accurate near 0 and 180°)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    cross = np.linalg.norm(np.cross(a, b, axis=0), axis=0)
    return np.degrees(np.arctan2(cross, np.sum(a * b, axis=0)))


def _ra_dec_deg(v):
    return np.degrees(np.arctan2(v[1], v[0])) % 360.0, np.degrees(np.arctan2(v[2], np.hypot(v[0], v[1])))


def _ecliptic_lon_lat_deg(v, jd):
    """Ecliptic longitude/latitude of date of an ECI (mean-of-date) vector, deg."""
    eps = mean_obliquity(jd)
    x, y, z = v
    y_ecl = math.cos(eps) * y + math.sin(eps) * z
    z_ecl = -math.sin(eps) * y + math.cos(eps) * z
    return np.degrees(np.arctan2(y_ecl, x)) % 360.0, np.degrees(np.arctan2(z_ecl, np.hypot(x, y_ecl)))


def _wrap_deg(a):
    return (np.asarray(a) + 180.0) % 360.0 - 180.0


# --------------------------------------------------------------------------
# Time
# --------------------------------------------------------------------------

def test_julian_date_from_utc_known_dates():
    assert julian_date_from_utc("2000-01-01T12:00:00Z") == pytest.approx(2451545.0, abs=1e-9)
    # Meeus Example 12.b: 1987 April 10, 19h21m00s UT is JD 2446896.30625.
    assert julian_date_from_utc("1987-04-10T19:21:00Z") == pytest.approx(2446896.30625, abs=1e-9)
    # An offset is converted to UTC; no offset means UTC.
    midnight = julian_date_from_utc("2024-01-15T00:00:00Z")
    assert midnight == pytest.approx(2460324.5, abs=1e-9)
    assert julian_date_from_utc("2024-01-15T02:00:00+02:00") == pytest.approx(midnight, abs=1e-9)
    assert julian_date_from_utc("2024-01-15T00:00:00") == pytest.approx(midnight, abs=1e-9)


def test_julian_date_without_offset_is_utc_whatever_the_local_zone(monkeypatch):
    import time
    monkeypatch.setenv("TZ", "Asia/Tokyo")
    time.tzset()
    try:
        assert julian_date_from_utc("2000-01-01T12:00:00") == pytest.approx(2451545.0, abs=1e-9)
    finally:
        monkeypatch.undo()
        time.tzset()


@pytest.mark.parametrize("bad", ["", "yesterday", "2024-13-01T00:00:00Z", "2024-02-30T00:00:00Z",
                                 "2024-01-15T25:00:00Z", None, 2451545.0])
def test_julian_date_from_utc_rejects_bad_strings(bad):
    with pytest.raises(ValueError, match="ISO 8601"):
        julian_date_from_utc(bad)


def test_epoch_clock_and_day_of_year():
    epoch = Epoch.from_utc("2024-01-15T00:00:00Z")
    assert epoch.julian_date(0.0) == pytest.approx(2460324.5, abs=1e-9)
    assert epoch.julian_date(86400.0) - epoch.julian_date(0.0) == pytest.approx(1.0, abs=1e-9)
    offset_s = (epoch.julian_date_tt(0.0) - epoch.julian_date(0.0)) * 86400.0
    assert offset_s == pytest.approx(69.184, abs=1e-3)  # 32.184 s + 37 leap seconds (since 2017-01-01)
    # Day of year, 1.0 = 1 January 00:00 (the climatology's convention); 2024 is a leap year.
    days = epoch.day_of_year(np.array([0.0, 0.5 * 86400.0, 351.5 * 86400.0, 366 * 86400.0, -15 * 86400.0]))
    np.testing.assert_allclose(days, [15.0, 15.5, 366.5, 15.0, 365.0], atol=1e-6, rtol=0)
    assert np.isnan(epoch.day_of_year(np.array([np.nan]))[0])  # bad samples become NaN, not an error


# TT − UTC = 32.184 s (TT − TAI, IAU 1991) + TAI − UTC, the leap seconds of IERS Bulletin C: 32 s from
# 1999-01-01 to 2006-01-01, 35 s from 2012-07-01 to 2015-07-01, 36 s from 2015-07-01 to 2017-01-01, 37 s since
# (Bulletin C 52, 2016 July: the leap second at the end of 2016-12-31). The values are exact: 1 µs of slack for
# the float64 Julian date.
@pytest.mark.parametrize("utc, expected_s", [
    ("2000-01-01T12:00:00Z", 64.184),
    ("2013-09-10T00:00:00Z", 67.184),   # Kondor's epoch (config/kondor.yaml)
    ("2016-06-01T00:00:00Z", 68.184),
    ("2016-12-31T23:59:59Z", 68.184),   # the last second before the leap second ...
    ("2017-01-01T00:00:00Z", 69.184),   # ... and the first after it
    ("2019-07-21T00:00:00Z", 69.184),   # Meteor-M No.2-2's epoch
])
def test_tt_minus_utc_follows_the_leap_seconds(utc, expected_s):
    epoch = Epoch.from_utc(utc)
    assert tt_minus_utc_s(epoch.julian_date_utc) == pytest.approx(expected_s, abs=1e-6)
    assert (epoch.julian_date_tt(0.0) - epoch.julian_date(0.0)) * 86400.0 == pytest.approx(expected_s, abs=1e-3)


def test_tt_minus_utc_outside_the_table_takes_its_ends():
    # Before 1960 UTC did not exist: the table's first value, on 1960-01-01 (MJD 36934; USNO tai-utc.dat:
    # TAI − UTC = 1.4178180 s + (MJD − 37300) × 0.001296 s); after the last leap second in the table: its value.
    # Arrays are taken element by element, across the step.
    first = 32.184 + 1.4178180 + (36934 - 37300) * 0.001296
    dates = np.array([julian_date_from_utc(text) for text in
                      ("1900-01-01T00:00:00Z", "1960-01-01T00:00:00Z", "2016-12-31T12:00:00Z", "2099-12-31T00:00:00Z")])
    np.testing.assert_allclose(tt_minus_utc_s(dates), [first, first, 68.184, 69.184], atol=1e-6, rtol=0)
    epoch = Epoch.from_utc("2016-12-31T23:59:58Z")
    steps = (epoch.julian_date_tt(np.array([0.0, 1.0, 2.0, 3.0])) - epoch.julian_date(np.array([0.0, 1.0, 2.0, 3.0])))
    np.testing.assert_allclose(steps * 86400.0, [68.184, 68.184, 69.184, 69.184], atol=1e-3, rtol=0)
    # A bad sample's time stays bad (NaN), as everywhere in the array code.
    assert np.isnan(tt_minus_utc_s(np.array([np.nan, np.inf]))).all() and np.isnan(epoch.julian_date_tt(np.nan))


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), 2378496.5, 2500000.0, "soon"])
def test_epoch_rejects_out_of_range(bad):
    with pytest.raises(ValueError, match="epoch Julian date"):
        Epoch(bad)


def test_gmst_reference_values():
    # J2000.0: 280.46061837° (the constant of IAU 1982 GMST at 2000 Jan 1 12h UT1).
    assert math.degrees(greenwich_mean_sidereal_angle(2451545.0)) == pytest.approx(280.46061837, abs=1e-7)
    # Meeus Example 12.a: 1987 April 10, 0h UT → 13h10m46.3668s = 197.693195°.
    # Meeus Example 12.b: 1987 April 10, 19h21m00s UT → 8h34m57.0896s = 128.7378734°.
    # Tolerance 1e-6° (0.0002 s): the formula is the same, only rounding differs.
    got = np.degrees(greenwich_mean_sidereal_angle([2446895.5, 2446896.30625]))
    np.testing.assert_allclose(got, [197.693195, 128.7378734], atol=1e-6, rtol=0)


def test_earth_rotation_angle_agrees_with_orbit_rate():
    """The epoch's GMST and orbit.eci_to_ecef's constant rate stay together over a day (< 1e-5 rad)."""
    epoch = Epoch.from_utc("2024-06-01T00:00:00Z")
    t = np.array([0.0, 3600.0, 86400.0])
    gmst = epoch.earth_rotation_angle(t)
    linear = epoch.earth_rotation_angle(0.0) + EARTH_ROTATION_RATE_RAD_S * t
    assert np.all((gmst >= 0.0) & (gmst < 2.0 * math.pi))
    np.testing.assert_allclose(np.angle(np.exp(1j * (gmst - linear))), 0.0, atol=1e-5, rtol=0)


# --------------------------------------------------------------------------
# The Sun
# --------------------------------------------------------------------------

def test_sun_meeus_example_25b():
    """1992 Oct 13.0 TD (JD 2448908.5): α = 198.378178°, δ = −7.783871°, R = 0.99760775 au.

    Meeus Ex. 25.b (VSOP87, apparent place).

    Tolerance 0.015°: the series' 0.01° plus the nutation (≈ 0.004° here)
    that an apparent place contains and a mean-of-date direction does not.
    Distance to 1e-4 au, the series' accuracy.
    """
    position = sun_position_eci_m(2448908.5)
    ra, dec = _ra_dec_deg(position)
    assert ra == pytest.approx(198.378178, abs=0.015)
    assert dec == pytest.approx(-7.783871, abs=0.015)
    assert np.linalg.norm(position) / ASTRONOMICAL_UNIT_M == pytest.approx(0.99760775, abs=1e-4)


# USNO "Earth's Seasons", 2024, UTC; at each the Sun's apparent longitude is 0, 90, 180, 270°.
SEASONS_2024 = [
    ("2024-03-20T03:06:00Z", 0.0, 0.0),
    ("2024-06-20T20:51:00Z", 90.0, 23.44),
    ("2024-09-22T12:44:00Z", 180.0, 0.0),
    ("2024-12-21T09:21:00Z", 270.0, -23.44),
]


@pytest.mark.parametrize("iso, ra_deg, dec_deg", SEASONS_2024)
def test_sun_at_equinoxes_and_solstices(iso, ra_deg, dec_deg):
    """δ = 0 at the equinoxes and ±ε ≈ ±23.44° at the solstices; α = 0, 90, 180, 270°.

    Tolerance 0.01° in δ: series 0.01° (×sin ε ≈ 0.4 at the equinoxes), the
    2024 true obliquity 23.4386° (IAU 2006 mean 23.4361° plus nutation
    0.0025°) against the rounded 23.44°, and the minute-rounded times
    (0.0007°). 0.02° in α: series plus the nutation in longitude (≤ 0.005°).
    """
    jd = Epoch.from_utc(iso).julian_date_tt(0.0)
    direction = sun_direction_eci(jd)
    ra, dec = _ra_dec_deg(direction)
    assert dec == pytest.approx(dec_deg, abs=0.01)
    assert _wrap_deg(ra - ra_deg) == pytest.approx(0.0, abs=0.02)
    # The ecliptic longitude itself is 0/90/180/270° to the series' 0.01°
    # plus the 2024 nutation in longitude (|Δψ| ≈ 0.001°).
    longitude, _ = _ecliptic_lon_lat_deg(direction, jd)
    assert _wrap_deg(longitude - ra_deg) == pytest.approx(0.0, abs=0.011)


def test_sun_vectorised_and_unit():
    jd = 2460000.5 + np.linspace(0.0, 365.0, 7)
    directions = sun_direction_eci(jd)
    assert directions.shape == (3, 7)
    np.testing.assert_allclose(np.linalg.norm(directions, axis=0), 1.0, atol=1e-12, rtol=0)
    np.testing.assert_allclose(directions[:, 3], sun_direction_eci(jd[3]), atol=1e-15, rtol=0)
    # Over a year the Sun's direction sweeps the ecliptic: its mean is near zero.
    assert np.linalg.norm(sun_direction_eci(2460000.5 + np.arange(365.0)).mean(axis=1)) < 0.03


# --------------------------------------------------------------------------
# The Moon
# --------------------------------------------------------------------------

def test_moon_meeus_example_47a():
    """1992 April 12.0 TD: λ = 133.162655°, β = −3.229126°, Δ = 368409.7 km.

    Meeus Ex. 47.a (geometric, mean equinox of date).

    Tolerance 0.05° in λ and β and 150 km in Δ: the truncated series was
    measured against ERFA's full-series moon98 at ≤ 0.041° and ≤ 81 km over
    1950–2050.
    """
    jd = 2448724.5
    position = moon_position_eci_m(jd)
    lon, lat = _ecliptic_lon_lat_deg(position, jd)
    assert _wrap_deg(lon - 133.162655) == pytest.approx(0.0, abs=0.05)
    assert lat == pytest.approx(-3.229126, abs=0.05)
    assert np.linalg.norm(position) / 1e3 == pytest.approx(368409.7, abs=150.0)


# USNO "Phases of the Moon", UTC: a new moon at the total solar eclipse of
# 2024 April 8 and full moons at the total lunar eclipses of 2022 November 8
# and 2025 March 14 (at an eclipse the Moon is near its node, so the
# geocentric elongation itself, not only the longitude difference, is near
# 0° or 180°).
SYZYGIES = [
    ("2024-04-08T18:21:00Z", 0.0),
    ("2022-11-08T11:02:00Z", 180.0),
    ("2025-03-14T06:55:00Z", 180.0),
]


@pytest.mark.parametrize("iso, expected_deg", SYZYGIES)
def test_moon_phase_at_syzygies(iso, expected_deg):
    """At new/full moon the ecliptic longitudes of Moon and Sun differ by 0/180°; at an eclipse so does the elongation.

    Tolerances: longitude difference 0.06° (series 0.04° + the Moon's
    0.5°/h relative motion over the half-minute rounding, 0.004°);
    elongation within 1° of 0/180°: a total eclipse needs the geocentric
    separation from the Sun or the anti-Sun below ≈ 1° (lunar parallax
    0.95°; umbra radius ≈ 0.7°).
    """
    jd = Epoch.from_utc(iso).julian_date_tt(0.0)
    sun, moon = sun_direction_eci(jd), moon_direction_eci(jd)
    sun_lon, _ = _ecliptic_lon_lat_deg(sun, jd)
    moon_lon, _ = _ecliptic_lon_lat_deg(moon, jd)
    assert _wrap_deg(moon_lon - sun_lon - expected_deg) == pytest.approx(0.0, abs=0.06)
    assert abs(_separation_deg(sun, moon) - expected_deg) < 1.0


def test_moon_parallax_from_low_orbit():
    """Seen from 500 km altitude across the line of sight, the Moon shifts by atan(r/Δ) ≈ 1°."""
    jd = 2460400.5 + np.array([0.0, 3.3, 11.7])
    geocentric = moon_position_eci_m(jd)
    distance = np.linalg.norm(geocentric, axis=0)
    unit = geocentric / distance
    radius = EARTH_MEAN_RADIUS_M + 500e3
    # An observer perpendicular to the Moon's direction, and one right under it.
    across = np.cross(unit, np.array([0.0, 0.0, 1.0])[:, None], axis=0)
    across = radius * across / np.linalg.norm(across, axis=0)
    shift = _separation_deg(moon_direction_from(across, jd), unit)
    np.testing.assert_allclose(shift, np.degrees(np.arctan(radius / distance)), atol=1e-9, rtol=0)
    assert np.all((shift > 0.95) & (shift < 1.15))
    np.testing.assert_allclose(_separation_deg(moon_direction_from(radius * unit, jd), unit), 0.0, atol=1e-6, rtol=0)
    # The Sun's parallax from the same place is below 10″.
    assert np.all(_separation_deg(sun_direction_from(across, jd), sun_direction_eci(jd)) < 10.0 / 3600.0)
    # One observer, many times; many observers, one time.
    assert moon_direction_from(across[:, 0], jd).shape == (3, 3)
    assert moon_direction_from(across, jd[0]).shape == (3, 3)
    with pytest.raises(ValueError, match=r"\(3,\)"):
        moon_direction_from(np.zeros((2, 3)), jd)


# --------------------------------------------------------------------------
# Distance to a chord's swept arc
# --------------------------------------------------------------------------

CROSSING = np.full(4, 68.0 * DEG)
SCAN_START = np.full(4, 70.5 * DEG)


def _normal(azimuth):
    """Unit normal of a chord's plane in the sensor frame."""
    return np.array([-math.sin(azimuth), math.cos(azimuth), 0.0])


@pytest.mark.parametrize("chord", range(4))
def test_arc_distance_on_the_arc_is_zero(chord):
    azimuth = CHORD_AZIMUTHS_RAD[chord]
    on_arc = chord_line_of_sight(69.2 * DEG, azimuth)
    distance = angular_distance_to_scan_arc(on_arc, CROSSING, SCAN_START)
    assert distance[chord] == pytest.approx(0.0, abs=1e-12)
    # The neighbouring chords are 90° away in azimuth: far from this arc.
    others = np.delete(distance, chord)
    assert np.all(others > 60.0 * DEG)
    assert chords_seeing_body(on_arc, CROSSING, SCAN_START, 0.01 * DEG).tolist() == [k == chord for k in range(4)]


def test_arc_distance_beside_the_arc_is_the_offset_from_its_plane():
    offset = 2.0 * DEG
    point = math.cos(offset) * chord_line_of_sight(69.0 * DEG, 0.0) + math.sin(offset) * _normal(0.0)
    assert angular_distance_to_scan_arc(point, CROSSING, SCAN_START)[0] == pytest.approx(offset, abs=1e-12)


def test_arc_distance_beyond_the_ends_is_to_the_nearer_end():
    # In the chord plane, 5° outside the scan start and 3° inside the crossing.
    outward = chord_line_of_sight(SCAN_START[1] + 5.0 * DEG, CHORD_AZIMUTHS_RAD[1])
    inward = chord_line_of_sight(CROSSING[1] - 3.0 * DEG, CHORD_AZIMUTHS_RAD[1])
    assert angular_distance_to_scan_arc(outward, CROSSING, SCAN_START)[1] == pytest.approx(5.0 * DEG, abs=1e-12)
    assert angular_distance_to_scan_arc(inward, CROSSING, SCAN_START)[1] == pytest.approx(3.0 * DEG, abs=1e-12)
    # Out of the plane too: right spherical triangle, cos d = cos(along) cos(across).
    across = 4.0 * DEG
    point = math.cos(across) * outward + math.sin(across) * _normal(CHORD_AZIMUTHS_RAD[1])
    expected = math.acos(math.cos(5.0 * DEG) * math.cos(across))
    assert angular_distance_to_scan_arc(point, CROSSING, SCAN_START)[1] == pytest.approx(expected, abs=1e-12)


def test_arc_distance_from_the_opposite_chord_is_large():
    """A body on the −X chord at nadir ψ is ψ + crossing from the +X arc (through the boresight)."""
    psi = 69.0 * DEG
    point = chord_line_of_sight(psi, CHORD_AZIMUTHS_RAD[2])
    distance = angular_distance_to_scan_arc(point, CROSSING, SCAN_START)
    assert distance[0] == pytest.approx(psi + CROSSING[0], abs=1e-12)
    assert distance[2] == pytest.approx(0.0, abs=1e-12)
    assert chords_seeing_body(point, CROSSING, SCAN_START, 10.0 * DEG).tolist() == [False, False, True, False]


def test_arc_distance_matches_brute_force_sampling():
    """Random directions and arcs, vectorised, against the nearest of 2001 samples along each arc."""
    rng = np.random.default_rng(7)
    n = 300
    directions = rng.normal(size=(3, n))
    # Bias half of them towards the scanned band so that the near cases are exercised.
    directions[2, : n // 2] = -0.35 * np.abs(directions[2, : n // 2])
    crossing = rng.uniform(55.0, 75.0, size=(4, n)) * DEG
    start = crossing + rng.uniform(0.5, 6.0, size=(4, n)) * DEG
    exact = angular_distance_to_scan_arc(directions, crossing, start)
    assert exact.shape == (4, n)

    fraction = np.linspace(0.0, 1.0, 2001)
    samples_nadir = crossing[..., None] + (start - crossing)[..., None] * fraction  # (4, n, S)
    lines = chord_line_of_sight(samples_nadir, CHORD_AZIMUTHS_RAD[:, None, None])  # (3, 4, n, S)
    unit = directions / np.linalg.norm(directions, axis=0)
    cosines = np.einsum("in,iknS->knS", unit, lines)
    brute = np.arccos(np.clip(cosines.max(axis=-1), -1.0, 1.0))
    spacing = (start - crossing) / 2000.0
    # The nearest sample is never nearer than the arc, and at most half a spacing farther.
    assert np.all(exact <= brute + 1e-7)
    assert np.all(brute - exact <= 0.5 * spacing + 1e-7)


def test_arc_distance_nan_angles_give_nan_and_no_detection():
    crossing = CROSSING.copy()
    crossing[3] = np.nan
    point = chord_line_of_sight(69.0 * DEG, CHORD_AZIMUTHS_RAD[3])
    assert np.isnan(angular_distance_to_scan_arc(point, crossing, SCAN_START)[3])
    # On its own chord (distance 0 but no horizon): not reported. ±X arcs are
    # ≈ 83° away (within 90°), the +Y arc 137° (through the boresight).
    assert chords_seeing_body(point, crossing, SCAN_START, 90.0 * DEG).tolist() == [True, False, True, False]


def test_chord_check_rejects_bad_inputs():
    point = chord_line_of_sight(69.0 * DEG, 0.0)
    for bad in (-0.01, float("nan"), 2.0, "wide"):
        with pytest.raises(ValueError, match="exclusion angle"):
            chords_seeing_body(point, CROSSING, SCAN_START, bad)
    with pytest.raises(ValueError, match="direction_sensor"):
        angular_distance_to_scan_arc(point[:2], CROSSING, SCAN_START)
    with pytest.raises(ValueError, match="crossing_nadir_rad"):
        angular_distance_to_scan_arc(point, CROSSING[:3], SCAN_START)
    with pytest.raises(ValueError, match="scan_start_nadir_rad"):
        angular_distance_to_scan_arc(point, CROSSING, SCAN_START[:, None, None].reshape(2, 2))


# --------------------------------------------------------------------------
# Occultation
# --------------------------------------------------------------------------

def test_occultation_by_the_earth_disc():
    radius = EARTH_MEAN_RADIUS_M + 500e3
    position = np.array([radius, 0.0, 0.0])
    limb = math.asin(EARTH_MEAN_RADIUS_M / radius)  # 68.0° from the nadir at 500 km
    angles_from_nadir = np.array([0.0, limb - 0.1 * DEG, limb + 0.1 * DEG, 90.0 * DEG, 180.0 * DEG])
    # Directions at those angles from the nadir (−x), tilted towards +y.
    directions = np.array([-np.cos(angles_from_nadir), np.sin(angles_from_nadir), 0.0 * angles_from_nadir])
    assert occulted_by_earth(5.0 * directions, position).tolist() == [True, True, False, False, False]
    # A Moon straight behind the Earth, seen from the far side.
    jd = 2460400.5
    behind = -radius * moon_direction_eci(jd)
    assert bool(occulted_by_earth(moon_direction_from(behind, jd), behind))
    assert not bool(occulted_by_earth(moon_direction_from(-behind, jd), -behind))
    with pytest.raises(ValueError, match="Earth radius"):
        occulted_by_earth(directions, position, earth_radius_m=-1.0)


# --------------------------------------------------------------------------
# The whole check for an orbit and attitude
# --------------------------------------------------------------------------

def _orbit_showing(direction_eci, nadir_angle_rad, t_s):
    """A 500 km orbit whose +X (along-track) chord looks at ``direction_eci`` at ``nadir_angle_rad`` at ``t_s``.

    The orbit plane contains the direction (normal h ⊥ it), and the argument
    of latitude is such that the direction lies ahead, ``nadir_angle_rad``
    from the nadir.
    """
    normal = np.cross(direction_eci, [0.0, 0.0, 1.0])
    normal /= np.linalg.norm(normal)
    inclination = math.acos(normal[2])
    raan = math.atan2(normal[0], -normal[1])
    node = np.array([math.cos(raan), math.sin(raan), 0.0])
    u_direction = math.atan2(np.dot(direction_eci, np.cross(normal, node)), np.dot(direction_eci, node))
    return CircularOrbit(500e3, inclination, raan, u_direction - math.pi + nadir_angle_rad, epoch_s=t_s)


def _scan_geometry(orbit, t_s, q):
    position, _ = orbit.state_eci(np.atleast_1d(t_s))
    horizon = tangent_nadir_angles(position, sensor_axes_eci(orbit, np.atleast_1d(t_s), q), SPHERE, 0.0)
    start = sphere_nadir_angle_of_height(60e3, orbit.radius_m, EARTH_MEAN_RADIUS_M) + IFOV_HALF_ANGLE_RAD
    return horizon, np.broadcast_to(start, horizon.shape)


EPOCH = Epoch.from_utc("2024-03-01T00:00:00Z")
T0 = 1000.0


def test_sun_placed_in_the_along_track_chord():
    sun = sun_direction_eci(EPOCH.julian_date_tt(T0))
    orbit = _orbit_showing(sun, 69.5 * DEG, T0)
    # Guard on the construction: the Sun is 69.5° from the nadir, ahead.
    frame = orbit.orbital_frame_eci(T0)
    assert np.dot(sun, -frame[:, 2]) == pytest.approx(math.cos(69.5 * DEG), abs=1e-9)
    assert np.dot(sun, frame[:, 0]) == pytest.approx(math.sin(69.5 * DEG), abs=1e-9)

    t = T0 + np.array([0.0, 600.0, 1200.0])
    horizon, start = _scan_geometry(orbit, t, None)
    check = bright_body_in_chords(orbit, t, None, EPOCH, horizon, start, 0.5 * DEG)
    assert check.bodies == ("sun", "moon")
    assert check.in_field.shape == (2, 4, 3) and check.direction_sensor.shape == (3, 2, 3)
    # Blinded at t0 on +X only; ten minutes later the orbit has turned 38°
    # and the chord recovers by itself.
    assert check.body("sun")[:, 0].tolist() == [True, False, False, False]
    assert check.blinded[:, 1:].sum() == 0
    assert check.blinding_body[:, 0].tolist() == [0, -1, -1, -1]
    assert check.distance_rad[0, 0, 0] < 0.02 * DEG  # the Sun sits on the arc (10″ solar parallax)
    assert not check.occulted[0, 0]


def test_yaw_moves_the_sun_to_a_cross_track_chord():
    sun = sun_direction_eci(EPOCH.julian_date_tt(T0))
    orbit = _orbit_showing(sun, 69.5 * DEG, T0)
    q = quaternion_from_roll_pitch_yaw(0.0, 0.0, 0.5 * math.pi)
    horizon, start = _scan_geometry(orbit, T0, q)
    check = bright_body_in_chords(orbit, T0, q, EPOCH, horizon, start, 0.5 * DEG, bodies=("sun",))
    # The body axis now along the orbital +X (the flight direction) carries the blinded chord.
    axes = body_axes_in_orbital(q)  # columns: body X, Y, Z in orbital components
    along = int(np.argmax(np.abs(axes[0])))
    assert along == 1
    expected = 1 if axes[0, along] > 0 else 3
    assert check.blinded[:, 0].tolist() == [k == expected for k in range(4)]


def test_sun_behind_the_earth_cannot_blind():
    sun = sun_direction_eci(EPOCH.julian_date_tt(T0))
    orbit = _orbit_showing(sun, 60.0 * DEG, T0)  # inside the Earth disc (limb at 68°)
    horizon, start = _scan_geometry(orbit, T0, None)
    check = bright_body_in_chords(orbit, T0, None, EPOCH, horizon, start, {"sun": 10.0 * DEG, "moon": 0.5 * DEG})
    assert check.near_arc[0, 0, 0]  # 8° from the crossing: within 10°
    assert check.occulted[0, 0]
    assert not check.in_field[0, 0, 0]


def test_moon_check_uses_the_parallax():
    """A Moon put on the +X arc as seen from the spacecraft is found; its geocentric direction is ≈ 1° off."""
    jd = EPOCH.julian_date_tt(T0)
    direction = moon_direction_eci(jd)
    for _ in range(6):  # the parallax depends on the orbit it selects: iterate to a fixed point
        orbit = _orbit_showing(direction, 69.2 * DEG, T0)
        position, _ = orbit.state_eci(T0)
        direction = moon_direction_from(position, jd)
    horizon, start = _scan_geometry(orbit, T0, None)
    check = bright_body_in_chords(orbit, T0, None, EPOCH, horizon, start, 0.2 * DEG, bodies=("moon", "sun"))
    assert check.body("moon")[:, 0].tolist() == [True, False, False, False]
    assert check.distance_rad[0, 0, 0] < 1e-6
    parallax = _separation_deg(direction, moon_direction_eci(jd))
    assert 0.3 < parallax < 1.2


def test_bright_body_check_rejects_bad_configuration():
    orbit = CircularOrbit(500e3, 74.5 * DEG)
    horizon, start = _scan_geometry(orbit, 0.0, None)
    for bodies in (("mars",), ("sun", "sun"), ()):
        with pytest.raises(ValueError, match="bodies"):
            bright_body_in_chords(orbit, 0.0, None, EPOCH, horizon, start, 0.5 * DEG, bodies=bodies)
    with pytest.raises(ValueError, match="missing"):
        bright_body_in_chords(orbit, 0.0, None, EPOCH, horizon, start, {"sun": 0.5 * DEG})
    with pytest.raises(ValueError, match="exclusion angle for moon"):
        bright_body_in_chords(orbit, 0.0, None, EPOCH, horizon, start, {"sun": 0.5 * DEG, "moon": -1.0})
