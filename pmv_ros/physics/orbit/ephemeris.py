"""Where the Sun and the Moon are: the run's clock on the astronomical time scales, and the ephemerides.

Sensor fault "bright body in a chord's field": while the Sun
or the Moon is within a configurable angle of the part of a chord's scan that
looks at space, the chord's crossing is unreliable. This module and
:mod:`pmv_ros.physics.instrument.bright_body` are the pure part of that check:

1. time — the simulation clock (seconds since a run epoch) mapped to Julian
   dates, the day of year and the Greenwich sidereal angle (:class:`Epoch`);
2. ephemeris — low-precision analytic series for the geocentric Sun and Moon
   (:func:`sun_position_eci_m`, :func:`moon_position_eci_m`) and their
   directions from the spacecraft (parallax: ≈ 1° for the Moon at 500 km);
3. the check — angular distance from a direction to each chord's swept arc
   (:func:`angular_distance_to_scan_arc`), the Earth occultation, and both put
   together for an orbit and attitude (:mod:`pmv_ros.physics.instrument.bright_body`).

Frame: "ECI" here is the mean equator and mean equinox of date (precession
applied, nutation ≤ 0.005° left out, as the low-precision series are).
Vectors are ``(3,)`` or ``(3, N)``.

Time scales: the ephemerides take a Julian date in TT; :meth:`Epoch.julian_date_tt`
gives it from the run's UTC clock with TT − UTC from the leap-second table
(:func:`tt_minus_utc_s`). A UTC date is within 70 s of TT, which moves the
Moon by < 0.01°, below the series' accuracy, so either may be passed where
the caller has only UTC. The sidereal angle takes UT1, for which UTC
(|UT1 − UTC| < 0.9 s, 0.004°) is used.

Sources: the Sun — the Astronomical Almanac's low-precision formulas for the
Sun (section C, "Low precision formulae for the Sun", ≈ 0.01° in 1950–2050);
the Moon — the largest periodic terms of the ELP-2000/82 lunar theory
(Chapront-Touzé & Chapront) as tabulated in J. Meeus, *Astronomical
Algorithms*, 2nd ed., ch. 47; the sidereal angle — IAU 1982 GMST (Aoki et
al. 1982) in Meeus's form, eq. 12.4; mean obliquity — IAU 1980 (Lieske et
al. 1977), linear term.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from datetime import datetime, timezone

import numpy as np

from ..constants import SECONDS_PER_DAY
from .two_body import CircularOrbit, check_range

# --------------------------------------------------------------------------
# Constants of the ephemerides (used by this module only).
# --------------------------------------------------------------------------

#: Astronomical unit, m (IAU 2012 Resolution B2, exact).
ASTRONOMICAL_UNIT_M = 149_597_870_700.0


#: Julian date of the epoch J2000.0 (2000 January 1, 12h), days.
JD_J2000 = 2451545.0

#: Days in a Julian century.
DAYS_PER_JULIAN_CENTURY = 36525.0

#: Julian date of the Unix epoch 1970-01-01T00:00, days.
JD_UNIX_EPOCH = 2440587.5

#: TT − TAI, s: exact by definition (IAU 1991 Resolution A4, TT = TAI + 32.184 s).
TT_MINUS_TAI_S = 32.184

#: Range of epochs accepted, Julian dates (1900-01-01 … 2100-01-01): the
#: series are fitted around J2000 and degrade slowly outside 1950–2050.
EPOCH_JD_MIN = 2415020.5
EPOCH_JD_MAX = 2488069.5

#: Mean Earth–Moon distance of the series, m (Meeus ch. 47).
MOON_MEAN_DISTANCE_M = 385_000.56e3

#: Names accepted by :func:`bright_body_in_chords`.
BODY_NAMES = ("sun", "moon")

_J2000_UTC = datetime(2000, 1, 1, 12, 0, 0, tzinfo=timezone.utc)
_DEG = math.pi / 180.0


# --------------------------------------------------------------------------
# 1. Time
# --------------------------------------------------------------------------

def julian_date_from_utc(iso_string: str) -> float:
    """Julian date (UTC scale), days, of an ISO 8601 time such as ``"2024-01-15T00:00:00Z"``.

    A time with an offset (``+02:00``) is converted to UTC; a time without
    one is taken as UTC. Leap seconds are not counted (a Julian date in the
    UTC scale is a calendar label: every day is 86400 s).

    Args:
        iso_string: ISO 8601 date-time, e.g. ``"2024-01-15T00:00:00Z"``.

    Raises:
        ValueError: the string is not an ISO 8601 date-time.
    """
    if not isinstance(iso_string, str):
        raise ValueError(f"UTC time must be an ISO 8601 string such as '2024-01-15T00:00:00Z', got {iso_string!r}")
    try:
        moment = datetime.fromisoformat(iso_string.strip())
    except ValueError:
        raise ValueError(f"UTC time {iso_string!r} is not an ISO 8601 date-time such as "
                         "'2024-01-15T00:00:00Z'") from None
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=timezone.utc)
    return JD_J2000 + (moment - _J2000_UTC).total_seconds() / SECONDS_PER_DAY


def tt_minus_utc_s(julian_date_utc):
    """TT − UTC, s, at UTC Julian date(s): 32.184 s + TAI − UTC from ERFA's leap-second table.

    TAI − UTC is ``erfa.dat`` (the IERS leap seconds since 1972, and the
    drifting offsets of 1960–1971). Dates outside the table are clamped to
    it: before 1960, when UTC did not exist, the value of 1960-01-01
    (0.94 s); after the table's last leap second, that leap second's value
    (a leap second IERS Bulletin C announces later is not in the installed
    table). A non-finite date gives NaN.

    Args:
        julian_date_utc: Julian date in the UTC scale (every day 86400 s), days, scalar or array.
    """
    import erfa

    jd = np.asarray(julian_date_utc, float)
    finite = np.isfinite(jd)
    clamped = np.clip(np.where(finite, jd, JD_J2000), *_leap_table_span_jd())
    year, month, day, fraction = erfa.jd2cal(clamped, 0.0)
    return np.where(finite, TT_MINUS_TAI_S + erfa.dat(year, month, day, fraction), np.nan)[()]


@functools.lru_cache(maxsize=1)
def _leap_table_span_jd() -> tuple[float, float]:
    """Julian dates (UTC) of the first and the last entry of ERFA's leap-second table."""
    import erfa

    table = erfa.leap_seconds.get()
    first, last = (erfa.cal2jd(int(row["year"]), int(row["month"]), 1) for row in (table[0], table[-1]))
    return float(sum(first)), float(sum(last))


