"""``pmv simulate``: the main job — the three nodes in one process, fast time, live statistics, a report."""

from __future__ import annotations

import math
import signal
import sys
import time
from pathlib import Path

from ..analysis.statistics import PENDING, statistic_text
from ..physics.constants import ARCMIN_RAD
from .common import add_json_flag, format_table, print_json, ranged_float

#: The table's columns: (key, heading, format of a defined statistic); :func:`_rows` writes each cell's text.
COLUMNS = [
    ("channel", "channel", ""),
    ("count", "N", "d"),
    ("mean_arcmin", "mean, ′", "+.2f"),
    ("sigma_arcmin", "σ, ′", ".2f"),
    ("limit", "mean ± 3σ, ′", "+.2f"),
    ("max_abs_arcmin", "max |e|, ′", ".2f"),
    ("k1", "k=1, ′", ".2f"),
    ("k2", "k=2, ′", ".2f"),
    ("hump", "k=15…25 peak, ′", ".2f"),
]
_SPECS = {key: spec for key, _, spec in COLUMNS}


def add_parser(subparsers) -> None:
    """Register ``pmv simulate``."""
    parser = subparsers.add_parser(
        "simulate", help="run sensor, star tracker and error monitor in fast time and report",
        description="The main job: sensor_node, star_tracker_node and error_monitor_node in one process on one "
                    "executor, in fast time, with live statistics and a report (JSON + PNG plots).")
    parser.add_argument("--config", required=True, help="ros__parameters preset, e.g. config/kondor.yaml")
    parser.add_argument("--orbits", type=ranged_float(0.0, 1000.0, low_open=True), default=1.0,
                        help="how many orbits to fly (default 1)")
    parser.add_argument("--rate-hz", type=ranged_float(0.1, 100.0, " Hz"), default=None,
                        help="sensor output rate (default: the preset's)")
    parser.add_argument("--seed", type=_seed, default=None,
                        help="seed of the run's random processes, 0 … 2^31−1 (default: the preset's)")
    parser.add_argument("--epoch", default=None, metavar="ISO8601",
                        help="UTC start of the run, e.g. 2016-11-11T00:00:00Z (default: the preset's sim.epoch_utc)")
    parser.add_argument("--report", default=None, help="write statistics.json and PNG plots into this folder")
    parser.add_argument("--record", default=None, metavar="FILE.mcap",
                        help="record every topic of the run into a new rosbag2 MCAP file (logged at simulation time)")
    parser.add_argument("--closed-loop", action="store_true",
                        help="close the loop: the sensor follows attitude/truth from attitude_controller_node, a rigid "
                             "body held nadir-pointing by a PD loop on pmv/attitude; the report adds the true pointing "
                             "error beside the residuals")
    parser.add_argument("--compensation", choices=("off", "on"), default=None,
                        help="with --closed-loop: the sensor's on-board oblateness compensation (default: the "
                             "preset's); off shows the oblateness going into the pointing")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    add_json_flag(parser)
    parser.set_defaults(func=run)


def _seed(text: str) -> int:
    """``--seed``: an integer 0 … 2^31 − 1."""
    import argparse

    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if not 0 <= value <= 2**31 - 1:
        raise argparse.ArgumentTypeError(f"{value} is outside the allowed range 0 … 2147483647")
    return value


def _rows(statistics_dict: dict) -> list[dict]:
    """The table's rows, each statistic as its text (:func:`~pmv_ros.analysis.statistics.statistic_text`:
    "pending" while it is not defined, as /pmv/error_statistics says it)."""
    rows = []
    for name, channel in statistics_dict["channels"].items():
        harmonics = {int(k): v for k, v in channel["harmonics_arcmin"].items()}
        hump = [v for k, v in harmonics.items() if 15 <= k <= 25 and v is not None and math.isfinite(v)]
        low, high = channel["limit_low_arcmin"], channel["limit_high_arcmin"]
        figures = {"mean_arcmin": channel["mean_arcmin"], "sigma_arcmin": channel["sigma_arcmin"],
                   "max_abs_arcmin": channel["max_abs_arcmin"], "k1": harmonics.get(1), "k2": harmonics.get(2),
                   "hump": max(hump) if hump else None}
        row = {key: statistic_text(value, _SPECS[key]) for key, value in figures.items()}
        limit = [statistic_text(value, _SPECS["limit"]) for value in (low, high)]
        row.update(channel=name, count=format(channel["count"], _SPECS["count"]),
                   limit=PENDING if PENDING in limit else " … ".join(limit))
        rows.append(row)
    return rows


