"""Where the four scan chords see the horizon of an oblate Earth.

The sensor frame is the body frame: boresight along −Z (nadir at zero
attitude), chords in the order +X, +Y, −X, −Y (interfaces.md). A chord at
azimuth α scans the half-plane spanned by the boresight and the direction
(cos α, sin α, 0); a line of sight on it at nadir angle φ is

    los = sin φ · (cos α, sin α, 0) + cos φ · (0, 0, −1).

Opposite chords share one plane, so one quadratic gives both horizons of a
pair (:func:`tangent_nadir_angles`).

Arrays: vectors ``(3, ...)``, rotation matrices ``(3, 3, ...)`` whose
columns are the sensor X, Y, Z axes expressed in an Earth-centred frame with
z along the polar axis (ECI or ECEF: the ellipsoid is the same in both).
"""

from __future__ import annotations

import numpy as np

from .constants import GRS80, Ellipsoid

#: Chord order on the wire and in every (4, ...) array (interfaces.md).
CHORD_NAMES = ("+X", "+Y", "-X", "-Y")
#: Azimuth of each chord about the boresight, measured from +X towards +Y, rad.
CHORD_AZIMUTHS_RAD = np.array([0.0, 0.5 * np.pi, np.pi, 1.5 * np.pi])
#: Boresight in the sensor frame.
BORESIGHT_SENSOR = np.array([0.0, 0.0, -1.0])


def chord_line_of_sight(nadir_angle_rad, azimuth_rad):
    """Unit line of sight in the sensor frame at a nadir angle along a chord azimuth.

    Args:
        nadir_angle_rad: angle from the boresight, rad (array-like).
        azimuth_rad: chord azimuth, rad (broadcast against the nadir angle).

    Returns:
        ``(3, ...)`` unit vectors in the sensor frame.
    """
    phi = np.asarray(nadir_angle_rad, float)
    alpha = np.asarray(azimuth_rad, float)
    s = np.sin(phi)
    return np.array([s * np.cos(alpha), s * np.sin(alpha), -np.cos(phi) + 0.0 * alpha])


def _scaled(vectors, axes_m):
    """Vectors in coordinates where the ellipsoid of semi-axes ``axes_m`` is the unit sphere."""
    return vectors / axes_m.reshape((3,) + (1,) * (vectors.ndim - 1))


def _semi_axes(ellipsoid: Ellipsoid, height_m) -> np.ndarray:
    """Semi-axes (a+h, a+h, b+h), m, of the ellipsoid raised by ``height_m``.

    The surface of constant geodetic height is not exactly an ellipsoid; raising
    both semi-axes by h differs from it by about f·h (≈ 0.2 km at h = 60 km),
    far below what moves a horizon by 0.01′.
    """
    h = float(height_m)
    return np.array([ellipsoid.a_m + h, ellipsoid.a_m + h, ellipsoid.b_m + h])


