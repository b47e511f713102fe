"""Running a campaign's tasks on Dask: an embedded LocalCluster or a user's scheduler, each finished task
written as it arrives."""

from __future__ import annotations

import itertools
import time
from pathlib import Path


from .results import run_task, stale_results, task_path, write_result
from .tasks import Settings, Task


# ------------------------------------------------------------------------ running on Dask

#: Environment of the embedded cluster's worker processes: one BLAS/OpenMP thread each, and glibc's own
#: malloc thresholds. Dask's default also sets MALLOC_TRIM_THRESHOLD_ = 65536, which fixes the mmap
#: threshold at 128 kB: the sensor model's temporaries are then mapped and unmapped on every call and
#: a task takes ≈ 1.6× longer (42 against 25 µs a sample on a 2-core machine).
WORKER_ENVIRONMENT = {"OMP_NUM_THREADS": 1, "MKL_NUM_THREADS": 1, "OPENBLAS_NUM_THREADS": 1}

#: Dask's diagnostics in the embedded cluster, for a dashboard nobody opens here: the workers' statistical
#: profiler off (it samples each worker's stack every 10 ms: ≈ 11 % of a 1 Hz campaign's CPU time, all
#: processes, 6 tasks of 2.5 orbits on 2 workers: 44–46 against 50–51 µs a sample), and the system monitor
#: and the event-loop watchdog every second or more instead of every 0.5 s and 20 ms (the client's process,
#: which runs the scheduler: ≈ 2 against ≈ 3.5 µs a sample), on a 2-core machine.
QUIET_DIAGNOSTICS = {"distributed.worker.profile.enabled": False,
                     "distributed.admin.system-monitor.interval": "5s",
                     "distributed.admin.tick.interval": "1s"}


#: How long a campaign waits for the scheduler of ``--scheduler`` to answer, s (read when the client is opened).
SCHEDULER_TIMEOUT_S = 10.0

#: How long a campaign waits for the cluster's first worker, s (``pmv campaign --worker-timeout-s``): a scheduler
#: with no worker would otherwise hold the campaign at 0 % for ever. The embedded cluster's workers start in
#: a few seconds; a user's cluster may be starting its workers beside the campaign.
WORKER_TIMEOUT_S = 60.0

#: Tasks on the cluster at once, per worker thread: the next are submitted as these finish, so the client and
#: the scheduler hold a bounded window of tasks whatever the plan's size, and every worker has one queued.
TASKS_PER_WORKER = 2


#: Address schemes a campaign connects to: Dask's TCP, TLS and websocket comms (UCX and in-process are not for a
#: scheduler of another process started by a user).
SCHEDULER_SCHEMES = ("tcp", "tls", "ws", "wss")


def check_scheduler_address(address: str) -> str:
    """``address`` if it is a Dask scheduler address a campaign can connect to; ValueError (one line) if not.

    ``host:port`` or ``scheme://host:port`` with a scheme of
    :data:`SCHEDULER_SCHEMES`; tls:// and wss:// only where Dask's TLS
    settings give the client a certificate context (without one, distributed
    fails inside its connector, not with a message).
    """
    from distributed.comm.addressing import parse_address
    from distributed.security import Security

    try:
        scheme, location = parse_address(str(address), strict=False)
    except ValueError as error:
        raise ValueError(f"scheduler address {address!r} is not a Dask address ({error})") from None
    if scheme not in SCHEDULER_SCHEMES:
        raise ValueError(f"scheduler address {address!r}: the {scheme}:// comm is not supported here (one of "
                         + ", ".join(f"{name}://" for name in SCHEDULER_SCHEMES) + ")")
    host, _, port = location.rpartition(":")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ValueError(f"scheduler address {address!r} is not host:port (e.g. tcp://127.0.0.1:8786)")
    if scheme in ("tls", "wss") and Security().get_connection_args("client").get("ssl_context") is None:
        raise ValueError(f"scheduler address {address!r}: {scheme}:// needs Dask's TLS settings "
                         "(distributed.comm.tls.ca-file, .client.cert and .client.key in the Dask configuration)")
    return str(address)