def greenwich_mean_sidereal_angle(jd_ut1):
    """Greenwich mean sidereal angle (IAU 1982 GMST), rad in [0, 2π).

    The angle of the Greenwich meridian from the mean equinox of date, i.e.
    from the x axis of the mean-of-date ECI frame used here. Meeus,
    *Astronomical Algorithms*, eq. 12.4 (the Aoki et al. 1982 expression
    referred to 0h UT):
    θ = 280.46061837° + 360.98564736629° d + 0.000387933° T² − T³/38710000°,
    d = JD − 2451545.0, T = d/36525.

    Args:
        jd_ut1: Julian date in UT1 (UTC will do: < 0.004°), days, array-like.
    """
    d = np.asarray(jd_ut1, float) - JD_J2000
    t = d / DAYS_PER_JULIAN_CENTURY
    # 360°·d is whole turns plus 360°·frac(d): keep the large part out of the sum.
    degrees = (280.46061837 + 360.0 * np.mod(d, 1.0) + 0.98564736629 * d
               + 0.000387933 * t**2 - t**3 / 38710000.0)
    return np.mod(degrees, 360.0) * _DEG


@dataclass(frozen=True)
class Epoch:
    """The run epoch: the UTC instant at simulation time 0.

    Maps the simulation clock (s since the epoch) to the Julian dates the
    ephemerides need, the day of year of the radiance climatology and the
    Earth's rotation angle, so that all three agree with the Sun.

    Args:
        julian_date_utc: Julian date (UTC scale) at simulation time 0, days
            (1900 … 2100). Use :meth:`from_utc` for an ISO string.
    """

    julian_date_utc: float

    def __post_init__(self) -> None:
        check_range("epoch Julian date (UTC)", self.julian_date_utc, EPOCH_JD_MIN, EPOCH_JD_MAX, " d")

    @classmethod
    def from_utc(cls, iso_string: str) -> "Epoch":
        """The epoch at an ISO 8601 UTC time, e.g. ``"2024-01-15T00:00:00Z"``."""
        return cls(julian_date_from_utc(iso_string))

    def julian_date(self, t_s):
        """Julian date (UTC scale) at simulation time ``t_s`` (s), days."""
        return self.julian_date_utc + np.asarray(t_s, float) / SECONDS_PER_DAY

    def seconds_since_j2000(self, t_s=0.0):
        """UTC seconds from J2000.0 (2000-01-01 12:00 UTC, every day 86400 s) at simulation time ``t_s`` (s).

        The epoch's part is rounded to the millisecond — what a Julian date in
        float64 resolves (≈ 40 µs) — so an epoch given to the second gives a
        whole number, the same in every run of that epoch.
        """
        return round((self.julian_date_utc - JD_J2000) * SECONDS_PER_DAY, 3) + np.asarray(t_s, float)

    def julian_date_tt(self, t_s):
        """Julian date in Terrestrial Time at simulation time ``t_s`` (s), days (TT − UTC: :func:`tt_minus_utc_s`)."""
        jd_utc = self.julian_date(t_s)
        return jd_utc + tt_minus_utc_s(jd_utc) / SECONDS_PER_DAY

    def day_of_year(self, t_s):
        """Fractional day of the UTC calendar year at ``t_s`` (s): 1.0 = 1 January 00:00.

        The convention of :func:`pmv_ros.physics.environment.horizon_radiance_climatology`;
        restarts at 1.0 on each 1 January.
        """
        unix_days = self.julian_date(t_s) - JD_UNIX_EPOCH
        finite = np.isfinite(unix_days)
        whole_days = np.floor(np.where(finite, unix_days, 0.0)).astype(np.int64).astype("datetime64[D]")
        year_start = whole_days.astype("datetime64[Y]").astype("datetime64[D]").astype(np.int64)
        return np.where(finite, unix_days - year_start + 1.0, np.nan)[()]

    def earth_rotation_angle(self, t_s):
        """Angle of the Greenwich meridian from the ECI x axis at ``t_s`` (s), rad in [0, 2π).

        IAU 1982 Greenwich mean sidereal time (:func:`greenwich_mean_sidereal_angle`),
        which is referred to the mean equinox of date — the x axis of this
        module's ECI frame (the IAU 2000 Earth Rotation Angle is referred to
        the CIO instead and differs by the accumulated precession in right
        ascension, ≈ 0.3° in 2024). For :func:`pmv_ros.physics.orbit.two_body.eci_to_ecef`
        pass ``angle_at_epoch_rad=epoch.earth_rotation_angle(0.0)``: its rate
        differs from GMST's by 1e-11 rad/s (< 1e-4° a year).
        """
        return greenwich_mean_sidereal_angle(self.julian_date(t_s))


