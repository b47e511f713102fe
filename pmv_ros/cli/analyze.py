"""``pmv analyze``: the flight-test error statistics of recorded telemetry — arguments and printing.

The analysis itself, its inputs (two CSV layouts and rosbag2 recordings) and
its sign conventions are :mod:`pmv_ros.apps.telemetry`.
"""

from __future__ import annotations

import math


from ..analysis.flight_test import U_RESOLUTION_RAD
from ..physics.constants import ARCMIN_RAD
from ..physics.conventions import CONVENTIONS, PAPER
from ..physics.orbit.two_body import MAX_ALTITUDE_M, MIN_ALTITUDE_M
from ..apps.telemetry import (
    DEFAULT_TIME_LAYOUT_BIN_DEG,
    PHASE_SOURCES,
    TRUTH_TOPICS,
    analyze_recording,
    analyze_telemetry,
    is_recording,
    read_telemetry,
)
from .common import add_json_flag, format_table, print_json, ranged_float


def _namespace(text: str) -> str:
    """A ROS namespace as ``--namespace`` takes it ('sat1' or '/sat1'), checked with rclpy's own rule."""
    if not text.strip("/"):  # the default: no rclpy needed (analyzing a CSV needs no ROS at all)
        return ""
    import argparse

    from rclpy.exceptions import InvalidNamespaceException
    from rclpy.validate_namespace import validate_namespace

    try:
        validate_namespace("/" + text.strip("/"))
    except InvalidNamespaceException as error:
        reason = str(error).splitlines()[0].rstrip(":")
        raise argparse.ArgumentTypeError(f"{text!r} is not a ROS namespace: {reason}") from None
    return text.strip("/")


def add_parser(subparsers) -> None:
    """Register ``pmv analyze``."""
    parser = subparsers.add_parser(
        "analyze",
        help="flight-test error statistics of recorded telemetry or a rosbag2 recording (physics.md §5, §5.1)",
        description="The published flight-test procedure on recorded telemetry: average over the orbits at "
                    "each orbital angle, remove the offsets K and T, remove the oblateness model (published "
                    "closed form and sign convention), meridional residual MO, σ and MO ± 3σ; harmonic "
                    "amplitudes at k = 1, 2, 15…25 of the orbital frequency per complete orbit. On a rosbag2 "
                    "recording also the per-sample statistics /pmv/error_statistics computes.")
    parser.add_argument("file", metavar="FILE", help="telemetry CSV (orbit,u_deg,roll_arcmin,pitch_arcmin or "
                        "t_s,roll_rad,pitch_rad[,truth_roll_rad,truth_pitch_rad][,u_deg]), or a rosbag2 recording: "
                        "a directory, FILE.mcap or FILE.db3 with /pmv/attitude, truth and /orbit/odometry")
    parser.add_argument("--altitude-km", default=None,
                        type=ranged_float(MIN_ALTITUDE_M / 1e3, MAX_ALTITUDE_M / 1e3, " km"),
                        help="circular orbit altitude above the 6371 km mean radius (a CSV needs it; a recording: "
                             "default the orbit its sensor states on /diagnostics, else the mean of /orbit/odometry)")
    parser.add_argument("--inclination-deg", default=None, type=ranged_float(0.0, 180.0, " deg"),
                        help="orbit inclination, 0 … 180 deg (a CSV needs it; a recording: as --altitude-km)")
    parser.add_argument("--convention", choices=CONVENTIONS, default=None,
                        help="sign convention of roll and pitch in the input (and the report): paper for the "
                             "published tables (the CSV default); a recording's default is what its sensor states "
                             "on /diagnostics, else ros (REP-103)")
    parser.add_argument("--u0-deg", type=ranged_float(-360.0, 360.0, " deg"), default=None,
                        help="CSV time layout without a u_deg column: argument of latitude at t_s = 0")
    parser.add_argument("--truth", default=None, metavar="TOPIC",
                        help="recording: the truth topic (geometry_msgs/QuaternionStamped, body in the orbital "
                             f"frame); default {TRUTH_TOPICS[0]}, else {TRUTH_TOPICS[1]}")
    parser.add_argument("--namespace", default="", type=_namespace, metavar="NS",
                        help="recording: the spacecraft's namespace (its topics /NS/pmv/attitude, … and the "
                             "orbit status of /NS/sensor_node on /diagnostics); default none")
    parser.add_argument("--phase", choices=PHASE_SOURCES, default="auto",
                        help="recording: where the orbital angle comes from — odometry (/orbit/odometry), "
                             "elements (the epoch and elements on the sensor's /diagnostics), auto (odometry, "
                             "else elements; default). Never from the stamps alone")
    parser.add_argument("--u-bin-deg", type=ranged_float(math.degrees(U_RESOLUTION_RAD), 360.0, " deg"), default=None,
                        help="width of the orbital-angle bins the orbits are averaged in (default: exact u for "
                             f"the orbit layout, {DEFAULT_TIME_LAYOUT_BIN_DEG:g} deg for time series)")
    parser.add_argument("--keep-oblateness", action="store_true",
                        help="do not remove the oblateness model (skip step 4)")
    parser.add_argument("--roll-drift-arcmin-per-orbit", type=ranged_float(-600.0, 600.0, "′"), default=0.0,
                        help="step 1: known linear drift of the roll reference, reset at each ascending node")
    parser.add_argument("--pitch-drift-arcmin-per-orbit", type=ranged_float(-600.0, 600.0, "′"), default=0.0,
                        help="step 1: known linear drift of the pitch reference, reset at each ascending node")
    add_json_flag(parser)
    parser.set_defaults(func=run)


