"""Soak: the three nodes for a day of simulated time keep flat memory and flat callback time (issue 6, item 5).

The in-process pipeline (sensor, star tracker, monitor on one executor, the
Kondor preset, sensor at 1 Hz) runs in fast time. After a warm-up of more
than one orbit — once the monitor's one-orbit ring is full it fits the
harmonics at every statistics publication (1 Hz), which raises the tick time
from ≈ 2 to ≈ 3.5 ms once and for all — the resident set size (VmRSS, after
a garbage collection) may grow by less than 10 MB, and the time the
callbacks of one tick take (sensor step and everything it triggers, down to
the monitor's residual) must not grow: the smaller median of the last two
blocks may exceed the smaller of the first two by a factor of 2 at most (the
smaller of two, and the factor, because the machine's speed drifts by up to
1.6× for tens of seconds). That time is the CPU time of the executor's thread
(``time.thread_time``), not wall time: on a machine whose other jobs come and
go a tick's wall time moved 3× within one run (34 → 116 ms a tick beside a
CPU hog on every core) with nothing growing in the pipeline.
The bounded structures are checked too: monitor truth history and pending
queue, the star tracker's release queue, the sensor's precomputed block.

By default a short version runs (40 simulated minutes, inside the first orbit); the full day
(86 400 ticks, a few minutes) runs with::

    make test-long                      # every test marked long, full length
    .venv/bin/python -m pytest -q -s tests/system/test_soak.py --run-long

and prints the figures.
"""

from __future__ import annotations

import gc
import statistics
import time
from pathlib import Path

import pytest
from geometry_msgs.msg import Vector3Stamped
from rclpy.node import Node

from pmv_ros.nodes.pipeline import Pipeline
from pmv_ros.runtime.sensor.sample_stream import FAST_TIME_BLOCK

pytestmark = [pytest.mark.serial]

REPO = Path(__file__).resolve().parents[2]
RATE_HZ = 1.0
#: (simulated run, warm-up) in seconds: short (default) and full (--run-long). The short run stays within the
#: first orbit (the monitor's ring still filling, no harmonic fit yet): a smoke test of the same checks in a
#: quarter of the time, which a CPU hog on both cores stretched past five minutes; the regime after the ring has
#: filled is the full run's.
SHORT = (2400.0, 1200.0)
FULL = (24 * 3600.0, 2 * 3600.0)
#: Blocks the run after the warm-up is measured in.
BLOCKS = 6
RSS_GROWTH_LIMIT_MB = 10.0
#: Last blocks against first blocks, best of two each. These virtual machines change speed by up to
#: 1.6× for tens of seconds (measured: block medians 5.7 → 9.0 ms and 8.3 → 5.1 ms within one short
#: run, no change in the code path), so 1.5 failed on noise; growth from an unbounded structure
#: over hours is far larger than 2×.
LATENCY_GROWTH_LIMIT = 2.0


def rss_mb() -> float:
    """Resident set size of this process after a full garbage collection, MB (VmRSS of /proc/self/status)."""
    gc.collect()
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024.0
    raise RuntimeError("no VmRSS in /proc/self/status")


@pytest.mark.long
def test_soak_memory_and_callback_time_stay_flat(run_long, capsys):
    duration_s, warm_up_s = FULL if run_long else SHORT
    ticks, warm_up_ticks = int(duration_s * RATE_HZ), int(warm_up_s * RATE_HZ)
    block_ticks = (ticks - warm_up_ticks) // BLOCKS
    with Pipeline(REPO / "config/kondor.yaml", {"sensor.rate_hz": RATE_HZ}, collect=False) as pipeline:
        residuals = []  # counted, not kept: a consumer of the monitor's output like any other
        listener = Node("soak_listener", context=pipeline.context)
        listener.create_subscription(Vector3Stamped, "/pmv/residual", lambda _: residuals.append(None) or
                                     residuals.clear() if len(residuals) > 1000 else None, 100)
        pipeline.executor.add_node(listener)
        pipeline.nodes.append(listener)
        monitor, tracker, sensor = pipeline.monitor.monitor, pipeline.star_tracker, pipeline.sensor

        pipeline.step(warm_up_ticks)
        rss = [rss_mb()]
        block_medians, block_p99 = [], []
        bounds = {"pending": 0, "truth_buffer": 0, "release_queue": 0, "sensor_block": 0}
        started = time.perf_counter()
        for _ in range(BLOCKS):
            durations = []
            for _ in range(block_ticks):
                t0 = time.thread_time()
                pipeline.step()
                durations.append(time.thread_time() - t0)
                bounds["pending"] = max(bounds["pending"], monitor.pending_count)
                bounds["truth_buffer"] = max(bounds["truth_buffer"], monitor.truth_buffer_length)
                bounds["release_queue"] = max(bounds["release_queue"], tracker.release_queue_length)
                bounds["sensor_block"] = max(bounds["sensor_block"], sensor.samples_computed_ahead)
            durations.sort()
            block_medians.append(statistics.median(durations) * 1e3)
            block_p99.append(durations[int(0.99 * len(durations))] * 1e3)
            rss.append(rss_mb())
        wall_s = time.perf_counter() - started
        counters = monitor.counters
        simulated_s = sensor.sim_time_s

    growth_mb = max(rss) - rss[0]
    figures = (f"soak {simulated_s / 3600:.1f} h simulated at {RATE_HZ:g} Hz ({ticks} ticks, {wall_s:.0f} s wall "
               f"after warm-up): RSS {rss[0]:.1f} → {rss[-1]:.1f} MB (max growth {growth_mb:+.2f} MB); "
               f"tick callback CPU time per block, median ms: {', '.join(f'{m:.3f}' for m in block_medians)}; "
               f"p99 ms: {', '.join(f'{p:.2f}' for p in block_p99)}; used {counters['used']}, bounds {bounds}")
    print(figures)
    if run_long:
        with capsys.disabled():
            print("\n" + figures)

    assert simulated_s == pytest.approx(duration_s, abs=2.0)
    assert growth_mb < RSS_GROWTH_LIMIT_MB, figures
    assert min(block_medians[-2:]) <= LATENCY_GROWTH_LIMIT * min(block_medians[:2]), figures
    # The monitor kept up: every sample was aligned but those the star tracker left without truth (its frames
    # without attitude: the Sun once an orbit, star-poor fields, the SAA).
    without_truth = sum(counters[k] for k in ("skipped_truth_gap", "skipped_stale_truth", "skipped_no_truth"))
    assert counters["used"] + without_truth >= 0.98 * (ticks - 2), counters
    assert counters["skipped_pending_overflow"] == 0, counters
    assert counters["clock_jumps"] == 0
    # Bounded structures: the samples waiting for truth (across a gap of the star tracker's they wait until
    # max_truth_wait_s = 10 s gives them up: 11 at 1 Hz), the 60 s truth history at a frame a second, the frames
    # waiting for publication, one precomputed block.
    assert bounds["pending"] <= 12 and bounds["truth_buffer"] <= 122, bounds
    assert bounds["release_queue"] <= 2 and bounds["sensor_block"] <= FAST_TIME_BLOCK, bounds
