"""From attitude error to ground position error of a nadir-pointing imager (physics.md §7).

The chain of the geolocation paper: the line of sight of a pixel, given in
the body frame, is turned into the orbital frame by the attitude
(R = R_z(ψ)·R_y(θ)·R_x(φ), REP-103, the convention of :mod:`pmv_ros.physics.attitude`),
intersected with the sphere R + h₁ (the root on the visible side), and the
ground point with and without the attitude error compared along and across
the track: P_X = ρ·[asin(X′/ρ) − asin(X/ρ)], likewise P_Y, and the circular
error Δl = √(P_X² + P_Y²).

Coordinates are Earth-centred with the axes of the orbital frame at the
imaging instant: X along the track, Y across it (orbit normal), Z up to the
spacecraft. The Greenwich step of the paper (node, inclination, u) only
renames the point and is not needed for the error. Signs follow the attitude
convention: a positive pitch (right-hand about +Y) turns the boresight back,
the ground point to −X; a positive roll (right-hand about +X) to +Y.
"""

from __future__ import annotations

import math
from typing import Iterable, NamedTuple

import numpy as np

from .attitude import body_axes_in_orbital, quaternion_from_roll_pitch_yaw
from .constants import EARTH_MEAN_RADIUS_M


class GroundError(NamedTuple):
    """Ground position error, m: along track (+ forward), across track (+ towards the orbit normal), circular."""

    along_track_m: np.ndarray | float
    cross_track_m: np.ndarray | float
    circular_m: np.ndarray | float


def line_of_sight_body(look_along_rad=0.0, look_across_rad=0.0):
    """Unit line of sight of a pixel in the body frame, ``(3[, ...])``; (0, 0) is the boresight −Z_B.

    Args:
        look_along_rad: angle of the pixel from the boresight towards +X_B (along track), rad.
        look_across_rad: angle of the pixel from the boresight towards +Y_B (across track), rad.
    """
    along, across = np.broadcast_arrays(np.asarray(look_along_rad, float), np.asarray(look_across_rad, float))
    vector = np.array([np.tan(along), np.tan(across), -np.ones_like(along)])
    return vector / np.linalg.norm(vector, axis=0)


def intersect_sphere(line_of_sight_orbital, altitude_m, sphere_radius_m):
    """Point where a ray from the spacecraft meets the sphere, Earth-centred orbital axes, ``(3, N)`` m.

    The spacecraft is at (0, 0, R + H) — ``R`` = EARTH_MEAN_RADIUS_M. The
    nearer root of |X_s + s·d| = ρ is the visible side; a ray that misses
    the sphere gives NaN.

    Args:
        line_of_sight_orbital: ``(3, N)`` unit directions in the orbital frame.
        altitude_m: ``(N,)`` or scalar spacecraft altitude H above the mean radius, m.
        sphere_radius_m: ``(N,)`` or scalar ρ = R + h₁, m.
    """
    direction = np.asarray(line_of_sight_orbital, float)
    spacecraft_z = EARTH_MEAN_RADIUS_M + np.asarray(altitude_m, float)
    radius = np.asarray(sphere_radius_m, float)
    # |X_s + s d|² = ρ² with X_s = (0, 0, z): s² + 2 s z d_z + z² − ρ² = 0.
    half_b = spacecraft_z * direction[2]
    discriminant = half_b * half_b - (spacecraft_z * spacecraft_z - radius * radius)
    with np.errstate(invalid="ignore"):
        distance = -half_b - np.sqrt(discriminant)
    distance = np.where((discriminant >= 0.0) & (distance > 0.0), distance, np.nan)
    point = distance * direction
    point[2] = point[2] + spacecraft_z
    return point


def ground_error(roll_rad, pitch_rad, altitude_m, yaw_rad=0.0, *, look_along_rad=0.0, look_across_rad=0.0,
                 target_height_m=0.0) -> GroundError:
    """Ground position error, m, that an attitude error causes for an imager pixel (physics.md §7).

    The imager's boresight is −Z_B (nadir at zero attitude); a pixel looks
    at (``look_along_rad``, ``look_across_rad``) from it. Yaw matters only
    off nadir. Everything broadcasts; scalars give floats.

    Args:
        roll_rad, pitch_rad, yaw_rad: attitude error, rad (convention of
            :mod:`pmv_ros.physics.attitude`).
        altitude_m: spacecraft altitude H above the 6371 km mean radius, m.
        look_along_rad, look_across_rad: pixel direction from the boresight, rad.
        target_height_m: height h₁ of the imaged surface above the mean radius, m.

    Returns:
        :class:`GroundError` (along-track, cross-track, circular), m; NaN
        where a line of sight misses the Earth.
    """
    arrays = np.broadcast_arrays(*(np.asarray(a, float) for a in (
        roll_rad, pitch_rad, yaw_rad, altitude_m, look_along_rad, look_across_rad, target_height_m)))
    shape = arrays[0].shape
    roll, pitch, yaw, altitude, along, across, height = (a.ravel() for a in arrays)
    if np.any(altitude <= 0.0):
        raise ValueError(f"altitude must be positive, got {altitude.min()} m")
    radius = EARTH_MEAN_RADIUS_M + height
    sight_body = line_of_sight_body(along, across)
    # R maps body components to orbital ones; for zero attitude error the line of sight is unchanged.
    rotation = body_axes_in_orbital(quaternion_from_roll_pitch_yaw(roll, pitch, yaw))
    sight_with_error = np.einsum("ijn,jn->in", rotation.reshape(3, 3, -1), sight_body)
    nominal = intersect_sphere(sight_body, altitude, radius)
    erroneous = intersect_sphere(sight_with_error, altitude, radius)
    with np.errstate(invalid="ignore"):
        along_track = radius * (np.arcsin(erroneous[0] / radius) - np.arcsin(nominal[0] / radius))
        cross_track = radius * (np.arcsin(erroneous[1] / radius) - np.arcsin(nominal[1] / radius))
    circular = np.hypot(along_track, cross_track)
    if shape == ():
        return GroundError(float(along_track[0]), float(cross_track[0]), float(circular[0]))
    return GroundError(along_track.reshape(shape), cross_track.reshape(shape), circular.reshape(shape))


