"""``pmv analyze``: the flight-test error statistics (physics.md §5, §5.1) of recorded telemetry.

Two CSV layouts (interfaces.md), each with a header row:

* ``orbit,u_deg,roll_arcmin,pitch_arcmin`` — the published form: the sensor
  error against the reference at orbital angles u, orbit by orbit;
* ``t_s,roll_rad,pitch_rad[,truth_roll_rad,truth_pitch_rad]`` — a recording of
  the sensor (and the star tracker): the error is sensor − truth, or the
  sensor output itself without truth columns (a nadir-holding spacecraft).
  u(t) = u0 + 2π t / T with T the period of the circular orbit.

Extra columns are ignored; blank lines and lines starting with ``#`` are
skipped; a row with a NaN/Inf cell (a telemetry drop-out) is skipped and
counted. Anything else wrong in the file is a one-line error naming the file,
line and column, exit status 2.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass

import numpy as np

from ..core.constants import ARCMIN_RAD
from ..core.ground_error import ground_error
from ..core.orbit import MAX_ALTITUDE_M, MIN_ALTITUDE_M, CircularOrbit
from ..core.statistics import ORBIT_HARMONICS, correct_reference_drift, flight_test_statistics
from .common import add_json_flag, format_table, print_json, ranged_float

ORBIT_LAYOUT = ("orbit", "u_deg", "roll_arcmin", "pitch_arcmin")
TIME_LAYOUT = ("t_s", "roll_rad", "pitch_rad")
TRUTH_COLUMNS = ("truth_roll_rad", "truth_pitch_rad")

#: Default u bin of step 2 for the time layout, deg (the orbit layout groups exact u).
DEFAULT_TIME_LAYOUT_BIN_DEG = 1.0


@dataclass(frozen=True)
class Telemetry:
    """Columns of a telemetry CSV as float arrays, with the layout and the rows skipped."""

    path: str
    layout: str
    columns: dict
    rows_skipped: int


def _parse_error(path: str, line: int, message: str) -> ValueError:
    return ValueError(f"{path}, line {line}: {message}")


def read_telemetry(path: str) -> Telemetry:
    """Read a telemetry CSV of either layout; ValueError with file, line and column on any defect."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as stream:
            lines = [(number, text) for number, text in enumerate(stream, start=1)
                     if text.strip() and not text.lstrip().startswith("#")]
    except (OSError, UnicodeDecodeError) as error:
        reason = error.strerror if isinstance(error, OSError) and error.strerror else type(error).__name__
        raise ValueError(f"{path}: cannot read the file ({reason})") from None
    if not lines:
        raise ValueError(f"{path}: empty file, expected a header row {','.join(ORBIT_LAYOUT)} "
                         f"or {','.join(TIME_LAYOUT)}")
    rows = list(zip((n for n, _ in lines), csv.reader(text for _, text in lines)))
    header_line, header = rows[0]
    header = [name.strip() for name in header]
    layout, wanted = _layout(path, header_line, header)
    index = {name: header.index(name) for name in wanted}
    values = {name: [] for name in wanted}
    skipped = 0
    for line, cells in rows[1:]:
        if len(cells) != len(header):
            raise _parse_error(path, line, f"{len(cells)} cells, the header has {len(header)}")
        row = {}
        for name in wanted:
            text = cells[index[name]].strip()
            try:
                row[name] = float(text)
            except ValueError:
                raise ValueError(f"{path}, line {line}, column '{name}': {text!r} is not a number") from None
        if not all(math.isfinite(v) for v in row.values()):
            skipped += 1
            continue
        for name in wanted:
            values[name].append(row[name])
    if not values[wanted[0]]:
        raise ValueError(f"{path}: no usable data rows after the header (line {header_line})")
    return Telemetry(path, layout, {name: np.array(v) for name, v in values.items()}, skipped)


def _layout(path: str, line: int, header: list[str]) -> tuple[str, tuple[str, ...]]:
    present = set(header)
    if set(ORBIT_LAYOUT) <= present:
        return "orbit", ORBIT_LAYOUT
    if set(TIME_LAYOUT) <= present:
        truth = [name for name in TRUTH_COLUMNS if name in present]
        if len(truth) == 1:
            missing = (set(TRUTH_COLUMNS) - set(truth)).pop()
            raise _parse_error(path, line, f"missing column '{missing}' (it goes with '{truth[0]}')")
        return "time", TIME_LAYOUT + (TRUTH_COLUMNS if truth else ())
    # Name the missing columns of the layout the header is closer to.
    closer = max((ORBIT_LAYOUT, TIME_LAYOUT), key=lambda layout: len(present & set(layout)))
    missing = ", ".join(f"'{name}'" for name in closer if name not in present)
    raise _parse_error(path, line, f"missing column {missing}; expected the columns {','.join(ORBIT_LAYOUT)} "
                                   f"or {','.join(TIME_LAYOUT)}[,{','.join(TRUTH_COLUMNS)}]")


