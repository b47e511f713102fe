"""An orbit flown from a two-line element set: SGP4, and TEME turned into the project's ECI frame.

``orbit.source: tle`` (interfaces.md "Orbit sources"). Three parts:

1. the element set — :func:`parse_element_set` checks the two lines the way
   the format defines them (NORAD two-line elements, as in Hoots & Roehrich,
   *Spacetrack Report No. 3*, and CelesTrak's format notes): 69 columns,
   the line numbers, the blank separator columns, the modulo-10 checksums,
   the same catalogue number on both lines, each field a number of its
   layout and inside its range, and a perigee above the atmosphere; every
   problem is one ValueError naming the line, the field and its columns;
2. propagation — SGP4 of the ``sgp4`` package (python-sgp4, Vallado's 2006
   code, WGS72 constants as the element sets are fitted with). A time at
   which SGP4 returns an error code raises :class:`OrbitPropagationError`,
   which names the time and SGP4's message;
3. the frame — SGP4 gives TEME (true equator, "uniform" equinox of date).
   The project's ECI frame is the mean equator and mean equinox of date
   (:mod:`pmv_ros.physics.orbit.ephemeris`): r_MOD = Nᵀ · R_z(Eq) · r_TEME, with
   N the IAU 1980 nutation matrix (106 terms, ``erfa.nutm80``: mean → true
   of date) and Eq the equation of the equinoxes (IAU 1994,
   ``erfa.eqeq94``): TEME's x axis lies Eq east of the true equinox along
   the true equator (Vallado et al. 2006, AIAA 2006-6753, §"TEME"). Error
   bound of the conversion: the 1994 equation of the equinoxes carries two
   terms (≤ 0.0027″) that the 1982 one of the TEME definition does not,
   0.1 m at 7000 km; the nutation is evaluated in TT (TT − UTC from the
   leap-second table: :func:`pmv_ros.physics.orbit.ephemeris.tt_minus_utc_s`);
   the celestial-pole offsets (dψ, dε, ≈ 0.05″ = 2 m) are left out, as TEME
   leaves them out. Velocities are
   rotated by the same matrix (its own rate, ≈ 1e-11 rad/s, is neglected:
   < 1e-7 m/s). The Earth-fixed frame of the project then follows from the
   GMST rotation of :func:`pmv_ros.physics.orbit.two_body.eci_to_ecef`, which leaves
   nutation out (≤ 0.005°, the project's documented approximation).

SGP4's own error against the real spacecraft is ≈ 1 km at the element set's
epoch, growing by 1–3 km a day (Vallado et al. 2006): element sets are fresh
for days, not years.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone

import numpy as np

from ..constants import EARTH_MEAN_RADIUS_M, SECONDS_PER_DAY
from .ephemeris import JD_J2000, Epoch, tt_minus_utc_s
from .two_body import MAX_ALTITUDE_M, MIN_ALTITUDE_M, StateOrbit, orbit_angles_from_state

#: Columns a line of an element set has (the checksum is the last).
LINE_LENGTH = 69

#: Separator columns that must be blank, 1-based, per line (the format's layout).
BLANK_COLUMNS = {1: (2, 9, 18, 33, 44, 53, 62, 64), 2: (2, 8, 17, 26, 34, 43, 52)}

#: Step of the start-up check of SGP4 over the first span of a run, s: decay shows as an error
#: code at some time, and one a minute finds it (the last minutes of a decay take longer).
CHECK_STEP_S = 60.0

#: Longest stretch between the element set's epoch and a run, days: SGP4 is fitted for days to
#: weeks (its error grows by 1–3 km a day); a year keeps a campaign's days in range.
MAX_DAYS_FROM_ELEMENTS = 366.0

_JD_MJD_ZERO = 2400000.5
_EPOCH_J2000 = datetime(2000, 1, 1, 12, 0, 0, tzinfo=timezone.utc)


class OrbitPropagationError(ValueError):
    """SGP4 returned an error code: ``t_s`` the simulation time, ``code`` SGP4's code, and a one-line message."""

    def __init__(self, message: str, t_s: float, code: int):
        super().__init__(message)
        self.t_s, self.code = t_s, code


