#!/usr/bin/env python3
"""Per sample: follow mode (one truth message → one sample) against the own attitude (blocks of 512), in one run.

Both through :class:`~pmv_ros.runtime.sensor.runtime.SensorRuntime` in fast time, stepped, as ``pmv simulate``
steps it, for the Kondor and Meteor-M No.2 presets (flight environment on, the Sun and Moon check on):

* ``own attitude`` — the preset's own attitude profile: ``step()`` per sample, the stream computing blocks of
  512 samples ahead;
* ``follow`` — ``attitude.source: follow``: per sample one ``add_truth`` (the own run's attitude at that
  sample's time) and one ``step()``, which senses that one sample.

Each round builds both runtimes afresh (so the caches of the orbit's and the fields' nodes start empty in both)
and flies ``--samples`` samples in each; rounds alternate the two, A B A B, and each figure is the median of its
rounds in CPU time of this process (on a shared machine wall time measures the neighbours). The numba kernels
are loaded (or compiled) once, before the first round.

``--baseline DIR`` also measures the own attitude in another tree (its ``.venv/bin/python`` with ``PYTHONPATH=DIR``,
this script run there with ``--own-only``), alternating a child of this tree with a child of that one.

    .venv/bin/python benchmarks/bench_sensing.py [--rounds 5] [--samples 1024] [--baseline DIR]

Last line of text: ``follow / own attitude: N.NNx`` (the larger of the two presets'); then the headline
(README.md): that preset's follow mode, µs a sample, its own attitude beside it (a part of the product: no ratio).
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

PRESETS = ("kondor", "meteor_m2")


def sensor_values(tree: Path, preset: str, **overrides) -> dict:
    """The sensor node's values of a preset of ``tree``, in fast time (as ``pmv simulate`` sets them)."""
    from pmv_ros.runtime.common import parameters
    from pmv_ros.runtime.common.assembly import SENSOR_PARAMS

    document = yaml.safe_load((tree / "config" / f"{preset}.yaml").read_text())
    return parameters.preset_values(document, "sensor_node", SENSOR_PARAMS, {"sim.fast_time": True, **overrides})


def runtime(values: dict):
    from pmv_ros.runtime.common.assembly import read_correction
    from pmv_ros.runtime.sensor.runtime import SensorRuntime

    return SensorRuntime(values, clock_epoch_s=0.0, correction=read_correction(values), stepped=True)


def own_attitude(values: dict, samples: int):
    """CPU seconds per sample of the own attitude, and the (stamp, q) of its samples."""
    sensor = runtime(values)
    truth = []
    start = time.process_time()
    for _ in range(samples):
        for sample in sensor.step().samples:
            truth.append((sample.t_s, sample.q_xyzw))
    return (time.process_time() - start) / samples, truth


def follow(values: dict, truth: list) -> float:
    """CPU seconds per sample in follow mode: one truth message, one step, one sample."""
    sensor = runtime(dict(values, **{"attitude.source": "follow"}))
    frame = sensor.frames.orbital
    published = 0
    start = time.process_time()
    for t_s, q in truth:
        sensor.add_truth(frame, t_s, q, t_s)
        published += len(sensor.step().samples)
    elapsed = time.process_time() - start
    if published != len(truth):
        raise RuntimeError(f"follow mode published {published} of {len(truth)} samples")
    return elapsed / len(truth)


def own_only(tree: Path, samples: int) -> dict:
    """Per-sample CPU seconds of the own attitude for each preset (one round), for a parent process."""
    return {preset: own_attitude(sensor_values(tree, preset), samples)[0] for preset in PRESETS}


def child(python: str, tree: Path, samples: int) -> dict:
    environment = dict(os.environ, PYTHONPATH=str(tree))
    result = subprocess.run([python, __file__, "--own-only", "--tree", str(tree), "--samples", str(samples)],
                            env=environment, cwd=tree, capture_output=True, text=True, check=True)
    return json.loads(result.stdout.strip().splitlines()[-1])


def load_average() -> str:
    try:
        return " ".join(Path("/proc/loadavg").read_text().split()[:3])
    except OSError:
        return "n/a"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--samples", type=int, default=1024, help="samples per case and round")
    parser.add_argument("--baseline", type=Path, help="another tree to measure the own attitude against")
    parser.add_argument("--own-only", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--tree", type=Path, default=Path(__file__).resolve().parents[1], help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.own_only:
        own_attitude(sensor_values(args.tree, PRESETS[0]), 16)  # load the kernels before timing
        print(json.dumps(own_only(args.tree, args.samples)))
        return

    tree = Path(__file__).resolve().parents[1]
    print(f"load average at start: {load_average()}")
    per_sample = {}  # preset → (own, follow) CPU s a sample
    for preset in PRESETS:
        values = sensor_values(tree, preset)
        own_attitude(values, 16)  # load the kernels (and the tables) before timing
        own_s, follow_s = [], []
        for _ in range(args.rounds):
            seconds, truth = own_attitude(values, args.samples)
            own_s.append(seconds)
            follow_s.append(follow(values, truth))
        own, followed = statistics.median(own_s), statistics.median(follow_s)
        per_sample[preset] = own, followed
        print(f"{preset:10s} own attitude {own * 1e6:7.1f} µs/sample, follow {followed * 1e6:7.1f} µs/sample: "
              f"{followed / own:.2f}x")
    if args.baseline is not None:
        baseline = args.baseline.resolve()
        python = str(baseline / ".venv" / "bin" / "python")
        mine, theirs = {p: [] for p in PRESETS}, {p: [] for p in PRESETS}
        for _ in range(args.rounds):
            for preset, seconds in child(sys.executable, tree, args.samples).items():
                mine[preset].append(seconds)
            for preset, seconds in child(python, baseline, args.samples).items():
                theirs[preset].append(seconds)
        for preset in PRESETS:
            a, b = statistics.median(mine[preset]), statistics.median(theirs[preset])
            print(f"{preset:10s} own attitude: this tree {a * 1e6:7.1f} µs/sample, baseline {b * 1e6:7.1f} µs/sample: "
                  f"{a / b:.2f}x")
    print(f"load average at end: {load_average()}")
    worst = max(per_sample, key=lambda preset: per_sample[preset][1] / per_sample[preset][0])
    own, followed = per_sample[worst]
    print(f"follow / own attitude: {followed / own:.2f}x")
    headline("follow_sample", f"the sensor in follow mode ({worst}), µs per sample", followed * 1e6, "µs/sample",
             "lower", own * 1e6, "µs/sample", "the own attitude's sample, alternating in the same run")


if __name__ == "__main__":
    main()
