"""Monte-Carlo error budgets over a year on Dask: tasks, their result files, and the budget (``pmv campaign``).

A campaign is a set of tasks (day of year, seed[, environment component]);
each flies K orbits from 00:00 of the preset's time of day on that day
through the core (:func:`pmv_ros.runtime.flight.fly`: the nodes' models and the
monitor's statistics, no ROS) on a Dask worker. Every finished task becomes
one Parquet file in the output folder, written by the client under a
temporary name and renamed into place, so a file is either whole or absent:
a re-run skips the tasks whose file is there, a killed worker or campaign
loses only the tasks in flight, and no task is counted twice. Dask reruns a
task whose worker died (the scheduler's ``allowed-failures``).

The budget reads the task files back, one at a time: statistics per channel
(roll, pitch, meridional: count, mean, σ, mean ± 3σ, max |e|) by season and
over the year, per day of year, on a latitude × day map, and — with
components — each environment component alone beside the total with their
root sum of squares (physics.md §4, last sentence). It writes
``budget.json`` and two PNG plots.
"""

from __future__ import annotations

import datetime as dt
import json
import math
import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from ..storage.json_output import finite_json
from ..physics.constants import ARCMIN_RAD
from ..runtime.assembly import build_source_orbit
from ..runtime.flight import OUTCOME_CODES, flight_values, fly
from ..analysis.statistics import CHANNELS
from ..runtime.monitor_records import Status
from .report import channel_to_dict
from ..physics.orbit import CircularOrbit
from ..analysis.statistics import RunningStatistics

#: Environment components a campaign can fly alone (``--components``), with the overrides that isolate each.
#: "total" is the preset as it is. The oblateness component keeps the GRS80 Earth under a uniform
#: horizon, so what it shows is what is left after the monitor removes the closed-form model; the
#: others fly a spherical Earth (nothing to remove: the monitor keeps its oblateness-free statistics).
COMPONENTS = {
    "total": {},
    "oblateness": {"sensor.earth_model": "GRS80", "environment.climatology": False, "environment.weather": False,
                   "environment.height_variation": False},
    "climatology": {"sensor.earth_model": "sphere", "environment.climatology": True, "environment.weather": False,
                    "environment.height_variation": False, "remove_oblateness": False},
    "weather": {"sensor.earth_model": "sphere", "environment.climatology": False, "environment.weather": True,
                "environment.height_variation": False, "remove_oblateness": False},
    "height": {"sensor.earth_model": "sphere", "environment.climatology": False, "environment.weather": False,
               "environment.height_variation": True, "remove_oblateness": False},
}

#: Meteorological seasons of the northern hemisphere, by month.
SEASONS = {"DJF": (12, 1, 2), "MAM": (3, 4, 5), "JJA": (6, 7, 8), "SON": (9, 10, 11)}

#: Latitude bins of the latitude × day map, deg.
LATITUDE_BIN_DEG = 10.0

#: Largest number of seeds and of orbits per task a campaign accepts (typo guards).
MAX_SEEDS = 100_000
MAX_ORBITS_PER_TASK = 100.0

#: Most sensor samples one task may fly: a task holds its samples in memory (≈ 250 bytes each while it
#: runs), so 5 million is ≈ 1.3 GB on a worker. More orbits at a high rate: more days or seeds instead.
MAX_TASK_SAMPLES = 5_000_000

#: Key of the task description in each result file's Parquet metadata.
METADATA_KEY = b"pmv_campaign"

#: Version of the result files' layout and description; a file of another version is recomputed.
RESULT_FORMAT = 2

#: Columns of a result file, in order: float64 except ``outcome`` (int8).
RESULT_COLUMNS = ("t_s", "u_rad", "latitude_rad", "outcome", "roll_rad", "pitch_rad", "meridional_rad")

#: Largest result file read back, bytes (MAX_TASK_SAMPLES rows of 7 columns, compressed, fit well inside).
MAX_RESULT_BYTES = 512 << 20

#: Largest task description in a result file's metadata, bytes (≈ 3 kB in practice).
MAX_DESCRIPTION_BYTES = 1 << 20

