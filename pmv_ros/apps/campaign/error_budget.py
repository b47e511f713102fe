"""A campaign's budget: the task files read back one at a time into statistics by season, over the year,
per day and on a latitude × day map, with each environment component beside the total; budget.json and
the plots."""

from __future__ import annotations

import json
import math
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ...storage.json_output import finite_json
from ...physics.constants import ARCMIN_RAD
from ...runtime.flight import OUTCOME_CODES
from ...analysis.statistics import CHANNELS
from ...runtime.monitor.records import Status
from ...analysis.statistics import RunningStatistics
from ...runtime.control.pointing import AXES
from ..report import truth_lost_summary
from .results import POINTING_COLUMNS, _write_atomically, check_result, read_result, task_path
from .tasks import COMPONENTS, LATITUDE_BIN_DEG, SEASONS, Settings, Task


# ------------------------------------------------------------------------ the budget

def _statistics_dict(stats: RunningStatistics) -> dict:
    """Count, mean, σ, mean ± 3σ, max |e| and the limit |mean| + 3σ of one channel, arcmin."""
    mean, sigma = stats.mean / ARCMIN_RAD, stats.sigma / ARCMIN_RAD
    return {"count": stats.count, "mean_arcmin": mean, "sigma_arcmin": sigma,
            "limit_low_arcmin": mean - 3.0 * sigma, "limit_high_arcmin": mean + 3.0 * sigma,
            "limit_arcmin": abs(mean) + 3.0 * sigma, "max_abs_arcmin": stats.max_abs / ARCMIN_RAD}


def _new_channels() -> dict:
    return {channel: RunningStatistics() for channel in CHANNELS}


def budget(out: Path, tasks: list[Task], settings: Settings | None = None) -> dict:
    """Aggregate the task files of ``tasks`` into the error budget (JSON-ready, arcmin).

    Keys: ``components`` → component → ``{"year": …, "DJF": …, …}`` → channel
    → statistics; ``rss`` (with components): the root sum of squares of the
    components' σ and limits beside the total's; ``by_day`` → component → day
    → channel → statistics pooled over seeds, with the seeds' σ range;
    ``latitude_day`` (total): mean roll, pitch and meridional residual per
    latitude bin and day; ``tasks``: each task's own statistics (the monitor's);
    ``truth_lost`` (total): the samples skipped for want of star-tracker truth
    by the tracker's reason and their share of all the samples flown (of the
    year, when the days sample it). A closed-loop campaign adds ``pointing``
    (component → group → roll/pitch → statistics of the true pointing error,
    after each task's settling time) and ``pointing_by_day``.
    """
    ok = OUTCOME_CODES.index(Status.OK)
    groups = {}  # component → group → channel → RunningStatistics
    days = {}  # component → day → channel → RunningStatistics
    seed_sigma = {}  # component → day → channel → [σ per seed]
    edges = np.arange(-90.0, 90.0 + LATITUDE_BIN_DEG, LATITUDE_BIN_DEG)
    task_days = sorted({task.day for task in tasks})
    grid = {channel: (np.zeros((edges.size - 1, len(task_days))), np.zeros((edges.size - 1, len(task_days))))
            for channel in CHANNELS}  # sums, counts
    per_task = []
    lost, samples = {}, 0  # the total's samples without truth by the tracker's reason, and all its samples
    pointing = {}  # component → group → axis → RunningStatistics (closed-loop files)
    pointing_days = {}  # component → day → axis → RunningStatistics
    for task in tasks:
        path = task_path(out, task)
        table, description = read_result(path) if settings is None else check_result(path, settings, task)
        used = table.column("outcome").to_numpy() == ok
        latitude = np.degrees(table.column("latitude_rad").to_numpy())[used]
        season = description["season"]
        component = groups.setdefault(task.component,
                                      {"year": _new_channels(), **{s: _new_channels() for s in SEASONS}})
        day = days.setdefault(task.component, {}).setdefault(task.day, _new_channels())
        sigmas = seed_sigma.setdefault(task.component, {}).setdefault(task.day, {c: [] for c in CHANNELS})
        row = np.clip(np.digitize(latitude, edges) - 1, 0, edges.size - 2)
        column = task_days.index(task.day)
        for channel in CHANNELS:
            values = table.column(f"{channel}_rad").to_numpy()[used]
            for target in (component["year"], component[season], day):
                target[channel].update(values)
            alone = RunningStatistics()
            alone.update(values)
            sigmas[channel].append(alone.sigma / ARCMIN_RAD)
            if task.component == "total":
                finite = np.isfinite(values)
                sums, counts = grid[channel]
                np.add.at(sums[:, column], row[finite], values[finite])
                np.add.at(counts[:, column], row[finite], 1.0)
        if POINTING_COLUMNS[0] in table.column_names:
            _add_pointing(table, task, season, pointing, pointing_days)
        per_task.append({**asdict(task), "epoch_utc": description["epoch_utc"], "season": season,
                         "samples": description["samples"], **description["summary"],
                         **({"pointing": description["pointing"]} if "pointing" in description else {})})
        if task.component == "total":
            samples += description["samples"]
            for key, count in description.get("truth_lost", {}).items():
                lost[key] = lost.get(key, 0) + count
    result = {"components": {}, "by_day": {}, "tasks": per_task,
              "truth_lost": truth_lost_summary(lost, samples)}
    for name, by_group in groups.items():
        result["components"][name] = {group: {c: _statistics_dict(s) for c, s in channels.items()}
                                      for group, channels in by_group.items() if channels[CHANNELS[0]].count
                                      or channels[CHANNELS[1]].count}
    for name, by_day in days.items():
        result["by_day"][name] = {
            str(day): {c: {**_statistics_dict(s), "seed_sigma_min_arcmin": min(seed_sigma[name][day][c]),
                           "seed_sigma_max_arcmin": max(seed_sigma[name][day][c])}
                       for c, s in channels.items()}
            for day, channels in sorted(by_day.items())}
    if "total" in groups:
        with np.errstate(invalid="ignore", divide="ignore"):
            result["latitude_day"] = {
                "latitude_edges_deg": edges.tolist(), "days": task_days,
                **{f"{c}_mean_arcmin": (grid[c][0] / grid[c][1] / ARCMIN_RAD).tolist() for c in CHANNELS},
                "count": grid[CHANNELS[0]][1].astype(int).tolist()}
    if pointing:
        result["pointing"] = {name: {group: {axis: _statistics_dict(stats) for axis, stats in axes.items()}
                                     for group, axes in by_group.items() if axes[AXES[0]].count}
                              for name, by_group in pointing.items()}
        result["pointing_by_day"] = {name: {str(day): {axis: _statistics_dict(stats) for axis, stats in axes.items()}
                                            for day, axes in sorted(by_day.items())}
                                     for name, by_day in pointing_days.items()}
    parts = [name for name in COMPONENTS if name != "total" and name in groups]
    if parts and "total" in groups:
        result["rss"] = _rss(result["components"], parts)
    return finite_json(result)


