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
"""

from __future__ import annotations

import numpy as np

from ..constants import EARTH_MEAN_RADIUS_M
from ..geometry import sphere_nadir_angle_of_height, sphere_tangent_height
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


def chord_nadir_of_height(height_m, horizon_nadir_rad, tangent_height_rate_m, earth_radius_m=EARTH_MEAN_RADIUS_M):
    """Nadir angle of the line of sight grazing ``height_m`` on a chord, rad (inverse of the above)."""
    rho, offset = _equivalent_sphere(horizon_nadir_rad, tangent_height_rate_m, earth_radius_m)
    return sphere_nadir_angle_of_height(height_m, rho, earth_radius_m) + offset


def _central_angle_inwards(inward_angle_rad, kappa):
    """Central angle, rad, from the horizon point to where a line of sight x inside the limb hits.

    Stable form of acos(cos x − κ sin x) − x (κ = s/R): the near
    intersection of the equivalent sphere; NaN where x < 0.
    """
    x = np.asarray(inward_angle_rad, float)
    with np.errstate(invalid="ignore"):
        arg = np.sqrt(np.sin(0.5 * x) ** 2 + 0.5 * kappa * np.sin(x))
        return np.where(x >= 0.0, 2.0 * np.arcsin(np.minimum(arg, 1.0)) - x, np.nan)


def chord_ground_distance(nadir_angle_rad, horizon_nadir_rad, tangent_height_rate_m,
                          earth_radius_m=EARTH_MEAN_RADIUS_M):
    """Ground distance inwards from the horizon point to where a line of sight hits, m (NaN if it misses)."""
    x = np.asarray(horizon_nadir_rad, float) - np.asarray(nadir_angle_rad, float)
    kappa = np.asarray(tangent_height_rate_m, float) / np.asarray(earth_radius_m, float)
    return np.asarray(earth_radius_m, float) * _central_angle_inwards(x, kappa)


def chord_nadir_of_ground_distance(ground_distance_m, horizon_nadir_rad, tangent_height_rate_m,
                                   earth_radius_m=EARTH_MEAN_RADIUS_M):
    """Nadir angle, rad, of the line of sight hitting the ground ``ground_distance_m`` inside the horizon point."""
    rho, offset = _equivalent_sphere(horizon_nadir_rad, tangent_height_rate_m, earth_radius_m)
    r = np.asarray(earth_radius_m, float)
    horizon_central = np.arctan2(np.asarray(tangent_height_rate_m, float), r)  # π/2 − φ₀ of the sphere
    central = horizon_central - np.asarray(ground_distance_m, float) / r
    return np.arctan2(r * np.sin(central), rho - r * np.cos(central)) + offset


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
    delta = np.asarray(layer_nadir_rad, float) - np.asarray(horizon_nadir_rad, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        return (np.asarray(layer_height_m, float) + earth_radius_m * (1.0 - np.cos(delta))) / np.sin(delta)


def sphere_chord(altitude_m, earth_radius_m=EARTH_MEAN_RADIUS_M):
    """(φ₀, s) of a chord at zero attitude over a sphere: asin(R/(R+H)), (R+H)·cos φ₀ (physics.md §2)."""
    rho = earth_radius_m + np.asarray(altitude_m, float)
    phi0 = np.arcsin(earth_radius_m / rho)
    return phi0, rho * np.cos(phi0)


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
