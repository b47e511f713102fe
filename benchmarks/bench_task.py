#!/usr/bin/env python3
"""A campaign task's samples per CPU second: this tree against another, in one run, alternating.

What one Dask worker of ``pmv campaign`` does with a task, without Dask: :func:`pmv_ros.apps.campaign.run_task`
(the flight's parameters, the sensor in its blocks, the star tracker's frames, the monitor, the result table),
on Meteor-M No.2 with its flight environment, at each of ``--rates-hz``. A task is ``--orbits`` orbits at 10 Hz
and ten times as many at 1 Hz (the same samples; ``pmv campaign`` flies a year in long tasks), each a day and
seed of its own.

Each round starts a child process per tree — this one with this tree's ``.venv``, the baseline with its own
``.venv/bin/python`` and ``PYTHONPATH=DIR`` — and the two alternate, so a change of load hits both alike. A child
flies one task untimed (the compiled kernels and the tables are loaded then), then ``--tasks`` tasks timed by
its own CPU time, which a neighbour's load moves much less than wall time. Printed: each round's rates and
ratio with the load average, then per rate the median of the rounds' ratios (this tree over the baseline: ≥ 1
means as fast), and the headline: the slowest rate's median, in samples per CPU second, against the baseline's.
Without ``--baseline`` it cannot run: one line says so (``make bench`` lists it as not run here).

``--closed-loop``: both trees fly ``pmv campaign --closed-loop``'s tasks (the sensor following the plant of
``attitude_controller_node``, stepped at its control rate; the baseline must have the closed loop too), and this
tree's child also flies the same tasks open loop after them, so each round prints what the closing costs here.

    .venv/bin/python benchmarks/bench_task.py --baseline DIR [--rounds 3] [--tasks 3] [--rates-hz 10,1]
        [--orbits 1] [--closed-loop]
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_name] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import yaml  # noqa: E402
from headline import headline  # noqa: E402  (this folder: the script's own)

HERE = Path(__file__).resolve().parents[1]
PRESET = "meteor_m2"
EPOCH_UTC = "2024-01-15T00:00:00Z"


def fly_tasks(tree: Path, rate_hz: float, orbits: float, tasks: int, closed_loop: bool = False) -> dict:
    """Samples and CPU seconds of ``tasks`` campaign tasks of ``tree`` (imported from PYTHONPATH), after one untimed;
    ``closed_loop``: the tasks closed-loop (and then the same ones open loop, timed apart: ``open_cpu_s``)."""
    from pmv_ros.apps import campaign

    document = yaml.safe_load((tree / "config" / f"{PRESET}.yaml").read_text())
    modes = [{"closed_loop": True}, {}] if closed_loop else [{}]  # a tree without the closed loop: no keyword
    result = {}
    for mode in modes:
        settings = campaign.Settings(document, EPOCH_UTC, rate_hz, orbits, **mode)
        campaign.run_task(settings, campaign.Task(1, 0))
        samples, start = 0, time.process_time()
        for k in range(tasks):
            table, _ = campaign.run_task(settings, campaign.Task(2 + k, 1 + k))
            samples += table.num_rows
        result.setdefault("samples", samples)
        result["cpu_s" if "cpu_s" not in result else "open_cpu_s"] = time.process_time() - start
    return result


def child(python: str, tree: Path, rate_hz: float, orbits: float, tasks: int, closed_loop: bool,
          with_open: bool = False) -> tuple[float, float | None]:
    """Samples per CPU second of a child process flying ``tree``'s tasks (closed-loop ones with ``closed_loop``),
    and with ``with_open`` those of the same tasks flown open loop after them (else None)."""
    command = [python, __file__, "--child", str(tree), "--rates-hz", str(rate_hz), "--orbits", str(orbits),
               "--tasks", str(tasks)] + (["--closed-loop"] if closed_loop else [])
    done = subprocess.run(command, env=dict(os.environ, PYTHONPATH=str(tree)), cwd=tree, capture_output=True,
                          text=True, timeout=1800)
    if done.returncode:
        raise SystemExit(f"{tree}: the child failed:\n{done.stderr[-3000:]}")
    result = json.loads(done.stdout.strip().splitlines()[-1])
    opened = result["samples"] / result["open_cpu_s"] if with_open and "open_cpu_s" in result else None
    return result["samples"] / result["cpu_s"], opened


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, help="another checkout with its own .venv")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--tasks", type=int, default=3, help="timed tasks per child (default 3)")
    parser.add_argument("--rates-hz", default="10,1", help="sensor rates, comma-separated (default 10,1)")
    parser.add_argument("--orbits", type=float, default=1.0, help="orbits per task at 10 Hz (default 1)")
    parser.add_argument("--closed-loop", action="store_true",
                        help="closed-loop tasks in both trees (and open-loop ones in this tree's child)")
    parser.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    rates = [float(rate) for rate in args.rates_hz.split(",")]
    if args.child is not None:
        print(json.dumps(fly_tasks(args.child, rates[0], args.orbits, args.tasks, args.closed_loop)))
        return
    if args.baseline is None:
        raise SystemExit("bench_task: needs --baseline DIR, another checkout with its own .venv to measure against")
    baseline = args.baseline.resolve()
    python = str(baseline / ".venv" / "bin" / "python")
    closed = args.closed_loop
    print(f"Meteor-M No.2, flight environment, {'closed-loop ' if closed else ''}{args.tasks} tasks a child; load "
          f"average at start: {os.getloadavg()[0]:.2f}")
    medians, rates_of = {}, {}
    for rate in rates:
        orbits = args.orbits * 10.0 / rate  # the samples of a 10 Hz task at any rate
        ratios, rates_of[rate] = [], ([], [])
        for round_number in range(1, args.rounds + 1):
            mine, opened = child(sys.executable, HERE, rate, orbits, args.tasks, closed, with_open=closed)
            theirs, _ = child(python, baseline, rate, orbits, args.tasks, closed)
            ratios.append(mine / theirs)
            rates_of[rate][0].append(mine)
            rates_of[rate][1].append(theirs)
            here = f"; open loop in this tree {opened:,.0f}, closed / open {opened / mine:.2f}x the CPU time" \
                if opened is not None else ""
            print(f"{rate:g} Hz round {round_number}: this tree {mine:,.0f}, baseline {theirs:,.0f} samples per CPU "
                  f"second: {mine / theirs:.2f}x{here} (load {os.getloadavg()[0]:.2f})")
        medians[rate] = statistics.median(ratios)
        print(f"{rate:g} Hz: this tree / baseline {medians[rate]:.2f}x (median of {args.rounds} rounds, "
              f"{min(ratios):.2f}–{max(ratios):.2f})")
    print("this tree / baseline: " + ", ".join(f"{rate:g} Hz {ratio:.2f}x" for rate, ratio in medians.items()))
    slowest = min(rates)
    mine, theirs = (statistics.median(values) for values in rates_of[slowest])
    kind = "closed-loop campaign task" if closed else "campaign task"
    headline("closed_task" if closed else "task", f"a {kind} at {slowest:g} Hz, samples per CPU second", mine,
             "samples/CPU s", "higher", theirs, "samples/CPU s", f"the same tasks in {baseline.name}",
             ratio=medians[slowest])


if __name__ == "__main__":
    main()
