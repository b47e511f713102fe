"""Throughput of the radiance environment: climatology + weather + layer heights.

Budget (issue 5): the signal chain runs ≥ 20,000 chords/s and the sensor node
evaluates the environment at ≤ 8 points per chord, so the environment keeps
the total within 2× the chain's time if it evaluates ≥ 160,000 points/s.

Baseline measured in the same run: the climatology alone (what every point
costs without the random fields). Printed: time per call, points/s, the ratio
to the budget, the ratio to the baseline, and the slowdown of a chain running
at exactly 20,000 chords/s, 1 + 160,000 / (points/s).

Run: ``.venv/bin/python benchmarks/bench_environment.py [--repeats N]``
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from pmv_ros.physics.environment import EnvironmentParameters, RadianceEnvironment

CHAIN_CHORDS_PER_S = 20000.0
POINTS_PER_CHORD = 8
BUDGET_POINTS_PER_S = CHAIN_CHORDS_PER_S * POINTS_PER_CHORD


def best_time_s(function, repeats: int) -> float:
    """Shortest wall time of ``repeats`` calls of ``function``, s (after one warm-up call)."""
    function()
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        function()
        best = min(best, time.perf_counter() - start)
    return best


def points(n: int, rng):
    """n points uniform on the sphere (rad) at times spread over one second of a scan (s)."""
    return (np.arcsin(rng.uniform(-1.0, 1.0, n)), rng.uniform(-math.pi, math.pi, n),
            1000.0 + rng.uniform(0.0, 1.0, n))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7,
                        help="timed calls per case for the largest batch (more for small ones); the best is kept")
    args = parser.parse_args()
    rng = np.random.default_rng(0)

    baseline = RadianceEnvironment(EnvironmentParameters(weather_enabled=False, height_variation_enabled=False))
    print(f"budget: {BUDGET_POINTS_PER_S:,.0f} points/s "
          f"({CHAIN_CHORDS_PER_S:,.0f} chords/s × {POINTS_PER_CHORD} points/chord)")
    print(f"{'case':42s} {'points':>7s} {'µs/call':>9s} {'points/s':>11s} {'×budget':>8s} "
          f"{'×baseline':>9s} {'chain slowdown':>14s}")

    # Batch sizes: one scan (4 chords × 8 points), a few hundred chords, one
    # second of the chain at full rate.
    for n in (4 * POINTS_PER_CHORD, 1024, int(BUDGET_POINTS_PER_S)):
        lat, lon, t = points(n, rng)
        repeats = max(args.repeats, 20000 // n)
        base_s = best_time_s(lambda: baseline.sample(lat, lon, t), repeats)
        for components in (128, 256, 512):
            env = RadianceEnvironment(EnvironmentParameters(n_components=components))
            elapsed_s = best_time_s(lambda: env.sample(lat, lon, t), repeats)
            rate = n / elapsed_s
            label = f"sample(): weather + h_w + clim., M = {components}"
            print(f"{label:42s} {n:7d} {elapsed_s * 1e6:9.1f} {rate:11,.0f} {rate / BUDGET_POINTS_PER_S:8.1f} "
                  f"{elapsed_s / base_s:9.1f} {1.0 + BUDGET_POINTS_PER_S / rate:14.2f}")
        print(f"{'baseline: climatology only':42s} {n:7d} {base_s * 1e6:9.1f} {n / base_s:11,.0f} "
              f"{n / base_s / BUDGET_POINTS_PER_S:8.1f} {1.0:9.1f} {1.0 + BUDGET_POINTS_PER_S * base_s / n:14.2f}")


if __name__ == "__main__":
    main()