# --------------------------------------------------------------------------
# 2. Ephemerides
# --------------------------------------------------------------------------

def mean_obliquity(jd_tt):
    """Mean obliquity of the ecliptic of date, rad: 23°26′21.448″ − 46.815″ T (IAU 1980, linear term).

    Args:
        jd_tt: Julian date (TT), days, array-like.
    """
    t = (np.asarray(jd_tt, float) - JD_J2000) / DAYS_PER_JULIAN_CENTURY
    return (23.4392911 - 0.0130042 * t) * _DEG


def _ecliptic_to_eci(longitude_rad, latitude_rad, distance, jd_tt):
    """Cartesian ``(3[, N])`` in the mean equator/equinox of date from ecliptic-of-date spherical coordinates."""
    eps = mean_obliquity(jd_tt)
    cb = np.cos(latitude_rad)
    x = cb * np.cos(longitude_rad)
    y_ecl = cb * np.sin(longitude_rad)
    z_ecl = np.sin(latitude_rad)
    # Rotation about the equinox direction by −ε (ecliptic → equator).
    y = np.cos(eps) * y_ecl - np.sin(eps) * z_ecl
    z = np.sin(eps) * y_ecl + np.cos(eps) * z_ecl
    return distance * np.array([x, y, z])


def sun_position_eci_m(jd_tt):
    """Geocentric position of the Sun, m, ``(3[, N])``, mean equator and equinox of date.

    The Astronomical Almanac's low-precision Sun (≈ 0.01° in 1950–2050): a
    Keplerian Earth orbit with the equation of centre to second order in the
    eccentricity e = 0.0167 (2e = 1.915°, 5e²/4 = 0.020°), the mean
    longitude including the annual aberration (−20.5″), latitude taken as 0:
    n = JD − 2451545.0; L = 280.460° + 0.9856474° n; g = 357.528° + 0.9856003° n;
    λ = L + 1.915° sin g + 0.020° sin 2g;
    R = 1.00014 − 0.01671 cos g − 0.00014 cos 2g  au.
    Against ERFA (epv00 plus aberration, precessed to date) over 1950–2050
    the direction is within 0.011° (rms 0.003°), the distance within 1e-4 au.

    Args:
        jd_tt: Julian date (TT), days, scalar or ``(N,)``.
    """
    n = np.asarray(jd_tt, float) - JD_J2000
    mean_longitude = (280.460 + 0.9856474 * n) * _DEG
    mean_anomaly = (357.528 + 0.9856003 * n) * _DEG
    longitude = mean_longitude + (1.915 * np.sin(mean_anomaly) + 0.020 * np.sin(2.0 * mean_anomaly)) * _DEG
    distance_au = 1.00014 - 0.01671 * np.cos(mean_anomaly) - 0.00014 * np.cos(2.0 * mean_anomaly)
    return _ecliptic_to_eci(longitude, 0.0 * n, distance_au * ASTRONOMICAL_UNIT_M, jd_tt)