def _add_pointing(table, task: Task, season: str, pointing: dict, pointing_days: dict) -> None:
    """A closed-loop task's true pointing error (its samples after the loop's settling time) into the year's,
    its season's and its day's statistics."""
    groups = pointing.setdefault(task.component, {"year": _new_axes(), **{s: _new_axes() for s in SEASONS}})
    day = pointing_days.setdefault(task.component, {}).setdefault(task.day, _new_axes())
    for axis, column in zip(AXES, POINTING_COLUMNS):
        values = table.column(column).to_numpy()
        for target in (groups["year"], groups[season], day):
            target[axis].update(values)


def _new_axes() -> dict:
    return {axis: RunningStatistics() for axis in AXES}


def _rss(components: dict, parts: list[str]) -> dict:
    """Per group and channel: σ and limit of the total beside the root sum of squares of the components'."""
    rss = {}
    for group, channels in components["total"].items():
        rss[group] = {}
        for channel, total in channels.items():
            entries = [components[part].get(group, {}).get(channel) for part in parts]
            if any(entry is None for entry in entries):
                continue
            rss[group][channel] = {
                "total_sigma_arcmin": total["sigma_arcmin"], "total_limit_arcmin": total["limit_arcmin"],
                "rss_sigma_arcmin": math.sqrt(sum(e["sigma_arcmin"] ** 2 for e in entries)),
                "rss_limit_arcmin": math.sqrt(sum(e["limit_arcmin"] ** 2 for e in entries)),
                **{f"{part}_sigma_arcmin": e["sigma_arcmin"] for part, e in zip(parts, entries)},
                **{f"{part}_limit_arcmin": e["limit_arcmin"] for part, e in zip(parts, entries)},
            }
    return rss


def write_budget(out: Path, result: dict) -> list[str]:
    """Write ``budget.json`` and the plots into ``out``; returns the file names."""
    out = Path(out)
    _write_atomically(out / "budget.json", json.dumps(result, indent=1, allow_nan=False).encode())
    return ["budget.json"] + _plot(out, result)


