"""The harmonic fit on the star tracker's real gaps: what the rule of statistics.fit_harmonics reports, and how well.

    python design/harmonic_gaps.py [--seeds 1-3] [--trials 20]

Each preset (Kondor, Meteor-M No.2, No.2-2) flies one orbit at 1 Hz through the campaign core
(``runtime.flight.fly``: the nodes' own runtimes) twice with the same seed: with the star tracker of the preset,
whose frames without attitude leave the monitor's gaps (the Sun once an orbit while |β| < 30°, the SAA, star-poor
fields), and with the ideal tracker, which leaves none. On the samples the monitor used:

* the coverage: the share of the orbit without samples, the largest hole, and each §5.1 harmonic's noise gain
  (the standard error of its amplitude over that of an evenly covered orbit of as many samples);
* a known signal on those samples: k = 1, 2 at 5′ and 9′, 1′ at k = 15…25, 0.2–0.3′ at every other k ≤ 60
  (random phases) and 0.5′ of white noise — the signal :data:`statistics.MAX_NOISE_GAIN` was first measured on —
  fitted by the rule (``--trials`` draws): the largest amplitude error of the harmonics reported, by noise gain;
* the model's own residual (sensor − ideal tracker, oblateness kept) on the used samples against the same
  residual over the whole orbit (every k ≤ 60 fitted on all samples): the error of what the monitor reports,
  and what it leaves pending.

Printed per preset and seed; the rule's constant is statistics.MAX_NOISE_GAIN.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(HERE))

from pmv_ros.analysis.statistics import MAX_NOISE_GAIN, ORBIT_HARMONICS, fit_harmonics  # noqa: E402
from pmv_ros.physics.constants import ARCMIN_RAD  # noqa: E402
from pmv_ros.runtime.flight import flight_values, fly  # noqa: E402
from pmv_ros.storage.files import read_yaml_file  # noqa: E402

PRESETS = ("kondor", "meteor_m2", "meteor_m2_2")


def known_signal(phase: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
    """The synthetic residual (arcmin) at orbital angles ``phase`` and its true amplitudes."""
    truth = {k: 5.0 if k == 1 else 9.0 if k == 2 else 1.0 if 15 <= k <= 25 else rng.uniform(0.2, 0.3)
             for k in range(1, 61)}
    signal = sum(a * np.cos(k * phase + rng.uniform(0.0, 2.0 * np.pi)) for k, a in truth.items())
    return signal + rng.normal(0.0, 0.5, phase.size), truth


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", default="1-3")
    parser.add_argument("--trials", type=int, default=20)
    args = parser.parse_args(argv)
    low, _, high = args.seeds.partition("-")
    seeds = range(int(low), int(high or low) + 1)
    ks = list(ORBIT_HARMONICS)
    print(f"rule: the §5.1 harmonics fitted together, reported where the noise gain ≤ {MAX_NOISE_GAIN:g} "
          f"(load {os.getloadavg()[0]:.1f})")
    by_gain = {}
    model_errors = {"k1,2": [], "k15-25": []}
    for preset in PRESETS:
        document = read_yaml_file(HERE / "config" / f"{preset}.yaml", "preset")
        for seed in seeds:
            settings = {"sensor.rate_hz": 1.0, "seed": seed, "remove_oblateness": False}
            period = 5677.0 if preset == "kondor" else 6075.0
            samples = int(period)
            real = fly(flight_values(document, settings), samples)
            ideal = fly(flight_values(document, {**settings, "ideal": True}), samples)
            used = real.outcome == 0
            phase = 2.0 * np.pi * real.t_s / period
            fit = fit_harmonics(phase[used], np.zeros(int(used.sum())), ks)
            gains = dict(zip(ks, fit.noise_gain))
            print(f"{preset} seed {seed}: {100 * (1 - used.mean()):.1f} % of the orbit without truth, largest hole "
                  f"{np.degrees(fit.largest_hole_rad):.0f}°; noise gain k=1 {gains[1]:.2f}, k=2 {gains[2]:.2f}, "
                  f"k=15…25 {min(gains[k] for k in range(15, 26)):.2f}–{max(gains[k] for k in range(15, 26)):.2f}")
            rng = np.random.default_rng(seed)
            worst = {}
            for _ in range(args.trials):
                signal, truth = known_signal(phase, rng)
                found = fit_harmonics(phase[used], signal[used], ks, max_noise_gain=np.inf)
                for k, amplitude, gain in zip(ks, found.amplitude, found.noise_gain):
                    error = abs(amplitude - truth[k])
                    worst[k] = max(worst.get(k, 0.0), error)
                    by_gain.setdefault(min(int(gain * 2) / 2, 5.0), []).append(error)
            print(f"  known signal, {args.trials} draws: largest error k=1 {worst[1]:.2f}′, k=2 {worst[2]:.2f}′, "
                  f"k=15…25 {max(worst[k] for k in range(15, 26)):.2f}′")
            for channel in ("roll", "pitch"):
                residual = getattr(ideal, f"{channel}_rad") / ARCMIN_RAD
                aligned = np.isfinite(residual)  # the ideal tracker's: all but the last samples, still waiting
                if aligned.mean() < 0.99:
                    print(f"  model's {channel}: the sensor itself leaves holes; skipped")
                    continue
                whole = fit_harmonics(phase[aligned], residual[aligned], range(1, 61), jointly=range(1, 61))
                mine = fit_harmonics(phase[used & aligned], residual[used & aligned], ks)
                errors = {k: mine.amplitude[i] - whole.amplitude[k - 1] for i, k in enumerate(ks)}
                shown = [k for k in ks if np.isfinite(errors[k])]
                model_errors["k1,2"] += [abs(errors[k]) for k in (1, 2) if k in shown]
                model_errors["k15-25"] += [abs(errors[k]) for k in range(15, 26) if k in shown]
                print(f"  model's {channel} residual: whole-orbit k=1 {whole.amplitude[0]:.2f}′ k=2 "
                      f"{whole.amplitude[1]:.2f}′ k=20 {whole.amplitude[19]:.2f}′; error on the used samples "
                      + " ".join(f"{k}:{errors[k]:+.2f}" for k in shown)
                      + (f"; pending {mine.pending_note}" if mine.pending_note else ""))
    print("known signal, largest error by noise gain (half-unit bins):")
    for gain in sorted(by_gain):
        errors = np.array(by_gain[gain])
        rms = np.sqrt(np.mean(errors ** 2))
        print(f"  gain {gain:.1f}–{gain + 0.5:.1f}: {errors.size:5d} amplitudes, RMS error {rms:.2f}′, "
              f"largest {errors.max():.2f}′")
    for name, errors in model_errors.items():
        if errors:
            print(f"model's residuals, {name} reported: RMS error {np.sqrt(np.mean(np.square(errors))):.2f}′, "
                  f"largest {max(errors):.2f}′ ({len(errors)} amplitudes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
