"""``pmv scenario {A,B,C,D}``: one pair of opposite chords through the signal chain under a radiance model."""

from __future__ import annotations

import math

from ..physics.chain import DetectionStatus
from ..physics.constants import ARCMIN_RAD
from ..physics.instrument.correction import load_correction
from ..physics.orbit.two_body import MAX_ALTITUDE_M, MIN_ALTITUDE_M
from ..physics.radiance import MAX_LAYER_HEIGHT_M, MEAN_EARTH_RADIANCE_RU, WINDOW_HEIGHT_M, WINDOW_HEIGHT_SIGMA_M
from ..physics.instrument.scenarios import (
    MAX_JUMP_DISTANCE_M,
    MAX_SCENARIO_RADIANCE_RU,
    MODEL_B_RADIANCES_RU,
    MODEL_C_JUMP_DISTANCE_M,
    MODEL_C_JUMP_RU,
    run_pair,
    scenario,
)
from .common import OneLineParser, add_json_flag, fail, format_table, print_json, ranged_float

COLUMNS = [
    ("chord", "chord", "d"),
    ("horizon_radiance_ru", "B, r.u.", ".3g"),
    ("window_height_km", "h_w, km", ".4g"),
    ("gam_arcmin", "Gam, ′", ".3f"),
    ("del_arcmin", "Del, ′", ".3f"),
    ("pop_arcmin", "POP, ′", "+.3f"),
    ("gam_corrected_arcmin", "Gam′, ′", ".3f"),
]

_RADIANCE = ranged_float(0.0, MAX_SCENARIO_RADIANCE_RU, " r.u.", low_open=True)
_HEIGHT = ranged_float(0.0, MAX_LAYER_HEIGHT_M / 1e3, " km")


def add_parser(subparsers) -> None:
    """Register ``pmv scenario`` and its four models."""
    parser = subparsers.add_parser(
        "scenario", help="one pair of opposite chords through the signal chain under radiance model A–D",
        description="Both chords of a pair through the sensor's signal chain (physics.md §4) under a radiance "
                    "model of physics.md §3.1; prints β (uncorrected) and β′ (brightness-corrected). On a sphere "
                    "at zero attitude these are the methodical errors.")
    models = parser.add_subparsers(dest="model", required=True, parser_class=OneLineParser, metavar="{A,B,C,D}")
    a = models.add_parser("A", help="step: uniform B(1), B(2) behind the two horizons",
                          description="Model A: uniform radiance behind each horizon (the calibration rig).")
    a.add_argument("--b1", type=_RADIANCE, default=1.0, help="radiance behind horizon 1, r.u. (default 1)")
    a.add_argument("--b2", type=_RADIANCE, default=2.0, help="radiance behind horizon 2, r.u. (default 2)")
    b = models.add_parser("B", help="latitude/season gradient, linear over the surface",
                          description="Model B: radiance linear over the Earth's surface between the horizon points.")
    b.add_argument("--b1", type=_RADIANCE, default=MODEL_B_RADIANCES_RU[0],
                   help=f"radiance at horizon point 1, r.u. (default {MODEL_B_RADIANCES_RU[0]})")
    b.add_argument("--b2", type=_RADIANCE, default=MODEL_B_RADIANCES_RU[1],
                   help=f"radiance at horizon point 2, r.u. (default {MODEL_B_RADIANCES_RU[1]})")
    c = models.add_parser("C", help="weather: a radiance jump inside horizon 1",
                          description="Model C: uniform radiance B, a jump on the disc of chord 1.")
    c.add_argument("--b", type=_RADIANCE, default=MEAN_EARTH_RADIANCE_RU,
                   help=f"radiance behind both horizons, r.u. (default {MEAN_EARTH_RADIANCE_RU})")
    c.add_argument("--jump", type=ranged_float(-MAX_SCENARIO_RADIANCE_RU, MAX_SCENARIO_RADIANCE_RU, " r.u."),
                   default=MODEL_C_JUMP_RU, help=f"radiance jump BA_s, r.u. (default {MODEL_C_JUMP_RU})")
    c.add_argument("--jump-distance-km", type=ranged_float(0.0, MAX_JUMP_DISTANCE_M / 1e3, " km"),
                   default=MODEL_C_JUMP_DISTANCE_M / 1e3,
                   help="ground distance of the jump inside horizon point 1, km "
                        f"(default {MODEL_C_JUMP_DISTANCE_M / 1e3:g})")
    d = models.add_parser("D", help="emitting-layer height raised or lowered behind horizon 1",
                          description="Model D: equal radiance, window-layer height h_w on chord 1, 40 km on chord 2.")
    d.add_argument("--b", type=_RADIANCE, default=MEAN_EARTH_RADIANCE_RU,
                   help=f"radiance behind both horizons, r.u. (default {MEAN_EARTH_RADIANCE_RU})")
    d.add_argument("--height-km", type=_HEIGHT, default=(WINDOW_HEIGHT_M + WINDOW_HEIGHT_SIGMA_M) / 1e3,
                   help="window-layer height behind horizon 1, km, 0 … 100 (default 50 = 40 + σ_h)")
    for model_parser in (a, b, c, d):
        model_parser.add_argument("--altitude-km", type=ranged_float(MIN_ALTITUDE_M / 1e3, MAX_ALTITUDE_M / 1e3, " km"),
                                  default=500.0, help="circular orbit altitude (default 500)")
        model_parser.add_argument("--correction", default="calibrated", metavar="{calibrated,none,FILE.csv}",
                                  help="brightness-correction table: the calibrated rig table (default), none, "
                                       "or a del_arcmin,pop_arcmin CSV file")
        add_json_flag(model_parser)
        model_parser.set_defaults(func=run)
    parser.set_defaults(func=run)


