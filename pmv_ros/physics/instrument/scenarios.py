"""Radiance models A–D of physics.md §3.1 over a pair of opposite chords, through the signal chain.

Each model builds a :class:`PairScenario` — the horizon each of the two
opposite chords sees, over a sphere of the mean radius at zero attitude —
with the parameters of physics.md §3.1 as defaults; :func:`run_pair` puts
both chords through the chain and returns β = ½(Gam(1) − Gam(2)) and
β′ = ½(Gam′(1) − Gam′(2)) (physics.md §4, step 7). On a sphere at zero
attitude the true β is 0, so β and β′ *are* the methodical errors.

* Model A — step: uniform B(1) behind chord 1, B(2) behind chord 2 (what
  the calibration rig imitates).
* Model B — latitude/season gradient: radiance linear over the Earth's
  surface between the two horizon points, B(1) at chord 1's, B(2) at
  chord 2's (defaults: the southern-summer extreme, 1.6 and 3.5 r.u.).
* Model C — weather: uniform B on both, plus a jump BA_s = 0.4 r.u. on the
  disc of chord 1 at a ground distance of R_x = 300 km inside its horizon
  point (configurable).
* Model D — emitting-layer height: equal radiance B, h_w raised or lowered
  on chord 1 (default 40 + σ_h = 50 km), 40 km on chord 2.

Both chords share one scan start θ₀ = φ(top) + γ (an instrument angle),
where "top" is the highest emitting layer of the pair.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..chain import (
    DEFAULT_CHAIN_PARAMETERS,
    ChainParameters,
    ChordReadings,
    pair_angles,
    scan_start_nadir_angle,
    sense_horizon_chords,
    sphere_chord,
)
from ..constants import EARTH_MEAN_RADIUS_M
from .correction import calibrated_correction_table
from ..orbit.two_body import MAX_ALTITUDE_M, MIN_ALTITUDE_M
from ..radiance import MAX_LAYER_HEIGHT_M, MEAN_EARTH_RADIANCE_RU, WINDOW_HEIGHT_M, WINDOW_HEIGHT_SIGMA_M

#: Radiance models of physics.md §3.1.
MODELS = ("A", "B", "C", "D")
#: Largest radiance a scenario accepts, r.u. (the physical range is 1 … 4; beyond it the table is extrapolated).
MAX_SCENARIO_RADIANCE_RU = 20.0
#: Model B defaults: L(1) = 4, L(2) = 8.75 mW/(cm²·sr) at 45° S in southern summer (physics.md §3.1).
MODEL_B_RADIANCES_RU = (1.6, 3.5)
#: Model C defaults: σ_B½ = 0.4 r.u. at R_x = 300 km (physics.md §3.1).
MODEL_C_JUMP_RU = 0.4
MODEL_C_JUMP_DISTANCE_M = 300e3
#: Largest jump distance, m (about the ground distance between the horizons of a low orbit).
MAX_JUMP_DISTANCE_M = 5000e3


@dataclass(frozen=True)
class PairScenario:
    """The horizons of a pair of opposite chords (chord 1, chord 2); per-chord tuples, SI and r.u."""

    model: str
    description: str
    altitude_m: float
    horizon_radiance_ru: tuple
    gradient_ru_per_m: tuple = (0.0, 0.0)
    jump_ru: tuple = (0.0, 0.0)
    jump_distance_m: tuple = (math.inf, math.inf)
    window_height_m: tuple = (WINDOW_HEIGHT_M, WINDOW_HEIGHT_M)
    earth_radius_m: float = EARTH_MEAN_RADIUS_M


@dataclass(frozen=True)
class PairResult:
    """A pair through the chain: β, β′ (rad) and both chords' readings (arrays of 2)."""

    scenario: PairScenario
    readings: ChordReadings
    beta_rad: float
    beta_corrected_rad: float
    scan_start_nadir_rad: float
    true_horizon_nadir_rad: float


def _radiance(name, value):
    number = _number(name, value)
    if not (0.0 < number <= MAX_SCENARIO_RADIANCE_RU):
        raise ValueError(f"{name} = {value} r.u. is outside the allowed range (0, {MAX_SCENARIO_RADIANCE_RU:g}] r.u.")
    return number


def _number(name, value):
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return number


def _height(name, value_m):
    number = _number(name, value_m)
    if not (0.0 <= number <= MAX_LAYER_HEIGHT_M):
        raise ValueError(f"{name} = {number / 1e3:g} km is outside the allowed range "
                         f"[0, {MAX_LAYER_HEIGHT_M / 1e3:g}] km")
    return number


def _altitude(value_m):
    number = _number("altitude", value_m)
    if not (MIN_ALTITUDE_M <= number <= MAX_ALTITUDE_M):
        raise ValueError(f"altitude = {number / 1e3:g} km is outside the allowed range "
                         f"[{MIN_ALTITUDE_M / 1e3:g}, {MAX_ALTITUDE_M / 1e3:g}] km")
    return number


def model_a(b1=1.0, b2=2.0, altitude_m=500e3, window_height_m=WINDOW_HEIGHT_M) -> PairScenario:
    """Model A: uniform radiance B(1), B(2) r.u. behind the two horizons (physics.md §3.1)."""
    b1, b2 = _radiance("B(1)", b1), _radiance("B(2)", b2)
    h_w = _height("window height", window_height_m)
    return PairScenario("A", f"step: B(1) = {b1:g} r.u., B(2) = {b2:g} r.u.", _altitude(altitude_m), (b1, b2),
                        window_height_m=(h_w, h_w))