#: Relative agreement asked of a file's values with the monitor's own summary in its description: float64
#: sums of ≤ 5 million values in another order differ by ≲ 1e-12 relative; 1e-9 leaves room, a changed
#: value of 0.01″ in 5 million moves a mean by more.
SUMMARY_TOLERANCE = 1e-9

#: The settings that decide what a task computes; a folder holds one campaign's.
MANIFEST = "campaign.json"


def parse_days(spec: str, year: int, from_elements: bool = False) -> list[int]:
    """Days of year from ``"1,91,182,274"``, ``"1-365:7"`` or a mix; ValueError naming a bad item.

    Days run 1 … 365 (366 in a leap year of the preset's epoch); a range
    ``a-b:s`` takes a, a + s, … up to b. With ``from_elements`` (orbit.source
    tle) they are days from the element set's epoch instead, 0 … 365.
    """
    last = 366 if _is_leap(year) else 365
    if from_elements:
        return _parse_day_items(spec, 0, 365, "days from the element set's epoch")
    return _parse_day_items(spec, 1, last, f"days of year {year}")


def _parse_day_items(spec: str, low: int, last: int, meaning: str) -> list[int]:
    days = set()
    for item in str(spec).split(","):
        item = item.strip()
        if not item:
            raise ValueError(f"--days {spec!r} has an empty item")
        body, _, step_text = item.partition(":")
        first_text, dash, last_text = body.partition("-")
        try:
            first = int(first_text)
            stop = int(last_text) if dash else first
            step = int(step_text) if step_text else 1
        except ValueError:
            raise ValueError(f"--days item {item!r} is not a day, a range a-b or a range a-b:step") from None
        for day in (first, stop):
            if not low <= day <= last:
                raise ValueError(f"--days: day {day} is outside the allowed range {low} … {last} ({meaning})")
        if step < 1:
            raise ValueError(f"--days item {item!r}: the step must be ≥ 1")
        if stop < first:
            raise ValueError(f"--days item {item!r}: the range ends before it starts")
        days.update(range(first, stop + 1, step))
    return sorted(days)


def _is_leap(year: int) -> bool:
    return year % 4 == 0 and (year % 100 != 0 or year % 400 == 0)


def day_epoch(epoch_utc: str, day: int) -> str:
    """The preset's epoch moved to ``day`` of its year, same time of day, as ISO 8601 UTC."""
    moment = dt.datetime.fromisoformat(epoch_utc.strip())
    if moment.tzinfo is None:
        moment = moment.replace(tzinfo=dt.timezone.utc)
    moment = moment.astimezone(dt.timezone.utc)
    start = moment.replace(month=1, day=1) + dt.timedelta(days=day - 1)
    return start.strftime("%Y-%m-%dT%H:%M:%SZ")


def elements_day_epoch(epoch_utc: str, day: int) -> str:
    """``day`` days after an element set's epoch (ISO 8601 UTC, to the microsecond), as ISO 8601 UTC."""
    moment = dt.datetime.fromisoformat(epoch_utc.strip()).astimezone(dt.timezone.utc)
    return (moment + dt.timedelta(days=day)).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


def season_of(epoch_utc: str) -> str:
    """The meteorological season (northern names DJF, MAM, JJA, SON) of a UTC date."""
    month = dt.datetime.fromisoformat(epoch_utc.replace("Z", "+00:00")).month
    return next(name for name, months in SEASONS.items() if month in months)


@dataclass(frozen=True)
class Task:
    """One unit of work: a day of year, a seed, an environment component."""

    day: int
    seed: int
    component: str = "total"

    @property
    def name(self) -> str:
        """The task's file stem (also its Dask key)."""
        return f"day{self.day:03d}-seed{self.seed}-{self.component}"


@dataclass(frozen=True)
class Settings:
    """What every task of a campaign shares: the parsed preset, its epoch, the rate and the length."""

    document: dict
    epoch_utc: str
    rate_hz: float | None
    orbits_per_task: float
    #: orbit.source tle: ``epoch_utc`` is the element set's epoch and the days count from it
    days_from_elements: bool = False

    def manifest(self) -> dict:
        """The settings as JSON-ready data (``campaign.json``)."""
        return {"preset": self.document, "rate_hz": self.rate_hz, "orbits_per_task": self.orbits_per_task}


