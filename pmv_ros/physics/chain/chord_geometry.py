"""Geometry of a chord near its horizon: the equivalent sphere, tangent heights, ground distances, the scan start.

A chord is described near its horizon by the hard-Earth horizon nadir
angle φ₀, the rate s = dh/dφ of tangent height with nadir angle there
(the slant range; (R + H)·cos φ₀ on a sphere) and the local Earth radius R.
These fix the *equivalent sphere* of the chord — orbit radius
ρ = √(R² + s²), nadir angles offset by φ₀ − atan(R/s) — which is exact on
a sphere (:func:`chord_tangent_height`, :func:`chord_ground_distance` and
their inverses). On the ellipsoid only the curvature term of h(φ) is
approximate: a radius off by 0.6 % (GRS80's meridian radius at the
equator against the mean R) moves the 60 km layer by ≈ 10 m, 0.01′.

Each formula the chain's kernel uses is a compiled elementwise function (:mod:`pmv_ros.physics.compiled`):
the kernel calls it on one chord, numpy callers on arrays — the same code.
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled import elementwise
from ..constants import EARTH_MEAN_RADIUS_M
from ..geometry import sphere_tangent_height
from ..radiance import CO2_TOP_HEIGHT_M
from .parameters import DEFAULT_CHAIN_PARAMETERS, ChainParameters


def _equivalent_sphere(horizon_nadir_rad, tangent_height_rate_m, earth_radius_m):
    """(ρ, nadir offset): orbit radius and angle offset of the chord's equivalent sphere."""
    phi0 = np.asarray(horizon_nadir_rad, float)
    s = np.asarray(tangent_height_rate_m, float)
    r = np.asarray(earth_radius_m, float)
    return np.hypot(r, s), phi0 - np.arctan2(r, s)


def chord_tangent_height(nadir_angle_rad, horizon_nadir_rad, tangent_height_rate_m,
                         earth_radius_m=EARTH_MEAN_RADIUS_M):
    """Tangent height of a line of sight on a chord, m (negative inside the disc, see geometry.py).

    Args:
        nadir_angle_rad: nadir angle θ of the line of sight, rad.
        horizon_nadir_rad: φ₀, the chord's hard-Earth horizon nadir angle, rad.
        tangent_height_rate_m: s = dh/dφ at the horizon, m/rad (slant range).
        earth_radius_m: local Earth radius R, m.
    """
    rho, offset = _equivalent_sphere(horizon_nadir_rad, tangent_height_rate_m, earth_radius_m)
    return sphere_tangent_height(np.asarray(nadir_angle_rad, float) - offset, rho, earth_radius_m)


@elementwise
def nadir_of_height(height_m, horizon_nadir_rad, tangent_height_rate_m, earth_radius_m):
    """:func:`chord_nadir_of_height` of one chord (the kernels' form: every argument given)."""
    rho = math.hypot(earth_radius_m, tangent_height_rate_m)
    return (math.asin((earth_radius_m + height_m) / rho) + horizon_nadir_rad
            - math.atan2(earth_radius_m, tangent_height_rate_m))


def chord_nadir_of_height(height_m, horizon_nadir_rad, tangent_height_rate_m, earth_radius_m=EARTH_MEAN_RADIUS_M):
    """Nadir angle of the line of sight grazing ``height_m`` on a chord, rad (inverse of the above):
    asin((R + h)/ρ) + φ₀ − atan2(R, s) on the equivalent sphere of orbit radius ρ = √(R² + s²)."""
    return nadir_of_height(height_m, horizon_nadir_rad, tangent_height_rate_m, earth_radius_m)


@elementwise
def central_angle_inwards(inward_angle_rad, kappa):
    """Central angle, rad, from the horizon point to where a line of sight x inside the limb hits.

    Stable form of acos(cos x − κ sin x) − x (κ = s/R): the near
    intersection of the equivalent sphere; NaN where x < 0.
    """
    if math.isnan(inward_angle_rad) or math.isnan(kappa) or inward_angle_rad < 0.0:  # (NaN first: no signal)
        return math.nan
    arg = math.sqrt(math.sin(0.5 * inward_angle_rad) ** 2 + 0.5 * kappa * math.sin(inward_angle_rad))
    if arg > 1.0:
        arg = 1.0
    return 2.0 * math.asin(arg) - inward_angle_rad


@elementwise
def ground_distance(nadir_angle_rad, horizon_nadir_rad, tangent_height_rate_m, earth_radius_m):
    """:func:`chord_ground_distance` of one chord (the kernels' form: every argument given)."""
    return earth_radius_m * central_angle_inwards(horizon_nadir_rad - nadir_angle_rad,
                                                  tangent_height_rate_m / earth_radius_m)