def model_b(b1=MODEL_B_RADIANCES_RU[0], b2=MODEL_B_RADIANCES_RU[1], altitude_m=500e3,
            earth_radius_m=EARTH_MEAN_RADIUS_M) -> PairScenario:
    """Model B: radiance linear over the surface from B(1) at one horizon point to B(2) at the other, r.u."""
    b1, b2 = _radiance("B(1)", b1), _radiance("B(2)", b2)
    altitude = _altitude(altitude_m)
    phi0, _ = sphere_chord(altitude, earth_radius_m)
    # Ground distance between the two horizon points across the sub-satellite point.
    separation_m = 2.0 * earth_radius_m * (0.5 * math.pi - float(phi0))
    gradient = (b2 - b1) / separation_m
    return PairScenario("B", f"gradient: B(1) = {b1:g} r.u. → B(2) = {b2:g} r.u. over {separation_m / 1e3:.0f} km",
                        altitude, (b1, b2), gradient_ru_per_m=(gradient, -gradient), earth_radius_m=earth_radius_m)


def model_c(b=MEAN_EARTH_RADIANCE_RU, jump=MODEL_C_JUMP_RU, jump_distance_m=MODEL_C_JUMP_DISTANCE_M,
            altitude_m=500e3) -> PairScenario:
    """Model C: uniform B r.u. on both chords, a jump of ``jump`` r.u. on chord 1's disc at ``jump_distance_m``."""
    b = _radiance("B", b)
    jump = _number("jump", jump)
    if not (b + jump > 0.0):
        raise ValueError(f"the radiance beyond the jump, B + jump = {b + jump:g} r.u., must be positive")
    distance = _number("jump distance", jump_distance_m)
    if not (0.0 <= distance <= MAX_JUMP_DISTANCE_M):
        raise ValueError(f"jump distance = {distance / 1e3:g} km is outside the allowed range "
                         f"[0, {MAX_JUMP_DISTANCE_M / 1e3:g}] km")
    return PairScenario("C", f"weather: B = {b:g} r.u., jump {jump:+g} r.u. at {distance / 1e3:g} km inside horizon 1",
                        _altitude(altitude_m), (b, b), jump_ru=(jump, 0.0), jump_distance_m=(distance, math.inf))


def model_d(b=MEAN_EARTH_RADIANCE_RU, height_m=WINDOW_HEIGHT_M + WINDOW_HEIGHT_SIGMA_M, altitude_m=500e3,
            other_height_m=WINDOW_HEIGHT_M) -> PairScenario:
    """Model D: equal radiance B r.u.; window-layer height ``height_m`` (m) behind chord 1,
    ``other_height_m`` behind 2."""
    b = _radiance("B", b)
    h1, h2 = _height("window height", height_m), _height("other window height", other_height_m)
    return PairScenario("D", f"layer height: B = {b:g} r.u., h_w = {h1 / 1e3:g} km vs {h2 / 1e3:g} km",
                        _altitude(altitude_m), (b, b), window_height_m=(h1, h2))


_BUILDERS = {"A": model_a, "B": model_b, "C": model_c, "D": model_d}


def scenario(model: str, **options) -> PairScenario:
    """Build a scenario by model letter A–D with that model's keyword options."""
    key = str(model).strip().upper()
    if key not in _BUILDERS:
        raise ValueError(f"unknown radiance model {model!r}; choose one of {', '.join(MODELS)}")
    return _BUILDERS[key](**options)


_CALIBRATED = object()


def run_pair(pair: PairScenario, correction=_CALIBRATED,
             params: ChainParameters = DEFAULT_CHAIN_PARAMETERS) -> PairResult:
    """Both chords of a scenario through the chain: β and β′ (physics.md §4, step 7).

    Args:
        pair: the scenario.
        correction: the table F — by default the calibrated rig table for the
            scenario's altitude; None for no correction; or any callable/table.
        params: chain parameters.
    """
    if correction is _CALIBRATED:
        correction = calibrated_correction_table(pair.altitude_m, params)
    phi0, slope = sphere_chord(pair.altitude_m, pair.earth_radius_m)
    top = max([params.co2_top_height_m, *pair.window_height_m])
    theta0 = float(scan_start_nadir_angle(phi0, slope, top, params, pair.earth_radius_m))
    readings = sense_horizon_chords(
        phi0, slope, np.asarray(pair.horizon_radiance_ru), scan_start_nadir_rad=theta0,
        gradient_ru_per_m=np.asarray(pair.gradient_ru_per_m), jump_ru=np.asarray(pair.jump_ru),
        jump_distance_m=np.asarray(pair.jump_distance_m), window_height_m=np.asarray(pair.window_height_m),
        earth_radius_m=pair.earth_radius_m, correction=correction, params=params)
    beta = float(pair_angles(readings.gam_rad[0], readings.gam_rad[1]))
    beta_corrected = float(pair_angles(readings.gam_corrected_rad[0], readings.gam_corrected_rad[1]))
    return PairResult(pair, readings, beta, beta_corrected, theta0, float(phi0))