def open_client(scheduler: str | None, workers: int, timeout_s: float | None = None):
    """A Dask client: on the scheduler at ``scheduler``, or on an embedded LocalCluster of ``workers`` processes.

    The embedded cluster runs one thread per worker process, no dashboard, few
    diagnostics (:data:`QUIET_DIAGNOSTICS`), and reschedules a task whose worker
    died (``allowed-failures``).
    Returns ``(client, cluster or None)``; ValueError naming the address if
    it is not one (:func:`check_scheduler_address`) or the scheduler cannot
    be reached within ``timeout_s`` (default :data:`SCHEDULER_TIMEOUT_S`).
    """
    import logging

    import dask
    from distributed import Client, LocalCluster

    if scheduler is not None:
        timeout_s = SCHEDULER_TIMEOUT_S if timeout_s is None else timeout_s
        return _connect(check_scheduler_address(scheduler), timeout_s), None
    with dask.config.set({"distributed.scheduler.allowed-failures": 3,
                          "distributed.nanny.pre-spawn-environ": WORKER_ENVIRONMENT, **QUIET_DIAGNOSTICS}):
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


def wait_for_a_worker(client, where: str, timeout_s: float = WORKER_TIMEOUT_S) -> None:
    """Return once the cluster has a worker; ValueError (one line) if none joined within ``timeout_s``.

    Dask's own wait (``Client.wait_for_workers``) with its own timeout.
    """
    try:
        client.wait_for_workers(1, timeout=timeout_s)
    except TimeoutError:
        raise ValueError(f"the Dask scheduler at {where} has no worker: none joined within {timeout_s:g} s (start one "
                         f"with `dask worker {where}`, or give --worker-timeout-s)") from None


def _window(client) -> int:
    """How many tasks to keep on the cluster: :data:`TASKS_PER_WORKER` per worker thread it has now."""
    return TASKS_PER_WORKER * max(1, sum(client.nthreads().values()))


def run_campaign(settings: Settings, tasks: list[Task], out: Path, *, scheduler: str | None = None,
                 workers: int = 2, progress: bool = True, client=None,
                 worker_timeout_s: float = WORKER_TIMEOUT_S) -> dict:
    """Run the tasks not yet done on Dask, writing each result as it arrives; returns what ran.

    ``client``: a Dask client to use (and leave open) instead of opening one
    from ``scheduler``/``workers``. The cluster must have a worker within
    ``worker_timeout_s``; tasks are submitted as earlier ones finish, a
    bounded window at a time (:data:`TASKS_PER_WORKER`). A task that killed
    its worker more often than the scheduler allows, or that the scheduler
    lost, is a ValueError naming it. Returns ``{"ran": n, "skipped": m,
    "wall_s": s, "compute_s": s, "samples": n}``.
    """
    from concurrent.futures import CancelledError

    from distributed import as_completed
    from distributed.scheduler import KilledWorker
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
        wait_for_a_worker(client, scheduler or "the embedded cluster", worker_timeout_s)
        waiting = iter(todo)
        futures = {}

        def submit(count: int):
            for task in itertools.islice(waiting, count):
                future = client.submit(run_task, settings, task, key=f"pmv-campaign-{task.name}", pure=False)
                futures[future] = task
                yield future

        running = as_completed(list(submit(_window(client))))
        with tqdm(total=len(todo), unit="task", disable=not progress, dynamic_ncols=True,
                  desc=f"campaign: {len(todo)} of {len(tasks)} tasks to run") as bar:
            for future in running:
                task = futures.pop(future)
                try:
                    table, compute_s = future.result()
                except KilledWorker:
                    raise ValueError(f"task {task.name} ended its worker process more often than the scheduler "
                                     "allows (allowed-failures): out of memory on the worker?") from None
                except CancelledError:
                    raise ValueError(f"task {task.name} was cancelled by the Dask scheduler at "
                                     f"{scheduler or 'the embedded cluster'} (did it restart or stop?)") from None
                write_result(out, task, table)
                future.release()
                report["ran"] += 1
                report["compute_s"] += compute_s
                report["samples"] += table.num_rows
                bar.update(1)
                for queued in submit(max(0, _window(client) - len(futures))):
                    running.add(queued)
    finally:
        if own:
            client.close()
        if cluster is not None:
            cluster.close()
    report["wall_s"] = time.perf_counter() - started
    return report
