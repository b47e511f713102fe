"""``pmv oblateness``: the oblateness error over one orbit, from ray geometry on the ellipsoid.

It prints the published table (physics.md §2.1), so the paper's sign
convention is the default; ``--convention ros`` gives REP-103, the signs of
``/pmv/attitude``. The conversion is :func:`pmv_ros.physics.conventions.convert`.
"""

from __future__ import annotations

import math

import numpy as np

from ..physics.constants import ARCMIN_RAD, GRS80
from ..physics.conventions import CONVENTIONS, convert
from ..physics.instrument.oblateness import closed_form_oblateness, oblateness_error
from ..physics.orbit.two_body import MAX_ALTITUDE_M, MIN_ALTITUDE_M, CircularOrbit
from .common import add_json_flag, format_table, print_json, ranged_float

#: Finest step of the table, deg: 360,000 rows of ray geometry, the cost linear in the rows (≈ 2 s of CPU and
#: ≈ 0.35 GB at this step); a finer one would only grow the table (and could not be allocated at all near 0).
MIN_STEP_DEG = 0.001

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
                    "on the GRS80 ellipsoid (physics.md §2.1); signs as published unless --convention ros.")
    parser.add_argument("--altitude-km", required=True,
                        type=ranged_float(MIN_ALTITUDE_M / 1e3, MAX_ALTITUDE_M / 1e3, " km"),
                        help="circular orbit altitude above the 6371 km mean radius")
    parser.add_argument("--inclination-deg", required=True, type=ranged_float(0.0, 180.0, " deg"),
                        help="orbit inclination, 0 … 180 deg")
    parser.add_argument("--step-deg", type=ranged_float(MIN_STEP_DEG, 360.0, " deg"), default=15.0,
                        help=f"step in argument of latitude u, {MIN_STEP_DEG:g} … 360 (default 15)")
    parser.add_argument("--height-km", type=ranged_float(0.0, 100.0, " km"), default=0.0,
                        help="height of the grazing layer above the ellipsoid (default 0: hard Earth)")
    parser.add_argument("--closed-form", action="store_true",
                        help="print the published closed-form model instead of the ray geometry")
    parser.add_argument("--convention", choices=CONVENTIONS, default="paper",
                        help="sign convention of roll and pitch: paper (the published table, default) or ros "
                             "(REP-103, as on /pmv/attitude); physics.md \"Sign conventions\"")
    add_json_flag(parser)
    parser.set_defaults(func=run)


def oblateness_rows(altitude_m: float, inclination_rad: float, step_rad: float, height_m: float = 0.0,
                    closed_form: bool = False, convention: str = "paper") -> list[dict]:
    """Rows {u_deg, meridional_arcmin, pitch_arcmin, roll_arcmin} over one orbit (arcmin for people).

    Roll and pitch in ``convention``; the meridional component (Δβ)m as the paper defines it, in either.
    """
    u = np.arange(0.0, 2.0 * math.pi - 1e-9, step_rad)
    if closed_form:
        meridional, roll, pitch = closed_form_oblateness(u, altitude_m, inclination_rad)
        roll, pitch = convert(roll, pitch, "ros", convention)
    else:
        orbit = CircularOrbit(altitude_m, inclination_rad)
        roll, pitch = convert(*oblateness_error(orbit, u, GRS80, height_m), "ros", convention)
        # The meridional component: projection on the meridian direction (angle B to the orbit
        # plane), in the paper's signs (pitch = (Δβ)m cos B, roll = −(Δβ)m sin B).
        paper_roll, paper_pitch = convert(roll, pitch, convention, "paper")
        b_angle = np.arctan2(math.cos(inclination_rad), math.sin(inclination_rad) * np.cos(u))
        meridional = paper_pitch * np.cos(b_angle) - paper_roll * np.sin(b_angle)
    return [
        {"u_deg": round(math.degrees(ui), 9), "meridional_arcmin": m / ARCMIN_RAD,
         "pitch_arcmin": p / ARCMIN_RAD, "roll_arcmin": r / ARCMIN_RAD}
        for ui, m, p, r in zip(u, meridional, pitch, roll)
    ]


def run(args) -> int:
    """Print the oblateness table (or JSON)."""
    rows = oblateness_rows(args.altitude_km * 1e3, math.radians(args.inclination_deg), math.radians(args.step_deg),
                           args.height_km * 1e3, args.closed_form, args.convention)
    method = "closed-form model (physics.md §2.1)" if args.closed_form else "ray geometry on GRS80"
    if args.json:
        print_json({"altitude_km": args.altitude_km, "inclination_deg": args.inclination_deg,
                    "height_km": args.height_km, "method": method, "convention": args.convention, "rows": rows})
    else:
        signs = ("published (paper) sign convention" if args.convention == "paper"
                 else "REP-103 sign convention (as on /pmv/attitude)")
        print(f"Oblateness error, H = {args.altitude_km:g} km, i = {args.inclination_deg:g}°, "
              f"layer {args.height_km:g} km — {method}; arcmin, {signs}")
        print(format_table(rows, COLUMNS))
    return 0