def mean_sun_right_ascension(jd_utc):
    """Right ascension of the mean Sun, rad in [0, 2π): its mean longitude L = 280.460° + 0.9856474° n.

    The fictitious mean Sun runs along the equator at the Sun's mean rate; local
    mean solar time at a right ascension α is 12 h + (α − α_mean)/15° (h). L is the
    Astronomical Almanac's low-precision mean longitude, the one of
    :func:`sun_position_eci_m` (n = JD − 2451545.0).

    Args:
        jd_utc: Julian date, days (UTC; TT − UTC shifts L by 8·10⁻⁴ °, far below what matters here).
    """
    n = np.asarray(jd_utc, float) - JD_J2000
    return np.mod((280.460 + 0.9856474 * n) * _DEG, 2.0 * math.pi)[()]


def raan_from_local_time_of_node(ltan_h: float, epoch: Epoch) -> float:
    """RAAN at the epoch, rad in [0, 2π), of an orbit whose ascending node is at local mean solar time ``ltan_h``.

    Ω = α_mean(epoch) + 15°·(LTAN − 12 h) (:func:`mean_sun_right_ascension`).
    A sun-synchronous orbit keeps this local time while its node drifts with
    the mean Sun (J2: :attr:`pmv_ros.physics.orbit.two_body.CircularOrbit.raan_rate_rad_s`).

    Args:
        ltan_h: local time of the ascending node, h (0 … 24).
        epoch: the UTC instant at which Ω is wanted.
    """
    check_range("local time of the ascending node", ltan_h, 0.0, 24.0, " h")
    alpha = float(mean_sun_right_ascension(epoch.julian_date_utc))
    return float(np.mod(alpha + (ltan_h - 12.0) * (math.pi / 12.0), 2.0 * math.pi))


def local_time_of_node_h(orbit: CircularOrbit, epoch: Epoch, t_s):
    """Local mean solar time of the orbit's ascending node at simulation time ``t_s`` (s), h in [0, 24).

    The inverse of :func:`raan_from_local_time_of_node` for Ω(t) of the orbit;
    ``epoch`` is the UTC instant at simulation time 0.
    """
    t = np.asarray(t_s, float)
    alpha = mean_sun_right_ascension(epoch.julian_date(t))
    return np.mod(12.0 + (orbit.raan(t) - alpha) * (12.0 / math.pi), 24.0)[()]