def _orbit_source(sources: dict | None) -> str:
    """Where the orbit came from, for the report's second line ('' for a CSV: the flags, always)."""
    if not sources:
        return ""
    if sources["altitude"] == sources["inclination"]:
        return f" (from {sources['altitude']})"
    return f" (H from {sources['altitude']}, i from {sources['inclination']})"


def _resolved(amplitude):
    """An amplitude, or None (printed —) where the sampling cannot resolve it (NaN)."""
    return amplitude if amplitude is not None and math.isfinite(amplitude) else None


def _format_report(report: dict) -> str:
    lines = [
        f"{report['file']}: {report['layout']} layout, {report['samples']} samples "
        f"({report['rows_skipped']} rows skipped), {report['orbits']} orbits, "
        f"{report['orbital_angles']} orbital angles; orbital angle from {report['phase_source']}; "
        f"{report['convention']} sign convention",
        f"H = {report['altitude_km']:g} km, i = {report['inclination_deg']:g}°, T = {report['period_s']:.0f} s"
        + _orbit_source(report.get("orbit_source")) + "; "
        + ("oblateness model removed (published closed form)" if report["oblateness_removed"]
           else "oblateness kept"),
        f"offsets: K (roll) = {report['roll_offset_arcmin']:+.2f}′, "
        f"T (pitch) = {report['pitch_offset_arcmin']:+.2f}′",
        f"meridional residual: MO = {report['mo_arcmin']:.2f}′, σ = {report['sigma_arcmin']:.2f}′, "
        f"MO ± 3σ = {report['limit_low_arcmin']:+.2f}′ … {report['limit_high_arcmin']:+.2f}′ "
        f"(≈ {report['limit_ground_m']:.0f} m on the ground at nadir)",
        "",
    ]
    recovered = report.get("recording", {}).get("recovered")
    if recovered:
        lines.insert(1, f"recording cut short ({recovered['stopped']}): recovered {recovered['messages']} messages "
                        f"from the first {recovered['bytes_read']} of {recovered['file_bytes']} bytes")
    rows = []
    for name, detail in report["channels"].items():
        harmonics = detail["harmonics_arcmin"]
        hump = [harmonics[str(k)] for k in range(15, 26) if harmonics.get(str(k)) is not None]
        hump = [a for a in hump if math.isfinite(a)]
        rows.append({"channel": name, "mean": detail["mean_arcmin"], "sigma": detail["sigma_arcmin"],
                     "max": detail["max_abs_arcmin"], "k1": _resolved(harmonics["1"]), "k2": _resolved(harmonics["2"]),
                     "hump": max(hump) if hump else None})
    lines.append(format_table(rows, [("channel", "channel", ""), ("mean", "mean, ′", "+.2f"),
                                     ("sigma", "σ, ′", ".2f"), ("max", "max |e|, ′", ".2f"),
                                     ("k1", "k=1, ′", ".2f"), ("k2", "k=2, ′", ".2f"),
                                     ("hump", "max k=15…25, ′", ".2f")]))
    lines.append("harmonic amplitudes: mean over complete orbits, after offset"
                 + (" and oblateness removal" if report["oblateness_removed"] else " removal")
                 + "; — where the sampling cannot resolve them")
    if "per_sample" in report:
        lines += ["", f"per sample, as /pmv/error_statistics (truth from {report['truth_topic']}, offsets kept):"]
        lines.append(format_table(
            [{"channel": name, **detail} for name, detail in report["per_sample"].items()],
            [("channel", "channel", ""), ("count", "N", "d"), ("mean_arcmin", "mean, ′", "+.2f"),
             ("sigma_arcmin", "σ, ′", ".2f"), ("max_abs_arcmin", "max |e|, ′", ".2f")]))
    return "\n".join(lines)


def run(args) -> int:
    """Analyse the file and print the report (or JSON)."""
    options = dict(u_bin_rad=None if args.u_bin_deg is None else math.radians(args.u_bin_deg),
                   remove_oblateness=not args.keep_oblateness,
                   roll_drift_rad_per_orbit=args.roll_drift_arcmin_per_orbit * ARCMIN_RAD,
                   pitch_drift_rad_per_orbit=args.pitch_drift_arcmin_per_orbit * ARCMIN_RAD)
    altitude_m = None if args.altitude_km is None else args.altitude_km * 1e3
    inclination_rad = None if args.inclination_deg is None else math.radians(args.inclination_deg)
    if is_recording(args.file):
        # Errors of a recording name the file themselves.
        report = analyze_recording(args.file, altitude_m, inclination_rad,
                                   convention=args.convention, truth_topic=args.truth, phase=args.phase,
                                   namespace=args.namespace, **options)
    else:
        missing = [flag for flag, value in (("--altitude-km", altitude_m), ("--inclination-deg", inclination_rad))
                   if value is None]
        if missing:
            raise ValueError(f"{args.file}: a telemetry CSV carries no orbit: give {' and '.join(missing)}")
        telemetry = read_telemetry(args.file)
        try:
            report = analyze_telemetry(
                telemetry, altitude_m, inclination_rad,
                u0_rad=None if args.u0_deg is None else math.radians(args.u0_deg),
                convention=args.convention or PAPER, **options)
        except ValueError as error:
            raise ValueError(f"{args.file}: {error}") from None
    if args.json:
        print_json(report)
    else:
        print(_format_report(report))
    return 0
