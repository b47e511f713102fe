"""``pmv campaign`` on Dask: an external scheduler gives the embedded cluster's results; a killed worker loses nothing.

A scheduler and two workers are started with Dask's own command line
(``python -m dask scheduler|worker``) on 127.0.0.1 at free ports; every wait
is bounded. Tasks are short (a tenth of an orbit at 10 Hz, ≈ 0.2–0.4 s each).
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from pmv_ros.apps import campaign

pytestmark = [pytest.mark.multi_process]

REPO = Path(__file__).resolve().parents[2]
METEOR = REPO / "config" / "meteor_m2.yaml"

#: Three days × two seeds, 0.1 orbit each (≈ 6,100 samples, ≈ 0.2–0.4 s a task on one core). What the tests
#: compare is bit for bit and counts every sample, so any length shows a lost, doubled or different task; a
#: task lasts long enough that the worker killed below is busy and tasks are left when the first file lands.
DAYS, SEEDS, ORBITS_PER_TASK = [1, 120, 240], 2, 0.1
CAMPAIGN = ["--config", str(METEOR), "--days", ",".join(map(str, DAYS)), "--seeds", str(SEEDS),
            "--orbits-per-task", str(ORBITS_PER_TASK), "--rate-hz", "10", "--quiet", "--json"]
TASKS = 6
WAIT_S = 120.0


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _wait_for_port(port: int, process: subprocess.Popen, timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise RuntimeError(f"the Dask process exited with {process.returncode}")
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.5):
                return
        except OSError:
            time.sleep(0.2)
    raise TimeoutError(f"nothing listens on 127.0.0.1:{port} after {timeout_s:g} s")


def _start(arguments, log: Path) -> subprocess.Popen:
    """A Dask process in its own session (so the test can kill it with its children)."""
    handle = open(log, "wb")
    # The embedded cluster's worker environment (campaign.WORKER_ENVIRONMENT): speed only, not results.
    environment = {**os.environ, "DASK_DISTRIBUTED__NANNY__PRE_SPAWN_ENVIRON": repr(campaign.WORKER_ENVIRONMENT)}
    return subprocess.Popen([sys.executable, "-m", "dask", *arguments], stdout=handle, stderr=subprocess.STDOUT,
                            start_new_session=True, env=environment)


def _stop(process: subprocess.Popen) -> None:
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGTERM)
        try:
            process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait(timeout=20)


def _wait_for_workers(address: str, count: int, timeout_s: float = 60.0) -> None:
    from distributed import Client

    with Client(address, timeout="20s") as client:
        client.wait_for_workers(count, timeout=timeout_s)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """A scheduler and two single-thread workers on 127.0.0.1: (address, [worker processes])."""
    tmp_path = tmp_path_factory.mktemp("dask")
    port = _free_port()
    address = f"tcp://127.0.0.1:{port}"
    processes = [_start(["scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard"],
                        tmp_path / "scheduler.log")]
    try:
        _wait_for_port(port, processes[0])
        workers = [_start(["worker", address, "--host", "127.0.0.1", "--nthreads", "1", "--nworkers", "1",
                           "--no-dashboard", "--death-timeout", "60"], tmp_path / f"worker{i}.log")
                   for i in range(2)]
        processes += workers
        _wait_for_workers(address, 2)
        yield address, workers
    finally:
        for process in reversed(processes):
            _stop(process)


def _pmv(arguments, timeout_s: float = WAIT_S) -> dict:
    result = subprocess.run([sys.executable, "-m", "pmv_ros.cli", "campaign", *arguments], capture_output=True,
                            text=True, timeout=timeout_s)
    assert result.returncode == 0, result.stderr[-2000:]
    return json.loads(result.stdout)


def _tables(out: Path) -> dict:
    """Every task file of a folder: name → (table, description)."""
    return {path.stem: campaign.read_result(path) for path in sorted(out.glob("*.parquet"))}


def _same_results(a: Path, b: Path) -> None:
    first, second = _tables(a), _tables(b)
    assert sorted(first) == sorted(second) and len(first) == TASKS
    for name, (table, description) in first.items():
        other = second[name][0]
        assert table.column_names == other.column_names, name
        for column in table.column_names:  # bit for bit; NaN (a sample not used) equals NaN
            assert np.array_equal(table.column(column).to_numpy(), other.column(column).to_numpy(),
                                  equal_nan=column != "outcome"), (name, column)
        assert description == second[name][1], name
    budget_a = json.loads((a / "budget.json").read_text())
    budget_b = json.loads((b / "budget.json").read_text())
    assert budget_a == budget_b


@pytest.fixture(scope="module")
def external(cluster, tmp_path_factory):
    """The campaign run once on the external cluster (both workers alive): its folder."""
    out = tmp_path_factory.mktemp("external") / "out"
    report = _pmv([*CAMPAIGN, "--scheduler", cluster[0], "--out", str(out)])
    assert report["ran"] == TASKS and report["scheduler"] == cluster[0]
    return out


def test_external_scheduler_gives_the_embedded_results(tmp_path, external):
    # One embedded worker runs the six tasks one after another in one process; the external cluster spreads
    # them over two: the same files whatever the placement.
    embedded = _pmv([*CAMPAIGN, "--workers", "1", "--out", str(tmp_path / "embedded")])
    assert embedded["ran"] == TASKS
    _same_results(tmp_path / "embedded", external)
    for name in ("budget.json", "sigma_limit.png", "latitude_season.png"):
        assert (external / name).stat().st_size > 0


def test_a_worker_killed_mid_campaign_loses_nothing_and_a_rerun_skips_all(tmp_path, cluster, external):
    """Runs last in this module: it kills one of the module's two workers."""
    address, workers = cluster
    out = tmp_path / "killed"
    run = subprocess.Popen([sys.executable, "-m", "pmv_ros.cli", "campaign", *CAMPAIGN, "--scheduler", address,
                            "--out", str(out)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + WAIT_S
        while not list(out.glob("*.parquet")) and time.monotonic() < deadline and run.poll() is None:
            time.sleep(0.05)
        assert run.poll() is None, "the campaign ended before a worker could be killed"
        done_at_kill = len(list(out.glob("*.parquet")))
        assert 1 <= done_at_kill < TASKS
        os.killpg(workers[0].pid, signal.SIGKILL)  # the worker, its nanny and anything it runs
        stdout, stderr = run.communicate(timeout=WAIT_S)
    finally:
        if run.poll() is None:
            run.kill()
            run.wait(timeout=20)
    assert run.returncode == 0, stderr[-2000:]
    report = json.loads(stdout)
    assert report["ran"] == TASKS and report["skipped"] == 0
    # Nothing lost, nothing twice: one whole file per task, no temporary file left, every sample counted once.
    files = sorted(out.glob("*.parquet"))
    assert [path.stem for path in files] == sorted(task.name for task in campaign.plan(DAYS, SEEDS, False))
    assert not list(out.glob(".*tmp*"))
    budget = json.loads((out / "budget.json").read_text())
    assert len(budget["tasks"]) == TASKS
    for channel in ("roll", "pitch", "meridional"):
        per_task = sum(task["channels"][channel]["count"] for task in budget["tasks"])
        assert budget["components"]["total"]["year"][channel]["count"] == per_task > 0
    assert sum(task["samples"] for task in budget["tasks"]) == sum(t.num_rows for t, _ in _tables(out).values())
    # The same results as the run with both workers alive.
    _same_results(out, external)
    # A re-run finds every task done and trusts it: what ``pmv campaign --scheduler`` runs (run_campaign, with the
    # command's settings: the folder's campaign.json must match them) returns before it would ask the cluster.
    settings = _settings()
    campaign.prepare_folder(out, settings)
    again = campaign.run_campaign(settings, campaign.plan(DAYS, SEEDS, False), out, scheduler=address, progress=False)
    assert again["ran"] == 0 and again["skipped"] == TASKS and again["recomputed"] == {}


def _settings():
    """The Settings ``pmv campaign CAMPAIGN`` makes (Meteor-M's preset epoch, 10 Hz)."""
    import yaml

    from pmv_ros.runtime.common.assembly import SENSOR_PARAMS
    from pmv_ros.runtime.common.parameters import preset_values

    document = yaml.safe_load(METEOR.read_text())
    epoch_utc = preset_values(document, "sensor_node", SENSOR_PARAMS)["sim.epoch_utc"]
    return campaign.Settings(document, epoch_utc, 10.0, ORBITS_PER_TASK)
