"""``pmv campaign``: a Monte-Carlo error budget over days, seasons and seeds, on Dask, with the ROS-free core."""

from __future__ import annotations

import argparse
import importlib.util
import os
import time
from pathlib import Path

from .common import add_json_flag, format_table, print_json, ranged_float

COLUMNS = [
    ("group", "group", ""),
    ("channel", "channel", ""),
    ("count", "N", "d"),
    ("mean_arcmin", "mean, ′", "+.2f"),
    ("sigma_arcmin", "σ, ′", ".2f"),
    ("limit", "mean ± 3σ, ′", ""),
    ("max_abs_arcmin", "max |e|, ′", ".2f"),
]

RSS_COLUMNS = [
    ("group", "group", ""),
    ("channel", "channel", ""),
    ("total_sigma_arcmin", "σ total, ′", ".2f"),
    ("rss_sigma_arcmin", "σ RSS, ′", ".2f"),
    ("total_limit_arcmin", "limit total, ′", ".2f"),
    ("rss_limit_arcmin", "limit RSS, ′", ".2f"),
]

#: Most worker processes an embedded cluster starts (a typo guard).
MAX_WORKERS = 256


def _positive_int(low: int, high: int):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
        if not low <= value <= high:
            raise argparse.ArgumentTypeError(f"{text} is outside the allowed range {low} … {high}")
        return value
    return parse


def _scheduler(text: str) -> str:
    """``--scheduler``: a Dask scheduler address a campaign can connect to."""
    from ..apps.campaign.cluster import check_scheduler_address

    try:
        return check_scheduler_address(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def add_parser(subparsers) -> None:
    """Register ``pmv campaign``."""
    from ..apps.campaign import MAX_ORBITS_PER_TASK, MAX_SEEDS
    from ..apps.campaign.cluster import WORKER_TIMEOUT_S

    parser = subparsers.add_parser(
        "campaign", help="Monte-Carlo error budget over days of the year and seeds, on Dask",
        description="Fly K orbits for every (day of year, seed[, environment component]) through the ROS-free "
                    "core (the nodes' models and the monitor's statistics) on Dask — an embedded local cluster "
                    "by default, or the cluster of --scheduler — one Parquet file per task in --out (a re-run "
                    "skips finished tasks), then the budget: statistics per channel by season and over the "
                    "year, budget.json and PNG plots.")
    parser.add_argument("--config", required=True, help="ros__parameters preset, e.g. config/meteor_m2.yaml")
    parser.add_argument("--days", required=True,
                        help="days of year of the preset's year: a list and/or ranges, e.g. 1,91,182,274 or 1-365:7; "
                             "with orbit.source tle, days from the element set's epoch, 0 … 365, e.g. 0-6")
    parser.add_argument("--seeds", required=True, type=_positive_int(1, MAX_SEEDS),
                        help="seeds per day: 0 … N−1, each the seed of every node's random processes")
    parser.add_argument("--orbits-per-task", type=ranged_float(0.0, MAX_ORBITS_PER_TASK, low_open=True), default=1.0,
                        help="orbits flown by each task (default 1)")
    parser.add_argument("--rate-hz", type=ranged_float(0.1, 100.0, " Hz"), default=None,
                        help="sensor output rate (default: the preset's)")
    parser.add_argument("--closed-loop", action="store_true",
                        help="close the loop in every task (the sensor in follow mode inside "
                             "attitude_controller_node's plant and PD loop, as pmv simulate --closed-loop): "
                             "the budget adds the true pointing error beside the residuals")
    parser.add_argument("--components", action="store_true",
                        help="also fly each environment component alone (oblateness, climatology, weather, layer "
                             "height) and give their root sum of squares beside the total")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--scheduler", default=None, type=_scheduler,
                       help="address of a running Dask scheduler, e.g. tcp://host:8786 (default: an embedded cluster)")
    where.add_argument("--workers", type=_positive_int(1, MAX_WORKERS), default=None,
                       help="worker processes of the embedded cluster (default: the CPU count)")
    parser.add_argument("--worker-timeout-s", type=ranged_float(1.0, 3600.0, " s"), default=WORKER_TIMEOUT_S,
                        help="how long to wait for the cluster's first worker before giving up, s "
                             f"(default {WORKER_TIMEOUT_S:g})")
    parser.add_argument("--out", required=True, help="folder for the task files, budget.json and the plots")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    add_json_flag(parser)
    parser.set_defaults(func=run)


def _rows(components: dict) -> list[dict]:
    rows = []
    for name, groups in components.items():
        for group, channels in groups.items():
            for channel, stats in channels.items():
                limit = ("—" if stats["mean_arcmin"] is None or stats["sigma_arcmin"] is None
                         else f"{stats['limit_low_arcmin']:+.2f} … {stats['limit_high_arcmin']:+.2f}")
                rows.append({"group": f"{name} {group}", "channel": channel, "count": stats["count"],
                             "mean_arcmin": stats["mean_arcmin"], "sigma_arcmin": stats["sigma_arcmin"],
                             "limit": limit, "max_abs_arcmin": stats["max_abs_arcmin"]})
    return rows


