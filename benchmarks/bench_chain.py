#!/usr/bin/env python3
"""Chords per second through the full signal chain: the fast chain against the reference transcription.

Both are measured in the same run on one core (BLAS/OpenMP threads pinned
to 1 before numpy loads). The fast chain runs a batch of chords with
random horizons — radiance 1–4 r.u., window-layer height 20–60 km, a
Model B gradient, a Model C jump on a third of them, horizon shifts of a
few tenths of a degree as attitude would give — including the
brightness correction; best of several repeats. The reference is the
literal loop program of tests/reference_chain.py (the test oracle) on a
few sensed chords of the same batch (per chord the best of 3 runs, which
favours the reference). The ratio is fast / reference.

Usage:  python benchmarks/bench_chain.py [--chords N] [--reference-chords K] [--json]
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_name] = "1"

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from pmv_ros.physics.chain import (  # noqa: E402
    DEFAULT_CHAIN_PARAMETERS,
    DetectionStatus,
    response_tables,
    scan_start_nadir_angle,
    sense_horizon_chords,
    sphere_chord,
)
from pmv_ros.physics.instrument.correction import calibrated_correction_table  # noqa: E402
from reference_chain import reference_chord  # noqa: E402


def make_batch(n: int, seed: int = 1) -> dict:
    """Per-chord inputs of a varied batch at 500 km (arrays of n)."""
    rng = np.random.default_rng(seed)
    phi0, slope = sphere_chord(500e3)
    start = float(scan_start_nadir_angle(phi0, slope)) + np.radians(1.0)  # a fixed instrument angle with margin
    jump = np.where(rng.random(n) < 1 / 3, rng.uniform(-0.4, 0.4, n), 0.0)
    return {
        "horizon_nadir_rad": phi0 + np.radians(rng.uniform(-0.5, 0.5, n)),
        "tangent_height_rate_m": np.full(n, slope),
        "disc_radiance_ru": rng.uniform(1.0, 4.0, n),
        "gradient_ru_per_m": rng.uniform(-4e-7, 4e-7, n),
        "jump_ru": jump,
        "jump_distance_m": rng.uniform(100e3, 700e3, n),
        "window_height_m": rng.uniform(20e3, 60e3, n),
        "scan_start_nadir_rad": np.full(n, start),
    }


def time_fast(batch: dict, table, repeats: int) -> tuple[float, np.ndarray]:
    """Best wall time of ``repeats`` runs over the whole batch, s, and the status codes."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        readings = sense_horizon_chords(correction=table, **batch)
        best = min(best, time.perf_counter() - t0)
    return best, readings.status


def time_reference(batch: dict, table, chords, repeats: int) -> float:
    """Wall time of the reference transcription over ``chords`` (indices), s: per chord the best of ``repeats``."""
    pairs = (table.del_rad.tolist(), table.pop_rad.tolist())
    total = 0.0
    for k in chords:
        best = float("inf")
        for _ in range(repeats):
            t0 = time.perf_counter()
            reference_chord(
                batch["horizon_nadir_rad"][k], batch["tangent_height_rate_m"][k], batch["disc_radiance_ru"][k],
                DEFAULT_CHAIN_PARAMETERS, scan_start_nadir_rad=batch["scan_start_nadir_rad"][k],
                gradient_ru_per_m=batch["gradient_ru_per_m"][k], jump_ru=batch["jump_ru"][k],
                jump_distance_m=batch["jump_distance_m"][k], window_height_m=batch["window_height_m"][k], table=pairs)
            best = min(best, time.perf_counter() - t0)
        total += best
    return total


def flight_environment():
    """The environment the presets fly (config/kondor.yaml's, calibrated by tools/calibrate_environment.py)."""
    import yaml

    from pmv_ros.runtime.common import parameters
    from pmv_ros.runtime.common.assembly import SENSOR_PARAMS, build_detector, build_models, parse_epoch

    document = yaml.safe_load((Path(__file__).resolve().parents[1] / "config" / "kondor.yaml").read_text())
    values = parameters.preset_values(document, "sensor_node", SENSOR_PARAMS,
                                      {"sim.fast_time": True, "radiance.source": "environment"})
    orbit, _, _ = build_models(values)
    return build_detector(values, orbit, parse_epoch(values["sim.epoch_utc"])).radiance