# Periodic terms of the Moon: multiples of the Delaunay arguments (D, M, M', F)
# and amplitudes. From the ELP-2000/82 series as tabulated by Meeus (ch. 47,
# tables 47.A and 47.B), kept down to ≈ 0.01° in longitude and latitude and
# ≈ 80 km in distance. The named ones: equation of centre (0 0 1 0), evection
# (2 0 −1 0), variation (2 0 0 0), annual equation (0 1 0 0), reduction to the
# ecliptic (0 0 0 2), parallactic inequality (1 0 0 0).
#                       D   M   M'  F   longitude 1e-6 deg   distance m
_MOON_LONGITUDE_DISTANCE_TERMS = np.array([
    (0, 0, 1, 0, 6288774, -20905355),
    (2, 0, -1, 0, 1274027, -3699111),
    (2, 0, 0, 0, 658314, -2955968),
    (0, 0, 2, 0, 213618, -569925),
    (0, 1, 0, 0, -185116, 48888),
    (0, 0, 0, 2, -114332, -3149),
    (2, 0, -2, 0, 58793, 246158),
    (2, -1, -1, 0, 57066, -152138),
    (2, 0, 1, 0, 53322, -170733),
    (2, -1, 0, 0, 45758, -204586),
    (0, 1, -1, 0, -40923, -129620),
    (1, 0, 0, 0, -34720, 108743),
    (0, 1, 1, 0, -30383, 104755),
    (2, 0, 0, -2, 15327, 10321),
    (0, 0, 1, 2, -12528, 0),
    (0, 0, 1, -2, 10980, 79661),
    (4, 0, -1, 0, 10675, -34782),
    (0, 0, 3, 0, 10034, -23210),
    (4, 0, -2, 0, 8548, -21636),
    (2, 1, -1, 0, -7888, 24208),
    (2, 1, 0, 0, -6766, 30824),
    (1, 0, -1, 0, -5163, -8379),
    (1, 1, 0, 0, 4987, -16675),
    (2, -1, 1, 0, 4036, -12831),
], dtype=float)
#                       D   M   M'  F   latitude 1e-6 deg
_MOON_LATITUDE_TERMS = np.array([
    (0, 0, 0, 1, 5128122),
    (0, 0, 1, 1, 280602),
    (0, 0, 1, -1, 277693),
    (2, 0, 0, -1, 173237),
    (2, 0, -1, 1, 55413),
    (2, 0, -1, -1, 46271),
    (2, 0, 0, 1, 32573),
    (0, 0, 2, 1, 17198),
    (2, 0, 1, -1, 9266),
    (0, 0, 2, -1, 8822),
    (2, -1, 0, -1, 8216),
], dtype=float)


def _moon_fundamental_arguments(t):
    """Mean longitude L′ and Delaunay arguments D, M, M′, F of date, rad (Meeus eqs. 47.1–47.5 to T²)."""
    mean_longitude = 218.3164477 + 481267.88123421 * t - 0.0015786 * t**2
    elongation = 297.8501921 + 445267.1114034 * t - 0.0018819 * t**2
    sun_anomaly = 357.5291092 + 35999.0502909 * t - 0.0001536 * t**2
    moon_anomaly = 134.9633964 + 477198.8675055 * t + 0.0087414 * t**2
    node_distance = 93.2720950 + 483202.0175233 * t - 0.0036539 * t**2
    return mean_longitude * _DEG, np.stack([elongation, sun_anomaly, moon_anomaly, node_distance]) * _DEG


def _periodic_sum(terms, arguments, amplitude_column, eccentricity_factor, trig):
    """Σ amplitude · E^|k_M| · trig(k · arguments) over the rows of ``terms``; arguments ``(4, ...)``."""
    multiples = terms[:, :4]
    phase = np.tensordot(multiples, arguments, axes=(1, 0))  # (terms, ...)
    # Terms with the Sun's anomaly shrink with the Earth's orbital eccentricity.
    weight = eccentricity_factor[None, ...] ** np.abs(multiples[:, 1]).reshape((-1,) + (1,) * (phase.ndim - 1))
    amplitude = terms[:, amplitude_column].reshape((-1,) + (1,) * (phase.ndim - 1))
    return np.sum(amplitude * weight * trig(phase), axis=0)


