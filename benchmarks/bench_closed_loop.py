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
message and stepped one sample at a time, as the closed loop drives it. The follower's attitudes (the own
profile's, at the same times) are computed before the timing: only the sensor's work is timed.

Both pipelines are built first and kept alive; the span is cut into rounds that alternate (a) (b) (c) (a) (b) (c) …
((a) (b) (b1) (b2) (c) with ``--parts``, below), so a change of load hits both alike; each round's figures are
printed with the load average. Only the stepping is timed (building the pipelines is the same work in both). Before
the first round each job and the per-sample run are stepped once untimed (``--warmup`` ticks): the first steps load
the compiled sensing code and fill caches, which would otherwise land on whichever job runs first. The median of
the rounds' ratios is printed beside the ratio of the totals (a round caught by a burst of load moves the median
less). The last line of text is the ratio of (b)'s and (a)'s total times; before it, what (b) would cost with the
sensor's runtime at 1.5× the open loop's a sample (the follow path's target), everything else as measured, and
(b1)'s and (b2)'s totals against (a)'s with ``--parts``. Then the headline (README.md): (b)'s µs a tick, (a)'s
beside it (a part of the product: no ratio).

``--parts``: two more closed loops in the same rounds, to tell what the loop's messages cost by themselves from
what its computation costs: (b1) the controller's ``_step`` (the method a user replaces to write a controller of
their own) replaced by one that holds the attitude and publishes it as the real one does, so no plant, law or
pointing statistics; (b2) that, with the sensor's follow sensing replaced by its own attitude profile's block
path as well (the attitude then flown is the profile's, not the one followed: only the cost counts here). What
(b2) costs over (a) is the loop's round trip over ROS with the two inputs' intake: two more deliveries a tick
(``pmv/attitude`` to the controller, ``attitude/truth`` to the sensor) and their checks, one more pass of the
drain (the truth is published from a callback), one more node and two more subscriptions asked at each pass.

    .venv/bin/python benchmarks/bench_closed_loop.py [--orbits 0.2] [--rounds 10] [--samples 1024] [--warmup 100]
                                                     [--parts]
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

os.environ.setdefault("ROS_LOG_DIR", tempfile.mkdtemp(prefix="pmv_bench_log_"))
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "OFF"

import numpy as np  # noqa: E402
import yaml  # noqa: E402

from bench_main_job import RuntimeTimes  # noqa: E402  (this folder: the script's own)
from headline import headline  # noqa: E402  (this folder: the script's own)
from pmv_ros.nodes.pipeline import Pipeline  # noqa: E402
from pmv_ros.runtime.common.assembly import READ_CORRECTION  # noqa: E402
from pmv_ros.runtime.control.controller import TruthPublication  # noqa: E402
from pmv_ros.runtime.flight import flight_values  # noqa: E402
from pmv_ros.runtime.sensor.runtime import SensorRuntime  # noqa: E402

KONDOR = Path(__file__).resolve().parents[1] / "config" / "kondor.yaml"


def hold_the_plant(pipeline: Pipeline) -> None:
    """(b1): the controller's ``_step`` without its plant, law and pointing statistics — the attitude held, the
    step's time, count, truth and health kept and published as ``ControllerRuntime._step`` does. ``_step`` is
    the method the controller's documentation has a user replace to write a controller of their own: this is
    such a controller, one that does nothing (so it sets the runtime's step state as ``_step`` does)."""
    runtime = pipeline.controller.runtime

    def step() -> None:
        runtime._steps += 1
        runtime.time_s = t_s = runtime.origin_s + runtime._steps * runtime.settings.period_s
        runtime.counters["steps"] += 1
        runtime._out.published.append(TruthPublication(t_s, runtime.q, runtime.rate))
        runtime._report(t_s)

    runtime._step = step


def sense_at_own_cost(pipeline: Pipeline) -> None:
    """(b2)'s second part: the following sensor's samples from its own attitude profile's blocks of 512, at the
    same times (what the open loop's sensing costs a sample, in the closed loop's place)."""
    runtime = pipeline.sensor.runtime
    stream, period = runtime.stream, 1.0 / runtime.values["sensor.rate_hz"]
    stream.samples = lambda times, _: [stream.next_profile_sample(t_s, period, runtime.fast_time_block)
                                       for t_s in times]


class MainJob:
    """One main job (``closed_loop`` or not) kept alive between rounds: its pipeline stepped a chunk at a time;
    ``stubs``: functions that take parts of a closed loop out (``--parts``)."""

    def __init__(self, closed_loop: bool, stubs=()):
        self.closed_loop = closed_loop
        self.pipeline = Pipeline(KONDOR, closed_loop=closed_loop)
        for stub in stubs:
            stub(self.pipeline)
        nodes = [self.pipeline.sensor] + ([self.pipeline.controller] if closed_loop else [])
        self.times = RuntimeTimes(nodes)
        self.ticks = 0

    def run(self, ticks: int) -> dict:
        """Step ``ticks`` ticks: wall time, and the time inside the sensor's and the controller's runtimes."""
        before = dict(self.times.seconds)
        started = time.perf_counter()
        self.pipeline.step(ticks)
        wall_s = time.perf_counter() - started
        self.ticks += ticks
        if self.pipeline.sensor.samples_published != self.ticks:
            raise RuntimeError(f"the {'closed' if self.closed_loop else 'open'} loop published "
                               f"{self.pipeline.sensor.samples_published} of {self.ticks} samples")
        spent = {name: self.times.seconds[name] - before.get(name, 0.0) for name in self.times.seconds}
        return {"wall_s": wall_s, "sensor_s": spent.get("sensor_node", 0.0),
                "controller_s": spent.get("attitude_controller_node", 0.0)}

    def close(self) -> None:
        self.pipeline.close()


def sensor_per_sample(samples: int) -> dict:
    """µs a sample of the sensor runtime alone: own attitude (blocks of 512) and follow (one truth, one sample)."""
    values = flight_values(yaml.safe_load(KONDOR.read_text())).sensor
    own = SensorRuntime(values, clock_epoch_s=0.0, correction=READ_CORRECTION, stepped=True)
    follow = SensorRuntime(dict(values, **{"attitude.source": "follow"}), clock_epoch_s=0.0,
                           correction=READ_CORRECTION, stepped=True)
    period = 1.0 / values["sensor.rate_hz"]
    # The attitudes the own profile flies, fed to the follower one truth message ahead of each sample: made
    # before the timing (in the closed loop the controller makes them, and its time is counted as its own).
    times = follow.sim_time_s + period * np.arange(1, samples + 1)
    attitudes = [tuple(q) for q in own.stream.profile.quaternion(times).T.tolist()]
    started = time.perf_counter()
    for _ in range(samples):
        own.step()
    own_s = time.perf_counter() - started
    orbital = follow.frames.orbital
    started = time.perf_counter()
    for q_xyzw in attitudes:
        now = follow.sim_time_s
        follow.add_truth(orbital, now + period, q_xyzw, now)
        follow.step()
    follow_s = time.perf_counter() - started
    return {"own_us": own_s / samples * 1e6, "follow_us": follow_s / samples * 1e6}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--orbits", type=float, default=0.2, help="span of each main job (default 0.2 orbit)")
    parser.add_argument("--rounds", type=int, default=10, help="alternating rounds the span is cut into (default 10)")
    parser.add_argument("--samples", type=int, default=1024,
                        help="samples of each per-sample run (default 1024: whole blocks of the own-attitude path)")
    parser.add_argument("--warmup", type=int, default=100,
                        help="ticks each job is stepped untimed before the rounds (default 100)")
    parser.add_argument("--parts", action="store_true",
                        help="also the closed loop without the controller's physics, and without the follow "
                             "sensing's extra as well: what the loop's messages cost by themselves")
    args = parser.parse_args()
    open_job, closed_job = MainJob(closed_loop=False), MainJob(closed_loop=True)
    parts = {}  # name → the closed loop with parts taken out (--parts)
    if args.parts:
        parts["(b1), without the controller's plant, law and pointing"] = MainJob(True, (hold_the_plant,))
        parts["(b2), as (b1) with the follow sensing at the own path's cost"] = MainJob(
            True, (hold_the_plant, sense_at_own_cost))
    part_s = dict.fromkeys(parts, 0.0)
    try:
        if args.warmup > 0:
            open_job.run(args.warmup)
            closed_job.run(args.warmup)
            for job in parts.values():
                job.run(args.warmup)
            sensor_per_sample(min(args.samples, args.warmup))
        rate = open_job.pipeline.sensor.get_parameter("sensor.rate_hz").value
        ticks = max(args.rounds, round(args.orbits * open_job.pipeline.sensor.orbit.period_s * rate))
        chunk = ticks // args.rounds
        print(f"load average at the start: {os.getloadavg()[0]:.2f} (2-core machines vary 2–3× hour to hour: "
              "compare the ratios of one run)")
        print(f"main jobs: Kondor at {rate:g} Hz, {chunk * args.rounds} ticks each ({args.orbits:g} orbit), both built "
              f"first and stepped alternately, {chunk} ticks a round; per-sample runs: {args.samples} samples")
        rounds = []
        for round_number in range(1, args.rounds + 1):
            opened, closed = open_job.run(chunk), closed_job.run(chunk)
            for name, job in parts.items():
                part_s[name] += job.run(chunk)["wall_s"]
            per_sample = sensor_per_sample(args.samples)
            rounds.append((opened, closed, per_sample))
            print(f"round {round_number}: open loop {opened['wall_s'] / chunk * 1e6:.0f} µs/tick (sensor runtime "
                  f"{opened['sensor_s'] / chunk * 1e6:.0f}), closed loop {closed['wall_s'] / chunk * 1e6:.0f} µs/tick "
                  f"(sensor runtime {closed['sensor_s'] / chunk * 1e6:.0f}, controller runtime "
                  f"{closed['controller_s'] / chunk * 1e6:.0f}), ratio {closed['wall_s'] / opened['wall_s']:.2f}x; "
                  f"sensor alone per sample: own attitude {per_sample['own_us']:.0f} µs, follow "
                  f"{per_sample['follow_us']:.0f} µs (load {os.getloadavg()[0]:.2f})")
    finally:
        for job in (open_job, closed_job, *parts.values()):
            job.close()
    total = {key: sum(r[0][key] for r in rounds) for key in ("wall_s", "sensor_s")}
    closed_total = {key: sum(r[1][key] for r in rounds) for key in ("wall_s", "sensor_s", "controller_s")}
    own_us = statistics.median(r[2]["own_us"] for r in rounds)
    follow_us = statistics.median(r[2]["follow_us"] for r in rounds)
    n = chunk * args.rounds
    open_us, closed_us = total["wall_s"] / n * 1e6, closed_total["wall_s"] / n * 1e6
    open_rest = open_us - total["sensor_s"] / n * 1e6
    closed_rest = closed_us - closed_total["sensor_s"] / n * 1e6
    print(f"over all rounds: open loop {open_us:.0f} µs/tick, of which its sensor runtime "
          f"{total['sensor_s'] / n * 1e6:.0f}; closed loop {closed_us:.0f} µs/tick, of which its sensor runtime (the "
          f"follow path) {closed_total['sensor_s'] / n * 1e6:.0f} "
          f"({closed_total['sensor_s'] / closed_total['wall_s']:.0%})"
          f" and the controller's {closed_total['controller_s'] / n * 1e6:.0f}; everything else "
          f"{open_rest:.0f} against {closed_rest:.0f} µs/tick; load average at the end: {os.getloadavg()[0]:.2f}")
    print(f"sensor alone per sample, follow / own attitude: {follow_us / own_us:.2f}x ({follow_us:.0f} against "
          f"{own_us:.0f} µs, medians of the rounds)")
    # What the closed loop would cost with the follow path at 1.5× the own-attitude path's cost a sample (the
    # sensing target), everything else as measured.
    at_target = closed_rest + 1.5 * total["sensor_s"] / n * 1e6
    print(f"closed loop with the sensor's runtime at 1.5x the open loop's (estimate): {at_target / open_us:.2f}x "
          "the open loop")
    for name, seconds in part_s.items():
        print(f"closed loop {name}: {seconds / n * 1e6:.0f} µs/tick, {seconds / total['wall_s']:.2f}x the open loop")
    ratios = [r[1]["wall_s"] / r[0]["wall_s"] for r in rounds]
    print(f"closed loop / open loop: {closed_us / open_us:.2f}x (median of the rounds' ratios "
          f"{statistics.median(ratios):.2f}x)")
    headline("closed_loop", "the closed loop (pmv simulate --closed-loop), µs per tick", closed_us, "µs/tick",
             "lower", open_us, "µs/tick", "the open loop's tick, alternating in the same run")


if __name__ == "__main__":
    main()