@dataclass(frozen=True)
class ElementSet:
    """The fields of a checked two-line element set (degrees and revolutions a day as written)."""

    line1: str
    line2: str
    catalog_number: str
    epoch_utc: datetime
    inclination_deg: float
    raan_deg: float
    eccentricity: float
    arg_perigee_deg: float
    mean_anomaly_deg: float
    mean_motion_rev_per_day: float
    bstar_per_earth_radius: float

    @property
    def epoch_julian_date_utc(self) -> float:
        """The element set's epoch as a Julian date (UTC scale), days."""
        return JD_J2000 + (self.epoch_utc - _EPOCH_J2000).total_seconds() / SECONDS_PER_DAY


def tle_checksum(line: str) -> int:
    """Modulo-10 checksum of the first 68 columns: the sum of the digits, a minus sign counting 1."""
    return sum(int(c) if c.isdigit() else (1 if c == "-" else 0) for c in line[:68]) % 10


def _field(line: str, number: int, name: str, first: int, last: int, pattern: str, low=None, high=None,
           convert=float, high_open: bool = False):
    """The field in 1-based columns ``first … last``, matched, converted and range-checked; ValueError naming it."""
    text = line[first - 1:last]
    where = f"orbit.tle_line{number}: {name} (columns {first}–{last})"
    if not re.fullmatch(pattern, text):
        raise ValueError(f"{where} = {text!r} is not in the element-set format")
    value = convert(text)
    if low is not None and (value < low or (value >= high if high_open else value > high)):
        bracket = ")" if high_open else "]"
        raise ValueError(f"{where} = {text.strip()} is outside the allowed range [{low:g}, {high:g}{bracket}")
    return value


def _implied_decimal(text: str) -> float:
    """A field written with an implied leading decimal point and an exponent: ' 28098-4' is 0.28098e-4."""
    text = text.strip()
    sign = -1.0 if text.startswith("-") else 1.0
    body = text.lstrip("+-")
    mantissa, exponent = body[:-2], body[-2:]
    return sign * float("0." + mantissa) * 10.0 ** int(exponent)