def moon_position_eci_m(jd_tt):
    """Geocentric position of the Moon, m, ``(3[, N])``, mean equator and equinox of date.

    Ecliptic longitude λ = L′ + Σ l sin(·), latitude β = Σ b sin(·), distance
    Δ = 385000.56 km + Σ r cos(·), with the largest periodic terms of
    ELP-2000/82 as tabulated by Meeus (*Astronomical Algorithms*, ch. 47)
    down to ≈ 0.01°. Against ERFA's moon98 (the full ch. 47 series) over
    1950–2050 the direction is within 0.041° (rms 0.011°) and the distance
    within 81 km (tests/physics/test_ephemeris.py states how this was measured).

    Args:
        jd_tt: Julian date (TT), days, scalar or ``(N,)``.
    """
    t = (np.asarray(jd_tt, float) - JD_J2000) / DAYS_PER_JULIAN_CENTURY
    mean_longitude, arguments = _moon_fundamental_arguments(t)
    eccentricity_factor = np.asarray(1.0 - 0.002516 * t - 0.0000074 * t**2)
    longitude = mean_longitude + 1e-6 * _DEG * _periodic_sum(
        _MOON_LONGITUDE_DISTANCE_TERMS, arguments, 4, eccentricity_factor, np.sin)
    distance = MOON_MEAN_DISTANCE_M + _periodic_sum(
        _MOON_LONGITUDE_DISTANCE_TERMS, arguments, 5, eccentricity_factor, np.cos)
    latitude = 1e-6 * _DEG * _periodic_sum(_MOON_LATITUDE_TERMS, arguments, 4, eccentricity_factor, np.sin)
    return _ecliptic_to_eci(longitude, latitude, distance, jd_tt)


def _unit(vectors):
    return vectors / np.linalg.norm(vectors, axis=0)


def _as_columns(a, b):
    """``a`` and ``b`` (each ``(3,)`` or ``(3, N)``) broadcast to one shape along the trailing axes."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape[:1] != (3,) or b.shape[:1] != (3,):
        raise ValueError(f"vectors must be shaped (3,) or (3, N), got {a.shape} and {b.shape}")
    if a.ndim < b.ndim:
        a = a.reshape(a.shape + (1,) * (b.ndim - a.ndim))
    elif b.ndim < a.ndim:
        b = b.reshape(b.shape + (1,) * (a.ndim - b.ndim))
    return np.broadcast_arrays(a, b)


def sun_direction_eci(jd_tt):
    """Unit vector from the Earth's centre to the Sun, ``(3[, N])``, ECI (mean of date).

    Args:
        jd_tt: Julian date (TT), days, scalar or ``(N,)``.
    """
    return _unit(sun_position_eci_m(jd_tt))


def moon_direction_eci(jd_tt):
    """Unit vector from the Earth's centre to the Moon, ``(3[, N])``, ECI (mean of date).

    Args:
        jd_tt: Julian date (TT), days, scalar or ``(N,)``.
    """
    return _unit(moon_position_eci_m(jd_tt))


def sun_direction_from(position_eci_m, jd_tt):
    """Unit vector from an observer to the Sun, ``(3[, N])``, ECI (parallax ≤ 10″ from low orbit).

    Args:
        position_eci_m: observer position, m, ``(3,)`` or ``(3, N)``.
        jd_tt: Julian date (TT), days, scalar or ``(N,)``.
    """
    body, observer = _as_columns(sun_position_eci_m(jd_tt), position_eci_m)
    return _unit(body - observer)


def moon_direction_from(position_eci_m, jd_tt):
    """Unit vector from an observer to the Moon, ``(3[, N])``, ECI, with the parallax (≈ 1° at 500 km).

    Args:
        position_eci_m: observer position, m, ``(3,)`` or ``(3, N)``.
        jd_tt: Julian date (TT), days, scalar or ``(N,)``.
    """
    body, observer = _as_columns(moon_position_eci_m(jd_tt), position_eci_m)
    return _unit(body - observer)


_DIRECTION_FROM = {"sun": sun_direction_from, "moon": moon_direction_from}
