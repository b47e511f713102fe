"""A campaign task's result: the task flown (:func:`run_task`) into a table that carries its description,
written as one Parquet file whole or not at all, and read back only if the description matches the task and
the values pass the monitor's bounds."""

from __future__ import annotations

import json
import math
import os
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from ...storage.json_output import finite_json
from ...physics.constants import ARCMIN_RAD
from ...runtime.flight import OUTCOME_CODES, flight_values, fly, fly_closed_loop
from ...analysis.statistics import CHANNELS
from ...runtime.monitor.records import Status
from ..report import channel_to_dict
from ...analysis.statistics import RunningStatistics
from .tasks import MAX_TASK_SAMPLES, Settings, Task, season_of, settings_digest, task_overrides, task_samples


#: Key of the task description in each result file's Parquet metadata.
METADATA_KEY = b"pmv_campaign"

#: Version of the result files' layout and description; a file of another version is recomputed.
RESULT_FORMAT = 2

#: Columns of a result file, in order: float64 except ``outcome`` (int8).
RESULT_COLUMNS = ("t_s", "u_rad", "latitude_rad", "outcome", "roll_rad", "pitch_rad", "meridional_rad")

#: Columns a closed-loop task adds after those: the true pointing error at each sample, rad (NaN during the
#: loop's settling time).
POINTING_COLUMNS = ("pointing_roll_rad", "pointing_pitch_rad")


def result_columns(settings: Settings) -> tuple:
    """The columns of a task file of this campaign."""
    return RESULT_COLUMNS + (POINTING_COLUMNS if settings.closed_loop else ())

#: Largest result file read back, bytes (MAX_TASK_SAMPLES rows of 7 columns, compressed, fit well inside).
MAX_RESULT_BYTES = 512 << 20

#: Largest task description in a result file's metadata, bytes (≈ 3 kB in practice).
MAX_DESCRIPTION_BYTES = 1 << 20

#: Largest Parquet footer of a result file, bytes: pyarrow parses it whole before anything can be checked, and a
#: result's holds its seven columns' row groups (a few kB) and the description.
MAX_FOOTER_BYTES = MAX_DESCRIPTION_BYTES + (1 << 20)

#: Relative agreement asked of a file's values with the monitor's own summary in its description: float64
#: sums of ≤ 5 million values in another order differ by ≲ 1e-12 relative; 1e-9 leaves room, a changed
#: value of 0.01″ in 5 million moves a mean by more.
SUMMARY_TOLERANCE = 1e-9

#: The settings that decide what a task computes; a folder holds one campaign's.
MANIFEST = "campaign.json"

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
        flight = (fly_closed_loop if settings.closed_loop else fly)(values, task_samples(values,
                                                                                       settings.orbits_per_task))
    columns = {
        "t_s": flight.t_s,
        "u_rad": flight.u_rad,
        "latitude_rad": flight.latitude_rad,
        "outcome": flight.outcome,
        "roll_rad": flight.roll_rad,
        "pitch_rad": flight.pitch_rad,
        "meridional_rad": flight.meridional_rad,
    }
    if settings.closed_loop:  # the pointing error after the loop's settling time, NaN before
        transient = flight.t_s < flight.pointing.skip_until_s
        columns.update(pointing_roll_rad=np.where(transient, np.nan, flight.true_roll_rad),
                       pointing_pitch_rad=np.where(transient, np.nan, flight.true_pitch_rad))
    table = pa.table(columns)
    description = {"format": RESULT_FORMAT, "task": asdict(task), "task_key": task.name,
                   "settings_sha256": settings_digest(settings), "overrides": finite_json(overrides),
                   "epoch_utc": overrides["sim.epoch_utc"],
                   "season": season_of(overrides["sim.epoch_utc"]),
                   "rate_hz": values.sensor["sensor.rate_hz"], "samples": int(flight.t_s.size),
                   "outcome_codes": [status.value for status in OUTCOME_CODES],
                   "summary": summary_to_dict(flight.summary),
                   "truth_lost": {k: v for k, v in flight.truth_lost.items() if v}}
    if settings.closed_loop:
        description["pointing"] = {channel.channel: channel_to_dict(channel) for channel in flight.pointing.channels()}
    table = table.replace_schema_metadata({METADATA_KEY: json.dumps(finite_json(description)).encode()})
    return table, time.perf_counter() - started


def summary_to_dict(summary) -> dict:
    """A :class:`~pmv_ros.runtime.monitor.core.MonitorSummary` as JSON-ready data (the report's layout), the
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

    Leftover temporary files of a killed campaign are removed (one campaign per folder at a time). A path
    that is not a folder and cannot become one — a file, a symbolic link to nothing or a loop of them, a
    parent that is a file, a place without write access — is a ValueError saying which.
    """
    out = Path(out)
    _make_folder(out)
    manifest = out / MANIFEST
    mine = finite_json(settings.manifest())
    if manifest.exists() or manifest.is_symlink():
        from ...storage.files import read_json_file

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