#: What a campaign imports beyond the rest of pmv_ros: none has a rosdep key (package.xml), so a ROS workspace
#: may lack them; the pip names are the import names.
CAMPAIGN_MODULES = ("dask", "distributed", "pyarrow", "threadpoolctl")


def run(args) -> int:
    """Plan the tasks, run those not done on Dask, aggregate and report."""
    missing = [name for name in CAMPAIGN_MODULES if importlib.util.find_spec(name) is None]
    if missing:
        raise ValueError(f"pmv campaign needs {', '.join(missing)}, which cannot be imported: "
                         f"pip install {' '.join(missing)}")
    from ..apps import campaign
    from ..runtime.common.assembly import SENSOR_PARAMS, parse_epoch
    from ..runtime.common.parameters import ParameterError, preset_values
    from ..physics.orbit.tle import parse_element_set
    from ..storage.files import read_yaml_file

    path = Path(args.config)
    if not path.exists():
        raise ValueError(f"config file {str(path)!r} does not exist")
    document = read_yaml_file(path, "params file") or {}
    if not isinstance(document, dict):
        raise ValueError(f"{path}: not a ros__parameters params file")
    try:
        sensor = preset_values(document, "sensor_node", SENSOR_PARAMS)
        epoch_utc = sensor["sim.epoch_utc"]
        parse_epoch(epoch_utc)
        year = int(epoch_utc.strip()[:4])
        from_elements = sensor["orbit.source"] == "tle"  # days from the element set's epoch
        if from_elements:
            epoch_utc = parse_element_set(sensor["orbit.tle_line1"], sensor["orbit.tle_line2"]).epoch_utc.isoformat()
        days = campaign.parse_days(args.days, year, from_elements)
        settings = campaign.Settings(document, epoch_utc, args.rate_hz, args.orbits_per_task, from_elements,
                                     closed_loop=args.closed_loop)
        tasks = campaign.plan(days, args.seeds, args.components)
        campaign.check(settings, tasks)
    except ParameterError as error:
        raise ValueError(f"{path}: {error}") from None
    out = Path(args.out)
    campaign.prepare_folder(out, settings)
    workers = args.workers or os.cpu_count() or 1
    started = time.perf_counter()
    ran = campaign.run_campaign(settings, tasks, out, scheduler=args.scheduler, workers=workers,
                                progress=not args.quiet, worker_timeout_s=args.worker_timeout_s)
    result = campaign.budget(out, tasks, settings)
    files = campaign.write_budget(out, result)
    wall_s = time.perf_counter() - started
    summary = {
        "config": str(path), "out": str(out), "days": days, "seeds": args.seeds,
        "components": list(result["components"]), "orbits_per_task": args.orbits_per_task,
        "scheduler": args.scheduler or f"embedded LocalCluster, {workers} worker process(es)",
        "tasks": len(tasks), "ran": ran["ran"], "skipped": ran["skipped"], "wall_s": wall_s,
        "task_compute_s": ran["compute_s"], "samples_run": ran["samples"],
        "samples_per_s_per_worker": ran["samples"] / ran["compute_s"] if ran["compute_s"] else None,
        "files": files,
        "budget": {key: result[key] for key in ("components", "rss", "truth_lost", "pointing") if key in result},
        "tasks_statistics": result["tasks"],
    }
    if ran["recomputed"]:  # task files that were there but not this campaign's results: name → why
        summary["recomputed"] = ran["recomputed"]
    if args.json:
        print_json(summary)
        return 0
    print(f"{path}: {len(tasks)} tasks ({len(days)} days × {args.seeds} seeds"
          f"{' × ' + str(len(campaign.COMPONENTS)) + ' components' if args.components else ''}), "
          f"{ran['ran']} run, {ran['skipped']} already done, in {wall_s:.1f} s wall on {summary['scheduler']}; "
          "residual statistics (sensor − star tracker as on /pmv/residual, arcmin):")
    if ran["recomputed"]:
        print(f"recomputed {len(ran['recomputed'])} task file(s) that did not hold their task's result: "
              + "; ".join(f"{name} ({reason})" for name, reason in sorted(ran["recomputed"].items())))
    print(format_table(_rows(result["components"]), COLUMNS))
    if "pointing" in result:
        print("true pointing error (closed loop: the body's roll and pitch against nadir, after each task's "
              "settling time, arcmin):")
        print(format_table(_rows(result["pointing"]), COLUMNS))
    if "rss" in result:
        rows = [{"group": group, "channel": channel, **values}
                for group, channels in result["rss"].items() for channel, values in channels.items()]
        print("components alone and their root sum of squares (limit = |mean| + 3σ):")
        print(format_table(rows, RSS_COLUMNS))
    lost = result.get("truth_lost") or {}
    if lost:
        print("samples without star-tracker truth, by its reason: " + ", ".join(
            f"{reason.replace('_', ' ')} {100.0 * cost['share']:.1f} %"
            for reason, cost in sorted(lost.items(), key=lambda item: -item[1]["samples"])) + " of the samples flown")
    print(f"results: {out}/ (one Parquet file per task), " + ", ".join(files))
    return 0
