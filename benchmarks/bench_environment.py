"""The flight environment's cost in the instrument, measured in one run (target: ≤ 1.2× the uniform instrument).

The instrument is a preset's sensor model (``--preset``, default meteor_m2: its calibrated flight
environment) as the sensor node and a campaign fly it: blocks of 512 samples (the node's fast-time block) at
the node's rate, zero attitude, the Sun/Moon exclusion off (it is not the environment). Two models in one
process: ``radiance.source: uniform`` (one disc radiance, one window height) and ``environment``
(climatology and weather as a horizon level per chord, the window-layer height at the horizon point; every
field in float64). They alternate over ``--rounds`` rounds and each keeps its best (a busy neighbour slows
whichever it overlaps); the ratio is given from the best wall times, from the best CPU times of this process
(another job's load moves those less), and per round. The load average is printed with them.

Rates: 10 Hz (the node's, the target) and 1 Hz (a campaign's year is flown at 1 Hz: the fields cost the
same per orbit at any rate, the chain's cost scales with the rate, so the environment weighs more there).

Each round flies a fresh instrument through ``--blocks`` consecutive blocks, as a node's stream does: the
environment's random fields are evaluated on their grid along the horizon as the samples reach new nodes
(pmv_ros/physics/instrument/horizon_fields.py), which is most of what the environment costs. Also printed:

* real time against fast time — the same instants of the same preset and seed on a clock that reads
  1.76·10⁹ s at the start and on one that reads 0: the largest difference of the sensed angles, arcmin
  (physics.md §3.2 item 6: ≤ 10⁻⁶′);
* ``--profile N``: the top N functions by own time of a fresh environment instrument flying the same
  blocks, from cProfile (the compiled pass is one entry; the fields' node evaluations,
  ``HorizonFields.fill``, are what the environment adds outside it);
* ``--points``: the fields' throughput per point (``RadianceEnvironment.sample``), the former table of
  this benchmark (issue 5's budget of 160,000 points/s).

Run: ``.venv/bin/python benchmarks/bench_environment.py [--preset P] [--rounds R] [--blocks B] [--profile N]
[--points]``
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_name] = "1"

import argparse  # noqa: E402
import cProfile  # noqa: E402
import io  # noqa: E402
import math  # noqa: E402
import pstats  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import yaml  # noqa: E402

from pmv_ros.physics.constants import ARCMIN_RAD  # noqa: E402
from pmv_ros.physics.environment import EnvironmentParameters, RadianceEnvironment  # noqa: E402
from pmv_ros.runtime.common import parameters  # noqa: E402
from pmv_ros.runtime.common.assembly import SENSOR_PARAMS, build_models  # noqa: E402
from pmv_ros.runtime.sensor.sample_stream import FAST_TIME_BLOCK  # noqa: E402

CONFIG = Path(__file__).resolve().parents[1] / "config"
TARGET_RATIO = 1.2
#: The field's clock of a real-time run at its start (ROS time of a node started in 2025), s.
REAL_TIME_START_S = 1_764_650_000.123


def preset_values(preset: str, **given) -> dict:
    document = yaml.safe_load((CONFIG / f"{preset}.yaml").read_text())
    return parameters.preset_values(document, "sensor_node", SENSOR_PARAMS,
                                    {"sim.fast_time": True, "sensor.bright_body_exclusion_deg": 0.0, **given})


class Flight:
    """A preset's sensor and ``blocks`` consecutive node blocks of samples at ``rate_hz`` (zero attitude)."""

    def __init__(self, preset: str, source: str, rate_hz: float, blocks: int, start_s: float = 0.0, **given):
        self.values = preset_values(preset, **{"radiance.source": source, **given})
        self.start_s = start_s
        self.times = [start_s + (np.arange(FAST_TIME_BLOCK) + 1 + b * FAST_TIME_BLOCK) / rate_hz for b in range(blocks)]
        self.attitude = np.tile(np.array([[0.0], [0.0], [0.0], [1.0]]), FAST_TIME_BLOCK)

    def fresh(self):
        """A new instrument (nothing of its grids evaluated yet), its kernels and tables loaded."""
        _, _, model = build_models(self.values, clock_epoch_s=self.start_s)
        model.prepare()
        return model

    def fly(self, model=None):
        model = self.fresh() if model is None else model
        return [model.sense(t, self.attitude) for t in self.times]


def timed(function) -> tuple[float, float]:
    """Wall and CPU time of one call, s."""
    wall, cpu = time.perf_counter(), time.process_time()
    function()
    return time.perf_counter() - wall, time.process_time() - cpu


def compare(preset: str, rate_hz: float, blocks: int, rounds: int) -> dict:
    """Alternating rounds of the uniform and the environment instrument; best wall and CPU times, per-round ratios."""
    flights = {source: Flight(preset, source, rate_hz, blocks) for source in ("uniform", "environment")}
    for flight in flights.values():
        flight.fly()  # warm-up
    best = {source: [math.inf, math.inf] for source in flights}
    per_round = []
    for _ in range(rounds):
        this_round = {}
        for source, flight in flights.items():
            model = flight.fresh()
            wall, cpu = timed(lambda: flight.fly(model))
            best[source] = [min(best[source][0], wall), min(best[source][1], cpu)]
            this_round[source] = wall
        per_round.append(this_round["environment"] / this_round["uniform"])
    samples = blocks * FAST_TIME_BLOCK
    return {"rate_hz": rate_hz, "samples": samples,
            "uniform_us_per_sample": 1e6 * best["uniform"][0] / samples,
            "environment_us_per_sample": 1e6 * best["environment"][0] / samples,
            "ratio_wall": best["environment"][0] / best["uniform"][0],
            "ratio_cpu": best["environment"][1] / best["uniform"][1], "ratio_rounds": per_round}


