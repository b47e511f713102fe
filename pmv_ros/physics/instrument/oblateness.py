"""The oblateness error of the geometric vertical: from ray geometry, and in closed form.

The sensor finds the geometric vertical — the bisector of the tangent rays of
opposite chords — which on an ellipsoid differs from the geocentric vertical
(physics.md §2.1). :func:`sensed_roll_pitch` gets it from exact tangency on
the ellipsoid for any orbit position and attitude; :func:`oblateness_error`
is that reading at zero attitude. :func:`closed_form_oblateness` is the
published approximation, used for on-board compensation and as a cross-check.
Signs follow :mod:`pmv_ros.physics.attitude` (REP-103); the published table's
(paper) signs are the opposite for roll and pitch — convert with
:func:`pmv_ros.physics.conventions.convert` where the table is read or printed.
"""

from __future__ import annotations

import math

import numpy as np

from ..attitude import body_axes_in_orbital, roll_pitch_from_nadir
from ..compiled import kernel
from ..constants import EARTH_MEAN_RADIUS_M, GRS80, Ellipsoid
from ..geometry import tangent_nadir_angles, vertical_from_horizon_angles
from ..orbit.two_body import CircularOrbit


def sensor_axes_eci(orbit: CircularOrbit, t_s, q_orbital_to_body=None):
    """Sensor (= body) axes in ECI, ``(3, 3[, N])``: orbital frame times the body attitude.

    Args:
        orbit: the spacecraft orbit.
        t_s: simulation time(s), s.
        q_orbital_to_body: ``(4[, N])`` attitude (x, y, z, w); None for zero attitude.
    """
    frame = orbit.orbital_frame_eci(t_s)
    if q_orbital_to_body is None:
        return frame
    body = body_axes_in_orbital(q_orbital_to_body)
    return np.einsum("ij...,jk...->ik...", frame, body)


def sensed_roll_pitch(orbit: CircularOrbit, t_s, q_orbital_to_body=None, ellipsoid: Ellipsoid = GRS80, height_m=0.0):
    """Roll and pitch, rad, an ideal-horizon sensor reads (geometry only, no radiance).

    Args:
        orbit: the spacecraft orbit.
        t_s: simulation time(s), s (scalar or ``(N,)``).
        q_orbital_to_body: ``(4[, N])`` body attitude; None for zero attitude.
        ellipsoid: Earth figure.
        height_m: height of the grazing layer above the ellipsoid, m.

    Returns:
        (roll_rad, pitch_rad), each shaped like ``t_s``.
    """
    position, _ = orbit.state_eci(t_s)
    angles = tangent_nadir_angles(position, sensor_axes_eci(orbit, t_s, q_orbital_to_body), ellipsoid, height_m)
    return roll_pitch_from_nadir(vertical_from_horizon_angles(angles))


def oblateness_error(orbit: CircularOrbit, u_rad, ellipsoid: Ellipsoid = GRS80, height_m=0.0):
    """Oblateness error (roll, pitch), rad, at arguments of latitude ``u_rad``: the zero-attitude reading.

    Vectorised: one call for any number of orbit positions (all four chords at once).
    """
    return sensed_roll_pitch(orbit, orbit.time_of_argument_of_latitude(u_rad), None, ellipsoid, height_m)


@kernel
def closed_form(u_rad, altitude_m, inclination_rad, a_m, b_m, mean_radius_m):
    """:func:`closed_form_oblateness` of one orbit position (floats): (meridional, roll, pitch), rad; NaN for a
    non-finite u or inclination or an altitude outside (0, ∞). The sensor's kernel calls it per sample."""
    if not (math.isfinite(u_rad) and math.isfinite(inclination_rad) and 0.0 < altitude_m < math.inf):
        return math.nan, math.nan, math.nan
    r, h = mean_radius_m, altitude_m
    subsatellite_lat = math.asin(math.sin(inclination_rad) * math.sin(u_rad))
    offset = 0.5 * math.pi - math.asin(r / (r + h))
    slant = math.sqrt(h * (2.0 * r + h))
    lat1, lat2 = subsatellite_lat - offset, subsatellite_lat + offset
    r1 = a_m * b_m / math.hypot(b_m * math.cos(lat1), a_m * math.sin(lat1))
    r2 = a_m * b_m / math.hypot(b_m * math.cos(lat2), a_m * math.sin(lat2))
    meridional = 0.5 * (math.atan((r1 - r) / slant) - math.atan((r2 - r) / slant))
    b_angle = math.atan2(math.cos(inclination_rad), math.sin(inclination_rad) * math.cos(u_rad))
    return meridional, meridional * math.sin(b_angle), -meridional * math.cos(b_angle)


@kernel
def _closed_form_each(u_rad, altitude_m, inclination_rad, a_m, b_m, mean_radius_m, out):
    for n in range(u_rad.size):
        out[0, n], out[1, n], out[2, n] = closed_form(u_rad[n], altitude_m[n], inclination_rad[n], a_m, b_m,
                                                      mean_radius_m)


def closed_form_oblateness(u_rad, altitude_m, inclination_rad, ellipsoid: Ellipsoid = GRS80,
                           mean_radius_m: float = EARTH_MEAN_RADIUS_M):
    """Published closed-form oblateness error (physics.md §2.1): meridional, roll, pitch in rad.

    Φ1,2 = Φ0 ∓ (90° − φ0); (Δβ)m = ½[atan((R1 − R)/L) − atan((R2 − R)/L)];
    B is the angle between the meridian and the orbit plane.

    Two choices that the text leaves open, settled against the published table
    and the ray geometry:

    * B is taken with ``arctan2(cos i, sin i cos u)`` so that it runs through
      the whole orbit (for u in 90…270° the along-track component changes
      sign, which the single-argument atan of the text would lose);
    * the published table has roll = −(Δβ)m·sin B (the text writes +) and
      pitch = (Δβ)m·cos B; the table's signs are the ones the ray geometry
      confirms. In REP-103, which this function returns, both are reversed:
      roll = (Δβ)m·sin B, pitch = −(Δβ)m·cos B (physics.md "Sign conventions").

    One position in floats is one call of the compiled :func:`closed_form` (the monitor's per-sample
    use); arrays run it element by element.

    Args:
        u_rad: argument of latitude, rad (array-like).
        altitude_m: orbit altitude H above the mean radius, m (> 0; NaN results otherwise).
        inclination_rad: inclination i, rad.
        ellipsoid: figure for R1, R2.
        mean_radius_m: R of the method, m.

    Returns:
        (meridional_rad, roll_rad, pitch_rad) shaped like the broadcast inputs: (Δβ)m as the
        paper defines it, roll and pitch in REP-103.
    """
    a, b = float(ellipsoid.a_m), float(ellipsoid.b_m)
    if type(u_rad) is float and type(altitude_m) is float and type(inclination_rad) is float:
        return closed_form(u_rad, altitude_m, inclination_rad, a, b, float(mean_radius_m))
    u, h, i = np.broadcast_arrays(*(np.asarray(x, float) for x in (u_rad, altitude_m, inclination_rad)))
    out = np.empty((3,) + u.shape)
    _closed_form_each(np.ascontiguousarray(u).ravel(), np.ascontiguousarray(h).ravel(),
                      np.ascontiguousarray(i).ravel(), a, b, float(mean_radius_m), out.reshape(3, -1))
    if u.ndim == 0:
        return out[0][()], out[1][()], out[2][()]
    return out[0], out[1], out[2]