def _arcmin_text(value_rad: float) -> str:
    """A statistic in rad as people read it on the progress line: arcmin to 0.01′, or "pending"."""
    text = statistic_text(value_rad / ARCMIN_RAD, ".2f")
    return text if text == PENDING else f"{text}′"


def _tracker_frames(pipeline, truth_lost: dict) -> dict | None:
    """The star tracker's frames without attitude the monitor heard of, on the ground track (None: an ideal or
    silent tracker, no frame to draw)."""
    import numpy as np

    from ..physics.star_tracker import Outcome

    stamps, codes = pipeline.monitor.truth_lost_frames
    runtime = pipeline.star_tracker.runtime
    if not stamps.size or runtime.tracker.parameters.ideal:
        return None
    track = np.linspace(pipeline.sensor.orbit.epoch_s, pipeline.sensor.sim_time_s, 2000)
    return {"track_deg": runtime.tracker.ground_track_deg(track),
            "frames_deg": runtime.tracker.ground_track_deg(stamps),
            "reasons": [Outcome(int(code)).reason for code in codes], "truth_lost": truth_lost}


def _stopped(args, pipeline, number: int, done: int, ticks: int) -> int:
    """A run stopped by a signal: close the recording whole, say so in one line; status 128 + the signal."""
    name = signal.Signals(number).name
    note = ""
    if pipeline.recording is not None:
        pipeline.recording.close()
        note = (f"; recording closed: {pipeline.recording.path}, "
                f"{sum(pipeline.recording.counts.values())} messages")
    print(f"pmv simulate: stopped by {name} after {done} of {ticks} ticks{note}", file=sys.stderr)
    return 128 + number


def run(args) -> int:
    """Fly the configured spacecraft for ``--orbits`` orbits and report.

    SIGINT or SIGTERM stops the run between two ticks: the recording is
    closed whole, one line says where the run stopped, and the status is
    128 + the signal's number (130, 143), as for a shell's interrupted job.
    A signal while the recording is being finalised lets the finalisation
    end (the file is complete) and then stops the run the same way, without
    the report.
    """
    from ..runtime.common.assembly import parse_epoch

    if args.compensation is not None and not args.closed_loop:
        raise ValueError("--compensation goes with --closed-loop (open loop: set sensor.oblateness_compensation "
                         "in the preset's /** section)")
    overrides = {} if args.rate_hz is None else {"sensor.rate_hz": args.rate_hz}
    if args.compensation is not None:  # the sensor's and the monitor's (it must not remove the model twice)
        overrides["sensor.oblateness_compensation"] = args.compensation == "on"
    if args.seed is not None:
        overrides["seed"] = args.seed
    if args.epoch is not None:
        parse_epoch(args.epoch)  # a bad date: one line, exit 2, before any node starts
        overrides["sim.epoch_utc"] = args.epoch
    stop = _StopOnSignal()
    try:
        return _fly(args, overrides, stop)
    finally:
        stop.restore()


