"""What the PMV module costs a Basilisk simulation: steps a second with and without it, in one run.

The Kondor scenario of pmv_ros.hosts.basilisk (spacecraft, two-body gravity, simpleNav, hillPoint →
attTrackingError → mrpFeedback → torque, all in one 10 Hz task) flown for ``--seconds`` of simulation time:

* ``bare`` — no PMV (the baseline);
* ``python module`` — a Python SysModel that only reads SCStatesMsg (the floor of any Python module);
* ``pmv direct`` — the PMV at each step (the preset, Kondor: the radiance environment evaluated per sample);
* ``pmv direct, geometric`` — the same with the ideal detector, uniform radiance and no Sun/Moon check;
* ``pmv batch 20 s`` — the PMV in a 20 s task, given every state through a recorder, sensing them in blocks.

Rounds alternate the cases; each figure is the best of its rounds, in CPU time of this process (Basilisk and
the module run on one thread; on a shared machine wall time measures the neighbours). The module's cost per
step is 1/rate − 1/rate(bare), measured in the same run.

    .venv/bin/python benchmarks/bench_basilisk.py [--rounds 3] [--seconds 60]
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

from Basilisk.architecture import messaging, sysModel

from pmv_ros.hosts.basilisk import kondor_scenario

PRESET = str(Path(__file__).resolve().parents[1] / "config" / "kondor.yaml")
GEOMETRIC = {"sensor.detector": "ideal", "radiance.source": "uniform", "sensor.bright_body_exclusion_deg": 0.0}


class StateProbe(sysModel.SysModel):
    """Reads the spacecraft's state at each step, and nothing else."""

    def __init__(self):
        super().__init__()
        self.scStateInMsg = messaging.SCStatesMsgReader()
        self.last = None

    def UpdateState(self, CurrentSimNanos):
        self.last = self.scStateInMsg().r_BN_N


CASES = {
    "bare": lambda: kondor_scenario(PRESET, pmv=None),
    "python module": lambda: kondor_scenario(PRESET, pmv=None, extra=(StateProbe(),)),
    "pmv direct": lambda: kondor_scenario(PRESET, pmv="direct"),
    "pmv direct, geometric": lambda: kondor_scenario(PRESET, GEOMETRIC, pmv="direct"),
    "pmv batch 20 s": lambda: kondor_scenario(PRESET, pmv="batch", batch_s=20.0),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--seconds", type=float, default=60.0, help="simulation time per case and round, s")
    args = parser.parse_args()
    best = dict.fromkeys(CASES, math.inf)
    steps = round(args.seconds * 10)
    for _ in range(args.rounds):
        for name, build in CASES.items():
            scenario = build()
            started = time.process_time()
            scenario.run(args.seconds)
            best[name] = min(best[name], time.process_time() - started)
    bare = best["bare"] / steps
    print(f"{steps} steps of 0.1 s per case, best of {args.rounds} rounds, CPU time")
    for name, seconds in best.items():
        per_step = seconds / steps
        added = "" if name == "bare" else f"   +{(per_step - bare) * 1e6:8.1f} µs a step"
        print(f"  {name:24s} {1.0 / per_step:9.0f} steps/s{added}")
    from headline import headline
    headline("basilisk", "Basilisk's Kondor scenario with the PMV module at each step", steps / best["pmv direct"],
             "steps/s", "higher", steps / best["bare"], "steps/s", "the same scenario without the module",
             ratio=best["bare"] / best["pmv direct"])


if __name__ == "__main__":
    main()