def chord_ground_distance(nadir_angle_rad, horizon_nadir_rad, tangent_height_rate_m,
                          earth_radius_m=EARTH_MEAN_RADIUS_M):
    """Ground distance inwards from the horizon point to where a line of sight hits, m (NaN if it misses)."""
    return ground_distance(nadir_angle_rad, horizon_nadir_rad, tangent_height_rate_m, earth_radius_m)


@elementwise
def nadir_of_ground_distance(ground_distance_m, horizon_nadir_rad, tangent_height_rate_m, earth_radius_m):
    """:func:`chord_nadir_of_ground_distance` of one chord (the kernels' form: every argument given)."""
    rho = math.hypot(earth_radius_m, tangent_height_rate_m)
    offset = horizon_nadir_rad - math.atan2(earth_radius_m, tangent_height_rate_m)
    horizon_central = math.atan2(tangent_height_rate_m, earth_radius_m)  # π/2 − φ₀ of the sphere
    central = horizon_central - ground_distance_m / earth_radius_m
    return math.atan2(earth_radius_m * math.sin(central), rho - earth_radius_m * math.cos(central)) + offset


def chord_nadir_of_ground_distance(ground_distance_m, horizon_nadir_rad, tangent_height_rate_m,
                                   earth_radius_m=EARTH_MEAN_RADIUS_M):
    """Nadir angle, rad, of the line of sight hitting the ground ``ground_distance_m`` inside the horizon point."""
    return nadir_of_ground_distance(ground_distance_m, horizon_nadir_rad, tangent_height_rate_m, earth_radius_m)


@elementwise
def height_rate_from_layer(horizon_nadir_rad, layer_nadir_rad, layer_height_m, earth_radius_m):
    """:func:`tangent_height_rate_from_layer` of one chord (the kernels' form: every argument given)."""
    delta = layer_nadir_rad - horizon_nadir_rad
    return (layer_height_m + earth_radius_m * (1.0 - math.cos(delta))) / math.sin(delta)


def tangent_height_rate_from_layer(horizon_nadir_rad, layer_nadir_rad, layer_height_m,
                                   earth_radius_m=EARTH_MEAN_RADIUS_M):
    """s = dh/dφ at the horizon, m/rad, from the nadir angles at which a chord grazes the surface and a layer.

    Solves h = s·sin δ − R·(1 − cos δ), δ = φ_layer − φ₀ (the equivalent
    sphere): exact on a sphere, and on the ellipsoid it makes the chord's
    equivalent sphere pass exactly through both grazing angles — e.g. φ₀ and
    φ(60 km) from :func:`pmv_ros.physics.geometry.tangent_nadir_angles` with
    ``height_m`` = 0 and 60 km. (A plain secant h/δ would be ≈ 3 % low at 60 km.)

    Args:
        horizon_nadir_rad: φ₀, rad.
        layer_nadir_rad: nadir angle grazing the layer, rad (> φ₀).
        layer_height_m: the layer's height, m (> 0).
        earth_radius_m: local Earth radius R, m.
    """
    return height_rate_from_layer(horizon_nadir_rad, layer_nadir_rad, layer_height_m, earth_radius_m)


@elementwise
def sphere_horizon_nadir(altitude_m, earth_radius_m):
    """φ₀ = asin(R/(R + H)) of a chord at zero attitude over a sphere, rad."""
    return math.asin(earth_radius_m / (earth_radius_m + altitude_m))


@elementwise
def sphere_slant_range(altitude_m, earth_radius_m):
    """s = (R + H)·cos φ₀ of a chord at zero attitude over a sphere, m (the slope dh/dφ at its horizon)."""
    return (earth_radius_m + altitude_m) * math.cos(sphere_horizon_nadir(altitude_m, earth_radius_m))


def sphere_chord(altitude_m, earth_radius_m=EARTH_MEAN_RADIUS_M):
    """(φ₀, s) of a chord at zero attitude over a sphere: asin(R/(R+H)), (R+H)·cos φ₀ (physics.md §2)."""
    return sphere_horizon_nadir(altitude_m, earth_radius_m), sphere_slant_range(altitude_m, earth_radius_m)


def scan_start_nadir_angle(horizon_nadir_rad, tangent_height_rate_m, top_height_m=CO2_TOP_HEIGHT_M,
                           params: ChainParameters = DEFAULT_CHAIN_PARAMETERS, earth_radius_m=EARTH_MEAN_RADIUS_M):
    """θ₀ = φ₃ + γ: the scan start just outside the top of the emitting atmosphere, rad (physics.md §1).

    Args:
        horizon_nadir_rad, tangent_height_rate_m, earth_radius_m: the chord (see :func:`chord_tangent_height`).
        top_height_m: height of the top of the atmosphere the scan must start above, m (60 km).
        params: chain parameters (γ).
    """
    return chord_nadir_of_height(top_height_m, horizon_nadir_rad, tangent_height_rate_m,
                                 earth_radius_m) + params.ifov_half_angle_rad