def real_against_fast(preset: str, blocks: int = 4, seed: int = 5) -> float:
    """Largest difference of sensed roll and pitch, arcmin, between a real-time and a fast-time run of one epoch."""
    fast = Flight(preset, "environment", 10.0, blocks, seed=seed)
    real = Flight(preset, "environment", 10.0, blocks, start_s=REAL_TIME_START_S, seed=seed,
                  **{"sim.fast_time": False})
    worst = 0.0
    for a, b in zip(fast.fly(), real.fly()):
        for name in ("sensed_roll_rad", "sensed_pitch_rad"):
            worst = max(worst, float(np.max(np.abs(getattr(a, name) - getattr(b, name)))))
    return worst / ARCMIN_RAD


def profile(preset: str, top: int, blocks: int) -> str:
    """A fresh environment instrument flying the blocks (its fields' nodes evaluated as it goes), top functions
    by own time."""
    flight = Flight(preset, "environment", 10.0, blocks)
    models = [flight.fresh() for _ in range(5)]
    profiler = cProfile.Profile()
    profiler.enable()
    for model in models:
        flight.fly(model)
    profiler.disable()
    out = io.StringIO()
    stats = pstats.Stats(profiler, stream=out)
    stats.sort_stats("tottime").print_stats(top)
    text = out.getvalue()
    return text[text.index("ncalls"):].rstrip() if "ncalls" in text else text


def point_throughput(repeats: int) -> None:
    """The fields' throughput per point, as issue 5 budgeted it (the former table of this benchmark)."""
    budget = 20000.0 * 8
    rng = np.random.default_rng(0)
    baseline = RadianceEnvironment(EnvironmentParameters(weather_enabled=False, height_variation_enabled=False))
    print(f"\nfields per point (budget {budget:,.0f} points/s: 20,000 chords/s × 8 points/chord)")
    print(f"{'case':42s} {'points':>7s} {'µs/call':>9s} {'points/s':>11s} {'×budget':>8s} {'×baseline':>9s}")
    for n in (32, 1024, int(budget)):
        lat, lon, t = (np.arcsin(rng.uniform(-1.0, 1.0, n)), rng.uniform(-math.pi, math.pi, n),
                       1000.0 + rng.uniform(0.0, 1.0, n))
        count = max(repeats, 20000 // n)

        def best_of(function):
            function()
            return min(timed(function)[0] for _ in range(count))

        base_s = best_of(lambda: baseline.sample(lat, lon, t))
        for components in (128, 256, 512):
            env = RadianceEnvironment(EnvironmentParameters(n_components=components))
            elapsed_s = best_of(lambda: env.sample(lat, lon, t))
            label = f"sample(): weather + h_w + clim., M = {components}"
            print(f"{label:42s} {n:7d} {elapsed_s * 1e6:9.1f} {n / elapsed_s:11,.0f} "
                  f"{n / elapsed_s / budget:8.1f} {elapsed_s / base_s:9.1f}")
        print(f"{'baseline: climatology only':42s} {n:7d} {base_s * 1e6:9.1f} {n / base_s:11,.0f} "
              f"{n / base_s / budget:8.1f} {1.0:9.1f}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="meteor_m2", help="the preset whose environment is flown (meteor_m2)")
    parser.add_argument("--rounds", type=int, default=7, help="alternating rounds, best kept (7)")
    parser.add_argument("--blocks", type=int, default=12, help="node blocks of 512 samples per round (12)")
    parser.add_argument("--profile", type=int, default=0, metavar="N", help="print the environment's top N functions")
    parser.add_argument("--points", action="store_true", help="also the fields' throughput per point")
    args = parser.parse_args(argv)

    print(f"{args.preset}, blocks of {FAST_TIME_BLOCK} samples, {args.rounds} alternating rounds of "
          f"{args.blocks} blocks; load average {os.getloadavg()[0]:.1f} at the start")
    for rate_hz in (10.0, 1.0):
        r = compare(args.preset, rate_hz, args.blocks, args.rounds)
        target = f"(target ≤ {TARGET_RATIO})" if rate_hz == 10.0 else "(a campaign's year at 1 Hz; no target)"
        print(f"{rate_hz:4.0f} Hz: uniform {r['uniform_us_per_sample']:6.1f} µs/sample, environment "
              f"{r['environment_us_per_sample']:6.1f} µs/sample: ×{r['ratio_wall']:.3f} wall, "
              f"×{r['ratio_cpu']:.3f} CPU {target}; rounds ×{min(r['ratio_rounds']):.2f} … "
              f"×{max(r['ratio_rounds']):.2f}")
        if rate_hz == 10.0:
            from headline import headline
            headline("environment", "the flight environment's added cost in the instrument, 10 Hz",
                     r["environment_us_per_sample"] - r["uniform_us_per_sample"], "µs/sample", "lower",
                     r["uniform_us_per_sample"], "µs/sample",
                     "the instrument with uniform radiance (target: added ≤ 0.2 of it)")
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
    print(f"real time against fast time: {real_against_fast(args.preset):.2e}′ at most (≤ 1e-6′)")
    if args.profile:
        print(f"\na fresh environment instrument, top {args.profile} by own time (5 × {args.blocks} blocks at 10 Hz):")
        print(profile(args.preset, args.profile, args.blocks))
    if args.points:
        point_throughput(7)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
