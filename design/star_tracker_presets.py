"""How far the star tracker moves the presets' residual statistics and the Meteor records' figures, against another
tree of pmv_ros, in units of their seed spread (physics.md §6: "its gaps thin the samples, its noise should not
show").

    python design/star_tracker_presets.py --baseline DIR [--seeds 1-6] [--rate-hz 1]

Each preset (Kondor, Meteor-M No.2, No.2-2) flies one orbit through the campaign core (``runtime.flight.fly``:
the nodes' own runtimes, as ``pmv simulate`` runs them) at ``--rate-hz`` for each seed (every node's, as a
campaign task sets it), in this tree and in DIR (its own interpreter): the monitor's residual statistics as the
preset configures them (mean and σ of roll, pitch and meridional, arcmin), and for the two Meteor-M records the
figures of physics.md §3.2 with the oblateness kept (pitch k = 2, roll k = 1, pitch k = 20, the largest pitch
k = 15…25). Printed: each figure's mean over the seeds in both trees, the baseline's seed spread (the standard
deviation over the seeds), and the move in units of it.

Then, in this tree alone, where a mean moves: the same flights with the ideal tracker (every frame gives
the true attitude, no gap) — the residual means over all the samples, and over only the samples the
real tracker's flight used (its gaps, the ideal tracker's values). If the second equals the real
tracker's mean and the first the baseline's, the move is the gaps' sampling of the orbit, not the
tracker's noise.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parents[1]

PROBE = r"""
import json, sys
sys.path.insert(0, sys.argv[1])
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.runtime.flight import flight_values, fly
from pmv_ros.storage.files import read_yaml_file
tree, rate, seeds = sys.argv[1], float(sys.argv[2]), [int(s) for s in sys.argv[3].split(",")]
out = {}
for preset in ("kondor", "meteor_m2", "meteor_m2_2"):
    document = read_yaml_file(f"{tree}/config/{preset}.yaml", "preset")
    for kept in ((False, True) if preset != "kondor" else (False,)):
        for seed in seeds:
            overrides = {"sensor.rate_hz": rate, "seed": seed}
            if kept:
                overrides["remove_oblateness"] = False
            values = flight_values(document, overrides)
            period = 5677.0 if preset == "kondor" else 6075.0
            summary = fly(values, int(1.05 * period * rate)).summary  # a whole orbit for the harmonics
            row = {}
            for channel in summary.channels:
                row[channel.channel + "_mean"] = channel.mean_rad / ARCMIN_RAD
                row[channel.channel + "_sigma"] = channel.sigma_rad / ARCMIN_RAD
                h = channel.harmonics_rad
                if kept and channel.channel == "pitch":
                    row["pitch_k2"], row["pitch_k20"] = h[2] / ARCMIN_RAD, h[20] / ARCMIN_RAD
                    row["pitch_k15_25_max"] = max(h[k] for k in range(15, 26)) / ARCMIN_RAD
                if kept and channel.channel == "roll":
                    row["roll_k1"] = h[1] / ARCMIN_RAD
            row["used"] = summary.counters["used"]
            name = preset + (" (oblateness kept)" if kept else "")
            out.setdefault(name, []).append(row)
print(json.dumps(out))
"""


DECOMPOSE = r"""
import json, sys
import numpy as np
sys.path.insert(0, sys.argv[1])
from pmv_ros.physics.constants import ARCMIN_RAD
from pmv_ros.runtime.flight import flight_values, fly
from pmv_ros.storage.files import read_yaml_file
tree, rate, seeds = sys.argv[1], float(sys.argv[2]), [int(s) for s in sys.argv[3].split(",")]
out = {}
for preset, kept in (("kondor", False), ("meteor_m2", False), ("meteor_m2", True), ("meteor_m2_2", False),
                     ("meteor_m2_2", True)):
    document = read_yaml_file(f"{tree}/config/{preset}.yaml", "preset")
    for seed in seeds:
        overrides = {"sensor.rate_hz": rate, "seed": seed}
        if kept:
            overrides["remove_oblateness"] = False
        period = 5677.0 if preset == "kondor" else 6075.0
        n = int(1.05 * period * rate)
        real = fly(flight_values(document, overrides), n)
        ideal = fly(flight_values(document, {**overrides, "ideal": True}), n)
        used = real.outcome == 0
        row = {}
        for channel in ("roll", "pitch", "meridional"):
            values = getattr(ideal, channel + "_rad") / ARCMIN_RAD
            row[channel] = (float(np.nanmean(values)), float(np.nanmean(values[used])),
                            float(np.nanmean(getattr(real, channel + "_rad")[used] / ARCMIN_RAD)))
        name = preset + (" (oblateness kept)" if kept else "")
        out.setdefault(name, []).append(row)
print(json.dumps(out))
"""


def run(tree: Path, rate: float, seeds: list, probe: str = PROBE) -> dict:
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    result = subprocess.run([str(tree / ".venv" / "bin" / "python"), "-c", probe, str(tree), str(rate),
                             ",".join(map(str, seeds))], capture_output=True, text=True, env=env, cwd=str(tree))
    if result.returncode:
        raise SystemExit(result.stderr[-3000:])
    return json.loads(result.stdout.strip().splitlines()[-1])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, required=True)
    parser.add_argument("--seeds", default="1-6")
    parser.add_argument("--rate-hz", type=float, default=1.0)
    args = parser.parse_args(argv)
    low, _, high = args.seeds.partition("-")
    seeds = list(range(int(low), int(high or low) + 1))
    print(f"seeds {seeds}, {args.rate_hz:g} Hz, one orbit each (load {os.getloadavg()[0]:.1f})")
    mine, base = run(HERE, args.rate_hz, seeds), run(args.baseline, args.rate_hz, seeds)
    for name in mine:
        print(name)
        for key in mine[name][0]:
            a = np.array([row[key] for row in base[name]])
            b = np.array([row[key] for row in mine[name]])
            spread = float(np.std(a, ddof=1))
            move = abs(b.mean() - a.mean())
            print(f"  {key:18s} baseline {a.mean():9.3f} ± {spread:.3f}   "
                  f"this {b.mean():9.3f} ± {np.std(b, ddof=1):.3f}"
                  f"   moved {move:.3f} = {move / spread if spread else float('inf'):.2f} spread")
    print("this tree, residual means, arcmin (mean over the seeds): ideal tracker on all samples / ideal tracker on "
          "the real tracker's samples / the real tracker")
    for name, rows in run(HERE, args.rate_hz, seeds, DECOMPOSE).items():
        for channel in ("roll", "pitch", "meridional"):
            means = np.array([row[channel] for row in rows]).mean(axis=0)
            print(f"  {name:30s} {channel:10s} {means[0]:8.3f} / {means[1]:8.3f} / {means[2]:8.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