def time_instrument(samples: int, repeats: int, sources=("uniform", "environment")) -> dict:
    """Chords/s of the whole instrument (geometry + radiance + chain + pair angles) over a Kondor orbit.

    Per source of radiance: "uniform" (one disc radiance) or "environment"
    (the flight environment of the presets: climatology, synoptic weather and
    window-layer height at each chord's horizon point on the rotating Earth,
    the random fields kept on their grid along the horizon — filled in the
    warm-up, so the repeats time the look-ups). The sources alternate repeat by
    repeat and each keeps its best, so a slow minute of the machine does not
    land on one of them only.
    """
    import math

    from pmv_ros.physics.orbit.two_body import CircularOrbit
    from pmv_ros.physics.instrument.sensor import ChainDetector, RadianceConfig, SensorConfig, SensorModel

    orbit = CircularOrbit(500e3, math.radians(74.5))
    t = np.linspace(0.0, orbit.period_s, samples)
    q = np.tile(np.array([[0.0], [0.0], [0.0], [1.0]]), samples)
    models = {}
    for source in sources:
        radiance = flight_environment() if source == "environment" else RadianceConfig(source=source)
        detector = ChainDetector(orbit.altitude_m, radiance, calibrated_correction_table(500e3))
        models[source] = SensorModel(orbit, SensorConfig(), detector)
        models[source].sense(t[:64], q[:, :64])  # warm-up
    best = dict.fromkeys(sources, math.inf)
    for _ in range(repeats):
        for source, model in models.items():
            started = time.perf_counter()
            model.sense(t, q)
            best[source] = min(best[source], time.perf_counter() - started)
    return {source: 4 * samples / best[source] for source in sources}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description="Fast signal chain vs the reference transcription, chords/s.")
    parser.add_argument("--chords", type=int, default=50000, help="fast-chain batch size (default 50000)")
    parser.add_argument("--reference-chords", type=int, default=16, help="chords through the reference (default 16)")
    parser.add_argument("--repeats", type=int, default=5, help="fast-chain repeats, best taken (default 5)")
    parser.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    args = parser.parse_args(argv)

    table = calibrated_correction_table(500e3)
    t0 = time.perf_counter()
    response_tables(DEFAULT_CHAIN_PARAMETERS)  # one-off set-up, reported separately
    setup_s = time.perf_counter() - t0
    batch = make_batch(args.chords)
    sense_horizon_chords(correction=table, **{k: v[:100] for k, v in batch.items()})  # warm-up

    fast_s, status = time_fast(batch, table, args.repeats)
    # Chords the chain senses: a chord that never crosses J(2) would keep the O(steps²) reference busy for
    # all 2000 steps (seconds), which would flatter the ratio.
    sensed = np.flatnonzero(status == DetectionStatus.OK)[:args.reference_chords]
    reference_s = time_reference(batch, table, sensed, repeats=3)
    fast_rate = args.chords / fast_s
    reference_rate = sensed.size / reference_s
    result = {
        "fast_chords_per_s": fast_rate,
        "reference_chords_per_s": reference_rate,
        "ratio": fast_rate / reference_rate,
        "fast_batch": args.chords,
        "fast_best_s": fast_s,
        "reference_chords": int(sensed.size),
        "reference_s": reference_s,
        "table_setup_s": setup_s,
        "chords_ok_percent": 100.0 * float(np.mean(status == DetectionStatus.OK)),
        "targets": {"fast_chords_per_s": 20000, "ratio": 1000},
    }
    # The environment's cost: the same instrument with uniform radiance and with the flight environment.
    samples = max(64, args.chords // 4)
    rates = time_instrument(samples, args.repeats)
    uniform_rate, environment_rate = rates["uniform"], rates["environment"]
    result.update({"instrument_uniform_chords_per_s": uniform_rate,
                   "instrument_environment_chords_per_s": environment_rate,
                   "environment_cost_factor": uniform_rate / environment_rate})
    if args.json:
        print(json.dumps(result))
    else:
        print(f"fast chain:     {fast_rate:12,.0f} chords/s  ({args.chords} chords, best of {args.repeats}: "
              f"{fast_s * 1e3:.1f} ms; {result['chords_ok_percent']:.1f} % sensed; tables {setup_s * 1e3:.0f} ms once)")
        print(f"reference:      {reference_rate:12,.1f} chords/s  "
              f"({sensed.size} chords, best of 3 each: {reference_s:.2f} s)")
        print(f"ratio:          {result['ratio']:12,.0f} ×        (targets: ≥ 20,000 chords/s and ≥ 1,000 ×)")
        print(f"instrument (geometry + chain), uniform radiance:  {uniform_rate:10,.0f} chords/s")
        print(f"instrument (geometry + chain), flight environment: {environment_rate:9,.0f} chords/s  "
              f"(cost factor {result['environment_cost_factor']:.2f} per chord; the environment's target is per "
              f"sensor sample: bench_environment.py)")
        from headline import headline
        headline("chain", "the signal chain, chords/s", fast_rate, "chords/s", "higher", reference_rate, "chords/s",
                 "the reference transcription (tests/reference_chain.py)", ratio=result["ratio"])
    return 0


if __name__ == "__main__":
    sys.exit(main())