def settings_digest(settings: Settings) -> str:
    """SHA-256 of the campaign's settings (the preset and its overrides, rate, length), as a result file records it."""
    import hashlib

    text = json.dumps(finite_json(settings.manifest()), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def plan(days, seeds: int, components: bool) -> list[Task]:
    """Every task: days × seeds (0 … seeds − 1) × components (just "total" without ``components``)."""
    names = list(COMPONENTS) if components else ["total"]
    return [Task(day, seed, name) for name in names for day in days for seed in range(seeds)]


def task_overrides(settings: Settings, task: Task) -> dict:
    """The parameters a task sets on every node: its seed and epoch, the rate, its component."""
    epoch = (elements_day_epoch if settings.days_from_elements else day_epoch)(settings.epoch_utc, task.day)
    overrides = {"seed": task.seed, "sim.epoch_utc": epoch}
    if settings.rate_hz is not None:
        overrides["sensor.rate_hz"] = settings.rate_hz
    overrides.update(COMPONENTS[task.component])
    return overrides


def task_samples(values, orbits: float) -> int:
    """Sensor samples in ``orbits`` orbits, counted as ``pmv simulate --orbits`` counts its ticks."""
    sensor = values.sensor
    orbit = CircularOrbit(sensor["orbit.altitude_km"] * 1e3, math.radians(sensor["orbit.inclination_deg"]),
                          j2_node_drift=sensor["orbit.j2_node_drift"])
    if sensor["orbit.source"] != "circular":  # the element set's nodal period
        orbit = build_source_orbit(sensor, 0.0, check_span_s=0.0)
    return max(2, round(orbits * orbit.period_s * sensor["sensor.rate_hz"]))


def check(settings: Settings, tasks: list[Task]) -> None:
    """Raise ValueError for settings that no task could fly, before any worker is asked."""
    first = tasks[0]
    values = flight_values(settings.document, task_overrides(settings, first))
    if values.sensor["attitude.source"] != "profile":
        raise ValueError("attitude.source = follow: a campaign flies the sensor's own attitude profile")
    if any(task.component != "total" for task in tasks) and values.sensor["radiance.source"] != "environment":
        raise ValueError("--components needs radiance.source: environment in the preset (the components are "
                         "the environment's)")
    samples = task_samples(values, settings.orbits_per_task)
    if samples > MAX_TASK_SAMPLES:
        raise ValueError(f"--orbits-per-task {settings.orbits_per_task:g} at {values.sensor['sensor.rate_hz']:g} Hz "
                         f"is {samples} samples a task, more than {MAX_TASK_SAMPLES} (fly fewer orbits per task)")
    period = 1.0 / values.sensor["sensor.rate_hz"]
    if period > values.star_tracker["max_truth_gap_s"]:
        raise ValueError(f"sensor rate {values.sensor['sensor.rate_hz']:g} Hz: samples {period:g} s apart are "
                         f"longer than the star tracker's max_truth_gap_s = {values.star_tracker['max_truth_gap_s']:g} s"
                         ", so it would measure no frame")
    for name in {task.component for task in tasks} - {first.component}:  # each component's overrides once
        flight_values(settings.document, task_overrides(settings, Task(first.day, first.seed, name)))
    if values.sensor["orbit.source"] != "circular":  # SGP4 over every day's span: an error code now, not on a worker
        span_s = samples / values.sensor["sensor.rate_hz"]
        for day in sorted({task.day for task in tasks}):
            sensor = flight_values(settings.document, task_overrides(settings, Task(day, first.seed))).sensor
            build_source_orbit(sensor, sensor["sim.start_time_s"], check_span_s=span_s)


def run_task(settings: Settings, task: Task):
    """Fly one task on this worker; returns ``(pyarrow.Table, compute seconds)``.

    BLAS runs on one thread here whatever the worker was started with: the
    workers are the parallelism (the sensor's matrix products are small).
    """
    import pyarrow as pa
    from threadpoolctl import threadpool_limits

    started = time.perf_counter()
    with threadpool_limits(limits=1, user_api="blas"):
        overrides = task_overrides(settings, task)
        values = flight_values(settings.document, overrides)
        flight = fly(values, task_samples(values, settings.orbits_per_task))
    table = pa.table({
        "t_s": flight.t_s,
        "u_rad": flight.u_rad,
        "latitude_rad": flight.latitude_rad,
        "outcome": flight.outcome,
        "roll_rad": flight.roll_rad,
        "pitch_rad": flight.pitch_rad,
        "meridional_rad": flight.meridional_rad,
    })
    description = {"format": RESULT_FORMAT, "task": asdict(task), "task_key": task.name,
                   "settings_sha256": settings_digest(settings), "overrides": finite_json(overrides),
                   "epoch_utc": overrides["sim.epoch_utc"],
                   "season": season_of(overrides["sim.epoch_utc"]),
                   "rate_hz": values.sensor["sensor.rate_hz"], "samples": int(flight.t_s.size),
                   "outcome_codes": [status.value for status in OUTCOME_CODES],
                   "summary": summary_to_dict(flight.summary)}
    table = table.replace_schema_metadata({METADATA_KEY: json.dumps(finite_json(description)).encode()})
    return table, time.perf_counter() - started


def summary_to_dict(summary) -> dict:
    """A :class:`~pmv_ros.runtime.monitor.MonitorSummary` as JSON-ready data (the report's layout), the
    counters that are not zero."""
    return {"oblateness_removed": summary.oblateness_removed,
            "channels": {channel.channel: channel_to_dict(channel) for channel in summary.channels},
            "counters": {k: v for k, v in summary.counters.items() if v}}


# ------------------------------------------------------------------------ result files

def task_path(out: Path, task: Task) -> Path:
    """Where a task's result lives."""
    return Path(out) / f"{task.name}.parquet"


def prepare_folder(out: Path, settings: Settings) -> None:
    """Create the output folder, or check that the campaign already in it used the same settings.

    Leftover temporary files of a killed campaign are removed (one campaign per folder at a time).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    manifest = out / MANIFEST
    mine = finite_json(settings.manifest())
    if manifest.exists() or manifest.is_symlink():
        from ..storage.files import read_json_file

        try:  # bounded: a FIFO, a device, a huge or deeply nested file is refused at once
            theirs = read_json_file(manifest, "campaign manifest")
        except ValueError as error:
            raise ValueError(f"{error} (remove it or use another --out)") from None
        if not isinstance(theirs, dict):
            raise ValueError(f"{manifest} is not a campaign manifest (remove it or use another --out)")
        if theirs != mine:
            different = [key for key in mine if theirs.get(key) != mine[key]]
            raise ValueError(f"{out} holds a campaign with other settings ({', '.join(different) or 'manifest'}): "
                             "use another --out, or the same preset, --rate-hz and --orbits-per-task")
    else:
        _write_atomically(manifest, json.dumps(mine, indent=1).encode())
    for leftover in out.glob(".*.parquet.tmp*"):
        leftover.unlink(missing_ok=True)


def write_result(out: Path, task: Task, table) -> Path:
    """Write a task's table as Parquet, atomically: a temporary file renamed into place."""
    import pyarrow.parquet as pq

    final = task_path(out, task)
    temporary = final.with_name(f".{final.name}.tmp{os.getpid()}")
    pq.write_table(table, temporary, compression="zstd")
    os.replace(temporary, final)
    return final


def _write_atomically(path: Path, data: bytes) -> None:
    temporary = path.with_name(f".{path.name}.tmp{os.getpid()}")
    temporary.write_bytes(data)
    os.replace(temporary, path)


class ResultRejected(ValueError):
    """A task file that cannot be used as the task's result; the message is the reason, one line."""


def read_result(path: Path, columns=None):
    """A task file: ``(pyarrow.Table, description dict)``; ResultRejected (one line) for a file that is not one.

    Bounded before anything is decompressed: a regular file of at most
    :data:`MAX_RESULT_BYTES`, at most :data:`MAX_TASK_SAMPLES` rows and as
    many uncompressed bytes as that many rows of the result's columns take,
    and a description of at most :data:`MAX_DESCRIPTION_BYTES`.
    """
    import pyarrow.parquet as pq

    from ..storage.files import check_regular_file, parse_json

    path = Path(path)
    try:
        check_regular_file(path, "task result", MAX_RESULT_BYTES)
    except ValueError as error:
        raise ResultRejected(str(error)) from None
    try:
        parquet = pq.ParquetFile(path)
    except Exception as error:  # pyarrow's errors (some are ValueErrors) for a file that is not Parquet
        raise ResultRejected(f"{path}: not a Parquet file ({_one_line(error)})") from None
    with parquet:
        meta = parquet.metadata
        declared = sum(meta.row_group(i).total_byte_size for i in range(meta.num_row_groups))
        if meta.num_rows > MAX_TASK_SAMPLES or declared > (MAX_TASK_SAMPLES * 8 * len(RESULT_COLUMNS)) * 2:
            raise ResultRejected(f"{path}: declares {meta.num_rows} rows, {declared} bytes, more than a task has")
        raw = (parquet.schema_arrow.metadata or {}).get(METADATA_KEY)
        if raw is None:
            raise ResultRejected(f"{path}: no task description in its metadata")
        if len(raw) > MAX_DESCRIPTION_BYTES:
            raise ResultRejected(f"{path}: its task description is larger than {MAX_DESCRIPTION_BYTES} bytes")
        try:
            description = parse_json(raw.decode("utf-8", "replace"), str(path), "task description")
        except ValueError as error:
            raise ResultRejected(str(error)) from None
        try:
            table = parquet.read(columns=columns)
        except Exception as error:
            raise ResultRejected(f"{path}: cannot read the table ({_one_line(error)})") from None
    if not isinstance(description, dict):
        raise ResultRejected(f"{path}: the task description is not a JSON object")
    return table, description


def _one_line(error: Exception) -> str:
    text = " ".join(str(error).split()) or type(error).__name__
    return text if len(text) <= 160 else text[:157] + "..."


def check_result(path: Path, settings: Settings, task: Task):
    """The task file at ``path`` as ``(table, description)`` if it is this task's result; else ResultRejected.

    Trusted only if its description matches the task — format version, task
    key, epoch and its season, seed, the settings' digest (preset and
    overrides, rate, length) and the task's overrides — its columns are the result's, and its
    values pass the bounds the monitor applies to what it counts (finite
    times and angles, latitudes on the Earth, residuals within the
    monitor's 30° bound on a sensor sample, outcome codes it knows) and agree
    with the monitor's own summary stored beside them (count, mean, σ of
    each channel to :data:`SUMMARY_TOLERANCE`).
    """
    from ..runtime.flight import PENDING_CODE
    from ..runtime.validation import InputBounds

    table, description = read_result(path)
    overrides = task_overrides(settings, task)
    expected = {"format": RESULT_FORMAT, "task_key": task.name, "task": asdict(task),
                "settings_sha256": settings_digest(settings), "overrides": finite_json(overrides),
                "epoch_utc": overrides["sim.epoch_utc"], "season": season_of(overrides["sim.epoch_utc"])}
    for key, value in expected.items():
        if description.get(key) != value:
            what = "missing" if key not in description else "does not match the task"
            raise ResultRejected(f"{path.name}: {key} {what}")
    if table.column_names != list(RESULT_COLUMNS):
        raise ResultRejected(f"{path.name}: columns {table.column_names} are not the result's")
    if description.get("samples") != table.num_rows:
        raise ResultRejected(f"{path.name}: {table.num_rows} rows, the description says {description.get('samples')}")
    try:
        columns = {name: table.column(name).to_numpy() for name in RESULT_COLUMNS}
    except Exception as error:
        raise ResultRejected(f"{path.name}: cannot read its columns ({_one_line(error)})") from None
    outcome = columns["outcome"]
    if outcome.dtype.kind not in "iu" or not np.all((outcome == PENDING_CODE)
                                                   | ((outcome >= 0) & (outcome < len(OUTCOME_CODES)))):
        raise ResultRejected(f"{path.name}: outcome codes the monitor does not have")
    for name in ("t_s", "u_rad", "latitude_rad"):
        if columns[name].dtype.kind != "f" or not np.all(np.isfinite(columns[name])):
            raise ResultRejected(f"{path.name}: {name} is not finite everywhere")
    if np.any(np.abs(columns["latitude_rad"]) > math.pi / 2) or np.any(np.diff(columns["t_s"]) <= 0.0):
        raise ResultRejected(f"{path.name}: latitudes or times out of their bounds")
    used = outcome == OUTCOME_CODES.index(Status.OK)
    bound = InputBounds().max_abs_angle_rad
    summary = description.get("summary")
    channels = summary.get("channels") if isinstance(summary, dict) else None
    if not isinstance(channels, dict):
        raise ResultRejected(f"{path.name}: no monitor summary in the description")
    for channel in CHANNELS:
        values = columns[f"{channel}_rad"]
        if values.dtype.kind != "f":
            raise ResultRejected(f"{path.name}: {channel}_rad is not floating point")
        values = values[used]
        finite = values[np.isfinite(values)]
        if np.any(np.isinf(values)) or np.any(np.abs(finite) > bound):
            raise ResultRejected(f"{path.name}: {channel} values beyond the monitor's ±{math.degrees(bound):g}° bound")
        mine = channels.get(channel)
        if not isinstance(mine, dict) or mine.get("count") != finite.size:
            raise ResultRejected(f"{path.name}: {finite.size} {channel} values, the monitor counted "
                                 f"{mine.get('count') if isinstance(mine, dict) else None}")
        if finite.size:
            stats = RunningStatistics()
            stats.update(finite)
            for key, value in (("mean_arcmin", stats.mean), ("sigma_arcmin", stats.sigma)):
                theirs = mine.get(key)
                if not isinstance(theirs, (int, float)) or not math.isclose(
                        value / ARCMIN_RAD, theirs, rel_tol=SUMMARY_TOLERANCE, abs_tol=1e-9):
                    raise ResultRejected(f"{path.name}: {channel} {key} does not agree with the monitor's summary")
    return table, description


def stale_results(out: Path, settings: Settings, tasks: list[Task]) -> dict[str, str]:
    """The tasks whose file is there but cannot be trusted: ``{task name: reason}`` (the files are removed)."""
    reasons = {}
    for task in tasks:
        path = task_path(out, task)
        if not (path.exists() or path.is_symlink()):
            continue
        try:
            check_result(path, settings, task)
        except ResultRejected as error:
            reasons[task.name] = str(error)
            try:
                path.unlink()
            except OSError as unlink_error:
                raise ValueError(f"{path}: cannot replace an untrusted result ({unlink_error.strerror})") from None
    return reasons


# ------------------------------------------------------------------------ running on Dask

#: Environment of the embedded cluster's worker processes: one BLAS/OpenMP thread each, and glibc's own
#: malloc thresholds. Dask's default also sets MALLOC_TRIM_THRESHOLD_ = 65536, which fixes the mmap
#: threshold at 128 kB: the sensor model's temporaries are then mapped and unmapped on every call and
#: a task takes ≈ 1.6× longer (42 against 25 µs a sample, measured 2026-12-01).
WORKER_ENVIRONMENT = {"OMP_NUM_THREADS": 1, "MKL_NUM_THREADS": 1, "OPENBLAS_NUM_THREADS": 1}


def open_client(scheduler: str | None, workers: int, timeout_s: float = 10.0):
    """A Dask client: on the scheduler at ``scheduler``, or on an embedded LocalCluster of ``workers`` processes.

    The embedded cluster runs one thread per worker process, no dashboard,
    and reschedules a task whose worker died (``allowed-failures``).
    Returns ``(client, cluster or None)``; ValueError naming the address if
    the scheduler cannot be reached within ``timeout_s``.
    """
    import logging

    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        return _connect(scheduler, timeout_s), None
    with dask.config.set({"distributed.scheduler.allowed-failures": 3,
                          "distributed.nanny.pre-spawn-environ": WORKER_ENVIRONMENT}):
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                               dashboard_address=":0",
                               silence_logs=logging.ERROR)
    return Client(cluster), cluster