def parse_element_set(line1, line2) -> ElementSet:
    """Check and read a two-line element set; ValueError with one line naming the line, field and columns."""
    lines = []
    for number, line in ((1, line1), (2, line2)):
        if not isinstance(line, str) or not line.strip():
            raise ValueError(f"orbit.tle_line{number} is empty: give line {number} of a two-line element set")
        line = line.rstrip("\r\n ")
        if not line.isascii() or not line.isprintable():
            raise ValueError(f"orbit.tle_line{number}: only printable ASCII characters belong in an element set")
        if len(line) != LINE_LENGTH:
            raise ValueError(f"orbit.tle_line{number}: column layout: {len(line)} columns, an element-set line "
                             f"has {LINE_LENGTH}")
        if line[0] != str(number):
            raise ValueError(f"orbit.tle_line{number}: column layout: column 1 is {line[0]!r}, the line number "
                             f"{number}")
        for column in BLANK_COLUMNS[number]:
            if line[column - 1] != " ":
                raise ValueError(f"orbit.tle_line{number}: column layout: column {column} must be blank, "
                                 f"found {line[column - 1]!r} (fields shifted?)")
        if not line[68].isdigit():
            raise ValueError(f"orbit.tle_line{number}: checksum (column 69) = {line[68]!r} is not a digit")
        if int(line[68]) != tle_checksum(line):
            raise ValueError(f"orbit.tle_line{number}: checksum (column 69) is {line[68]}, the line's is "
                             f"{tle_checksum(line)}")
        lines.append(line)
    line1, line2 = lines
    catalog = _field(line1, 1, "catalog number", 3, 7, r"[0-9A-Z][0-9]{4}|[ 0-9]{4}[0-9]", convert=str)
    if line2[2:7] != catalog:
        raise ValueError(f"orbit.tle_line2: catalog number (columns 3–7) = {line2[2:7]!r} is not line 1's "
                         f"{catalog!r}: the lines belong to two element sets")
    year = _field(line1, 1, "epoch year", 19, 20, r"[0-9]{2}", convert=int)
    year += 1900 if year >= 57 else 2000  # the format's two-digit years: 57 … 99 are 1957 … 1999
    days_in_year = 366 if (year % 4 == 0 and (year % 100 != 0 or year % 400 == 0)) else 365
    day = _field(line1, 1, "epoch day of year", 21, 32, r"[ 0-9]{3}\.[0-9]{8}", 1.0, days_in_year + 1.0,
                 high_open=True)
    epoch = datetime(year, 1, 1, tzinfo=timezone.utc) + timedelta(days=day - 1.0)
    _field(line1, 1, "first derivative of the mean motion", 34, 43, r"[ +-]\.[0-9]{8}")
    _field(line1, 1, "second derivative of the mean motion", 45, 52, r"[ +-][0-9]{5}[+-][0-9]",
           convert=_implied_decimal)
    bstar = _field(line1, 1, "B* drag term", 54, 61, r"[ +-][0-9]{5}[+-][0-9]", convert=_implied_decimal)
    inclination = _field(line2, 2, "inclination", 9, 16, r"[ 0-9]{3}\.[0-9]{4}", 0.0, 180.0)
    raan = _field(line2, 2, "right ascension of the ascending node", 18, 25, r"[ 0-9]{3}\.[0-9]{4}", 0.0, 360.0,
                  high_open=True)
    eccentricity = _field(line2, 2, "eccentricity", 27, 33, r"[0-9]{7}", convert=lambda t: float("0." + t))
    arg_perigee = _field(line2, 2, "argument of perigee", 35, 42, r"[ 0-9]{3}\.[0-9]{4}", 0.0, 360.0,
                         high_open=True)
    mean_anomaly = _field(line2, 2, "mean anomaly", 44, 51, r"[ 0-9]{3}\.[0-9]{4}", 0.0, 360.0, high_open=True)
    mean_motion = _field(line2, 2, "mean motion", 53, 63, r"[ 0-9]{2}\.[0-9]{8}", 0.05, 17.0)
    return ElementSet(line1, line2, catalog, epoch, inclination, raan, eccentricity, arg_perigee, mean_anomaly,
                      mean_motion, bstar)


def make_element_set(epoch_utc: datetime, inclination_deg: float, raan_deg: float, eccentricity: float,
                     arg_perigee_deg: float, mean_anomaly_deg: float, mean_motion_rev_per_day: float,
                     catalog_number: int = 99999, bstar_per_earth_radius: float = 0.0) -> tuple[str, str]:
    """Two element-set lines from SGP4 mean elements (``sgp4init`` and python-sgp4's ``export_tle``).

    The lines are checked by :func:`parse_element_set` before they are
    returned. Angles are written to 1e-4°, the mean motion to 1e-8 rev/day,
    the eccentricity to 1e-7 and the epoch to 1e-8 day (≈ 1 ms).
    """
    WGS72, Satrec = _sgp4_api()
    from sgp4.exporter import export_tle

    epoch = epoch_utc.astimezone(timezone.utc)
    days_since_1949 = (epoch - datetime(1949, 12, 31, tzinfo=timezone.utc)).total_seconds() / SECONDS_PER_DAY
    satrec = Satrec()
    satrec.sgp4init(WGS72, "i", int(catalog_number), days_since_1949, float(bstar_per_earth_radius), 0.0, 0.0,
                    float(eccentricity), math.radians(arg_perigee_deg % 360.0), math.radians(inclination_deg),
                    math.radians(mean_anomaly_deg % 360.0), mean_motion_rev_per_day * 2.0 * math.pi / 1440.0,
                    math.radians(raan_deg % 360.0))
    satrec.classification = "U"
    satrec.intldesg = ""
    line1, line2 = export_tle(satrec)
    parse_element_set(line1, line2)
    return line1, line2


