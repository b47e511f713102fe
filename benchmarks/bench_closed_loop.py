"""The closed-loop main job against the open-loop one, in one process and one run, alternating.

(a) Open loop: ``pmv simulate``'s pipeline (:class:`pmv_ros.nodes.pipeline.Pipeline`: sensor with its own
attitude profile, star tracker, monitor, report collector) on the Kondor preset at 10 Hz for ``--orbits``
(default 0.2) of an orbit.

(b) Closed loop: ``pmv simulate --closed-loop``'s pipeline on the same preset and span: the sensor in follow
mode, attitude_controller_node stepping the plant before each sample, the star tracker and the monitor as in
(a). Inside (b) the time spent in the sensor's runtime (its follow path: ``add_truth`` and ``step``) and in
the controller's runtime is taken (their public methods, outermost calls), so the share of the closed loop
that the sensor's follow path costs is printed beside the ratio.

(c) Per sample, the sensor alone (:class:`pmv_ros.runtime.sensor.runtime.SensorRuntime`, flight environment
on, Kondor): its own attitude profile stepped in fast time (blocks of 512) against follow mode fed one truth
message and stepped one sample at a time, as the closed loop drives it.

The rounds alternate (a) (b) (c) (a) (b) (c) …; each figure is the median of its rounds, each round's ratio is
printed with the load average. Only the stepping is timed (building the pipelines is the same work in both).
The last line is the ratio of the medians of (b) and (a).

    .venv/bin/python benchmarks/bench_closed_loop.py [--orbits 0.2] [--rounds 3] [--samples 600]
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from collections import Counter
from pathlib import Path

os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="pmv_bench_log_"))
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "OFF"

import yaml  # noqa: E402

from pmv_ros.nodes.pipeline import Pipeline  # noqa: E402
from pmv_ros.runtime.common.assembly import READ_CORRECTION  # noqa: E402
from pmv_ros.runtime.flight import flight_values  # noqa: E402
from pmv_ros.runtime.sensor.runtime import SensorRuntime  # noqa: E402

KONDOR = Path(__file__).resolve().parents[1] / "config" / "kondor.yaml"


class RuntimeTimes:
    """While installed on nodes: wall time inside each node's runtime (its public methods, outermost calls)."""

    def __init__(self, nodes):
        self.seconds = Counter()
        self._depth = [0]
        for node in nodes:
            runtime = node.runtime
            for name in dir(type(runtime)):
                if not name.startswith("_") and callable(getattr(type(runtime), name, None)):
                    setattr(runtime, name, self._timed(getattr(runtime, name), node.get_name()))

    def _timed(self, method, owner: str):
        depth, seconds, clock = self._depth, self.seconds, time.perf_counter

        def timed(*arguments, **keywords):
            if depth[0]:
                return method(*arguments, **keywords)
            depth[0] = 1
            started = clock()
            try:
                return method(*arguments, **keywords)
            finally:
                seconds[owner] += clock() - started
                depth[0] = 0

        return timed


def main_job(ticks: int, closed_loop: bool) -> dict:
    """One run of the main job (``closed_loop`` or not): stepping wall time, and the runtimes' share."""
    with Pipeline(KONDOR, closed_loop=closed_loop) as pipeline:
        times = RuntimeTimes([pipeline.sensor] + ([pipeline.controller] if closed_loop else []))
        started = time.perf_counter()
        pipeline.step(ticks)
        wall_s = time.perf_counter() - started
        published = pipeline.sensor.samples_published
    if published != ticks:
        raise RuntimeError(f"the {'closed' if closed_loop else 'open'} loop published {published} of {ticks} samples")
    return {"wall_s": wall_s, "sensor_s": times.seconds["sensor_node"],
            "controller_s": times.seconds["attitude_controller_node"]}