def _connect(scheduler: str, timeout_s: float):
    """A client of the scheduler at ``scheduler``, or ValueError (one line) within ``timeout_s``.

    distributed's own timeout covers the TCP connect, not the handshake after
    it: a peer that accepts and then stays silent (an HTTP server, a bare
    listener) held the client for minutes. So the client is made on a daemon
    thread and waited for at most ``timeout_s``; a connection still hanging
    then is given up (the thread ends with the process).
    """
    import threading

    from distributed import Client

    outcome = {}

    def connect():
        try:
            outcome["client"] = Client(scheduler, timeout=f"{timeout_s}s")
        except BaseException as error:  # reported below, on the caller's thread
            outcome["error"] = error

    thread = threading.Thread(target=connect, name="pmv-dask-connect", daemon=True)
    thread.start()
    thread.join(timeout_s)
    if thread.is_alive():
        raise ValueError(f"cannot reach the Dask scheduler at {scheduler}: no Dask answer within {timeout_s:g} s")
    error = outcome.get("error")
    if error is not None:
        if not isinstance(error, (OSError, TimeoutError, ValueError)):
            raise error
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ValueError(f"cannot reach the Dask scheduler at {scheduler}: {reason}") from None
    return outcome["client"]


def run_campaign(settings: Settings, tasks: list[Task], out: Path, *, scheduler: str | None = None,
                 workers: int = 2, progress: bool = True, client=None) -> dict:
    """Run the tasks not yet done on Dask, writing each result as it arrives; returns what ran.

    ``client``: a Dask client to use (and leave open) instead of opening one
    from ``scheduler``/``workers``. Returns ``{"ran": n, "skipped": m,
    "wall_s": s, "compute_s": s, "samples": n}``.
    """
    from distributed import as_completed
    from tqdm import tqdm

    out = Path(out)
    recomputed = stale_results(out, settings, tasks)
    todo = [task for task in tasks if not task_path(out, task).exists()]
    report = {"ran": 0, "skipped": len(tasks) - len(todo), "wall_s": 0.0, "compute_s": 0.0, "samples": 0,
              "recomputed": recomputed}
    if not todo:
        return report
    started = time.perf_counter()
    own = client is None
    cluster = None
    if own:
        client, cluster = open_client(scheduler, workers)
    try:
        futures = {client.submit(run_task, settings, task, key=f"pmv-campaign-{task.name}", pure=False): task
                   for task in todo}
        with tqdm(total=len(todo), unit="task", disable=not progress, dynamic_ncols=True,
                  desc=f"campaign: {len(todo)} of {len(tasks)} tasks to run") as bar:
            for future in as_completed(futures):
                task = futures.pop(future)
                table, compute_s = future.result()
                write_result(out, task, table)
                future.release()
                report["ran"] += 1
                report["compute_s"] += compute_s
                report["samples"] += table.num_rows
                bar.update(1)
    finally:
        if own:
            client.close()
        if cluster is not None:
            cluster.close()
    report["wall_s"] = time.perf_counter() - started
    return report


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
    latitude bin and day; ``tasks``: each task's own statistics (the monitor's).
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
    for task in tasks:
        path = task_path(out, task)
        table, description = read_result(path) if settings is None else check_result(path, settings, task)
        used = table.column("outcome").to_numpy() == ok
        latitude = np.degrees(table.column("latitude_rad").to_numpy())[used]
        season = description["season"]
        component = groups.setdefault(task.component, {"year": _new_channels(), **{s: _new_channels() for s in SEASONS}})
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
        per_task.append({**asdict(task), "epoch_utc": description["epoch_utc"], "season": season,
                         "samples": description["samples"], **description["summary"]})
    result = {"components": {}, "by_day": {}, "tasks": per_task}
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
    parts = [name for name in COMPONENTS if name != "total" and name in groups]
    if parts and "total" in groups:
        result["rss"] = _rss(result["components"], parts)
    return finite_json(result)


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


def _day_edges(days: list[int]) -> np.ndarray:
    """Cell edges between the campaign's days (midpoints; half a step beyond the ends)."""
    centres = np.asarray(days, float)
    if centres.size == 1:
        return np.array([centres[0] - 0.5, centres[0] + 0.5])
    middle = 0.5 * (centres[1:] + centres[:-1])
    return np.r_[centres[0] - (middle[0] - centres[0]), middle, centres[-1] + (centres[-1] - middle[-1])]
