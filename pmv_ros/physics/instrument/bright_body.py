"""Whether the Sun or the Moon is in a chord's field (the sensor fault "bright body in a chord's field").

The angular distance from a direction to each chord's swept arc
(:func:`angular_distance_to_scan_arc`), the Earth occultation
(:func:`occulted_by_earth`), and both put together for an orbit and attitude
(:func:`bright_body_in_chords`), the bodies placed by
:mod:`pmv_ros.physics.orbit.ephemeris` (ECI there: mean equator and equinox of date).

Vectors are ``(3,)`` or ``(3, N)``; per-chord arrays ``(4, ...)`` in the
order +X, +Y, −X, −Y of :mod:`pmv_ros.physics.geometry`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..compiled import elementwise, kernel
from ..constants import EARTH_MEAN_RADIUS_M
from ..orbit.ephemeris import _DIRECTION_FROM, BODY_NAMES, Epoch, _as_columns
from ..geometry import CHORD_AZIMUTHS_RAD, dot
from .oblateness import sensor_axes_eci
from ..orbit.two_body import CircularOrbit, check_range


@elementwise
def arc_distance(x, y, z, low_rad, high_rad):
    """Angle, rad, from a direction (x, y, z) — x along the chord, y across its plane, z along the
    boresight — to the chord's arc of lines of sight at nadir angles ``low_rad`` … ``high_rad``; NaN where
    an end is NaN (:func:`angular_distance_to_scan_arc`; the sensor's kernel calls it per chord)."""
    along = math.atan2(x, z)
    if not (math.isfinite(low_rad) and math.isfinite(high_rad)) or math.isnan(along) or math.isnan(y):
        return math.nan
    if low_rad <= along <= high_rad:
        return math.atan2(abs(y), math.hypot(x, z))
    # Angle between p and the line of sight (sin φ, cos φ, 0) in (x, z, y), to the nearer end.
    to_low = math.atan2(math.hypot(y, x * math.cos(low_rad) - z * math.sin(low_rad)),
                        x * math.sin(low_rad) + z * math.cos(low_rad))
    to_high = math.atan2(math.hypot(y, x * math.cos(high_rad) - z * math.sin(high_rad)),
                         x * math.sin(high_rad) + z * math.cos(high_rad))
    return min(to_low, to_high)


def angular_distance_to_scan_arc(direction_sensor, crossing_nadir_rad, scan_start_nadir_rad):
    """Angle from a direction to each chord's swept arc of lines of sight, rad, ``(4, ...)``.

    Chord k sweeps the great-circle arc of lines of sight at azimuth α_k
    (:data:`pmv_ros.physics.geometry.CHORD_AZIMUTHS_RAD`) with nadir angles
    between the scan start θ₀ and the crossing angle. In coordinates along
    the boresight b, the chord direction c_k and the chord-plane normal n_k,
    the direction is p = (z, x, y) = (p·b, p·c_k, p·n_k); its projection on
    the chord plane sits at the signed nadir angle ψ = atan2(x, z). If ψ lies
    on the arc the distance is the angle to the plane, atan2(|y|, √(x² + z²));
    otherwise it is the angle to the nearer end of the arc (:func:`arc_distance`).

    Args:
        direction_sensor: ``(3,)`` or ``(3, N)`` direction in the sensor frame
            (any length; need not be a unit vector).
        crossing_nadir_rad: ``(4,)`` or ``(4, N)`` nadir angle where each chord
            crosses the horizon, rad (one end of the arc).
        scan_start_nadir_rad: ``(4,)`` or ``(4, N)`` scan start θ₀ of each
            chord, rad (the other end).

    Returns:
        ``(4,)`` or ``(4, N)`` angles, rad; NaN where an end angle is NaN.
    """
    p = np.asarray(direction_sensor, float)
    if p.shape[:1] != (3,):
        raise ValueError(f"direction_sensor must be shaped (3,) or (3, N), got {p.shape}")
    crossing = np.asarray(crossing_nadir_rad, float)
    start = np.asarray(scan_start_nadir_rad, float)
    for name, angles in (("crossing_nadir_rad", crossing), ("scan_start_nadir_rad", start)):
        if angles.shape[:1] != (4,):
            raise ValueError(f"{name} must be shaped (4,) or (4, N) (chords +X, +Y, −X, −Y), got {angles.shape}")
    x, y, z = chord_coordinates(p, CHORD_AZIMUTHS_RAD.reshape((4,) + (1,) * (p.ndim - 1)))
    return arc_distance(x, y, z, np.minimum(crossing, start), np.maximum(crossing, start))


def chord_coordinates(direction_sensor, azimuth_rad):
    """(x, y, z) of a sensor-frame direction in a chord's coordinates: along the chord at ``azimuth_rad``,
    across its plane, along the boresight (arrays broadcast)."""
    p = np.asarray(direction_sensor, float)
    cos_a, sin_a = np.cos(azimuth_rad), np.sin(azimuth_rad)
    return cos_a * p[0] + sin_a * p[1], -sin_a * p[0] + cos_a * p[1], -p[2] + 0.0 * cos_a


def _check_exclusion(name: str, exclusion_rad) -> float:
    """The exclusion angle as float, rad, or ValueError naming it and the range 0 … π/2."""
    return check_range(f"exclusion angle for {name}", exclusion_rad, 0.0, 0.5 * math.pi, " rad")


def chords_seeing_body(body_direction_sensor, horizon_nadir_rad, scan_start_nadir_rad, exclusion_rad):
    """Which chords have a bright body within ``exclusion_rad`` of their swept arc, ``(4[, N])`` bool.

    The arc is the part of the scan the IFOV centre sweeps before the
    crossing: from θ₀ down to the crossing angle (physics.md §1, §4 step 1).
    The exclusion angle should cover the IFOV half-width γ (1.1°), the body's
    own radius and the stray-light margin of the optics. NaN angles (no
    horizon: the chord is already invalid) give False. Occultation by the
    Earth is not looked at here (see :func:`occulted_by_earth`).

    Args:
        body_direction_sensor: ``(3,)`` or ``(3, N)`` body direction in the sensor frame.
        horizon_nadir_rad: ``(4,)`` or ``(4, N)`` crossing nadir angle per chord, rad.
        scan_start_nadir_rad: ``(4,)`` or ``(4, N)`` scan start θ₀ per chord, rad.
        exclusion_rad: exclusion angle, rad (0 … π/2).

    Raises:
        ValueError: an exclusion angle out of range, or arrays of the wrong shape.
    """
    exclusion = _check_exclusion("the body", exclusion_rad)
    distance = angular_distance_to_scan_arc(body_direction_sensor, horizon_nadir_rad, scan_start_nadir_rad)
    return np.nan_to_num(distance, nan=np.inf) <= exclusion


@kernel
def occulted(direction, position_m, earth_radius_m):
    """:func:`occulted_by_earth` of one direction and position (3-tuples): the sensor's kernel calls it."""
    r_norm = math.sqrt(dot(position_m, position_m))
    cos_to_nadir = -dot(direction, position_m) / (math.sqrt(dot(direction, direction)) * r_norm)
    ratio = earth_radius_m / r_norm
    return cos_to_nadir > math.sqrt(1.0 - ratio * ratio)


@kernel
def _occulted_each(direction, position, earth_radius_m, out):
    for n in range(direction.shape[1]):
        out[n] = occulted((direction[0, n], direction[1, n], direction[2, n]),
                          (position[0, n], position[1, n], position[2, n]), earth_radius_m)


def occulted_by_earth(direction, position_m, earth_radius_m: float = EARTH_MEAN_RADIUS_M):
    """Whether a direction seen from ``position_m`` points behind the Earth's disc (a sphere), bool.

    True when the angle between the direction and the nadir is below the
    Earth's angular radius asin(R/|r|). The body's own radius is not
    counted: a body whose centre is just behind the limb counts as hidden.

    Args:
        direction: ``(3,)`` or ``(3, N)`` direction from the observer (any length), same frame as the position.
        position_m: ``(3,)`` or ``(3, N)`` observer position from the Earth's centre, m.
        earth_radius_m: radius of the occulting sphere, m (mean radius by default; raise
            it to let the atmosphere occult too).

    Returns:
        bool, shaped like the broadcast trailing axes (``()`` or ``(N,)``).
    """
    radius = check_range("Earth radius for occultation", earth_radius_m / 1e3, 1000.0, 10000.0, " km") * 1e3
    d, r = _as_columns(direction, position_m)
    shape = d.shape[1:]
    out = np.empty(int(np.prod(shape)), bool)
    _occulted_each(np.ascontiguousarray(d.reshape(3, -1)), np.ascontiguousarray(r.reshape(3, -1)), radius, out)
    return out.reshape(shape)[()] if not shape else out.reshape(shape)


@dataclass(frozen=True)
class BrightBodyCheck:
    """Result of :func:`bright_body_in_chords` for N samples.

    Fields:
        bodies: names of the bodies checked, in order (e.g. ``("sun", "moon")``).
        in_field: ``(B, 4, N)`` bool, body b is within its exclusion angle of
            chord k's swept arc and not hidden by the Earth.
        near_arc: ``(B, 4, N)`` bool, the same without the occultation test.
        occulted: ``(B, N)`` bool, body b is behind the Earth's disc.
        distance_rad: ``(B, 4, N)`` angle from body b to chord k's swept arc, rad (NaN: no horizon).
        direction_sensor: ``(3, B, N)`` unit direction of each body from the spacecraft, sensor frame.
    """

    bodies: tuple
    in_field: np.ndarray
    near_arc: np.ndarray
    occulted: np.ndarray
    distance_rad: np.ndarray
    direction_sensor: np.ndarray

    @property
    def blinded(self) -> np.ndarray:
        """``(4, N)`` bool: some body is in the chord's field (the chord's reading is invalid)."""
        return np.any(self.in_field, axis=0)

    @property
    def blinding_body(self) -> np.ndarray:
        """``(4, N)`` int8: index into :attr:`bodies` of the first body in the chord's field, −1 for none."""
        first = np.argmax(self.in_field, axis=0).astype(np.int8)
        return np.where(self.blinded, first, np.int8(-1)).astype(np.int8)

    def body(self, name: str) -> np.ndarray:
        """``(4, N)`` bool: the named body is in the chord's field."""
        return self.in_field[self.bodies.index(name)]


def bright_body_in_chords(orbit: CircularOrbit, t_s, q_orbital_to_body, epoch: Epoch,
                          horizon_nadir_rad, scan_start_nadir_rad, exclusion_rad,
                          bodies=("sun", "moon"), earth_radius_m: float = EARTH_MEAN_RADIUS_M) -> BrightBodyCheck:
    """Which chords see the Sun or the Moon in their field, for an orbit, times and attitudes.

    The body directions come from the spacecraft (Moon parallax included),
    go into the sensor frame through :func:`pmv_ros.physics.instrument.oblateness.sensor_axes_eci`,
    and are tested against each chord's swept arc
    (:func:`angular_distance_to_scan_arc`); a body behind the Earth's disc
    (:func:`occulted_by_earth`) cannot blind a chord.

    Args:
        orbit: the spacecraft orbit (its ECI is this module's mean-of-date frame).
        t_s: simulation time(s), s, scalar or ``(N,)``.
        q_orbital_to_body: ``(4[, N])`` attitude (x, y, z, w); None for zero attitude.
        epoch: the run epoch (simulation time 0).
        horizon_nadir_rad: ``(4, N)`` crossing nadir angle per chord, rad.
        scan_start_nadir_rad: ``(4, N)`` or ``(4,)`` scan start θ₀ per chord, rad.
        exclusion_rad: exclusion angle, rad (0 … π/2): one for all bodies, or
            a mapping from body name to angle.
        bodies: names from :data:`BODY_NAMES` to check, in order of precedence.
        earth_radius_m: radius of the occulting sphere, m.

    Raises:
        ValueError: an unknown or repeated body, an exclusion angle out of range, or
            arrays of the wrong shape.
    """
    bodies = tuple(bodies)
    if not bodies or len(set(bodies)) != len(bodies) or any(b not in BODY_NAMES for b in bodies):
        raise ValueError(f"bodies = {bodies!r} must be distinct names from {BODY_NAMES}")
    if isinstance(exclusion_rad, Mapping):
        missing = [b for b in bodies if b not in exclusion_rad]
        if missing:
            raise ValueError(f"exclusion angle missing for {missing}")
        exclusions = [_check_exclusion(b, exclusion_rad[b]) for b in bodies]
    else:
        exclusions = [_check_exclusion(b, exclusion_rad) for b in bodies]

    t = np.atleast_1d(np.asarray(t_s, float))
    position, _ = orbit.state_eci(t)
    axes = sensor_axes_eci(orbit, t, q_orbital_to_body)
    jd_tt = epoch.julian_date_tt(t)

    directions, occulted, distances = [], [], []
    for name in bodies:  # a loop over at most two bodies, not over samples
        direction_eci = _DIRECTION_FROM[name](position, jd_tt)
        occulted.append(occulted_by_earth(direction_eci, position, earth_radius_m))
        direction = np.einsum("ji...,j...->i...", axes, direction_eci)
        directions.append(direction)
        distances.append(angular_distance_to_scan_arc(direction, horizon_nadir_rad, scan_start_nadir_rad))
    distance = np.stack(distances)
    limit = np.array(exclusions).reshape((-1,) + (1,) * (distance.ndim - 1))
    near = np.nan_to_num(distance, nan=np.inf) <= limit
    hidden = np.stack(occulted)
    return BrightBodyCheck(
        bodies=bodies,
        in_field=near & ~hidden[:, None, ...],
        near_arc=near,
        occulted=hidden,
        distance_rad=distance,
        direction_sensor=np.stack(directions, axis=1),
    )
