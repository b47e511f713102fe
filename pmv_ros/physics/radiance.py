"""The infrared horizon as the sensor sees it: radiance of a line of sight (physics.md §3).

Radiance is in r.u. throughout the physics (1 r.u. = J = L_min =
2.5 mW/(cm²·sr), :data:`~pmv_ros.physics.constants.RADIANCE_UNIT_MW_CM2_SR`);
mW/(cm²·sr) appears only through :func:`ru_from_mw_cm2_sr` and
:func:`mw_cm2_sr_from_ru` at the edges.

The profile, from space inwards, as a function of the tangent height h of the
line of sight (physics.md §3):

* h > h_top (top of the emitting atmosphere, max(h_CO₂, h_w)): space, 0;
* h_w < h ≤ h_CO₂: the CO₂ layer, B_a = 0.3 J, constant;
* 0 < h ≤ h_w: the atmospheric-window region, a monotone ramp
  B_a + (B_m − B_a)·S(h/h_w) from B_m at the surface to B_a at h_w;
* h ≤ 0 (the line of sight hits the disc): the ground radiance at the point
  it hits — B_m at the horizon point, plus whatever the radiance model adds
  inside the disc (:func:`disc_radiance`).

The ramp shape S is the documented, replaceable choice the papers leave open
(they show it only as a figure): :class:`RampShape`, piecewise linear in
u = h/h_w through a few knots, S(0) = 1, S(1) = 0, non-increasing. The
default is linear (S = 1 − u); see ``tools/calibrate_chain.py`` for why —
the published Model A table cannot tell ramp shapes apart, so the simplest
one is kept.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .constants import RADIANCE_UNIT_MW_CM2_SR

#: Minimum horizon radiance (winter Antarctica), r.u. (physics.md §3).
MIN_EARTH_RADIANCE_RU = 1.0
#: Maximum horizon radiance (dry subtropics in summer), r.u. (physics.md §3).
MAX_EARTH_RADIANCE_RU = 4.0
#: Mean Earth radiance in the 6–20 µm band, r.u. (physics.md §3: ≈ 6 mW/(cm²·sr)).
MEAN_EARTH_RADIANCE_RU = 2.4
#: Radiance of the CO₂ layer, r.u.: B_a = 0.3 J (physics.md §3).
CO2_RADIANCE_RU = 0.3
#: Height of the top of the CO₂ layer, m (physics.md §3: ≈ 60 km, spread < 0.5 km).
CO2_TOP_HEIGHT_M = 60e3
#: Mean height of the window emitting layer h_w, m (physics.md §3: 40 ± 20 km).
WINDOW_HEIGHT_M = 40e3
#: Standard deviation of h_w, m (physics.md §3: close to uniform over 40 ± 20 km, σ_h ≈ 10 km).
WINDOW_HEIGHT_SIGMA_M = 10e3
#: Allowed range of any emitting-layer height, m (the scenario inputs of interfaces.md).
MAX_LAYER_HEIGHT_M = 100e3


def ru_from_mw_cm2_sr(radiance_mw_cm2_sr):
    """Radiance in r.u. from mW/(cm²·sr) (1 r.u. = 2.5 mW/(cm²·sr), physics.md §3)."""
    return np.asarray(radiance_mw_cm2_sr, float) / RADIANCE_UNIT_MW_CM2_SR


def mw_cm2_sr_from_ru(radiance_ru):
    """Radiance in mW/(cm²·sr) from r.u. (physics.md §3)."""
    return np.asarray(radiance_ru, float) * RADIANCE_UNIT_MW_CM2_SR


@dataclass(frozen=True)
class RampShape:
    """Shape S(u) of the window-region ramp, u = h/h_w: piecewise linear through knots.

    Args:
        heights: knot positions u (fractions of h_w), strictly increasing from 0 to 1.
        values: S at the knots, non-increasing from 1 to 0 (B_m at the
            surface, B_a at h_w).

    Raises:
        ValueError: knots that do not describe a monotone ramp from 1 to 0.
    """

    heights: tuple = (0.0, 1.0)
    values: tuple = (1.0, 0.0)

    def __post_init__(self) -> None:
        u = np.asarray(self.heights, float)
        s = np.asarray(self.values, float)
        if u.ndim != 1 or u.size < 2 or u.shape != s.shape:
            raise ValueError(f"ramp shape needs at least 2 knots and as many values as heights, "
                             f"got {u.size} and {s.size}")
        if not (np.all(np.isfinite(u)) and np.all(np.isfinite(s))):
            raise ValueError("ramp shape knots must be finite")
        if u[0] != 0.0 or u[-1] != 1.0 or np.any(np.diff(u) <= 0.0):
            raise ValueError(f"ramp knot heights must rise strictly from 0 to 1 (fractions of h_w), got {tuple(u)}")
        if s[0] != 1.0 or s[-1] != 0.0 or np.any(np.diff(s) > 0.0):
            raise ValueError(f"ramp knot values must fall monotonically from 1 to 0, got {tuple(s)}")
        object.__setattr__(self, "heights", tuple(float(x) for x in u))
        object.__setattr__(self, "values", tuple(float(x) for x in s))

    @classmethod
    def power(cls, exponent: float, knots: int = 17) -> "RampShape":
        """The family S(u) = (1 − u)^p tabulated at ``knots`` knots (p = 1: the linear ramp, 2 knots).

        Knot placement keeps the tabulation error ≤ 0.016 for p in 0.25 … 4 with
        17 knots: equal drops of S for p < 1 (the shape is steep near u = 1),
        half-way between that and uniform spacing for p > 1.
        """
        p = float(exponent)
        if not (math.isfinite(p) and 0.05 <= p <= 20.0):
            raise ValueError(f"ramp exponent p = {exponent} is outside the allowed range 0.05 … 20")
        if p == 1.0:
            return cls()
        if knots < 3:
            raise ValueError(f"a curved ramp needs at least 3 knots, got {knots}")
        z = np.linspace(0.0, 1.0, knots)
        equal_drop = 1.0 - (1.0 - z) ** (1.0 / p)
        u = equal_drop if p < 1.0 else 0.5 * (z + equal_drop)
        return cls(tuple(u), tuple((1.0 - u) ** p))

    def __call__(self, u):
        """S(u) for u in [0, 1] (clamped outside), dimensionless."""
        return np.interp(np.clip(np.asarray(u, float), 0.0, 1.0), self.heights, self.values)


#: The default (calibrated) ramp: linear in tangent height, see tools/calibrate_chain.py.
LINEAR_RAMP = RampShape()


def atmosphere_radiance(tangent_height_m, horizon_radiance_ru, window_height_m=WINDOW_HEIGHT_M,
                        co2_radiance_ru=CO2_RADIANCE_RU, co2_top_height_m=CO2_TOP_HEIGHT_M,
                        ramp: RampShape = LINEAR_RAMP):
    """Radiance of a line of sight that misses the Earth, r.u., from its tangent height (physics.md §3).

    Args:
        tangent_height_m: tangent height h ≥ 0 of the line of sight, m (values
            ≤ 0 give the surface value B_m).
        horizon_radiance_ru: B_m, the disc radiance at the horizon point, r.u.
        window_height_m: h_w, height of the window emitting layer, m.
        co2_radiance_ru: B_a, radiance of the CO₂ layer, r.u.
        co2_top_height_m: top of the CO₂ layer, m.
        ramp: the window-region ramp shape S(h/h_w).

    Returns:
        Radiance, r.u., broadcast over the arguments.
    """
    h, b_m, h_w, b_a, h_top = np.broadcast_arrays(*(np.asarray(a, float) for a in (
        tangent_height_m, horizon_radiance_ru, window_height_m, co2_radiance_ru, co2_top_height_m)))
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(h_w > 0.0, h / h_w, np.where(h > 0.0, 1.0, 0.0))
    ramp_value = b_a + (b_m - b_a) * ramp(u)
    top = np.maximum(h_top, h_w)
    return np.where(h > top, 0.0, np.where(h > h_w, b_a, ramp_value))


def disc_radiance(ground_distance_m, horizon_radiance_ru, gradient_ru_per_m=0.0, jump_ru=0.0,
                  jump_distance_m=math.inf):
    """Radiance of the Earth's disc at a ground distance inwards from the horizon point, r.u.

    The parametric disc of the radiance models (physics.md §3.1): B_m at the
    horizon point, a linear change along the surface (Model B), and a jump
    at a given distance (Model C, a cloud front):

        B(d) = B_m + g·d + ΔB·[d ≥ d_jump].

    Args:
        ground_distance_m: distance along the surface from the horizon point inwards, m (≥ 0).
        horizon_radiance_ru: B_m, r.u.
        gradient_ru_per_m: g, r.u. per metre of ground distance.
        jump_ru: ΔB, r.u.
        jump_distance_m: d_jump, m.
    """
    d = np.asarray(ground_distance_m, float)
    jump = np.where(d >= np.asarray(jump_distance_m, float), np.asarray(jump_ru, float), 0.0)
    return np.asarray(horizon_radiance_ru, float) + np.asarray(gradient_ru_per_m, float) * d + jump


def line_of_sight_radiance(tangent_height_m, ground_distance_m, horizon_radiance_ru, gradient_ru_per_m=0.0,
                           jump_ru=0.0, jump_distance_m=math.inf, window_height_m=WINDOW_HEIGHT_M,
                           co2_radiance_ru=CO2_RADIANCE_RU, co2_top_height_m=CO2_TOP_HEIGHT_M,
                           ramp: RampShape = LINEAR_RAMP):
    """Radiance of any line of sight on a chord, r.u.: the atmosphere above the limb, the disc below.

    Args:
        tangent_height_m: tangent height, m; ≤ 0 where the line of sight hits the Earth.
        ground_distance_m: for lines of sight that hit, ground distance of the
            hit point inwards from the horizon point, m (ignored elsewhere, may be NaN).
        Other arguments: as :func:`atmosphere_radiance` and :func:`disc_radiance`.
    """
    h = np.asarray(tangent_height_m, float)
    above = atmosphere_radiance(np.maximum(h, 0.0), horizon_radiance_ru, window_height_m, co2_radiance_ru,
                                co2_top_height_m, ramp)
    d = np.where(h > 0.0, 0.0, np.nan_to_num(np.asarray(ground_distance_m, float)))
    below = disc_radiance(d, horizon_radiance_ru, gradient_ru_per_m, jump_ru, jump_distance_m)
    return np.where(h > 0.0, above, below)
