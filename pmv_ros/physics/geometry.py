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
The sensor's kernel works on one sample: vectors as 3-tuples of floats
(:func:`dot`), and the same compiled stages
(:func:`tangent_angles`, :func:`roll_pitch`, :func:`line_of_sight_x` …)
that the array functions here run over their arrays.
"""

from __future__ import annotations

import math

import numpy as np

from .compiled import elementwise, kernel
from .constants import GRS80, Ellipsoid

#: Chord order on the wire and in every (4, ...) array (interfaces.md).
CHORD_NAMES = ("+X", "+Y", "-X", "-Y")
#: Azimuth of each chord about the boresight, measured from +X towards +Y, rad.
CHORD_AZIMUTHS_RAD = np.array([0.0, 0.5 * np.pi, np.pi, 1.5 * np.pi])
#: Boresight in the sensor frame.
BORESIGHT_SENSOR = np.array([0.0, 0.0, -1.0])


@kernel
def dot(a, b):
    """a·b of two 3-tuples."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


@elementwise
def line_of_sight_x(nadir_angle_rad, azimuth_rad):
    """x of the unit line of sight at a nadir angle along a chord azimuth (sensor frame): sin φ cos α."""
    return math.sin(nadir_angle_rad) * math.cos(azimuth_rad)


@elementwise
def line_of_sight_y(nadir_angle_rad, azimuth_rad):
    """y of the unit line of sight: sin φ sin α."""
    return math.sin(nadir_angle_rad) * math.sin(azimuth_rad)


@elementwise
def line_of_sight_z(nadir_angle_rad, azimuth_rad):
    """z of the unit line of sight: −cos φ (the boresight is −Z)."""
    return -math.cos(nadir_angle_rad) + 0.0 * azimuth_rad


def chord_line_of_sight(nadir_angle_rad, azimuth_rad):
    """Unit line of sight in the sensor frame at a nadir angle along a chord azimuth.

    Args:
        nadir_angle_rad: angle from the boresight, rad (array-like).
        azimuth_rad: chord azimuth, rad (broadcast against the nadir angle).

    Returns:
        ``(3, ...)`` unit vectors in the sensor frame.
    """
    return np.array([line_of_sight_x(nadir_angle_rad, azimuth_rad), line_of_sight_y(nadir_angle_rad, azimuth_rad),
                     line_of_sight_z(nadir_angle_rad, azimuth_rad)])


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


@kernel
def _pair_tangents(p, chord, boresight, k, p_b, b_b):
    """The horizons of the chord pair (+, −) in one plane: nadir angles, rad, NaN where there is none.

    (p·d)² − k |d|² = 0 with d = t c + b, t = tan φ: qa t² + 2 qb t + qc = 0. qc > 0 with p·b < 0: the
    boresight ray (not just its line) hits the Earth; qa < 0: a ray across it misses. Then the roots have
    opposite signs, one horizon on each chord, and both tangent rays lie ahead.
    """
    p_c, c_c, c_b = dot(p, chord), dot(chord, chord), dot(chord, boresight)
    qa = p_c * p_c - k * c_c
    qb = p_c * p_b - k * c_b
    qc = p_b * p_b - k * b_b
    disc = qb * qb - qa * qc
    if not (qa < 0.0 and qc > 0.0 and p_b < 0.0 and disc >= 0.0):
        return math.nan, math.nan
    root = math.sqrt(disc)
    t_plus = (-qb - root) / qa
    t_minus = (-qb + root) / qa
    plus = math.atan(t_plus) if p_c * t_plus + p_b < 0.0 else math.nan
    minus = -math.atan(t_minus) if p_c * t_minus + p_b < 0.0 else math.nan
    return plus, minus


@kernel
def tangent_angles(position_m, x_axis, y_axis, z_axis, semi_axes_m):
    """:func:`tangent_nadir_angles` of one sample: 3-tuples (position; the sensor axes; the raised ellipsoid's
    semi-axes, :func:`semi_axes`) → the four nadir angles (+X, +Y, −X, −Y), rad."""
    a, b, c = semi_axes_m
    p = (position_m[0] / a, position_m[1] / b, position_m[2] / c)
    boresight = (-z_axis[0] / a, -z_axis[1] / b, -z_axis[2] / c)
    k = dot(p, p) - 1.0
    p_b, b_b = dot(p, boresight), dot(boresight, boresight)
    px, mx = _pair_tangents(p, (x_axis[0] / a, x_axis[1] / b, x_axis[2] / c), boresight, k, p_b, b_b)
    py, my = _pair_tangents(p, (y_axis[0] / a, y_axis[1] / b, y_axis[2] / c), boresight, k, p_b, b_b)
    return px, py, mx, my


