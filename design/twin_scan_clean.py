"""What the error monitor's array scan of a clean batch buys: the one twin the monitor keeps.

The twin: :func:`pmv_ros.runtime.monitor.scan.scan_clean` validates a whole clean batch on arrays (a campaign's
flight: an orbit of samples in one call), where :class:`pmv_ros.runtime.monitor.scan.EventScan` — the general
path, clock jumps and bad stamps included — validates any input one event at a time. Both give the same
verdicts, counters and timelines
(``tests/runtime/test_monitor.py::test_the_array_scan_of_a_clean_batch_is_the_event_scan``).

This script measures, in one run:

* the campaign: ``pmv campaign``'s task on one worker (:func:`pmv_ros.apps.campaign.results.run_task`: the
  flight through the nodes' runtimes and its table; no Dask, whose overhead would only lower the share) on the
  Meteor-M No.2 preset at 10 Hz, with the array scan and with every batch sent through the event scan
  (``scan_clean`` declining, as it does for a batch that is not clean), alternating round by round; the
  figure is how much longer the tasks take without it, in CPU time of this process (another job's load moves
  it less than wall time; wall time is printed beside it);
* the main job: how many inputs of ``pmv simulate``'s pipeline the array scan takes (a node's messages come
  with their order and always go event by event, so none: its gain there is nil by construction).

    .venv/bin/python design/twin_scan_clean.py [--rounds 3] [--tasks 4] [--orbits 0.25] [--main-orbits 0.02]

Prints each round's figures, the load average, and the median share.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="pmv_design_log_"))
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "OFF"

import yaml  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from pmv_ros.apps import campaign  # noqa: E402
from pmv_ros.apps.campaign.results import run_task  # noqa: E402
from pmv_ros.runtime.monitor import core  # noqa: E402

METEOR = REPO / "config" / "meteor_m2.yaml"
KONDOR = REPO / "config" / "kondor.yaml"


@contextlib.contextmanager
def event_scan_only():
    """Every batch through the event scan: the array scan declines, as for a batch that is not clean."""
    original = core.scan_clean
    core.scan_clean = lambda monitor, feed: None
    try:
        yield
    finally:
        core.scan_clean = original


@contextlib.contextmanager
def counting_array_scans(counts: list):
    """Count the inputs the array scan takes (a segment returned)."""
    original = core.scan_clean

    def counted(monitor, feed):
        segment = original(monitor, feed)
        counts.append(segment is not None)
        return segment

    core.scan_clean = counted
    try:
        yield
    finally:
        core.scan_clean = original


def campaign_tasks(tasks: int, orbits: float) -> tuple[float, float, int]:
    """CPU s, wall s and samples of ``tasks`` campaign tasks run one after the other in this process."""
    settings = campaign.Settings(yaml.safe_load(METEOR.read_text()), "2024-01-15T00:00:00Z", 10.0, orbits)
    cpu, wall, samples = time.process_time(), time.perf_counter(), 0
    for k in range(tasks):
        table, _ = run_task(settings, campaign.Task(day=1 + 30 * k, seed=k))
        samples += table.num_rows
    return time.process_time() - cpu, time.perf_counter() - wall, samples


def main_job_array_scans(orbits: float) -> tuple[int, int]:
    """(inputs the monitor took, of them by the array scan) in ``orbits`` of ``pmv simulate``'s pipeline."""
    from pmv_ros.nodes.pipeline import Pipeline

    counts = []
    with counting_array_scans(counts), Pipeline(KONDOR, {}) as pipeline:
        rate = pipeline.sensor.get_parameter("sensor.rate_hz").value
        pipeline.step(max(1, round(orbits * pipeline.sensor.orbit.period_s * rate)))
        pipeline.drain()
        inputs = pipeline.monitor.monitor.counters["sensor_received"]
    return inputs, sum(counts)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--tasks", type=int, default=4, help="campaign tasks per measurement (default 4)")
    parser.add_argument("--orbits", type=float, default=0.25, help="orbits per task (default 0.25)")
    parser.add_argument("--main-orbits", type=float, default=0.02, help="orbits of the main job (default 0.02)")
    args = parser.parse_args(argv)

    loads = [os.getloadavg()[0]]
    campaign_tasks(1, 0.02)  # imports and caches, outside the rounds
    rounds = []
    for index in range(args.rounds):
        order = (False, True) if index % 2 == 0 else (True, False)
        figures = {}
        for without in order:
            with event_scan_only() if without else contextlib.nullcontext():
                figures[without] = campaign_tasks(args.tasks, args.orbits)
        (cpu_with, wall_with, samples), (cpu_without, wall_without, _) = figures[False], figures[True]
        rounds.append((cpu_without / cpu_with - 1.0, wall_without / wall_with - 1.0))
        loads.append(os.getloadavg()[0])
        print(f"round {index + 1}: {args.tasks} tasks, {samples} samples: with the array scan {cpu_with:.2f} s CPU "
              f"({wall_with:.2f} s wall), event scan only {cpu_without:.2f} s CPU ({wall_without:.2f} s wall): "
              f"{100 * rounds[-1][0]:+.0f} % CPU, {100 * rounds[-1][1]:+.0f} % wall; load {loads[-1]:.1f}")
    inputs, taken = main_job_array_scans(args.main_orbits)
    print(f"main job ({args.main_orbits:g} orbit): {taken} of the monitor's inputs ({inputs} sensor samples) "
          "taken by the array scan: its gain there is nil")
    cpu = statistics.median(share for share, _ in rounds)
    wall = statistics.median(share for _, share in rounds)
    print(f"campaign without the array scan: {100 * cpu:+.0f} % CPU time, {100 * wall:+.0f} % wall time (median of "
          f"{args.rounds} rounds; load average {', '.join(f'{load:.1f}' for load in loads)} on {os.cpu_count()} CPUs)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