def nadir_ground_error(roll_rad, pitch_rad, altitude_m, target_height_m=0.0) -> GroundError:
    """:func:`ground_error` for the boresight pixel (nadir imager), in closed form — cheap enough per sample.

    At zero look angle and zero yaw the boresight −Z_B in the orbital frame is
    R·(0, 0, −1) = (−cos φ sin θ, sin φ, −cos φ cos θ) (REP-103,
    :mod:`pmv_ros.physics.attitude`; a yaw would only turn this tilt about the
    vertical — the residuals the monitor passes have none); the rest is the
    same sphere intersection and P_X, P_Y of physics.md §7. Scalars give floats.

    Args:
        roll_rad, pitch_rad: attitude error, rad.
        altitude_m: spacecraft altitude H above the mean radius, m.
        target_height_m: height h₁ of the imaged surface above the mean radius, m.
    """
    if all(type(value) is float for value in (roll_rad, pitch_rad, altitude_m, target_height_m)):
        return _nadir_ground_error_scalar(roll_rad, pitch_rad, altitude_m, target_height_m)
    roll, pitch = np.asarray(roll_rad, float), np.asarray(pitch_rad, float)
    altitude = np.asarray(altitude_m, float)
    if np.any(altitude <= 0.0):
        raise ValueError(f"altitude must be positive, got {np.min(altitude)} m")
    radius = EARTH_MEAN_RADIUS_M + np.asarray(target_height_m, float)
    spacecraft_z = EARTH_MEAN_RADIUS_M + altitude
    cos_roll = np.cos(roll)
    direction_z = -cos_roll * np.cos(pitch)
    # Nearer root of s² + 2 s z d_z + z² − ρ² = 0 (as in intersect_sphere); the nominal point is the nadir.
    half_b = spacecraft_z * direction_z
    discriminant = half_b * half_b - (spacecraft_z - radius) * (spacecraft_z + radius)
    with np.errstate(invalid="ignore"):
        distance = -half_b - np.sqrt(discriminant)
        distance = np.where((discriminant >= 0.0) & (distance > 0.0), distance, np.nan)
        along_track = radius * np.arcsin(-distance * cos_roll * np.sin(pitch) / radius)
        cross_track = radius * np.arcsin(distance * np.sin(roll) / radius)
    circular = np.hypot(along_track, cross_track)
    if along_track.ndim == 0:
        return GroundError(float(along_track), float(cross_track), float(circular))
    return GroundError(along_track, cross_track, circular)


def _nadir_ground_error_scalar(roll: float, pitch: float, altitude: float, target_height: float) -> GroundError:
    """:func:`nadir_ground_error` for one sample in plain floats (the monitor calls it per residual)."""
    if altitude <= 0.0:
        raise ValueError(f"altitude must be positive, got {altitude} m")
    if not all(math.isfinite(value) for value in (roll, pitch, altitude, target_height)):
        return GroundError(math.nan, math.nan, math.nan)
    radius = EARTH_MEAN_RADIUS_M + target_height
    spacecraft_z = EARTH_MEAN_RADIUS_M + altitude
    cos_roll = math.cos(roll)
    half_b = spacecraft_z * -cos_roll * math.cos(pitch)
    discriminant = half_b * half_b - (spacecraft_z - radius) * (spacecraft_z + radius)
    distance = -half_b - math.sqrt(discriminant) if discriminant >= 0.0 else math.nan
    if not distance > 0.0:
        return GroundError(math.nan, math.nan, math.nan)
    along_sine = -distance * cos_roll * math.sin(pitch) / radius
    cross_sine = distance * math.sin(roll) / radius
    along = radius * math.asin(along_sine) if abs(along_sine) <= 1.0 else math.nan
    cross = radius * math.asin(cross_sine) if abs(cross_sine) <= 1.0 else math.nan
    return GroundError(along, cross, math.hypot(along, cross))


def combine_in_quadrature(errors: Iterable[GroundError]) -> GroundError:
    """Root-sum-square of independent error sources, component by component (physics.md §7)."""
    along = cross = 0.0
    for error in errors:
        along = along + np.square(error.along_track_m)
        cross = cross + np.square(error.cross_track_m)
    along, cross = np.sqrt(along), np.sqrt(cross)
    return GroundError(along, cross, np.hypot(along, cross))