def sensor_per_sample(samples: int) -> dict:
    """µs a sample of the sensor runtime alone: own attitude (blocks of 512) and follow (one truth, one sample)."""
    values = flight_values(yaml.safe_load(KONDOR.read_text())).sensor
    own = SensorRuntime(values, clock_epoch_s=0.0, correction=READ_CORRECTION, stepped=True)
    follow = SensorRuntime(dict(values, **{"attitude.source": "follow"}), clock_epoch_s=0.0,
                           correction=READ_CORRECTION, stepped=True)
    period = 1.0 / values["sensor.rate_hz"]
    # The attitudes the own profile flies, fed to the follower one truth message ahead of each sample.
    profile = own.stream.profile
    started = time.perf_counter()
    for _ in range(samples):
        own.step()
    own_s = time.perf_counter() - started
    orbital = follow.frames.orbital
    started = time.perf_counter()
    for _ in range(samples):
        now = follow.sim_time_s
        follow.add_truth(orbital, now + period, tuple(profile.quaternion(now + period)), now)
        follow.step()
    follow_s = time.perf_counter() - started
    return {"own_us": own_s / samples * 1e6, "follow_us": follow_s / samples * 1e6}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--orbits", type=float, default=0.2, help="span of each main-job run (default 0.2 orbit)")
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds (default 3)")
    parser.add_argument("--samples", type=int, default=600, help="samples of each per-sample run (default 600)")
    args = parser.parse_args()
    with Pipeline(KONDOR) as pipeline:
        rate = pipeline.sensor.get_parameter("sensor.rate_hz").value
        ticks = max(1, round(args.orbits * pipeline.sensor.orbit.period_s * rate))
    print(f"load average at the start: {os.getloadavg()[0]:.2f} (2-core machines vary 2–3× hour to hour: "
          "compare the ratios of one run)")
    print(f"main job: Kondor, {ticks} ticks at {rate:g} Hz ({args.orbits:g} orbit); per-sample runs: {args.samples} "
          "samples")
    opens, closeds, shares, controls, owns, follows = [], [], [], [], [], []
    for round_number in range(1, args.rounds + 1):
        open_loop = main_job(ticks, closed_loop=False)
        closed_loop = main_job(ticks, closed_loop=True)
        per_sample = sensor_per_sample(args.samples)
        opens.append(open_loop["wall_s"])
        closeds.append(closed_loop["wall_s"])
        shares.append(closed_loop["sensor_s"] / closed_loop["wall_s"])
        controls.append(closed_loop["controller_s"] / closed_loop["wall_s"])
        owns.append(per_sample["own_us"])
        follows.append(per_sample["follow_us"])
        print(f"round {round_number}: open loop {open_loop['wall_s']:.2f} s "
              f"({open_loop['wall_s'] / ticks * 1e6:.0f} µs/tick), closed loop {closed_loop['wall_s']:.2f} s "
              f"({closed_loop['wall_s'] / ticks * 1e6:.0f} µs/tick; sensor runtime {shares[-1]:.0%}, controller "
              f"runtime {controls[-1]:.0%}), ratio {closed_loop['wall_s'] / open_loop['wall_s']:.2f}x; sensor per "
              f"sample: own attitude {per_sample['own_us']:.0f} µs, follow {per_sample['follow_us']:.0f} µs "
              f"({per_sample['follow_us'] / per_sample['own_us']:.1f}x) (load {os.getloadavg()[0]:.2f})")
    open_s, closed_s = statistics.median(opens), statistics.median(closeds)
    own_us, follow_us = statistics.median(owns), statistics.median(follows)
    share = statistics.median(shares)
    print(f"medians: open loop {open_s / ticks * 1e6:.0f} µs/tick, closed loop {closed_s / ticks * 1e6:.0f} µs/tick, "
          f"of which the sensor's runtime (its follow path) {share:.0%} and the controller's "
          f"{statistics.median(controls):.0%}; load average at the end: {os.getloadavg()[0]:.2f}")
    print(f"sensor per sample, follow / own attitude: {follow_us / own_us:.2f}x ({follow_us:.0f} against "
          f"{own_us:.0f} µs)")
    # What the closed loop would cost if the follow path cost what the own-attitude path costs a sample.
    cheap_s = closed_s - share * closed_s + ticks * own_us * 1e-6
    print(f"closed loop with the follow path at the own-attitude cost (estimate): "
          f"{cheap_s / open_s:.2f}x the open loop")
    print(f"closed loop / open loop: {closed_s / open_s:.2f}x")


if __name__ == "__main__":
    main()