def element_set_altitude_m(line1, line2) -> float:
    """The nominal altitude of an element set: SGP4's mean semi-major axis less the 6371 km mean radius, m."""
    WGS72, Satrec = _sgp4_api()
    elements = parse_element_set(line1, line2)
    satrec = Satrec.twoline2rv(elements.line1, elements.line2, WGS72)
    return float(satrec.a * satrec.radiusearthkm * 1e3 - EARTH_MEAN_RADIUS_M)


def teme_to_mod_matrix(julian_date_utc):
    """Rotation from TEME to the mean equator and equinox of date at UTC Julian date(s): ``(3, 3[, N])``.

    Nᵀ · R_z(Eq) (module docstring): ``erfa.nutm80`` and ``erfa.eqeq94`` at
    TT (:func:`~pmv_ros.physics.orbit.ephemeris.tt_minus_utc_s`).
    """
    import erfa

    julian_date_utc = np.asarray(julian_date_utc, float)
    mjd_tt = julian_date_utc - _JD_MJD_ZERO + tt_minus_utc_s(julian_date_utc) / SECONDS_PER_DAY
    nutation = erfa.nutm80(_JD_MJD_ZERO, mjd_tt)  # (..., 3, 3), mean → true of date
    eq = erfa.eqeq94(_JD_MJD_ZERO, mjd_tt)
    c, s = np.cos(eq), np.sin(eq)
    zero, one = np.zeros_like(c), np.ones_like(c)
    # R_z(Eq) as an active rotation: TEME coordinates → true-of-date coordinates.
    spin = np.stack([np.stack([c, -s, zero], -1), np.stack([s, c, zero], -1), np.stack([zero, zero, one], -1)], -2)
    matrix = np.swapaxes(nutation, -1, -2) @ spin
    return np.moveaxis(matrix, (-2, -1), (0, 1)) if matrix.ndim == 3 else matrix


