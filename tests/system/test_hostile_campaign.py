"""``pmv campaign`` against what its arguments and its scheduler can be: one line, exit status 2, in bounded time
and memory.

* The plan: ``--days 1-365 --seeds 100000 --components`` (each value in its bound) is 182.5 million tasks; the
  whole list was built first (a MemoryError traceback at 2.7 GB). A plan past ``MAX_TASKS`` is refused before it
  is built; a plan at the bound is built (and its folder checked) in seconds.
* A scheduler with no worker held the campaign at 0 % for ever, saying nothing: after ``--worker-timeout-s``
  (Dask's own ``Client.wait_for_workers``) it is one line. Shown with the plan at its bound, so the test also
  measures what such a plan costs before any task runs.
* ``--out`` as a symbolic link to nothing or a loop of links: a FileExistsError traceback; one line now.
* ``--scheduler`` with a comm the campaign cannot use (``ucx://``, ``tls://`` without certificates): a TypeError
  traceback from inside distributed; one line now.

A scheduler is started with Dask's own command line (``python -m dask scheduler``) on 127.0.0.1, no worker.
Every ``pmv`` run is a child measured by :mod:`bounded_run`, its address space capped at 4 GB.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bounded_run import pmv, run_measured

pytestmark = [pytest.mark.adversarial, pytest.mark.multi_process]

REPO = Path(__file__).resolve().parents[2]
METEOR = REPO / "config" / "meteor_m2.yaml"
CAMPAIGN = ["campaign", "--config", METEOR, "--orbits-per-task", "0.01", "--quiet"]

#: A refusal's bounds (those of the other hostile-file tests).
REFUSAL_CPU_S, REFUSAL_PEAK_MB = 10.0, 300.0

#: What a plan at MAX_TASKS may cost before its first task: planned, checked, its 50,000 file names looked up —
#: ≈ 1.5 s of CPU and ≈ 100 MB here; the test allows a loaded machine much more.
PLAN_CPU_S, PLAN_PEAK_MB = 30.0, 400.0

WORKER_TIMEOUT_S = 5.0


def _one_line(run, *phrases) -> str:
    assert run.status == 2, run
    lines = run.stderr.strip().splitlines()
    assert run.stdout == "" and len(lines) == 1 and "Traceback" not in run.stderr, run.stderr[-3000:]
    for phrase in phrases:
        assert phrase in lines[0], lines[0]
    return lines[0]


def _campaign(*arguments, timeout_s: float = 120.0):
    run = run_measured(pmv(*CAMPAIGN, *arguments), timeout_s=timeout_s, limit_mb=4096)
    print(f"pmv campaign {' '.join(map(str, arguments))}: {run.summary()}")
    return run


def test_a_plan_past_the_bound_is_refused_before_it_is_built(tmp_path):
    from pmv_ros.apps.campaign import MAX_TASKS

    run = _campaign("--days", "1-365", "--seeds", "100000", "--components", "--workers", "1",
                    "--out", tmp_path / "out")
    _one_line(run, "182500000 tasks", f"more than the {MAX_TASKS}")
    assert run.cpu_s < REFUSAL_CPU_S and run.peak_mb <= REFUSAL_PEAK_MB, run
    assert not (tmp_path / "out").exists()  # nothing made before the refusal


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.fixture(scope="module")
def lonely_scheduler(tmp_path_factory):
    """A Dask scheduler on 127.0.0.1 that never gets a worker: its address."""
    port = _free_port()
    log = open(tmp_path_factory.mktemp("scheduler") / "scheduler.log", "wb")
    process = subprocess.Popen([sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1", "--port", str(port),
                                "--no-dashboard"], stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    try:
        deadline = time.monotonic() + 60.0
        while True:
            assert process.poll() is None, "the scheduler exited"
            try:
                with socket.create_connection(("127.0.0.1", port), timeout=0.5):
                    break
            except OSError:
                assert time.monotonic() < deadline, "the scheduler did not listen within 60 s"
                time.sleep(0.2)
        yield f"tcp://127.0.0.1:{port}"
    finally:
        os.killpg(process.pid, signal.SIGTERM)
        try:
            process.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait(timeout=20)
        log.close()


def test_a_plan_at_the_bound_on_a_scheduler_without_workers_is_one_line_after_the_timeout(tmp_path,
                                                                                          lonely_scheduler):
    from pmv_ros.apps.campaign import COMPONENTS, MAX_TASKS

    days = MAX_TASKS // (40 * len(COMPONENTS))  # 250 days × 40 seeds × the components: the bound exactly
    assert days * 40 * len(COMPONENTS) == MAX_TASKS
    run = _campaign("--days", f"1-{days}", "--seeds", "40", "--components", "--scheduler", lonely_scheduler,
                    "--worker-timeout-s", WORKER_TIMEOUT_S, "--out", tmp_path / "out")
    _one_line(run, f"the Dask scheduler at {lonely_scheduler} has no worker",
              f"none joined within {WORKER_TIMEOUT_S:g} s")
    assert run.wall_s >= WORKER_TIMEOUT_S  # it waited as long as it was told
    assert run.cpu_s < PLAN_CPU_S and run.peak_mb <= PLAN_PEAK_MB, run


@pytest.mark.parametrize("kind", ["dangling", "loop"])
def test_out_as_a_link_to_nothing_is_one_line(tmp_path, kind):
    out = tmp_path / "out"
    if kind == "dangling":
        out.symlink_to(tmp_path / "nowhere")
        phrase = "a symbolic link to"
    else:
        out.symlink_to(tmp_path / "other")
        (tmp_path / "other").symlink_to(out)
        phrase = "a loop of symbolic links"
    run = _campaign("--days", "1", "--seeds", "1", "--workers", "1", "--out", out)
    _one_line(run, str(out), phrase)
    assert run.cpu_s < REFUSAL_CPU_S and run.peak_mb <= REFUSAL_PEAK_MB, run


@pytest.mark.parametrize("address, phrase", [
    ("ucx://127.0.0.1:8786", "the ucx:// comm is not supported here"),
    ("tls://127.0.0.1:8786", "tls:// needs Dask's TLS settings"),
    ("inproc://nowhere", "the inproc:// comm is not supported here"),
    ("", "is not host:port"),
])
def test_a_scheduler_address_the_campaign_cannot_use_is_one_line(tmp_path, address, phrase):
    run = _campaign("--days", "1", "--seeds", "1", "--scheduler", address, "--out", tmp_path / "out")
    _one_line(run, phrase)
    assert run.cpu_s < REFUSAL_CPU_S and run.peak_mb <= REFUSAL_PEAK_MB, run