def _make_folder(out: Path) -> None:
    """``out`` as a folder (made with its parents if missing); ValueError with the reason in one line."""
    import errno
    import stat

    try:
        mode = os.stat(out).st_mode
    except OSError as error:
        if error.errno == errno.ELOOP:
            raise ValueError(f"--out {out}: a loop of symbolic links") from None
        if out.is_symlink():
            raise ValueError(f"--out {out}: a symbolic link to {os.readlink(out)!r}, which does not exist") from None
        if error.errno not in (errno.ENOENT,):
            raise ValueError(f"--out {out}: {error.strerror}") from None
        mode = None
    if mode is not None and not stat.S_ISDIR(mode):
        raise ValueError(f"--out {out} exists and is not a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise ValueError(f"--out {out}: cannot make the folder ({error.strerror or error})") from None


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
    :data:`MAX_RESULT_BYTES` whose footer (Parquet's metadata, parsed
    whole) is at most :data:`MAX_FOOTER_BYTES`, the result's columns with
    their types (a column of strings could hold anything), at most
    :data:`MAX_TASK_SAMPLES` rows and as many uncompressed bytes as that
    many rows of the result's columns take, and a description of at most
    :data:`MAX_DESCRIPTION_BYTES`.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    from ...storage.files import check_regular_file, open_regular_file, parse_json

    path = Path(path)
    try:
        info = check_regular_file(path, "task result", MAX_RESULT_BYTES)
        with open_regular_file(path, "task result", MAX_RESULT_BYTES) as stream:
            stream.seek(max(0, info.st_size - 8))
            tail = stream.read(8)
    except ValueError as error:
        raise ResultRejected(str(error)) from None
    if len(tail) == 8 and tail[4:] == b"PAR1" and int.from_bytes(tail[:4], "little") > MAX_FOOTER_BYTES:
        raise ResultRejected(f"{path}: not a Parquet file of a task's result (its footer declares "
                             f"{int.from_bytes(tail[:4], 'little')} bytes, more than the {MAX_FOOTER_BYTES} allowed)")
    try:
        parquet = pq.ParquetFile(path)
    except Exception as error:  # pyarrow's errors (some are ValueErrors) for a file that is not Parquet
        raise ResultRejected(f"{path}: not a Parquet file ({_one_line(error)})") from None
    with parquet:
        meta = parquet.metadata
        schema = parquet.schema_arrow
        types = [(field.name, field.type) for field in schema]
        # an open-loop task's columns, or a closed-loop one's (check_result holds them to the campaign's settings)
        expected = [(name, pa.int8() if name == "outcome" else pa.float64()) for name in RESULT_COLUMNS]
        if types not in (expected, expected + [(name, pa.float64()) for name in POINTING_COLUMNS]):
            raise ResultRejected(f"{path}: columns {[f'{name} {kind}' for name, kind in types][:10]} are not the "
                                 "result's")
        declared = sum(meta.row_group(i).total_byte_size for i in range(meta.num_row_groups))
        if (meta.num_rows > MAX_TASK_SAMPLES
                or declared > (MAX_TASK_SAMPLES * 8 * len(RESULT_COLUMNS + POINTING_COLUMNS)) * 2):
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
    from ...runtime.flight import PENDING_CODE
    from ...runtime.common.validation import InputBounds

    table, description = read_result(path)
    overrides = task_overrides(settings, task)
    expected = {"format": RESULT_FORMAT, "task_key": task.name, "task": asdict(task),
                "settings_sha256": settings_digest(settings), "overrides": finite_json(overrides),
                "epoch_utc": overrides["sim.epoch_utc"], "season": season_of(overrides["sim.epoch_utc"])}
    for key, value in expected.items():
        if description.get(key) != value:
            what = "missing" if key not in description else "does not match the task"
            raise ResultRejected(f"{path.name}: {key} {what}")
    if table.column_names != list(result_columns(settings)):
        raise ResultRejected(f"{path.name}: columns {table.column_names} are not the result's")
    if description.get("samples") != table.num_rows:
        raise ResultRejected(f"{path.name}: {table.num_rows} rows, the description says {description.get('samples')}")
    try:
        columns = {name: table.column(name).to_numpy() for name in result_columns(settings)}
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
        _check_summary(path, finite, channels.get(channel), f"{channel} values, the monitor counted",
                       f"{channel} {{key}} does not agree with the monitor's summary")
    if settings.closed_loop:
        _check_pointing(path, columns, description)
    return table, description


def _check_pointing(path: Path, columns: dict, description: dict) -> None:
    """A closed-loop file's pointing columns: finite or NaN (the transient), within the monitor's angle bound,
    and agreeing with the pointing summary in its description (count, mean, σ)."""
    from ...runtime.common.validation import InputBounds

    summary = description.get("pointing")
    if not isinstance(summary, dict):
        raise ResultRejected(f"{path.name}: no pointing summary in the description")
    bound = InputBounds().max_abs_angle_rad
    for name in POINTING_COLUMNS:
        axis = name.split("_")[1]
        values = columns[name]
        finite = values[np.isfinite(values)] if values.dtype.kind == "f" else None
        if finite is None or np.any(np.isinf(values)) or np.any(np.abs(finite) > bound):
            raise ResultRejected(f"{path.name}: {name} is not a pointing error within ±{math.degrees(bound):g}°")
        _check_summary(path, finite, summary.get(axis), f"{axis} pointing values, the summary counted",
                       f"pointing {axis} {{key}} does not agree with its summary")


def _check_summary(path: Path, finite: np.ndarray, mine, counted: str, disagrees: str) -> None:
    """The finite values of a column against the summary the task wrote of them: the count exactly, the mean and σ
    within SUMMARY_TOLERANCE. ``counted`` follows the count in the refusal; ``disagrees`` is the refusal's words
    for a figure (``{key}`` names it)."""
    if not isinstance(mine, dict) or mine.get("count") != finite.size:
        raise ResultRejected(f"{path.name}: {finite.size} {counted} "
                             f"{mine.get('count') if isinstance(mine, dict) else None}")
    if finite.size:
        stats = RunningStatistics()
        stats.update(finite)
        for key, value in (("mean_arcmin", stats.mean), ("sigma_arcmin", stats.sigma)):
            theirs = mine.get(key)
            if not isinstance(theirs, (int, float)) or not math.isclose(
                    value / ARCMIN_RAD, theirs, rel_tol=SUMMARY_TOLERANCE, abs_tol=1e-9):
                raise ResultRejected(f"{path.name}: {disagrees.format(key=key)}")


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