def add_parser(subparsers) -> None:
    """Register ``pmv analyze``."""
    parser = subparsers.add_parser(
        "analyze",
        help="flight-test error statistics of recorded telemetry (physics.md §5, §5.1)",
        description="The published flight-test procedure on recorded telemetry: average over the orbits at "
                    "each orbital angle, remove the offsets K and T, remove the oblateness model (published "
                    "closed form and sign convention), meridional residual MO, σ and MO ± 3σ; harmonic "
                    "amplitudes at k = 1, 2, 15…25 of the orbital frequency per complete orbit.")
    parser.add_argument("file", metavar="FILE.csv", help="telemetry: orbit,u_deg,roll_arcmin,pitch_arcmin "
                        "or t_s,roll_rad,pitch_rad[,truth_roll_rad,truth_pitch_rad]")
    parser.add_argument("--altitude-km", required=True,
                        type=ranged_float(MIN_ALTITUDE_M / 1e3, MAX_ALTITUDE_M / 1e3, " km"),
                        help="circular orbit altitude above the 6371 km mean radius")
    parser.add_argument("--inclination-deg", required=True, type=ranged_float(0.0, 180.0, " deg"),
                        help="orbit inclination, 0 … 180 deg")
    parser.add_argument("--u0-deg", type=ranged_float(-360.0, 360.0, " deg"), default=0.0,
                        help="time layout: argument of latitude at t = 0 (default 0)")
    parser.add_argument("--u-bin-deg", type=ranged_float(0.0, 360.0, " deg", low_open=True), default=None,
                        help="width of the orbital-angle bins the orbits are averaged in (default: exact u for "
                             f"the orbit layout, {DEFAULT_TIME_LAYOUT_BIN_DEG:g} deg for the time layout)")
    parser.add_argument("--keep-oblateness", action="store_true",
                        help="do not remove the oblateness model (skip step 4)")
    parser.add_argument("--roll-drift-arcmin-per-orbit", type=ranged_float(-600.0, 600.0, "′"), default=0.0,
                        help="step 1: known linear drift of the roll reference, reset at each ascending node")
    parser.add_argument("--pitch-drift-arcmin-per-orbit", type=ranged_float(-600.0, 600.0, "′"), default=0.0,
                        help="step 1: known linear drift of the pitch reference, reset at each ascending node")
    add_json_flag(parser)
    parser.set_defaults(func=run)


def analyze_telemetry(telemetry: Telemetry, altitude_m: float, inclination_rad: float, *, u0_rad: float = 0.0,
                      u_bin_rad: float | None = None, remove_oblateness: bool = True,
                      roll_drift_rad_per_orbit: float = 0.0, pitch_drift_rad_per_orbit: float = 0.0) -> dict:
    """Run the flight-test statistics on read telemetry; the report as a dict (arcmin for people)."""
    orbit = CircularOrbit(altitude_m, inclination_rad)
    period = orbit.period_s
    columns = telemetry.columns
    if telemetry.layout == "orbit":
        u = np.radians(columns["u_deg"])
        roll, pitch = columns["roll_arcmin"] * ARCMIN_RAD, columns["pitch_arcmin"] * ARCMIN_RAD
        orbit_index = columns["orbit"]
    else:
        u = u0_rad + 2.0 * math.pi * columns["t_s"] / period
        roll, pitch = columns["roll_rad"], columns["pitch_rad"]
        if "truth_roll_rad" in columns:
            roll, pitch = roll - columns["truth_roll_rad"], pitch - columns["truth_pitch_rad"]
        orbit_index = None
        if u_bin_rad is None:
            u_bin_rad = math.radians(DEFAULT_TIME_LAYOUT_BIN_DEG)
    # Step 1: the reference is taken as reset at each ascending node.
    elapsed_s = np.mod(u, 2.0 * math.pi) / (2.0 * math.pi) * period
    roll = correct_reference_drift(roll, elapsed_s, roll_drift_rad_per_orbit / period)
    pitch = correct_reference_drift(pitch, elapsed_s, pitch_drift_rad_per_orbit / period)
    result = flight_test_statistics(u, roll, pitch, altitude_m, inclination_rad, orbit_index=orbit_index,
                                    remove_oblateness=remove_oblateness, u_bin_rad=u_bin_rad)

    def arcmin(value):
        return float(value) / ARCMIN_RAD

    channels = {}
    for channel in result.channels:
        detail = {
            "count": channel.count, "mean_arcmin": arcmin(channel.mean_rad), "sigma_arcmin": arcmin(channel.sigma_rad),
            "three_sigma_arcmin": arcmin(channel.three_sigma_rad), "max_abs_arcmin": arcmin(channel.max_abs_rad),
            "harmonics_arcmin": {str(k): arcmin(a) for k, a in channel.harmonics_rad.items()},
            "harmonics_with_oblateness_arcmin": {str(k): arcmin(a)
                                                 for k, a in channel.harmonics_with_oblateness_rad.items()},
            "orbits_in_harmonics": channel.orbits_in_harmonics,
        }
        if channel.channel != "meridional":
            detail = {"offset_arcmin": arcmin(channel.offset_rad), **detail}
        channels[channel.channel] = detail
    series = [{"u_deg": math.degrees(u_i), "samples": int(n), "roll_arcmin": arcmin(r), "pitch_arcmin": arcmin(p),
               "oblateness_roll_arcmin": arcmin(o_r), "oblateness_pitch_arcmin": arcmin(o_p),
               "residual_roll_arcmin": arcmin(d_r), "residual_pitch_arcmin": arcmin(d_p),
               "meridional_arcmin": arcmin(m)}
              for u_i, n, r, p, o_r, o_p, d_r, d_p, m in zip(
                  result.u_rad, result.samples_per_u, result.roll_mean_rad, result.pitch_mean_rad,
                  result.oblateness_roll_rad, result.oblateness_pitch_rad, result.roll_residual_rad,
                  result.pitch_residual_rad, result.meridional_rad)]
    limit_ground = ground_error(result.limit_high_rad, 0.0, altitude_m).circular_m
    return {
        "file": telemetry.path, "layout": telemetry.layout,
        "altitude_km": altitude_m / 1e3, "inclination_deg": math.degrees(inclination_rad), "period_s": period,
        "samples": int(result.samples_per_u.sum()), "rows_skipped": telemetry.rows_skipped,
        "orbits": result.orbits, "orbital_angles": int(result.u_rad.size),
        "oblateness_removed": result.oblateness_removed,
        "roll_offset_arcmin": arcmin(result.roll_offset_rad), "pitch_offset_arcmin": arcmin(result.pitch_offset_rad),
        "mo_arcmin": arcmin(result.mo_rad), "sigma_arcmin": arcmin(result.sigma_m_rad),
        "limit_arcmin": arcmin(result.limit_high_rad), "limit_low_arcmin": arcmin(result.limit_low_rad),
        "limit_high_arcmin": arcmin(result.limit_high_rad), "limit_ground_m": float(limit_ground),
        "harmonics": list(ORBIT_HARMONICS),
        "channels": channels, "series": series,
    }