def _build(args):
    altitude_m = args.altitude_km * 1e3
    if args.model == "A":
        return scenario("A", b1=args.b1, b2=args.b2, altitude_m=altitude_m)
    if args.model == "B":
        return scenario("B", b1=args.b1, b2=args.b2, altitude_m=altitude_m)
    if args.model == "C":
        return scenario("C", b=args.b, jump=args.jump, jump_distance_m=args.jump_distance_km * 1e3,
                        altitude_m=altitude_m)
    return scenario("D", b=args.b, height_m=args.height_km * 1e3, altitude_m=altitude_m)


def _arcmin(value) -> float:
    return float(value) / ARCMIN_RAD


def run(args) -> int:
    """Run the scenario and print the pair's β, β′ and per-chord readings (or JSON)."""
    pair = _build(args)
    correction = load_correction(args.correction, pair.altitude_m)
    result = run_pair(pair, correction=correction)
    r = result.readings
    chords = []
    for k in range(2):
        chords.append({
            "chord": k + 1,
            "horizon_radiance_ru": pair.horizon_radiance_ru[k],
            "gradient_ru_per_1000km": pair.gradient_ru_per_m[k] * 1e6,
            "jump_ru": pair.jump_ru[k],
            "jump_distance_km": pair.jump_distance_m[k] / 1e3 if math.isfinite(pair.jump_distance_m[k]) else None,
            "window_height_km": pair.window_height_m[k] / 1e3,
            "gam_arcmin": _arcmin(r.gam_rad[k]), "del_arcmin": _arcmin(r.del_rad[k]),
            "pop_arcmin": _arcmin(r.pop_rad[k]), "gam_corrected_arcmin": _arcmin(r.gam_corrected_rad[k]),
            "status": DetectionStatus(int(r.status[k])).name,
        })
    correction_name = "none" if correction is None else correction.source
    failed = [c for c in chords if c["status"] != DetectionStatus.OK.name]
    if args.json:
        print_json({
            "model": pair.model, "description": pair.description, "altitude_km": args.altitude_km,
            "correction": correction_name,
            "beta_arcmin": _arcmin(result.beta_rad), "beta_corrected_arcmin": _arcmin(result.beta_corrected_rad),
            "gam_arcmin": [c["gam_arcmin"] for c in chords], "del_arcmin": [c["del_arcmin"] for c in chords],
            "gam_corrected_arcmin": [c["gam_corrected_arcmin"] for c in chords],
            "scan_start_nadir_deg": math.degrees(result.scan_start_nadir_rad),
            "true_horizon_nadir_deg": math.degrees(result.true_horizon_nadir_rad),
            "chords": chords,
        })
    else:
        print(f"Model {pair.model} — {pair.description}; H = {args.altitude_km:g} km; correction: {correction_name}")
        print(format_table(chords, COLUMNS))
        print(f"β  = {_arcmin(result.beta_rad):+.3f}′  (uncorrected, ½(Gam(1) − Gam(2)))")
        print(f"β′ = {_arcmin(result.beta_corrected_rad):+.3f}′  (brightness-corrected)")
    if failed:
        first = failed[0]
        return _chord_failure(first["chord"], first["status"])
    return 0


def _chord_failure(chord: int, status: str) -> int:
    reasons = {
        DetectionStatus.FIRST_THRESHOLD_NOT_REACHED.name: "never crossed the first threshold (0.33 J): "
                                                          "horizon too dark",
        DetectionStatus.SECOND_THRESHOLD_NOT_REACHED.name: "never crossed the second threshold (0.67 J): "
                                                           "horizon too dark",
    }
    fail("pmv scenario", f"chord {chord}: {reasons.get(status, status)}")
    return 1