class TleOrbit(StateOrbit):
    """The orbit of an element set, propagated by SGP4 and given in the project's ECI frame.

    The same interface as :class:`pmv_ros.physics.orbit.two_body.CircularOrbit` where
    the sensor, the pipeline and the monitor use it; its state, frame, u,
    inclination and altitude are those of the SGP4 state at each time
    (:class:`pmv_ros.physics.orbit.two_body.StateOrbit`). The nominal elements
    (``altitude_m``: SGP4's mean semi-major axis less the 6371 km mean
    radius; ``inclination_rad``: the mean inclination; ``raan_rad`` and
    ``arg_latitude_at_epoch_rad``: osculating at ``epoch_s``; ``period_s``:
    nodal, from SGP4's secular rates) are for messages, the instrument's fixed
    scan start and the number of samples in an orbit.

    Args:
        line1, line2: the element set (:func:`parse_element_set`).
        utc_at_epoch: the UTC instant at simulation time ``epoch_s``.
        epoch_s: the simulation time of the run's start, s.
        check_span_s: SGP4 is run over ``epoch_s … epoch_s + check_span_s``
            every :data:`CHECK_STEP_S` at construction: an error code there
            is a ValueError naming the time now, not a failure mid-run.

    Raises:
        ValueError: a malformed element set, an orbit below the atmosphere, a
            run more than :data:`MAX_DAYS_FROM_ELEMENTS` from the element set's
            epoch, or an SGP4 error code within the checked span
            (:class:`OrbitPropagationError`).
    """

    def __init__(self, line1: str, line2: str, utc_at_epoch: Epoch, epoch_s: float = 0.0,
                 check_span_s: float = SECONDS_PER_DAY):
        WGS72, Satrec = _sgp4_api()
        self.elements = parse_element_set(line1, line2)
        self._last = None  # (times, state) of the last state_eci call
        self.epoch_s = float(epoch_s)
        self.utc_at_epoch = utc_at_epoch
        satrec = Satrec.twoline2rv(self.elements.line1, self.elements.line2, WGS72)
        self._satrec = satrec
        # Minutes from the element set's epoch to the run's start (the clock's epoch_s).
        self._tsince_at_epoch_min = (utc_at_epoch.julian_date_utc - (satrec.jdsatepoch + satrec.jdsatepochF)) * 1440.0
        days = self._tsince_at_epoch_min / 1440.0
        if abs(days) > MAX_DAYS_FROM_ELEMENTS:
            raise ValueError(f"sim.epoch_utc is {days:+.1f} days from the element set's epoch "
                             f"{self.elements.epoch_utc:%Y-%m-%dT%H:%M:%S}Z: SGP4 holds for days to weeks, at most "
                             f"{MAX_DAYS_FROM_ELEMENTS:g} days are accepted (use a fresher element set)")
        radius_km = satrec.radiusearthkm
        perigee_m = satrec.a * radius_km * 1e3 * (1.0 - satrec.ecco) - EARTH_MEAN_RADIUS_M
        apogee_m = satrec.a * radius_km * 1e3 * (1.0 + satrec.ecco) - EARTH_MEAN_RADIUS_M
        if math.isfinite(perigee_m) and perigee_m < MIN_ALTITUDE_M:
            raise ValueError(f"orbit.tle_line2: the orbit is below the atmosphere: perigee {perigee_m / 1e3:.1f} km "
                             f"above the mean radius, at least {MIN_ALTITUDE_M / 1e3:g} km is needed "
                             "(mean motion and eccentricity)")
        if satrec.error or not math.isfinite(perigee_m):
            raise ValueError(f"orbit.tle_line2: SGP4 cannot start from these elements (error {satrec.error}: "
                             f"{_sgp4_message(satrec.error)})")
        if apogee_m > MAX_ALTITUDE_M:
            raise ValueError(f"orbit.tle_line2: apogee {apogee_m / 1e3:.0f} km is above the allowed "
                             f"{MAX_ALTITUDE_M / 1e3:g} km (mean motion and eccentricity)")
        if check_span_s > 0.0:
            self.check_propagation(self.epoch_s, self.epoch_s + check_span_s)
        position, velocity = self.state_eci(np.array([self.epoch_s]))
        u, _, _ = orbit_angles_from_state(position[:, 0], velocity[:, 0])
        h = np.cross(position[:, 0], velocity[:, 0])
        self.raan_rad = float(math.atan2(h[0], -h[1]))
        self.arg_latitude_at_epoch_rad = float(u)
        self.altitude_m = float(satrec.a * radius_km * 1e3 - EARTH_MEAN_RADIUS_M)
        self.inclination_rad = float(satrec.inclo)
        self.eccentricity = float(satrec.ecco)
        self.j2_node_drift = True  # SGP4 carries the secular J2 drift of node, perigee and mean anomaly

    def check_propagation(self, first_s: float, last_s: float) -> None:
        """Run SGP4 every :data:`CHECK_STEP_S` from ``first_s`` to ``last_s`` (simulation times, s), and at both ends.

        Raises:
            OrbitPropagationError: one line naming the first time SGP4 returns an error code.
        """
        grid = np.r_[np.arange(first_s, last_s, CHECK_STEP_S), last_s]
        self.state_teme(grid)

    @property
    def mean_motion_rad_s(self) -> float:
        """Rate of the argument of latitude averaged over an orbit (SGP4's secular dM/dt + dω/dt), rad/s."""
        return (self._satrec.mdot + self._satrec.argpdot) / 60.0

    @property
    def period_s(self) -> float:
        """Nodal period, s."""
        return 2.0 * math.pi / self.mean_motion_rad_s

    @property
    def raan_rate_rad_s(self) -> float:
        """Secular node drift of SGP4, rad/s."""
        return self._satrec.nodedot / 60.0

    def utc_julian_date(self, t_s):
        """UTC Julian date at simulation time(s) ``t_s``, days."""
        return self.utc_at_epoch.julian_date_utc + (np.asarray(t_s, float) - self.epoch_s) / SECONDS_PER_DAY

    def minutes_since_elements(self, t_s):
        """Minutes from the element set's epoch at simulation time(s) ``t_s`` (SGP4's tsince)."""
        return self._tsince_at_epoch_min + (np.asarray(t_s, float) - self.epoch_s) / 60.0

    def state_teme(self, t_s):
        """SGP4's position (m) and velocity (m/s) in TEME, each ``(3,)`` or ``(3, N)``.

        Raises:
            OrbitPropagationError: SGP4 returns an error code at one of the times (the first is named).
        """
        t = np.asarray(t_s, float)
        flat = np.ascontiguousarray(np.atleast_1d(t).ravel())
        satrec = self._satrec
        fraction = satrec.jdsatepochF + self.minutes_since_elements(flat) / 1440.0
        errors, position, velocity = satrec.sgp4_array(np.full(flat.shape, satrec.jdsatepoch), fraction)
        bad = np.flatnonzero(errors) if np.any(errors) else np.flatnonzero(~np.isfinite(flat))
        if bad.size:
            k = bad[0]
            code = int(errors[k])
            raise OrbitPropagationError(self._failure_message(float(flat[k]), code), float(flat[k]), code)
        position = position.T * 1e3
        velocity = velocity.T * 1e3
        if t.ndim == 0:
            return position[:, 0], velocity[:, 0]
        return position.reshape((3,) + t.shape), velocity.reshape((3,) + t.shape)

    def state_eci(self, t_s):
        """Position (m) and velocity (m/s) in the project's ECI frame (mean of date), ``(3,)`` or ``(3, N)``.

        The frame rotation is evaluated at the nearest whole UTC minute (it
        turns by < 0.2″ a day: ≤ 1e-4″, 3 mm, off). The sensor asks for the
        same times several times per block; the last answer is kept.
        """
        t = np.asarray(t_s, float)
        key = (t.shape, t.tobytes())
        if self._last is not None and self._last[0] == key:
            return self._last[1]
        position, velocity = self.state_teme(t)
        minutes = np.round(np.atleast_1d(self.utc_julian_date(t)).ravel() * 1440.0)
        whole, index = np.unique(minutes, return_inverse=True)
        rotation = teme_to_mod_matrix(whole / 1440.0)[..., index].reshape((3, 3) + t.shape)
        state = (np.einsum("ij...,j...->i...", rotation, position), np.einsum("ij...,j...->i...", rotation, velocity))
        for part in state:
            part.setflags(write=False)
        self._last = (key, state)
        return state

    def _failure_message(self, t_s: float, code: int) -> str:
        if not math.isfinite(t_s):
            return f"SGP4 was asked for the state at t = {t_s} s"
        seconds = round((float(self.utc_julian_date(t_s)) - JD_J2000) * SECONDS_PER_DAY)  # to the second
        when = _EPOCH_J2000 + timedelta(seconds=seconds)
        return (f"SGP4 error {code} at t = {t_s:.1f} s ({when:%Y-%m-%dT%H:%M:%S}Z, "
                f"{float(self.minutes_since_elements(t_s)) / 1440.0:+.3f} days from the element set's epoch): "
                f"{_sgp4_message(code)}")


#: The refusal of an element set where python-sgp4 is not installed (it has no rosdep key: package.xml).
NO_SGP4 = "orbit.source tle needs python-sgp4, which cannot be imported: pip install sgp4"


def _sgp4_api():
    """python-sgp4's ``(WGS72, Satrec)``; ValueError (:data:`NO_SGP4`) where it is not installed."""
    try:
        from sgp4.api import WGS72, Satrec
    except ImportError:
        raise ValueError(NO_SGP4) from None
    return WGS72, Satrec


def _sgp4_message(code: int) -> str:
    from sgp4.api import SGP4_ERRORS

    return SGP4_ERRORS.get(code, "unknown error")
