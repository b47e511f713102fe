"""Large well-formed inputs to ``pmv``: each costs at most linear time and bounded memory, and one step past its
bound is one line, exit status 2.

* A telemetry CSV of one orbit a row (every value in bounds): the harmonics of §5.1 grouped the samples orbit by
  orbit with one mask an orbit, O(N × orbits): 20,000 rows took 4.4 s, 50,000 19 s, 500,000 were killed at
  240 s. At the CSV's row bound (500,000 rows) it now runs in O(N log N); one row more is refused.
* The same procedure on samples that make an orbit each (crafted odometry, a hostile period), in a child.
* The arguments whose range made the work unbounded: ``pmv oblateness --step-deg`` (360/step rows: 1e-9 tried to
  allocate terabytes) and ``pmv analyze --u-bin-deg`` (a bin of 1e-300 deg overflowed the bin index and put
  every sample in one bin).

Each case is a child process measured by :mod:`bounded_run` (status, wall and CPU time, peak memory), printed.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

from bounded_run import pmv, run_measured

pytestmark = [pytest.mark.adversarial, pytest.mark.multi_process]

#: The stated cost of the CSV at its row bound, one orbit a row: ≈ 2–5 s of CPU and ≈ 0.5 GB (the series of
#: 500,000 distinct orbital angles is the largest part); the test allows a loaded machine twice that.
AT_BOUND_CPU_S, AT_BOUND_PEAK_MB = 30.0, 800.0

#: A refusal: the bound of the other hostile-file tests.
REFUSAL_CPU_S, REFUSAL_PEAK_MB = 10.0, 300.0

ANALYZE = ["--altitude-km", "500", "--inclination-deg", "74.5"]


def _orbit_a_row(path, rows: int):
    """An orbit-layout CSV of ``rows`` rows, orbit k on row k, random u and errors (all within their bounds)."""
    rng = np.random.default_rng(3)
    u = rng.uniform(0.0, 360.0, rows)
    errors = rng.uniform(-5.0, 5.0, (rows, 2))
    lines = [f"{k},{u[k]:.6f},{errors[k, 0]:.4f},{errors[k, 1]:.4f}" for k in range(rows)]
    path.write_text("orbit,u_deg,roll_arcmin,pitch_arcmin\n" + "\n".join(lines) + "\n")
    return path


def _one_line(run, *phrases) -> str:
    assert run.status == 2, run
    lines = run.stderr.strip().splitlines()
    assert run.stdout == "" and len(lines) == 1 and "Traceback" not in run.stderr, run.stderr[-3000:]
    for phrase in phrases:
        assert phrase in lines[0], lines[0]
    assert run.cpu_s < REFUSAL_CPU_S and run.peak_mb <= REFUSAL_PEAK_MB, run
    return lines[0]


def test_a_csv_of_one_orbit_a_row_at_the_row_bound_is_analysed_and_one_row_more_is_refused(tmp_path):
    from pmv_ros.storage.files import MAX_CSV_ROWS

    at_bound = _orbit_a_row(tmp_path / "at_bound.csv", MAX_CSV_ROWS)
    run = run_measured(pmv("analyze", at_bound, *ANALYZE), timeout_s=240, limit_mb=4096)
    print(f"{MAX_CSV_ROWS} rows, one orbit each: {run.summary()}")
    assert run.status == 0, run.stderr[-3000:]
    assert f"{MAX_CSV_ROWS} samples" in run.stdout and f"{MAX_CSV_ROWS} orbits" in run.stdout, run.stdout[:500]
    assert run.cpu_s < AT_BOUND_CPU_S and run.peak_mb <= AT_BOUND_PEAK_MB, run
    over = _orbit_a_row(tmp_path / "over.csv", MAX_CSV_ROWS + 1)
    run = run_measured(pmv("analyze", over, *ANALYZE), timeout_s=120)
    print(f"{MAX_CSV_ROWS + 1} rows: {run.summary()}")
    _one_line(run, str(over), f"more than {MAX_CSV_ROWS} data rows")


_ORBIT_A_SAMPLE = """
import math, sys, time
import numpy as np
from pmv_ros.analysis.flight_test import flight_test_statistics
n = int(sys.argv[1])
rng = np.random.default_rng(4)
u = 2.0 * math.pi * np.arange(n) + rng.uniform(0.0, 2.0 * math.pi, n)  # a new orbit at every sample
roll, pitch = rng.normal(0.0, 1e-3, (2, n))
started = time.process_time()
result = flight_test_statistics(u, roll, pitch, 500e3, math.radians(74.5))
print(result.orbits, time.process_time() - started)
"""


def test_samples_of_an_orbit_each_cost_linear_time(tmp_path):
    """What crafted odometry or a period of a second made of a recording: 300,000 samples, 300,000 orbits.
    The fix's cost is ≈ 1 s of CPU here; the mask an orbit took ≈ 9 × 10^10 comparisons (minutes)."""
    samples = 300_000
    run = run_measured([sys.executable, "-c", _ORBIT_A_SAMPLE, samples], timeout_s=120, limit_mb=4096)
    print(f"{samples} samples, an orbit each: {run.summary()}")
    assert run.status == 0, run.stderr[-3000:]
    orbits, procedure_s = run.stdout.split()
    assert int(orbits) == samples
    assert run.cpu_s < AT_BOUND_CPU_S and run.peak_mb <= AT_BOUND_PEAK_MB, run


@pytest.mark.parametrize("argv, phrase", [
    (["oblateness", *ANALYZE, "--step-deg", "1e-9"], "--step-deg: 1e-9 deg is outside the allowed range [0.001"),
    (["analyze", "telemetry.csv", *ANALYZE, "--u-bin-deg", "1e-300"], "--u-bin-deg: 1e-300 deg is outside"),
])
def test_an_argument_past_the_work_it_bounds_is_one_line(tmp_path, argv, phrase):
    (tmp_path / "telemetry.csv").write_text("orbit,u_deg,roll_arcmin,pitch_arcmin\n1,0,0,0\n1,90,0,0\n")
    run = run_measured(pmv(*argv), timeout_s=120, cwd=tmp_path, limit_mb=4096)
    print(f"pmv {' '.join(argv)}: {run.summary()}")
    _one_line(run, phrase)


def test_the_finest_oblateness_step_is_linear():
    """At the finest step (pmv_ros.cli.oblateness.MIN_STEP_DEG), 360,000 rows of ray geometry: ≈ 2 s of CPU and
    ≈ 0.35 GB."""
    from pmv_ros.cli.oblateness import MIN_STEP_DEG

    run = run_measured(pmv("oblateness", *ANALYZE, "--step-deg", MIN_STEP_DEG, "--json"), timeout_s=240,
                       limit_mb=4096)
    print(f"--step-deg {MIN_STEP_DEG}: {run.summary()}, {len(run.stdout)} bytes of JSON")
    assert run.status == 0, run.stderr[-3000:]
    assert run.stdout.count('"u_deg"') == round(360.0 / MIN_STEP_DEG)
    assert run.cpu_s < 60.0 and run.peak_mb <= AT_BOUND_PEAK_MB, run
