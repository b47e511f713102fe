"""The campaign trusts nothing it did not just write (issue 23).

A campaign of 4 tasks is run once (in this process, by the functions the
command runs); then its task files are tampered with
the ways the issue found — one task's file copied over another's, values
set to NaN, values set to 1e300, the task description removed from the
metadata — and ``pmv campaign`` is resumed in the same folder. The budget must
equal the untampered run's (bit for bit: the tasks are deterministic), and
the output must name each recomputed task and why. More ways a file can
lie (a dropped column, a wrong season, a summary that does not match the
values, a FIFO, garbage) are checked on ``check_result`` directly. And a
``--scheduler`` that accepts the connection and stays silent is one line
within the scheduler timeout (10 s; 2 s in the test).
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from campaign_cli import campaign_child

from pmv_ros.apps import campaign
from pmv_ros.runtime.flight import OUTCOME_CODES
from pmv_ros.runtime.monitor.records import Status
from pmv_ros.physics.constants import ARCMIN_RAD

pytestmark = [pytest.mark.adversarial, pytest.mark.multi_process]

REPO = Path(__file__).resolve().parents[2]
METEOR = REPO / "config" / "meteor_m2.yaml"
ARGUMENTS = ["--config", str(METEOR), "--days", "1,183", "--seeds", "2", "--orbits-per-task", "0.03",
             "--workers", "1", "--quiet", "--json"]


def _campaign(out: Path, *extra, timeout_s: float = 600.0) -> dict:
    result = subprocess.run([sys.executable, "-m", "pmv_ros.cli", "campaign", *ARGUMENTS, "--out", str(out), *extra],
                            capture_output=True, text=True, timeout=timeout_s)
    assert result.returncode == 0 and "Traceback" not in result.stderr, result.stderr[-3000:]
    return json.loads(result.stdout)


def _settings(days) -> tuple:
    """The Settings and tasks ``pmv campaign ARGUMENTS`` plans (``--rate-hz`` not given: the preset's)."""
    import yaml

    document = yaml.safe_load(METEOR.read_text())
    settings = campaign.Settings(document, _epoch({"preset": document}), None, float(ARGUMENTS[ARGUMENTS.index(
        "--orbits-per-task") + 1]))
    return settings, campaign.plan(days, 2, False)


@pytest.fixture(scope="module")
def clean(tmp_path_factory) -> Path:
    """The untampered campaign's folder, made in this process by the functions ``pmv campaign`` runs (its tasks
    are deterministic: on Dask or here, the same files); the resumed run below is the command itself, on Dask,
    and refuses this folder if its settings were not the command's."""
    out = tmp_path_factory.mktemp("trust") / "clean"
    settings, tasks = _settings([1, 183])
    campaign.prepare_folder(out, settings)
    for task in tasks:
        table, _ = campaign.run_task(settings, task)
        campaign.write_result(out, task, table)
    campaign.write_budget(out, campaign.budget(out, tasks, settings))
    assert len(list(out.glob("*.parquet"))) == 4 and campaign.stale_results(out, settings, tasks) == {}
    return out


def _rewrite(path: Path, change) -> None:
    """Rewrite a task file with ``change(table) -> table`` (the metadata kept unless ``change`` drops it)."""
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    pq.write_table(change(table), path)


def _set_values(value: float, rows: slice):
    """Set ``rows`` of the samples the monitor used (finite roll: the star tracker's gaps leave others NaN)."""
    import pyarrow as pa

    def change(table):
        roll = table.column("roll_rad").to_numpy().copy()
        roll[np.flatnonzero(np.isfinite(roll))[rows]] = value
        return table.set_column(table.column_names.index("roll_rad"), "roll_rad", pa.array(roll))

    return change


def test_a_resumed_campaign_recomputes_every_file_it_cannot_trust(clean, tmp_path):
    out = tmp_path / "tampered"
    shutil.copytree(clean, out)
    names = sorted(path.name for path in out.glob("*.parquet"))
    assert names == ["day001-seed0-total.parquet", "day001-seed1-total.parquet", "day183-seed0-total.parquet",
                     "day183-seed1-total.parquet"]
    shutil.copyfile(out / "day183-seed0-total.parquet", out / "day001-seed0-total.parquet")  # another day's result
    _rewrite(out / "day001-seed1-total.parquet", _set_values(float("nan"), slice(100, 400)))
    _rewrite(out / "day183-seed0-total.parquet", _set_values(1e300, slice(10, 11)))
    _rewrite(out / "day183-seed1-total.parquet", lambda table: table.replace_schema_metadata({}))
    report = _campaign(out)
    recomputed = report.get("recomputed", {})
    print("recomputed:", json.dumps(recomputed, indent=1))
    assert sorted(recomputed) == sorted(name.removesuffix(".parquet") for name in names)
    assert "task_key does not match" in recomputed["day001-seed0-total"]
    assert "roll values, the monitor counted" in recomputed["day001-seed1-total"]
    assert "beyond the monitor's" in recomputed["day183-seed0-total"]
    assert "no task description" in recomputed["day183-seed1-total"]
    assert report["ran"] == 4 and report["skipped"] == 0
    assert json.loads((out / "budget.json").read_text()) == json.loads((clean / "budget.json").read_text())
    # And a resume with nothing wrong trusts everything: what ``pmv campaign`` runs (run_campaign) finds
    # nothing to recompute and nothing to run — it returns before it would open a Dask client.
    settings, tasks = _settings([1, 183])
    again = campaign.run_campaign(settings, tasks, out, scheduler="tcp://127.0.0.1:9", progress=False)
    assert again["ran"] == 0 and again["skipped"] == 4 and again["recomputed"] == {}




@pytest.mark.parametrize("tamper, reason", [
    ("drop_column", "columns"),
    ("season", "season"),
    ("summary", "does not agree with the monitor's summary"),
    ("fifo", "FIFO"),
    ("garbage", "not a Parquet file"),
    ("inf", "beyond the monitor's"),
    ("outcome", "outcome codes"),
    ("format", "format does not match"),
])
def test_check_result_names_why_a_file_is_not_the_tasks_result(clean, tmp_path, tamper, reason):
    import pyarrow.parquet as pq

    manifest = json.loads((clean / "campaign.json").read_text())
    settings = campaign.Settings(manifest["preset"], _epoch(manifest), manifest["rate_hz"], manifest["orbits_per_task"])
    task = campaign.Task(day=1, seed=0)
    source = campaign.task_path(clean, task)
    campaign.check_result(source, settings, task)  # the clean file is trusted
    path = tmp_path / source.name
    shutil.copyfile(source, path)
    table = pq.read_table(path)
    description = json.loads(table.schema.metadata[campaign.METADATA_KEY])

    def with_description(**changes):
        described = {**description, **changes}
        return table.replace_schema_metadata({campaign.METADATA_KEY: json.dumps(described).encode()})

    if tamper == "drop_column":
        pq.write_table(table.drop_columns(["latitude_rad"]), path)
    elif tamper == "season":
        pq.write_table(with_description(season="JJA"), path)  # day 1 is in DJF
    elif tamper == "summary":  # one used value moved by 0.1′, the monitor's summary beside it not
        used = np.flatnonzero(table.column("outcome").to_numpy() == OUTCOME_CODES.index(Status.OK))
        roll = table.column("roll_rad").to_numpy()
        _rewrite(path, _set_values(float(roll[used[0]]) + 0.1 * ARCMIN_RAD, slice(used[0], used[0] + 1)))
    elif tamper == "fifo":
        path.unlink()
        os.mkfifo(path)
    elif tamper == "garbage":
        path.write_bytes(b"PAR1" + os.urandom(2000) + b"PAR1")
    elif tamper == "inf":
        _rewrite(path, _set_values(float("inf"), slice(5, 6)))
    elif tamper == "outcome":
        import pyarrow as pa

        outcome = table.column("outcome").to_numpy().copy()
        outcome[3] = 99
        pq.write_table(table.set_column(table.column_names.index("outcome"), "outcome",
                                        pa.array(outcome.astype(np.int8))), path)
    elif tamper == "format":
        pq.write_table(with_description(format=1), path)
    started = time.monotonic()
    with pytest.raises(campaign.ResultRejected) as refused:
        campaign.check_result(path, settings, task)
    assert reason in str(refused.value) and "\n" not in str(refused.value)
    assert time.monotonic() - started < 10.0


def _epoch(manifest) -> str:
    from pmv_ros.runtime.common.assembly import SENSOR_PARAMS
    from pmv_ros.runtime.common.parameters import preset_values

    return preset_values(manifest["preset"], "sensor_node", SENSOR_PARAMS)["sim.epoch_utc"]


#: The scheduler timeout of the silent-peer test, s (the command's is 10 s: cluster.SCHEDULER_TIMEOUT_S).
SILENT_TIMEOUT_S = 2.0


@pytest.mark.parametrize("peer", ["silent", "http"])
def test_a_scheduler_that_accepts_and_stays_silent_is_one_line_within_the_timeout(tmp_path, peer, run_long):
    if peer == "http" and not run_long:
        pytest.skip("the HTTP server as a scheduler runs with --run-long (the same path as the silent listener)")
    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen(8)
    port = listener.getsockname()[1]
    server = None
    if peer == "http":  # an HTTP server answers HTTP, never Dask
        listener.close()
        server = subprocess.Popen([sys.executable, "-m", "http.server", str(port), "--bind", "127.0.0.1"],
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=tmp_path)
        deadline = time.monotonic() + 60.0
        while True:  # until the server listens
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.5).close()
                break
            except OSError:
                assert server.poll() is None and time.monotonic() < deadline, "the HTTP server did not listen"
                time.sleep(0.05)
    try:
        started = time.monotonic()
        arguments = [a for a in ARGUMENTS[:-1] if a not in ("--workers", "1")]
        # The command's 10 s timeout shortened to 2 s (tests/campaign_cli.py): the same wait, on the clock.
        result = campaign_child([*arguments, "--scheduler", f"tcp://127.0.0.1:{port}", "--out", tmp_path / "out"],
                                scheduler_timeout_s=SILENT_TIMEOUT_S)
        took_s = time.monotonic() - started
    finally:
        if server is not None:
            server.terminate()
            server.wait(timeout=10)
        else:
            listener.close()
    lines = result.stderr.strip().splitlines()
    print(f"{peer} scheduler: status {result.returncode} after {took_s:.1f} s: {lines}")
    assert result.returncode == 2 and len(lines) == 1 and "Traceback" not in result.stderr, result.stderr[-2000:]
    assert f"127.0.0.1:{port}" in lines[0]
    # Ended by the timeout itself (the peer never answers): it says so, and names the timeout it waited.
    assert f"no Dask answer within {SILENT_TIMEOUT_S:g} s" in lines[0], lines[0]
    # The timeout after the interpreter's start-up (imports: a few seconds on a loaded machine), not minutes.
    assert took_s < SILENT_TIMEOUT_S + 20.0