def _plot(out: Path, result: dict) -> list[str]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    files = []
    by_day = result["by_day"]
    fig, axes = plt.subplots(len(CHANNELS), 1, figsize=(9, 9), sharex=True)
    for axis, channel in zip(axes, CHANNELS):
        for name, series in by_day.items():
            day = np.array([int(d) for d in series])
            sigma = np.array([series[d][channel]["sigma_arcmin"] for d in series], float)
            limit = np.array([series[d][channel]["limit_arcmin"] for d in series], float)
            if name == "total":
                low = np.array([series[d][channel]["seed_sigma_min_arcmin"] for d in series], float)
                high = np.array([series[d][channel]["seed_sigma_max_arcmin"] for d in series], float)
                axis.vlines(day, low, high, color="C0", alpha=0.5, lw=4, label="σ of each seed: range")
                axis.plot(day, sigma, "o-", color="C0", label="σ, all seeds")
                axis.plot(day, limit, "s--", color="C3", label="limit |mean| + 3σ")
            else:
                axis.plot(day, sigma, ".:", label=f"σ, {name} alone")
        axis.set_ylabel(f"{channel}, ′")
        axis.grid(alpha=0.3)
    axes[0].legend(fontsize=7, ncol=2)
    axes[-1].set_xlabel("day of year")
    fig.suptitle("Methodical error over the year (residual sensor − star tracker)")
    fig.tight_layout()
    fig.savefig(out / "sigma_limit.png", dpi=110)
    plt.close(fig)
    files.append("sigma_limit.png")

    if result.get("pointing_by_day"):
        files.append(_plot_pointing(out, result["pointing_by_day"]))
    grid = result.get("latitude_day")
    if grid:
        fig, axes = plt.subplots(1, len(CHANNELS), figsize=(13, 4.5), sharey=True)
        days, edges = grid["days"], np.array(grid["latitude_edges_deg"])
        x_edges = _day_edges(days)
        for axis, channel in zip(axes, CHANNELS):
            values = np.array(grid[f"{channel}_mean_arcmin"], float)
            finite = values[np.isfinite(values)]
            if channel == "meridional":
                mesh = axis.pcolormesh(x_edges, edges, values, cmap="viridis", shading="flat")
            else:
                bound = float(np.max(np.abs(finite))) if finite.size else 1.0
                mesh = axis.pcolormesh(x_edges, edges, values, cmap="RdBu_r", vmin=-bound, vmax=bound, shading="flat")
            fig.colorbar(mesh, ax=axis, label="mean residual, ′")
            axis.set_title(channel)
            axis.set_xlabel("day of year (DJF · MAM · JJA · SON)")
        axes[0].set_ylabel("sub-satellite latitude, deg")
        fig.suptitle("Mean residual by latitude and day of year (all seeds)")
        fig.tight_layout()
        fig.savefig(out / "latitude_season.png", dpi=110)
        plt.close(fig)
        files.append("latitude_season.png")
    return files


def _plot_pointing(out: Path, by_day: dict) -> str:
    """``pointing.png``: σ and |mean| + 3σ of the true pointing error per day (closed loop)."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(AXES), 1, figsize=(9, 6), sharex=True)
    for axis, name in zip(axes, AXES):
        for component, series in by_day.items():
            day = np.array([int(d) for d in series])
            sigma = np.array([series[d][name]["sigma_arcmin"] for d in series], float)
            limit = np.array([series[d][name]["limit_arcmin"] for d in series], float)
            axis.plot(day, sigma, "o-", label=f"σ, {component}")
            axis.plot(day, limit, "s--", label=f"|mean| + 3σ, {component}")
        axis.set_ylabel(f"true {name}, ′")
        axis.grid(alpha=0.3)
    axes[0].legend(fontsize=7, ncol=2)
    axes[-1].set_xlabel("day of year")
    fig.suptitle("True pointing error over the year (closed loop, after each run's settling time)")
    fig.tight_layout()
    fig.savefig(out / "pointing.png", dpi=110)
    plt.close(fig)
    return "pointing.png"


def _day_edges(days: list[int]) -> np.ndarray:
    """Cell edges between the campaign's days (midpoints; half a step beyond the ends)."""
    centres = np.asarray(days, float)
    if centres.size == 1:
        return np.array([centres[0] - 0.5, centres[0] + 0.5])
    middle = 0.5 * (centres[1:] + centres[:-1])
    return np.r_[centres[0] - (middle[0] - centres[0]), middle, centres[-1] + (centres[-1] - middle[-1])]