class _StopOnSignal:
    """SIGINT and SIGTERM stop the run between two ticks (≪ 1 s); the recording is then closed whole."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self):
        self.number = None
        self._previous = {}
        try:
            for number in self.SIGNALS:
                self._previous[number] = signal.signal(number, self._on_signal)
        except ValueError:  # not the main thread (an embedding caller): signals stay the caller's
            self.restore()

    def _on_signal(self, number, frame) -> None:
        self.number = number

    def restore(self) -> None:
        for number, handler in self._previous.items():
            signal.signal(number, handler)
        self._previous = {}


def _fly(args, overrides: dict, stop: _StopOnSignal) -> int:
    from tqdm import tqdm

    from ..nodes.params import ParameterError
    from ..nodes.pipeline import Pipeline
    from ..apps.report import flight_record, pointing_to_dict, statistics_to_dict, truth_lost_summary, write_report

    try:
        pipeline = Pipeline(args.config, overrides, record=args.record, closed_loop=args.closed_loop)
    except ParameterError as error:
        raise ValueError(f"{args.config}: {error}") from None
    started = time.perf_counter()
    with pipeline:
        if pipeline.sensor.get_parameter("orbit.source").value == "follow":
            raise ValueError(f"{args.config}: orbit.source = follow: pmv simulate flies an orbit of its own (circular "
                             "or tle), there is no user's orbit/odometry to follow")
        orbit = pipeline.sensor.orbit
        rate = pipeline.sensor.get_parameter("sensor.rate_hz").value
        ticks = max(1, round(args.orbits * orbit.period_s * rate))
        check = getattr(orbit, "check_propagation", None)  # an element set: SGP4 over the whole run, before it
        if check is not None:
            check(orbit.epoch_s, pipeline.sensor.sim_time_s + (ticks + 1) / rate)
        bar = tqdm(total=ticks, unit="tick", file=sys.stderr, disable=args.quiet, dynamic_ncols=True,
                   desc=f"{Path(args.config).stem} {args.orbits:g} orbit(s) at {rate:g} Hz", mininterval=1.0)
        refresh = max(1, ticks // 100)
        done = 0
        for tick in range(ticks):
            if stop.number is not None:
                break
            pipeline.step()
            done += 1
            if (tick + 1) % refresh == 0:
                bar.update(refresh)
                statistics = pipeline.monitor.latest_statistics
                if statistics is not None:
                    roll, pitch = statistics.channel("roll"), statistics.channel("pitch")
                    bar.set_postfix_str(f"σ roll {_arcmin_text(roll.sigma_rad)} "
                                        f"σ pitch {_arcmin_text(pitch.sigma_rad)} N={roll.count}")
        bar.update(done - bar.n)
        bar.close()
        if stop.number is not None:
            return _stopped(args, pipeline, stop.number, done, ticks)
        final = pipeline.monitor.publish_statistics(pipeline.sensor.sim_time_s)
        pipeline.drain()
        wall_s = time.perf_counter() - started
        result = statistics_to_dict(final)
        result.update({
            "config": str(args.config), "orbits": args.orbits, "rate_hz": rate,
            "simulated_s": pipeline.sensor.sim_time_s - orbit.epoch_s, "wall_s": wall_s,
            "altitude_km": orbit.altitude_m / 1e3, "inclination_deg": math.degrees(orbit.inclination_rad),
            "seed": pipeline.sensor.get_parameter("seed").value,
            "epoch_utc": pipeline.sensor.get_parameter("sim.epoch_utc").value,
        })
        if pipeline.controller is not None:
            result["pointing"] = pointing_to_dict(
                pipeline.controller.runtime, pipeline.sensor.get_parameter("sensor.oblateness_compensation").value)
        if pipeline.recording is not None:
            pipeline.recording.close()
            if stop.number is not None:  # a signal while the recording was being finalised: it was closed whole
                return _stopped(args, pipeline, stop.number, done, ticks)
            result["recording"] = {"file": str(pipeline.recording.path), "messages": dict(pipeline.recording.counts)}
        result["truth_lost"] = truth_lost_summary(pipeline.monitor.truth_lost, result["counters"].get(
            "sensor_received", 0))
        if args.report:
            live = {name: {int(k): v for k, v in c["harmonics_arcmin"].items()}
                    for name, c in result["channels"].items()}
            record = flight_record(pipeline.sensor.get_parameter("sim.flight_record").value)
            pointing = pipeline.controller.pointing.series() if pipeline.controller is not None else None
            result = write_report(args.report, result, pipeline.collector.residual_array(), orbit, live, record,
                                  tracker=_tracker_frames(pipeline, result["truth_lost"]), pointing=pointing)
    if args.json:
        print_json(result)
        return 0
    print(f"{result['config']}: {result['simulated_s']:.0f} s simulated in {wall_s:.1f} s wall "
          f"({result['simulated_s'] / wall_s:.0f}× real time); residual statistics, "
          f"oblateness {'removed' if result['oblateness_removed'] else 'kept'}:")
    columns = [(key, heading, "") for key, heading, _ in COLUMNS]
    print(format_table(_rows(result), columns))
    if "pointing" in result:
        pointing = result["pointing"]
        print(f"true pointing error (the body's roll and pitch against nadir; PD loop at "
              f"{pointing['bandwidth_hz']:g} Hz, oblateness compensation "
              f"{'on' if pointing['oblateness_compensation'] else 'off'}), after the loop's settling time "
              f"{pointing['settling_time_s']:.0f} s:")
        print(format_table(_rows({"channels": {f"true {axis}": pointing[axis] for axis in ("roll", "pitch")}}),
                           columns))
    counters = result["counters"]
    skipped = {k: v for k, v in counters.items() if (k.startswith("skipped_") or k.startswith("rejected_")) and v}
    print(f"samples used {counters.get('used', 0)}, not used: "
          + (", ".join(f"{k} {v}" for k, v in skipped.items()) or "none"))
    lost = result["truth_lost"]
    if lost:
        print("samples without star-tracker truth, by its reason: " + ", ".join(
            f"{reason.replace('_', ' ')} {cost['samples']} ({100.0 * cost['share']:.1f} % of the run)"
            for reason, cost in sorted(lost.items(), key=lambda item: -item[1]["samples"])))
    if args.report:
        print("report: " + ", ".join(result["report_files"]))
    if "recording" in result:
        counts = result["recording"]["messages"]
        print(f"recording: {result['recording']['file']}, {sum(counts.values())} messages on {len(counts)} topics")
    return 0
