"""``pmv oblateness``: the oblateness error over one orbit, from ray geometry on the ellipsoid."""

from __future__ import annotations

import math

import numpy as np

from ..core.constants import ARCMIN_RAD, GRS80
from ..core.oblateness import closed_form_oblateness, oblateness_error
from ..core.orbit import MAX_ALTITUDE_M, MIN_ALTITUDE_M, CircularOrbit
from .common import add_json_flag, format_table, print_json, ranged_float

COLUMNS = [
    ("u_deg", "u, deg", ".1f"),
    ("meridional_arcmin", "meridional, ′", "+.2f"),
    ("pitch_arcmin", "pitch, ′", "+.2f"),
    ("roll_arcmin", "roll, ′", "+.2f"),
]


def add_parser(subparsers) -> None:
    """Register ``pmv oblateness``."""
    parser = subparsers.add_parser(
        "oblateness",
        help="oblateness error of the geometric vertical over one orbit",
        description="Oblateness error of the sensed vertical at zero attitude, from exact tangent rays "
                    "on the GRS80 ellipsoid (physics.md §2.1), signs as published.")
    parser.add_argument("--altitude-km", required=True,
                        type=ranged_float(MIN_ALTITUDE_M / 1e3, MAX_ALTITUDE_M / 1e3, " km"),
                        help="circular orbit altitude above the 6371 km mean radius")
    parser.add_argument("--inclination-deg", required=True, type=ranged_float(0.0, 180.0, " deg"),
                        help="orbit inclination, 0 … 180 deg")
    parser.add_argument("--step-deg", type=ranged_float(0.0, 360.0, " deg", low_open=True), default=15.0,
                        help="step in argument of latitude u (default 15)")
    parser.add_argument("--height-km", type=ranged_float(0.0, 100.0, " km"), default=0.0,
                        help="height of the grazing layer above the ellipsoid (default 0: hard Earth)")
    parser.add_argument("--closed-form", action="store_true",
                        help="print the published closed-form model instead of the ray geometry")
    add_json_flag(parser)
    parser.set_defaults(func=run)


def oblateness_rows(altitude_m: float, inclination_rad: float, step_rad: float, height_m: float = 0.0,
                    closed_form: bool = False) -> list[dict]:
    """Rows {u_deg, meridional_arcmin, pitch_arcmin, roll_arcmin} over one orbit (arcmin for people)."""
    u = np.arange(0.0, 2.0 * math.pi - 1e-9, step_rad)
    model_meridional, model_roll, model_pitch = closed_form_oblateness(u, altitude_m, inclination_rad)
    if closed_form:
        meridional, roll, pitch = model_meridional, model_roll, model_pitch
    else:
        orbit = CircularOrbit(altitude_m, inclination_rad)
        roll, pitch = oblateness_error(orbit, u, GRS80, height_m)
        # The meridional component: projection on the meridian direction (angle B to the orbit plane).
        b_angle = np.arctan2(math.cos(inclination_rad), math.sin(inclination_rad) * np.cos(u))
        meridional = pitch * np.cos(b_angle) - roll * np.sin(b_angle)
    return [
        {"u_deg": round(math.degrees(ui), 9), "meridional_arcmin": m / ARCMIN_RAD,
         "pitch_arcmin": p / ARCMIN_RAD, "roll_arcmin": r / ARCMIN_RAD}
        for ui, m, p, r in zip(u, meridional, pitch, roll)
    ]


def run(args) -> int:
    """Print the oblateness table (or JSON)."""
    rows = oblateness_rows(args.altitude_km * 1e3, math.radians(args.inclination_deg), math.radians(args.step_deg),
                           args.height_km * 1e3, args.closed_form)
    method = "closed-form model (physics.md §2.1)" if args.closed_form else "ray geometry on GRS80"
    if args.json:
        print_json({"altitude_km": args.altitude_km, "inclination_deg": args.inclination_deg,
                    "height_km": args.height_km, "method": method, "rows": rows})
    else:
        print(f"Oblateness error, H = {args.altitude_km:g} km, i = {args.inclination_deg:g}°, "
              f"layer {args.height_km:g} km — {method}; arcmin, published sign convention")
        print(format_table(rows, COLUMNS))
    return 0