def _format_report(report: dict) -> str:
    lines = [
        f"{report['file']}: {report['layout']} layout, {report['samples']} samples "
        f"({report['rows_skipped']} rows skipped), {report['orbits']} orbits, "
        f"{report['orbital_angles']} orbital angles",
        f"H = {report['altitude_km']:g} km, i = {report['inclination_deg']:g}°, T = {report['period_s']:.0f} s; "
        + ("oblateness model removed (published closed form)" if report["oblateness_removed"]
           else "oblateness kept"),
        f"offsets: K (roll) = {report['roll_offset_arcmin']:+.2f}′, "
        f"T (pitch) = {report['pitch_offset_arcmin']:+.2f}′",
        f"meridional residual: MO = {report['mo_arcmin']:.2f}′, σ = {report['sigma_arcmin']:.2f}′, "
        f"MO ± 3σ = {report['limit_low_arcmin']:+.2f}′ … {report['limit_high_arcmin']:+.2f}′ "
        f"(≈ {report['limit_ground_m']:.0f} m on the ground at nadir)",
        "",
    ]
    rows = []
    for name, detail in report["channels"].items():
        harmonics = detail["harmonics_arcmin"]
        hump = [harmonics[str(k)] for k in range(15, 26) if harmonics.get(str(k)) is not None]
        hump = [a for a in hump if math.isfinite(a)]
        rows.append({"channel": name, "mean": detail["mean_arcmin"], "sigma": detail["sigma_arcmin"],
                     "max": detail["max_abs_arcmin"], "k1": harmonics["1"], "k2": harmonics["2"],
                     "hump": max(hump) if hump else None})
    lines.append(format_table(rows, [("channel", "channel", ""), ("mean", "mean, ′", "+.2f"),
                                     ("sigma", "σ, ′", ".2f"), ("max", "max |e|, ′", ".2f"),
                                     ("k1", "k=1, ′", ".2f"), ("k2", "k=2, ′", ".2f"),
                                     ("hump", "max k=15…25, ′", ".2f")]))
    lines.append("harmonic amplitudes: mean over complete orbits, after offset"
                 + (" and oblateness removal" if report["oblateness_removed"] else " removal")
                 + "; — where the sampling cannot resolve them")
    return "\n".join(lines)


def run(args) -> int:
    """Analyse the file and print the report (or JSON)."""
    telemetry = read_telemetry(args.file)
    try:
        report = analyze_telemetry(
            telemetry, args.altitude_km * 1e3, math.radians(args.inclination_deg),
            u0_rad=math.radians(args.u0_deg),
            u_bin_rad=None if args.u_bin_deg is None else math.radians(args.u_bin_deg),
            remove_oblateness=not args.keep_oblateness,
            roll_drift_rad_per_orbit=args.roll_drift_arcmin_per_orbit * ARCMIN_RAD,
            pitch_drift_rad_per_orbit=args.pitch_drift_arcmin_per_orbit * ARCMIN_RAD)
    except ValueError as error:
        raise ValueError(f"{args.file}: {error}") from None
    if args.json:
        print_json(report)
    else:
        print(_format_report(report))
    return 0