@kernel
def _tangent_angles_each(position, axes, semi_axes_m, out):
    for n in range(position.shape[1]):
        out[0, n], out[1, n], out[2, n], out[3, n] = tangent_angles(
            (position[0, n], position[1, n], position[2, n]), (axes[0, 0, n], axes[1, 0, n], axes[2, 0, n]),
            (axes[0, 1, n], axes[1, 1, n], axes[2, 1, n]), (axes[0, 2, n], axes[1, 2, n], axes[2, 2, n]),
            semi_axes_m)


def _leading(array, fixed: int, shape) -> np.ndarray:
    """``array`` with its first ``fixed`` axes kept and the rest aligned to broadcast against ``shape``."""
    rest = array.shape[fixed:]
    return array.reshape(array.shape[:fixed] + (1,) * (len(shape) - len(rest)) + rest)


def semi_axes(ellipsoid: Ellipsoid, height_m=0.0) -> tuple:
    """Semi-axes (a+h, a+h, b+h), m, of the ellipsoid raised by ``height_m``, as the kernels take them."""
    return tuple(float(x) for x in _semi_axes(ellipsoid, height_m))


def tangent_nadir_angles(position_m, sensor_axes, ellipsoid: Ellipsoid = GRS80, height_m=0.0):
    """Nadir angle at which each chord's line of sight grazes the raised ellipsoid.

    Exact ray–ellipsoid tangency: in coordinates scaled so the ellipsoid is the
    unit sphere, a ray p + s·d grazes it when (p·d)² = (|p|² − 1)|d|². With
    d = sin φ·c + cos φ·b (c the chord direction, b the boresight) this is a
    quadratic in tan φ whose two roots are the horizons of the two opposite
    chords of the plane (:func:`tangent_angles`, sample by sample).

    Args:
        position_m: spacecraft position ``(3, ...)``, m, Earth-centred, z polar.
        sensor_axes: ``(3, 3, ...)``, columns = sensor X, Y, Z in the same frame.
        ellipsoid: Earth figure (GRS80 by default; ``SPHERE`` to switch oblateness off).
        height_m: height of the grazing layer above the ellipsoid, m.

    Returns:
        ``(4, ...)`` nadir angles, rad, chords +X, +Y, −X, −Y; NaN where the
        chord's half-plane has no horizon (the boresight misses the Earth).
    """
    position = np.asarray(position_m, float)
    axes = np.asarray(sensor_axes, float)
    shape = np.broadcast_shapes(position.shape[1:], axes.shape[2:])
    position = np.ascontiguousarray(np.broadcast_to(_leading(position, 1, shape), (3,) + shape))
    axes = np.ascontiguousarray(np.broadcast_to(_leading(axes, 2, shape), (3, 3) + shape))
    out = np.empty((4,) + shape)
    _tangent_angles_each(position.reshape(3, -1), axes.reshape(3, 3, -1), semi_axes(ellipsoid, height_m),
                         out.reshape(4, -1))
    return out


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


@kernel
def roll_pitch(plus_x, plus_y, minus_x, minus_y):
    """:func:`roll_pitch_from_horizon_angles` of one sample's four nadir angles, rad: (roll, pitch)."""
    tilt_x = 0.5 * (plus_x - minus_x)
    tilt_y = 0.5 * (plus_y - minus_y)
    # With n ∝ (tan δx, tan δy, −1): roll = atan2(−n_y, −n_z) = −δy and
    # pitch = atan2(n_x, |(n_y, n_z)|) = atan(tan δx · cos δy) (REP-103, pmv_ros.physics.attitude).
    return -tilt_y, math.atan(math.tan(tilt_x) * math.cos(tilt_y if math.isfinite(tilt_y) else 0.0))


@kernel
def _roll_pitch_each(angles, roll, pitch):
    for n in range(angles.shape[1]):
        roll[n], pitch[n] = roll_pitch(angles[0, n], angles[1, n], angles[2, n], angles[3, n])


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
    shape = phi.shape[1:]
    flat = np.ascontiguousarray(phi.reshape(4, -1))
    roll, pitch = np.empty(flat.shape[1]), np.empty(flat.shape[1])
    _roll_pitch_each(flat, roll, pitch)
    return (roll.reshape(shape), pitch.reshape(shape)) if shape else (roll[0], pitch[0])

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