def tangent_nadir_angles(position_m, sensor_axes, ellipsoid: Ellipsoid = GRS80, height_m=0.0):
    """Nadir angle at which each chord's line of sight grazes the raised ellipsoid.

    Exact ray–ellipsoid tangency: in coordinates scaled so the ellipsoid is the
    unit sphere, a ray p + s·d grazes it when (p·d)² = (|p|² − 1)|d|². With
    d = sin φ·c + cos φ·b (c the chord direction, b the boresight) this is a
    quadratic in tan φ whose two roots are the horizons of the two opposite
    chords of the plane.

    Args:
        position_m: spacecraft position ``(3, ...)``, m, Earth-centred, z polar.
        sensor_axes: ``(3, 3, ...)``, columns = sensor X, Y, Z in the same frame.
        ellipsoid: Earth figure (GRS80 by default; ``SPHERE`` to switch oblateness off).
        height_m: height of the grazing layer above the ellipsoid, m.

    Returns:
        ``(4, ...)`` nadir angles, rad, chords +X, +Y, −X, −Y; NaN where the
        chord's half-plane has no horizon (the boresight misses the Earth).
    """
    axes = _semi_axes(ellipsoid, height_m)
    p = _scaled(np.asarray(position_m, float), axes)
    sensor_axes = np.asarray(sensor_axes, float)
    boresight = _scaled(-sensor_axes[:, 2], axes)
    k = np.einsum("i...,i...->...", p, p) - 1.0
    p_b = np.einsum("i...,i...->...", p, boresight)
    b_b = np.einsum("i...,i...->...", boresight, boresight)
    angles = []
    for column in (0, 1):  # the +X/−X pair, then the +Y/−Y pair
        chord = _scaled(sensor_axes[:, column], axes)
        p_c = np.einsum("i...,i...->...", p, chord)
        c_c = np.einsum("i...,i...->...", chord, chord)
        c_b = np.einsum("i...,i...->...", chord, boresight)
        # (p·d)^2 - k |d|^2 = 0 with d = t c + b, t = tan φ:  qa t^2 + 2 qb t + qc = 0
        qa = p_c**2 - k * c_c
        qb = p_c * p_b - k * c_b
        qc = p_b**2 - k * b_b
        disc = qb**2 - qa * qc
        # qc > 0 with p·b < 0: the boresight ray (not just its line) hits the
        # Earth; qa < 0: a ray across it misses. Then the roots have opposite
        # signs, one horizon on each chord, and both tangent rays lie ahead.
        ok = (qa < 0.0) & (qc > 0.0) & (p_b < 0.0) & (disc >= 0.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            root = np.sqrt(np.where(ok, disc, np.nan))
            t_plus = (-qb - root) / qa
            t_minus = (-qb + root) / qa
        t_plus = np.where(p_c * t_plus + p_b < 0.0, t_plus, np.nan)
        t_minus = np.where(p_c * t_minus + p_b < 0.0, t_minus, np.nan)
        angles.append((np.arctan(t_plus), -np.arctan(t_minus)))
    (px, mx), (py, my) = angles
    return np.stack([px, py, mx, my])


def vertical_from_horizon_angles(horizon_nadir_rad):
    """Geometric vertical in the sensor frame from the four horizon nadir angles.

    Each pair's bisector is tilted from the boresight by half the difference of
    its two horizon angles (physics.md §2.1: the bisector of the tangent rays);
    the two tilts, taken in the two orthogonal chord planes, fix the direction
    (tan δx, tan δy, −1). On a sphere this is exactly the direction to the centre.

    Args:
        horizon_nadir_rad: ``(4, ...)`` horizon nadir angles, rad, chords +X, +Y, −X, −Y.

    Returns:
        ``(3, ...)`` unit vector of the sensed nadir in the sensor frame (NaN if
        a pair is missing).
    """
    phi = np.asarray(horizon_nadir_rad, float)
    tilt_x = 0.5 * (phi[0] - phi[2])
    tilt_y = 0.5 * (phi[1] - phi[3])
    nadir = np.array([np.tan(tilt_x), np.tan(tilt_y), -np.ones_like(tilt_x)])
    return nadir / np.linalg.norm(nadir, axis=0)


def roll_pitch_from_horizon_angles(horizon_nadir_rad):
    """Roll and pitch, rad, read from the four horizon nadir angles, each pair on its own.

    Equivalent to :func:`vertical_from_horizon_angles` followed by
    :func:`pmv_ros.physics.attitude.roll_pitch_from_nadir`, written so that roll
    depends on the ±Y pair only and pitch on the ±X pair only: a lost chord
    makes its own angle NaN and leaves the other one standing (the ±Y tilt
    enters pitch at second order; it is taken as zero when that pair is lost).

    Args:
        horizon_nadir_rad: ``(4, ...)`` nadir angles, rad, chords +X, +Y, −X, −Y.

    Returns:
        (roll_rad, pitch_rad) shaped like one chord's angles.
    """
    phi = np.asarray(horizon_nadir_rad, float)
    tilt_x = 0.5 * (phi[0] - phi[2])
    tilt_y = 0.5 * (phi[1] - phi[3])
    # With n ∝ (tan δx, tan δy, −1): roll = atan2(−n_y, −n_z) = −δy and
    # pitch = atan2(n_x, |(n_y, n_z)|) = atan(tan δx · cos δy) (REP-103, pmv_ros.physics.attitude).
    roll = -tilt_y
    pitch = np.arctan(np.tan(tilt_x) * np.cos(np.where(np.isfinite(tilt_y), tilt_y, 0.0)))
    return roll, pitch

def sphere_tangent_height(nadir_angle_rad, orbit_radius_m, earth_radius_m):
    """Height above a sphere of the closest point of a line of sight, m: (R + H) sin φ − R.

    Negative where the line of sight hits the sphere (then it is minus the
    depth of the chord, a continuous stand-in used only to order samples).

    Args:
        nadir_angle_rad: nadir angle φ of the line of sight, rad.
        orbit_radius_m: R + H, m.
        earth_radius_m: R, m.
    """
    return orbit_radius_m * np.sin(np.asarray(nadir_angle_rad, float)) - earth_radius_m


def sphere_nadir_angle_of_height(height_m, orbit_radius_m, earth_radius_m):
    """Nadir angle whose line of sight grazes the height ``height_m`` over a sphere, rad: asin((R + h)/(R + H))."""
    return np.arcsin((earth_radius_m + np.asarray(height_m, float)) / orbit_radius_m)


def ellipsoid_line_of_sight(position_m, line_of_sight, ellipsoid: Ellipsoid = GRS80, height_m=0.0):
    """Where lines of sight meet, or pass closest to, the (raised) ellipsoid.

    Args:
        position_m: ``(3, ...)`` observer position, m, Earth-centred with z polar.
        line_of_sight: ``(3, ...)`` unit directions in the same frame (broadcast against position).
        ellipsoid: Earth figure.
        height_m: height the ellipsoid is raised by, m.

    Returns:
        dict with
        ``hits`` — bool, the line of sight meets the surface ahead;
        ``ground_point_m`` — ``(3, ...)`` first intersection, NaN where it misses;
        ``tangent_point_m`` — ``(3, ...)`` point of closest approach (in the
        metric where the ellipsoid is a sphere), the tangent point of a grazing ray;
        ``tangent_height_m`` — height of that point above the surface along its
        geocentric radius (negative inside: a continuous measure through the limb).
    """
    axes = _semi_axes(ellipsoid, height_m)
    p = np.asarray(position_m, float)
    d = np.asarray(line_of_sight, float)
    p, d = np.broadcast_arrays(p, d)
    ps, ds = _scaled(p, axes), _scaled(d, axes)
    dd = np.einsum("i...,i...->...", ds, ds)
    pd = np.einsum("i...,i...->...", ps, ds)
    pp = np.einsum("i...,i...->...", ps, ps)
    s_closest = np.maximum(-pd / dd, 0.0)
    closest_scaled2 = pp - pd**2 / dd
    hits = (pd < 0.0) & (closest_scaled2 < 1.0)
    with np.errstate(invalid="ignore"):
        s_ground = (-pd - np.sqrt(np.where(hits, pd**2 - dd * (pp - 1.0), np.nan))) / dd
    ground = p + s_ground * d
    tangent = p + s_closest * d
    scale = np.sqrt(np.maximum(np.einsum("i...,i...->...", _scaled(tangent, axes), _scaled(tangent, axes)), 1e-300))
    radius = np.linalg.norm(tangent, axis=0)
    return {
        "hits": hits,
        "ground_point_m": ground,
        "tangent_point_m": tangent,
        "tangent_height_m": radius * (1.0 - 1.0 / scale) + float(height_m),
    }
